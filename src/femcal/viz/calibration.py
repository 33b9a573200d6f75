"""The calibration report: pictures (matplotlib Agg, pyvista off-screen) and an HTML page
beside ``report.json``. Every file is written atomically."""

from __future__ import annotations

import html
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..correlate.shapes import modal_scale_factor, pair_modes
from ..io.atomic import write_atomic


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    from .frf import save_figure

    save_figure(fig, path, dpi=100)
    return path


def frf_comparison(path: Path, outcome, pairs: list[tuple[int, int]]) -> Path:
    """Magnitude panels: the measured FRFs, the damping-equalised test model, the FE model
    before and after, for the given (output, input) index pairs."""
    plt = _plt()
    cols = min(3, len(pairs))
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 3.3 * rows), squeeze=False)
    data = outcome.data
    band = outcome.report["band_hz"]
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


def mac_matrices(path: Path, outcome) -> Path:
    """MAC between test modes and FE modes near the band, before and after."""
    plt = _plt()
    band = outcome.report["band_hz"]
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


def crlb_plot(path: Path, outcome) -> Path:
    """Per parameter: the change p and its Cramér-Rao bound (bars, %), and the bound's
    correlation matrix (the CRLB matrix normalised)."""
    plt = _plt()
    rep = outcome.report
    names = [p["name"] for p in rep["parameters"]]
    crlb = np.array([np.inf if p["crlb_p"] is None else p["crlb_p"] for p in rep["parameters"]])
    change = np.array([p["p"] for p in rep["parameters"]])
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.5), gridspec_kw={"width_ratios": [1.4, 1]})
    x = np.arange(len(names))
    ax = axes[0]
    shown = np.where(np.isfinite(crlb), crlb, np.nan) * 100
    ax.bar(x - 0.2, np.abs(change) * 100, 0.4, color="tab:red", label="|change| (%)")
    ax.bar(x + 0.2, shown, 0.4, color="tab:blue", label="CRLB (%)")
    ax.axhline(100 * rep["crlb"]["identifiable_below"], color="k", ls="--", lw=0.8,
               label="identifiable below")  # fmt: skip
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=90, fontsize=8)
    ax.set_ylabel("% of the nominal value")
    ax.set_title("parameter change and Cramér-Rao lower bound")
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    corr = np.array([[np.nan if v is None else v for v in row]
                     for row in rep["crlb"]["correlation"]])  # fmt: skip
    im = axes[1].imshow(corr, vmin=-1, vmax=1, cmap="RdBu_r")
    axes[1].set_xticks(x, names, rotation=90, fontsize=7)
    axes[1].set_yticks(x, names, fontsize=7)
    axes[1].set_title("CRLB matrix (correlation of the bound)")
    fig.colorbar(im, ax=axes[1], fraction=0.046)
    return _save(fig, path)


def history_plot(path: Path, outcome) -> Path:
    """Deviation along the iterations of every start of the first cycle, and the best
    deviation of each cycle."""
    plt = _plt()
    rep = outcome.report
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for s in rep["starts"]:
        axes[0].semilogy(s["history"], marker=".", lw=0.8, label=f"start {s['start'] + 1}")
    axes[0].set_xlabel("Levenberg-Marquardt iteration")
    axes[0].set_ylabel("deviation (surrogate)")
    axes[0].set_title("starts of the first cycle")
    axes[0].legend(fontsize=7, ncol=2)
    axes[0].grid(True, which="both", alpha=0.3)
    dev = [c["deviation"] for c in rep["cycles"]]
    axes[1].semilogy(range(1, len(dev) + 1), dev, "o-", label="best of each cycle (surrogate)")
    axes[1].axhline(rep["deviation"]["before"], color="tab:blue", ls="--",
                    label="before (full model)")  # fmt: skip
    axes[1].axhline(rep["deviation"]["after"], color="tab:red", ls="--",
                    label="after (full model)")  # fmt: skip
    axes[1].set_xlabel("cycle (surrogate rebuilt)")
    axes[1].set_title("deviation")
    axes[1].legend(fontsize=8)
    axes[1].grid(True, which="both", alpha=0.3)
    return _save(fig, path)


def vector_plot(path: Path, outcome) -> Path | None:
    """Test shape against FE shape (after calibration, scaled by the modal scale factor),
    component by component, for each paired mode: points on the diagonal agree."""
    plt = _plt()
    from ..response.frf import channel_matrix

    Cg = channel_matrix(outcome.model, outcome.outputs)
    fe = np.asarray(Cg @ outcome.modes_after.shapes)
    pairs = pair_modes(outcome.test_shapes, outcome.test_hz, fe,
                       outcome.modes_after.frequencies_hz)  # fmt: skip
    if not pairs:
        return None
    fig, axes = plt.subplots(1, len(pairs), figsize=(3.4 * len(pairs), 3.5), squeeze=False)
    for ax, pr in zip(axes[0], pairs, strict=True):
        t = outcome.test_shapes[:, pr.test]
        a = fe[:, pr.fe]
        s = modal_scale_factor(t, a)
        t_r = (t / s).real  # test shape in the FE shape's scale and phase
        ax.plot(a, t_r, ".", ms=4)
        lim = float(np.abs(np.concatenate([a, t_r])).max()) * 1.05
        ax.plot([-lim, lim], [-lim, lim], "k--", lw=0.7)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_title(f"test {outcome.test_hz[pr.test]:.1f} Hz / FE "
                     f"{outcome.modes_after.frequencies_hz[pr.fe]:.1f} Hz\nMAC {pr.mac:.3f}",
                     fontsize=8)  # fmt: skip
        ax.set_xlabel("FE (after)")
        ax.set_ylabel("test (scaled)")
    return _save(fig, path)


def _table(rows: list[list[str]], head: list[str]) -> str:
    h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                   for r in rows)  # fmt: skip
    return f"<table><tr>{h}</tr>{body}</table>"


def _f(v, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def write_html(path: Path, report: dict, pictures: dict[str, str], mode_pictures: list[str]
               ) -> Path:  # fmt: skip
    """The HTML page: tables of parameters, modes, deviation and runs, and the pictures."""
    prm = [[p["name"], p["description"], f"{p['card']} {p['id']} {p['field']}",
            _f(p["nominal"], ".6g"), _f(p["calibrated"], ".6g"), f"{100 * p['p']:+.2f}",
            f"[{p['lower']:.6g}, {p['upper']:.6g}]", _f(p["crlb"], ".3g"),
            _f(None if p["crlb_p"] is None else 100 * p["crlb_p"], ".2f"),
            ("yes" if p["identifiable"] else "no") + (" (at a bound)" if p["at_bound"] else "")]
           for p in report["parameters"]]  # fmt: skip
    prm_head = ["name", "description", "field", "nominal", "calibrated", "change %", "bounds",
                "CRLB", "CRLB %", "identifiable"]  # fmt: skip
    truth = report.get("truth")
    if truth:  # a synthetic test: each parameter's error against its known value and CRLB
        for row, p in zip(prm, report["parameters"], strict=True):
            row += [_f(p["true"], ".6g"), _f(p["error_pct"], "+.2f"),
                    _f(p["error_over_crlb"], ".1f")]  # fmt: skip
        prm_head += ["true", "error %", "|error| / CRLB"]
    modes = [[f"{m['test_hz']:.3f}", _f(m["fe_before_hz"], ".3f"), _f(m["fe_after_hz"], ".3f"),
              _f(m["frequency_error_before_pct"], "+.2f"),
              _f(m["frequency_error_after_pct"], "+.2f"), _f(m["mac_before"], ".4f"),
              _f(m["mac_after"], ".4f")] for m in report["modes"]]  # fmt: skip
    cyc = [[c["cycle"], "multi-start" if c["cycle"] == 1 else
            ("kept" if c["accepted"] else "rejected")
            + (" (search candidate)" if c.get("from_search") else ""),
            _f(c.get("exact_deviation_at_candidate", c.get("exact_deviation_at_center")), ".6g"),
            _f(c.get("rho"), ".2f"), _f(c.get("radius"), ".3g"),
            _f(c.get("moved_informed", c.get("moved")), ".2e"),
            _f(c.get("search_best_deviation"), ".6g") if c.get("searched") else ""]
           for c in report["cycles"]]  # fmt: skip
    starts = [[s["start"] + 1, f"{s['history'][0]:.6g}", f"{s['deviation']:.6g}",
               s["iterations"], f"{s['seconds']:.1f}", s["message"]]
              for s in report["starts"]]  # fmt: skip
    dev = report["deviation"]
    imgs = "".join(f"<h2>{html.escape(t)}</h2><img src='{html.escape(src)}'>"
                   for t, src in pictures.items())  # fmt: skip
    mimgs = "".join(f"<img class='mode' src='{html.escape(s)}'>" for s in mode_pictures)
    deck = html.escape(report["calibrated_deck"])
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>femcal calibration</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:1500px}}table{{border-collapse:collapse;
margin:1em 0}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:right}}th{{background:#eee}}
img{{max-width:100%;display:block;margin:0.5em 0}}img.mode{{max-width:48%;display:inline-block}}
</style></head><body>
<h1>femcal calibration</h1>
<p>Deck {html.escape(report['deck'])}; test {html.escape(report['test'])}; band
{report['band_hz'][0]:g}-{report['band_hz'][1]:g} Hz; metric {report['metric']} at
{report['n_frequencies']} frequencies; damping equalised to zeta0 = {report['zeta0']:.4f};
{len(report['outputs'])} outputs x {len(report['inputs'])} inputs; channels left out:
{html.escape(', '.join(report['excluded_channels']) or 'none')}.
Calibrated deck: <a href="{deck}">{deck}</a>.
Run time {report['seconds']:.0f} s.</p>
<h2>Deviation</h2><p>before {dev['before']:.6g}, after {dev['after']:.6g}
(full model, log10 FRF residuals squared and summed){'' if report['settled'] else
'; the parameters had not settled when the cycles ran out'}.</p>
<h2>Parameters</h2>{_table(prm, prm_head)}
<p>CRLB: Cramér-Rao lower bound (one standard deviation) with sigma = {report['crlb']['sigma']:.4g}
({'given' if report['crlb']['sigma_given'] else 'from the residual'}); identifiable: CRLB below
{100 * report['crlb']['identifiable_below']:g} % of the nominal.{
f" True values: {html.escape(truth)} (a synthetic test)." if truth else ""}</p>
<h2>Modes</h2>{_table(modes, ["test Hz", "FE before Hz", "FE after Hz", "error before %",
 "error after %", "MAC before", "MAC after"])}
<h2>Runs</h2><p>Cycle 1 runs Levenberg-Marquardt from every start on the nominal model's
surrogate; each later cycle rebuilds the surrogate at the candidate point, where it is the full
model, keeps the step if the full model's cost fell (trust region) and runs LM again inside the
trust radius. When a kept step lowers the cost by less than {
100 * report.get('restart_fall', 0):g} %, or the cycles settle, the multi-start search runs again
on the current surrogate ({report.get('restarts', 0)} times here); a lower minimum elsewhere is
the next candidate.</p>{_table(cyc, ["cycle", "step", "full-model deviation at the candidate",
 "actual / predicted fall", "trust radius", "largest change (informed parameters)",
 "search again: best deviation (surrogate)"])}
{_table(starts, ["start", "deviation at start", "deviation", "iterations", "seconds", "stop"])}
{imgs}<h2>Paired modes after calibration</h2>{mimgs}
</body></html>
"""
    return write_atomic(path, lambda tmp: Path(tmp).write_text(page))


def write_report(outcome, out: str | os.PathLike[str], *,
                 progress: Callable[[str], None] | None = None) -> Path:  # fmt: skip
    """All pictures and ``report.html`` in ``out`` (``report.json`` is written by the run)."""
    say = progress or (lambda _m: None)
    out = Path(out)
    pics = out / "pictures"
    pics.mkdir(parents=True, exist_ok=True)
    # channels: the worst-fitting before calibration and a spread, first and second input
    err = np.mean(np.abs(np.log10(np.abs(outcome.H_before / outcome.H_test))), axis=(1, 2))
    order = np.argsort(err)[::-1]
    chans = list(dict.fromkeys([*order[:2], *np.linspace(0, len(order) - 1, 4).astype(int)]))
    pairs = [(int(o), i) for o in chans[:3] for i in range(len(outcome.inputs))][:6]
    pictures = {"FRFs: test, FE before and after": frf_comparison(pics / "frf.png", outcome, pairs),
                "Parameter changes and Cramér-Rao bounds": crlb_plot(pics / "crlb.png", outcome),
                "Deviation history": history_plot(pics / "history.png", outcome)}  # fmt: skip
    if len(outcome.test_hz):  # test modes to correlate (an identified test model)
        pictures["MAC matrices"] = mac_matrices(pics / "mac.png", outcome)
        vp = vector_plot(pics / "vectors.png", outcome)
        if vp is not None:
            pictures["Paired shapes, component against component"] = vp
    say("rendering the calibrated model's paired modes")
    from ..response.frf import channel_matrix
    from .render import render_modes

    fe = np.asarray(channel_matrix(outcome.model, outcome.outputs) @ outcome.modes_after.shapes)
    which: list[int] = []
    if len(outcome.test_hz):
        pairs_after = pair_modes(outcome.test_shapes, outcome.test_hz, fe,
                                 outcome.modes_after.frequencies_hz)  # fmt: skip
        which = sorted({p.fe for p in pairs_after})
    mode_pngs = []
    if which:
        mode_pngs = render_modes(outcome.modes_after, outcome.model, pics / "modes",
                                 title="calibrated", which=which, window=(960, 600))  # fmt: skip
    rel = {t: str(p.relative_to(out)) for t, p in pictures.items()}
    page = write_html(out / "report.html", outcome.report, rel,
                      [str(p.relative_to(out)) for p in mode_pngs])  # fmt: skip
    say(f"wrote {page} and {len(pictures) + len(mode_pngs)} pictures")
    return page
