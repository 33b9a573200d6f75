"""The calibration report's pictures (matplotlib, Agg backend) from a
:class:`~femcal.calibrate.result.CalibrationResult`: per configuration the FRFs before and
after, MAC matrices and paired shapes; the parameters' prior and posterior, the deviation
history. Every axis is labelled with its quantity and unit (log10 residuals and deviations
are dimensionless; a mode shape's is the model's), channels by their sensor's name where
the test names it. Each comes with a caption; every file is written atomically; the page and
the PDF that show them are :mod:`femcal.io.calibration`'s."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..calibrate.result import CalibrationResult, CaseResult
from ..correlate import in_scale_of, mac_text
from ..response.frf import channel_matrix
from .figures import mac_image, pyplot, save_figure, shape_scatter


@dataclass(frozen=True)
class Figure:
    """A picture of the report: its title, file, the caption that says what it shows, and
    the configuration it belongs to (None: the whole calibration)."""

    title: str
    path: Path
    caption: str
    case: str | None = None


def _save(fig, path: Path) -> Path:
    save_figure(fig, path, dpi=100)
    return path


def frf_comparison(path: Path, outcome: CaseResult, pairs: list[tuple[int, int]],
                   units: str = "") -> Path:  # fmt: skip
    """Magnitude panels: the measured FRFs, the damping-equalised test model, the FE model
    before and after, for the given (output, input) index pairs."""
    plt = pyplot()
    cols = min(3, len(pairs))
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 3.3 * rows), squeeze=False)
    data = outcome.data
    band = outcome.band
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
        ax.set_title(f"{outcome.channel_name(outcome.outputs[o])} / "
                     f"{outcome.channel_name(outcome.inputs[i])}", fontsize=9)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel(f"|H| ({units})" if units else "|H| (the test's units)")
        ax.grid(True, which="both", alpha=0.3)
        if n == 0:
            ax.legend(fontsize=9)
    for n in range(len(pairs), rows * cols):
        axes[divmod(n, cols)].set_visible(False)
    return _save(fig, path)


def mac_matrices(path: Path, outcome: CaseResult) -> Path:
    """MAC between test modes and FE modes near the band, before and after."""
    plt = pyplot()
    band = outcome.band
    in_band = [np.flatnonzero((m.frequencies_hz >= 0.7 * band[0])
                              & (m.frequencies_hz <= 1.3 * band[1]))
               for m in (outcome.modes_before, outcome.modes_after)]  # fmt: skip
    columns = max(len(c) for c in in_band)
    rows = len(outcome.test_hz)
    # cells wide enough for "0.38" at 9 pt
    fig, axes = plt.subplots(1, 2, figsize=(max(11.0, 2 * (0.4 * columns + 1.6)),
                                            max(4.5, 0.3 * rows + 1.6)))  # fmt: skip
    panels = ((axes[0], outcome.mac_before, outcome.modes_before, "before"),
              (axes[1], outcome.mac_after, outcome.modes_after, "after"))
    for (ax, M, modes, title), cols in zip(panels, in_band, strict=True):
        fe_hz = modes.frequencies_hz
        im = mac_image(ax, M[:, cols], printed_above=0.3, fontsize=9)
        ax.set_xticks(range(len(cols)), [f"{fe_hz[j]:.1f}" for j in cols], rotation=90,
                      fontsize=9)  # fmt: skip
        ax.set_yticks(range(len(outcome.test_hz)), [f"{f:.1f}" for f in outcome.test_hz])
        ax.set_xlabel("FE mode (Hz)")
        ax.set_ylabel("test mode (Hz)")
        ax.set_title(f"MAC, FE {title} calibration")
        fig.colorbar(im, ax=ax, fraction=0.04, label="MAC (0-1)")
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
    if any(r.true_p is not None for r in rs):  # a synthetic test (an added element's unknown)
        ax.plot(x, 100 * np.array([np.nan if r.true_p is None else r.true_p for r in rs]), "x",
                color="tab:red", ms=6, label="true (synthetic test)")  # fmt: skip
    bound = np.array([r.at_bound for r in rs])
    if bound.any():
        ax.plot(x[bound] + 0.15, change[bound], "o", mfc="none", mec="tab:red", ms=11,
                label="on a bound")  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xticks(x, names, rotation=90, fontsize=9)
    ax.set_ylabel("change from the nominal value (%)")
    ax.set_xlabel("parameter")
    ax.set_title("parameters: prior, calibrated value and posterior")
    ax.legend(fontsize=9, ncol=2)
    ax.grid(True, axis="y", alpha=0.3)
    free = np.flatnonzero(~held)
    corr = outcome.posterior.correlation[np.ix_(free, free)]
    im = axes[1].imshow(np.where(np.isfinite(corr), corr, np.nan), vmin=-1, vmax=1,
                        cmap="RdBu_r")  # fmt: skip
    axes[1].set_xticks(range(len(free)), [names[i] for i in free], rotation=90, fontsize=9)
    axes[1].set_yticks(range(len(free)), [names[i] for i in free], fontsize=9)
    axes[1].set_title("posterior correlation of the calibrated parameters")
    axes[1].set_xlabel("parameter")
    axes[1].set_ylabel("parameter")
    fig.colorbar(im, ax=axes[1], fraction=0.046, label="correlation (no unit)")
    return _save(fig, path)


def history_plot(path: Path, outcome: CalibrationResult) -> Path:
    """Deviation along the iterations of every start of the first cycle, and the best
    deviation of each cycle."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for s in outcome.cycles[0].starts:
        axes[0].semilogy(s.history, marker=".", lw=0.8, label=f"start {s.start + 1}")
    axes[0].set_xlabel("Levenberg-Marquardt iteration")
    loss = "Huber loss" if outcome.config.loss == "huber" else "deviation"
    axes[0].set_ylabel(f"objective: {loss} + prior\n(surrogate; no unit)")
    starts = len(outcome.cycles[0].starts)
    axes[0].set_title(f"the {starts} starts of the first cycle")
    if starts <= 8:  # more would hide the lines
        axes[0].legend(fontsize=9, ncol=2)
    axes[0].grid(True, which="both", alpha=0.3)
    dev = [c.deviation for c in outcome.cycles]
    axes[1].semilogy(range(1, len(dev) + 1), dev, "o-", label="best of each cycle (surrogate)")
    axes[1].axhline(outcome.deviation_before, color="tab:blue", ls="--",
                    label="before (full model)")  # fmt: skip
    axes[1].axhline(outcome.deviation_after, color="tab:red", ls="--",
                    label="after (full model)")  # fmt: skip
    axes[1].set_xlabel("cycle (surrogate rebuilt)")
    axes[1].set_ylabel("deviation: squared log10 residuals,\nsummed (dimensionless)")
    axes[1].set_title("deviation")
    axes[1].legend(fontsize=9)
    axes[1].grid(True, which="both", alpha=0.3)
    return _save(fig, path)


def _units(outcome: CaseResult) -> str:
    """The test FRFs' units (empty when not known)."""
    if outcome.data is not None:
        return outcome.data.units
    return outcome.identified.units if outcome.identified is not None else ""


def length_unit(units: str | None) -> str:
    """The length unit of FRF units such as ``mm/s^2/N`` or ``m/N`` (what the deck's
    coordinates are in, the test's units being the model's), or ``model length unit`` when
    they name none."""
    m = re.match(r"\s*(mm|cm|m|in|ft|um|µm)\b", units or "")
    return m.group(1) if m else "model length unit"


def vector_plot(path: Path, outcome: CaseResult) -> Path | None:
    """Test shape against FE shape (after calibration, scaled by the modal scale factor),
    component by component, for each paired mode: points on the diagonal agree; the three
    components farthest from it named by their sensor."""
    plt = pyplot()
    pairs = [m for m in outcome.modes if m.fe_after is not None]
    if not pairs:
        return None
    Cg = channel_matrix(outcome.model, outcome.outputs)
    fe = np.asarray(Cg @ outcome.modes_after.shapes[:, [m.fe_after - 1 for m in pairs]])
    cols = min(4, len(pairs))
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 3.6 * rows), squeeze=False)
    for ax in axes.flat[len(pairs):]:
        ax.set_visible(False)
    unit = "mass-normalised, model units"
    for k, (ax, pr) in enumerate(zip(axes.flat[: len(pairs)], pairs, strict=True)):
        a = fe[:, k]
        t_r = in_scale_of(outcome.test_shapes[:, pr.test_mode - 1], a)
        shape_scatter(ax, a, t_r)
        ax.set_title(f"test {pr.test_hz:.1f} Hz / FE {pr.fe_after_hz:.1f} Hz\n"
                     f"MAC {mac_text(pr.mac_after)}", fontsize=9)  # fmt: skip
        # the three farthest from the diagonal numbered, their names in the empty corner
        key = []
        for n, o in enumerate(np.argsort(np.abs(t_r - a))[::-1][:3], start=1):
            ch = outcome.outputs[o]
            ax.annotate(str(n), (a[o], t_r[o]), fontsize=8, color="tab:red",
                        xytext=(2, 2), textcoords="offset points")  # fmt: skip
            key.append(f"{n} {outcome.channel_names.get(ch.label, ch.label)}")
        ax.text(0.97, 0.03, "\n".join(key), transform=ax.transAxes, ha="right", va="bottom",
                fontsize=7.5, color="tab:red")  # fmt: skip
        ax.set_xlabel(f"FE shape after calibration\n({unit})", fontsize=9)
        ax.set_ylabel(f"test shape x MSF\n({unit})", fontsize=9)
    return _save(fig, path)


def model_form_plot(path: Path, outcome: CaseResult) -> Path | None:
    """Where the calibrated model still misses the test: on the frame, each sensor position
    coloured by its residual's RMS after calibration and the missing-element candidates
    numbered; beside it the residual's RMS over the channels at each frequency, before and
    after, with the test modes and the noise level."""
    form = outcome.model_form
    if form is None:
        return None
    plt = pyplot()
    model = outcome.model
    fig = plt.figure(figsize=(15, 5.8))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    xyz = model.xyz[model.is_grid]
    step = max(len(xyz) // 4000, 1)
    ax.scatter(*xyz[::step].T, s=0.3, c="0.75", depthshade=False)
    positions: dict[int, list[int]] = {}
    for o, ch in enumerate(outcome.outputs):
        if ch.grid is not None:
            positions.setdefault(ch.grid, []).append(o)
    if positions:
        grids = np.array(list(positions))
        at = model.xyz[model.node_index(grids)]
        rms = np.array([np.sqrt(np.mean(form.output_typical_after[v] ** 2))
                        for v in positions.values()])  # fmt: skip
        sc = ax.scatter(*at.T, c=rms, cmap="plasma", s=40, depthshade=False, edgecolors="k",
                        linewidths=0.4)  # fmt: skip
        fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.08,
                     label="typical residual after calibration (log10)")  # fmt: skip
        worst = np.argsort(rms)[::-1][:5]  # the worst five: a letter on the frame, named aside
        key = []
        for letter, i in zip("abcde", worst, strict=False):
            first = outcome.outputs[positions[int(grids[i])][0]]
            name = outcome.channel_names.get(first.label, first.label).split(" ")[0]
            ax.text(*at[i], f" {letter}", fontsize=10, weight="bold")
            key.append(f"{letter}: {name} ({rms[i]:.3g})")
        ax.text2D(0.0, 1.0, "worst sensors\n" + "\n".join(key), transform=ax.transAxes,
                  fontsize=9, va="top", family="monospace")  # fmt: skip
    for k, c in enumerate(form.candidates, start=1):
        ax.scatter(*c.xyz, marker="*", s=160, c="tab:red", depthshade=False)
        ax.text(*c.xyz, f"  {k}", color="tab:red", fontsize=9, weight="bold")
    length = length_unit(_units(outcome))
    for set_label, axis in ((ax.set_xlabel, "x"), (ax.set_ylabel, "y"), (ax.set_zlabel, "z")):
        set_label(f"{axis} ({length})")
    span = np.ptp(xyz, axis=0)
    ax.set_box_aspect(np.maximum(span, 0.05 * span.max()))
    ax.set_title("residual by sensor; red stars: missing-element candidates", fontsize=9)
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.semilogy(outcome.freq, form.frequency_typical_before, color="tab:blue", lw=0.9,
                 ls="--", label="typical, before calibration")  # fmt: skip
    ax2.semilogy(outcome.freq, form.frequency_typical_after, color="tab:red", lw=1.2,
                 label="typical, after calibration")  # fmt: skip
    ax2.semilogy(outcome.freq, form.frequency_rms_after, color="tab:red", lw=0.7, alpha=0.45,
                 label="RMS after (the antiresonances' tail)")  # fmt: skip
    if form.noise_sigma is not None:
        ax2.axhline(form.noise_sigma, color="k", lw=0.8, ls=":",
                    label="the test's noise (measured scatter)")  # fmt: skip
    for n, f in enumerate(outcome.test_hz):
        ax2.axvline(f, color="0.6", lw=0.6, label="test modes" if n == 0 else None)
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_ylabel("residual over the channels (log10)")
    ax2.set_title("residual by frequency")
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=9)
    return _save(fig, path)


def report_pictures(result: CalibrationResult, folder: Path) -> list[Figure]:
    """Every picture of the report in ``folder`` with its caption: the parameters' prior and
    posterior, the deviation history, and per configuration the FRFs of the worst-fitting
    channels before calibration and a spread of the others, with identified test modes the
    MAC matrices and the paired shapes (file names after the configuration's name where there
    are several)."""
    figures = [
        Figure("Parameters: prior, calibrated value and posterior",
               parameters_plot(folder / "parameters.png", result),
               "Left: each parameter's change from its nominal value (%), with the prior's "
               "standard deviation (grey bar about the nominal), the calibrated value with its "
               "posterior standard deviation (blue), held parameters (grey squares) and, for a "
               "synthetic test, the true change (red cross); a posterior bar much shorter than "
               "the prior's means the test informs the parameter. Right: the posterior "
               "correlation of the calibrated parameters; strong correlation means the test "
               "informs their combination more than each."),
        Figure("Deviation history", history_plot(folder / "history.png", result),
               "Left: the deviation plus the prior's term along the Levenberg-Marquardt "
               "iterations of every start of the first cycle (on the nominal surrogate). "
               "Right: the best deviation of each cycle on its surrogate, and the full "
               "model's before and after calibration."),
    ]  # fmt: skip
    several = len(result.cases) > 1
    for case in result.cases:
        pre = f"{case.name}_" if several else ""
        err = np.mean(np.abs(np.log10(np.abs(case.H_before / case.H_test))), axis=(1, 2))
        order = np.argsort(err)[::-1]
        chans = list(dict.fromkeys([*order[:2], *np.linspace(0, len(order) - 1, 4).astype(int)]))
        pairs = [(int(o), i) for o in chans[:3] for i in range(len(case.inputs))][:6]
        units = _units(case)
        figures.append(Figure(
            "FRFs: test, FE before and after",
            frf_comparison(folder / f"{pre}frf.png", case, pairs, units),
            "FRF magnitudes of the two channels that fit worst before calibration and a "
            "spread of the others, for each input (each panel: the output, by its sensor's "
            "name and channel, over the input; magnitude in the test's units"
            f"{f', {units}' if units else ''}): the measured FRF (grey), the identified "
            "test model with its damping equalised to zeta0 (black, what the FE model is "
            f"compared with), and the FE model before (blue, dashed) and after (red) "
            f"calibration, over the calibration band {case.band[0]:g}-{case.band[1]:g} "
            "Hz.", case.name))  # fmt: skip
        mf = model_form_plot(folder / f"{pre}model_form.png", case)
        if mf is not None:
            figures.append(Figure(
                "Model form: where the calibrated model still misses the test", mf,
                "Left: the frame (grey), each sensor position coloured by the typical size "
                "(robust standard deviation, RMS over its directions) of its residuals after "
                "calibration (the five worst named), and the missing-element "
                "candidates of the table above numbered in red. Right: the residuals' typical "
                "size over all channels at each frequency (robust standard deviation) before "
                "(blue, dashed) and after (red) calibration, their RMS after calibration "
                "(faint red: dominated by the few residuals near antiresonances), the "
                "identified test modes (grey lines) and the test's noise (dotted, the "
                "measured FRFs' scatter about the identified model): what stays far above "
                "the noise after calibration is what the model cannot represent.",
                case.name))  # fmt: skip
        if len(case.test_hz):  # test modes to correlate (an identified test model)
            figures.append(Figure(
                "MAC matrices", mac_matrices(folder / f"{pre}mac.png", case),
                "MAC of each identified test mode (rows) against the FE modes near the band "
                "(columns, by frequency) before and after calibration; values over 0.3 are "
                "printed.", case.name))  # fmt: skip
            vp = vector_plot(folder / f"{pre}vectors.png", case)
            if vp is not None:
                figures.append(Figure(
                    "Paired shapes, component against component", vp,
                    "For each test mode paired with an FE mode after calibration: every "
                    "sensor component of the test shape (scaled by the modal scale factor) "
                    "against the FE shape's, both in the FE model's mass-normalised units; "
                    "points on the diagonal agree, and the three farthest from it are named "
                    "by their sensor.",
                    case.name))  # fmt: skip
    return figures
