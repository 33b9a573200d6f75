"""The calibration report's pictures (matplotlib, Agg backend) from a
:class:`~femcal.calibrate.result.CalibrationResult`: FRFs before and after, MAC matrices, the
parameter changes with their Cramér-Rao bounds, the deviation history, paired shapes. Every
file is written atomically; the page that shows them is :mod:`femcal.io.calibration`'s."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..calibrate.result import CalibrationResult
from ..correlate import modal_scale_factor
from ..response.frf import channel_matrix
from .figures import pyplot, save_figure


def _save(fig, path: Path) -> Path:
    save_figure(fig, path, dpi=100)
    return path


def frf_comparison(path: Path, outcome: CalibrationResult, pairs: list[tuple[int, int]]) -> Path:
    """Magnitude panels: the measured FRFs, the damping-equalised test model, the FE model
    before and after, for the given (output, input) index pairs."""
    plt = pyplot()
    cols = min(3, len(pairs))
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 3.3 * rows), squeeze=False)
    data = outcome.data
    band = outcome.config.band
    for n, (o, i) in enumerate(pairs):
        ax = axes[divmod(n, cols)]
        lab_o, lab_i = outcome.outputs[o].label, outcome.inputs[i].label
        if data is not None:
            do = [c.label for c in data.outputs].index(lab_o)
            di = [c.label for c in data.inputs].index(lab_i)
            sel = (data.frequency_hz >= band[0]) & (data.frequency_hz <= band[1])
            ax.semilogy(data.frequency_hz[sel], np.abs(data.H[do, di, sel]), color="0.6", lw=0.7,
                        label="measured")  # fmt: skip
        f = outcome.freq
        ax.semilogy(f, np.abs(outcome.H_test[o, i]), "k", lw=1.1, label="test, damping equalised")
        ax.semilogy(f, np.abs(outcome.H_before[o, i]), color="tab:blue", lw=1.0, ls="--",
                    label="FE before")  # fmt: skip
        ax.semilogy(f, np.abs(outcome.H_after[o, i]), color="tab:red", lw=1.0, label="FE after")
        ax.set_title(f"{lab_o} / {lab_i}", fontsize=9)
        ax.set_xlabel("frequency (Hz)")
        ax.grid(True, which="both", alpha=0.3)
        if n == 0:
            ax.legend(fontsize=7)
    for n in range(len(pairs), rows * cols):
        axes[divmod(n, cols)].set_visible(False)
    return _save(fig, path)


def mac_matrices(path: Path, outcome: CalibrationResult) -> Path:
    """MAC between test modes and FE modes near the band, before and after."""
    plt = pyplot()
    band = outcome.config.band
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    panels = ((axes[0], outcome.mac_before, outcome.modes_before, "before"),
              (axes[1], outcome.mac_after, outcome.modes_after, "after"))
    for ax, M, modes, title in panels:
        fe_hz = modes.frequencies_hz
        cols = np.flatnonzero((fe_hz >= 0.7 * band[0]) & (fe_hz <= 1.3 * band[1]))
        im = ax.imshow(M[:, cols], vmin=0, vmax=1, cmap="viridis", aspect="auto")
        ax.set_xticks(range(len(cols)), [f"{fe_hz[j]:.1f}" for j in cols], rotation=90,
                      fontsize=7)  # fmt: skip
        ax.set_yticks(range(len(outcome.test_hz)), [f"{f:.1f}" for f in outcome.test_hz])
        ax.set_xlabel("FE mode (Hz)")
        ax.set_ylabel("test mode (Hz)")
        ax.set_title(f"MAC, FE {title} calibration")
        for (r, c), v in np.ndenumerate(M[:, cols]):
            if v > 0.3:
                ax.text(c, r, f"{v:.2f}", ha="center", va="center", fontsize=6,
                        color="k" if v > 0.6 else "w")  # fmt: skip
        fig.colorbar(im, ax=ax, fraction=0.04)
    return _save(fig, path)


def parameters_plot(path: Path, outcome: CalibrationResult) -> Path:
    """Per parameter: the change p (dots, % of the nominal) with its prior (grey) and
    posterior (blue) standard deviation as error bars about the nominal and the estimate,
    held parameters marked, a synthetic test's true changes as crosses; and the posterior's
    correlation matrix of the calibrated parameters."""
    plt = pyplot()
    rs = outcome.parameters
    names = [r.parameter.name for r in rs]
    x = np.arange(len(names))
    change = 100 * np.array([r.p for r in rs])
    held = np.array([r.held for r in rs])
    fig, axes = plt.subplots(1, 2, figsize=(15, 5.8), gridspec_kw={"width_ratios": [1.5, 1]})
    ax = axes[0]
    ax.errorbar(x - 0.15, np.zeros(len(x)), yerr=100 * np.array([r.prior_std_p for r in rs]),
                fmt="none", ecolor="0.6", elinewidth=3, label="prior (nominal +- 1 std)")
    ax.errorbar(x[~held] + 0.15, change[~held],
                yerr=100 * np.array([r.posterior_std_p for r in rs])[~held], fmt="o",
                color="tab:blue", ms=4, capsize=2, label="calibrated +- posterior std")  # fmt: skip
    ax.plot(x[held] + 0.15, change[held], "s", color="0.3", ms=4, label="held at nominal")
    if rs and rs[0].true_p is not None:
        ax.plot(x, 100 * np.array([r.true_p for r in rs]), "x", color="tab:red", ms=6,
                label="true (synthetic test)")  # fmt: skip
    bound = np.array([r.at_bound for r in rs])
    if bound.any():
        ax.plot(x[bound] + 0.15, change[bound], "o", mfc="none", mec="tab:red", ms=11,
                label="on a bound")  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xticks(x, names, rotation=90, fontsize=8)
    ax.set_ylabel("change from the nominal value (%)")
    ax.set_title("parameters: prior, calibrated value and posterior")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, axis="y", alpha=0.3)
    free = np.flatnonzero(~held)
    corr = outcome.posterior.correlation[np.ix_(free, free)]
    im = axes[1].imshow(np.where(np.isfinite(corr), corr, np.nan), vmin=-1, vmax=1,
                        cmap="RdBu_r")  # fmt: skip
    axes[1].set_xticks(range(len(free)), [names[i] for i in free], rotation=90, fontsize=7)
    axes[1].set_yticks(range(len(free)), [names[i] for i in free], fontsize=7)
    axes[1].set_title("posterior correlation of the calibrated parameters")
    fig.colorbar(im, ax=axes[1], fraction=0.046, label="correlation")
    return _save(fig, path)


def history_plot(path: Path, outcome: CalibrationResult) -> Path:
    """Deviation along the iterations of every start of the first cycle, and the best
    deviation of each cycle."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for s in outcome.cycles[0].starts:
        axes[0].semilogy(s.history, marker=".", lw=0.8, label=f"start {s.start + 1}")
    axes[0].set_xlabel("Levenberg-Marquardt iteration")
    axes[0].set_ylabel("deviation (surrogate)")
    axes[0].set_title("starts of the first cycle")
    axes[0].legend(fontsize=7, ncol=2)
    axes[0].grid(True, which="both", alpha=0.3)
    dev = [c.deviation for c in outcome.cycles]
    axes[1].semilogy(range(1, len(dev) + 1), dev, "o-", label="best of each cycle (surrogate)")
    axes[1].axhline(outcome.deviation_before, color="tab:blue", ls="--",
                    label="before (full model)")  # fmt: skip
    axes[1].axhline(outcome.deviation_after, color="tab:red", ls="--",
                    label="after (full model)")  # fmt: skip
    axes[1].set_xlabel("cycle (surrogate rebuilt)")
    axes[1].set_title("deviation")
    axes[1].legend(fontsize=8)
    axes[1].grid(True, which="both", alpha=0.3)
    return _save(fig, path)


def vector_plot(path: Path, outcome: CalibrationResult) -> Path | None:
    """Test shape against FE shape (after calibration, scaled by the modal scale factor),
    component by component, for each paired mode: points on the diagonal agree."""
    plt = pyplot()
    pairs = [m for m in outcome.modes if m.fe_after is not None]
    if not pairs:
        return None
    Cg = channel_matrix(outcome.model, outcome.outputs)
    fe = np.asarray(Cg @ outcome.modes_after.shapes[:, [m.fe_after - 1 for m in pairs]])
    fig, axes = plt.subplots(1, len(pairs), figsize=(3.4 * len(pairs), 3.5), squeeze=False)
    for k, (ax, pr) in enumerate(zip(axes[0], pairs, strict=True)):
        t = outcome.test_shapes[:, pr.test_mode - 1]
        a = fe[:, k]
        s = modal_scale_factor(t, a)
        t_r = (t / s).real  # test shape in the FE shape's scale and phase
        ax.plot(a, t_r, ".", ms=4)
        lim = float(np.abs(np.concatenate([a, t_r])).max()) * 1.05
        ax.plot([-lim, lim], [-lim, lim], "k--", lw=0.7)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_title(f"test {pr.test_hz:.1f} Hz / FE {pr.fe_after_hz:.1f} Hz\n"
                     f"MAC {pr.mac_after:.3f}", fontsize=8)  # fmt: skip
        ax.set_xlabel("FE (after)")
        ax.set_ylabel("test (scaled)")
    return _save(fig, path)


def report_pictures(result: CalibrationResult, folder: Path) -> dict[str, Path]:
    """Every picture of the report in ``folder``, by title: FRFs of the worst-fitting
    channels before calibration and a spread of the others (first and second input), the
    parameter changes and bounds, the deviation history, and with identified test modes the
    MAC matrices and the paired shapes."""
    err = np.mean(np.abs(np.log10(np.abs(result.H_before / result.H_test))), axis=(1, 2))
    order = np.argsort(err)[::-1]
    chans = list(dict.fromkeys([*order[:2], *np.linspace(0, len(order) - 1, 4).astype(int)]))
    pairs = [(int(o), i) for o in chans[:3] for i in range(len(result.inputs))][:6]
    pictures = {"FRFs: test, FE before and after": frf_comparison(folder / "frf.png", result,
                                                                  pairs),
                "Parameters: prior, calibrated value and posterior":
                    parameters_plot(folder / "parameters.png", result),
                "Deviation history": history_plot(folder / "history.png", result)}  # fmt: skip
    if len(result.test_hz):  # test modes to correlate (an identified test model)
        pictures["MAC matrices"] = mac_matrices(folder / "mac.png", result)
        vp = vector_plot(folder / "vectors.png", result)
        if vp is not None:
            pictures["Paired shapes, component against component"] = vp
    return pictures
