"""A drive iteration on disk: the JSON summary and the HTML page (RMS error of each control
channel at each iteration, the drives, the pictures). Each page is one file that can be sent
on: a header (femcal's version, when, the command, the input files with their sizes and
SHA-256 digests) and its pictures numbered, captioned and embedded as PNG data URIs (the PNG
files beside it stay, for other tools). Files are written atomically."""

from __future__ import annotations

import html
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_lines
from ..rig.iterate import Correction, Iteration, IterationSettings
from ..rig.limits import QUANTITIES, LimitCheck
from ..rig.plant import RigPlant
from ..rig.quality import ChannelStats, band_errors
from .html import PAGE_STYLE, embedded_figure, file_facts, html_header, html_table, provenance

_STYLE = PAGE_STYLE + ".warn{color:#a00}"

#: A control channel whose in-band error stays above this after the last step is doubted.
STILL_OFF = 0.10


def settings_dict(settings: IterationSettings) -> dict:
    """The iteration's settings as JSON."""
    s = settings
    return {"iterations": s.iterations, "gain": s.gain, "band_hz": list(s.band),
            "noise_floor": "measured" if s.noise_floor is None else s.noise_floor,
            "effort": s.effort, "roll_off_hz": s.roll_off_hz, "update_frf": s.update_frf,
            "taper_s": "when the ends do not join" if s.taper_s is None else s.taper_s,
            "warp": s.warp}


@dataclass(frozen=True)
class IterationFacts:
    """What the command adds to an iteration for its report.

    Attributes
    ----------
    limits : the last drive's peaks against the actuators' limits.
    limit_action : warn, scale or refuse; scale : the factor the drive was scaled by (1:
        not); drive_written : whether drive.rsp was written.
    stats : the control channels' minimum, maximum and RMS (target as iterated and
        response).
    damage : (n_control,) relative damage, response over target; sn_slope : its S-N slope.
    reference_error : (n_drives,) in the band, RMS of drive - reference over the
        reference's, when a reference drive was given; reference_rms : (n_drives,) its RMS.
    """

    limits: LimitCheck
    limit_action: str
    scale: float
    drive_written: bool
    stats: ChannelStats
    damage: np.ndarray
    sn_slope: float
    reference_error: np.ndarray | None = None
    reference_rms: np.ndarray | None = None


def _directions(plant: RigPlant, unseen, redundant: np.ndarray, redundant_unseen) -> dict:
    """The drive directions not seen and the redundant combinations, as JSON."""
    def by_actuator(values: np.ndarray) -> dict[str, float]:
        return {a: float(v) for a, v in zip(plant.inputs, values, strict=True)}

    return {"unseen": [{"low_hz": u.low_hz, "high_hz": u.high_hz, "directions": u.directions,
                        "pattern": by_actuator(u.pattern)} for u in unseen],
            "redundant": [{"pattern": by_actuator(redundant[:, k]),
                           "unseen_hz": [list(b) for b in redundant_unseen[k]]}
                          for k in range(redundant.shape[1])]}  # fmt: skip


def _limits_dict(facts: IterationFacts, plant: RigPlant) -> dict:
    """What the limits check found and did, as JSON."""
    return {"action": facts.limit_action, "exceeded": facts.limits.exceeded,
            "worst_ratio": facts.limits.worst, "scale": facts.scale,
            "drive_written": facts.drive_written,
            "messages": facts.limits.messages(plant.inputs, plant.input_units)}  # fmt: skip


def iteration_dict(result: Iteration, plant: RigPlant, settings: IterationSettings, *,
                   target: str, model: str, plant_deck: str, frf: str,
                   facts: IterationFacts | None = None,
                   uncontrolled: dict[str, float] | None = None) -> dict:  # fmt: skip
    """The JSON summary: settings, files, the target's noise floor and taper, per control
    channel its weight, in-band and out-of-band error after each step, its state, extremes
    and relative damage; per drive its RMS after each step and its peaks against its
    limits; the drive directions not seen; and each output's RMS in the last response."""
    names = [plant.outputs[c] for c in result.control]
    rms = np.sqrt(np.mean(result.response**2, axis=1))
    control = []
    for k, n in enumerate(names):
        entry = {"channel": n, "rms_error": [float(e) for e in result.rms_error[:, k]]}
        if result.out_of_band.size:
            entry["out_of_band_error"] = [float(e) for e in result.out_of_band[:, k]]
        if result.weights.size:
            entry["weight"] = float(result.weights[k])
        if result.status:
            entry["status"] = result.status[k]
        if result.noise is not None:
            entry["noise_floor"] = float(result.noise.fraction[k])
        if facts is not None:
            entry["target"] = facts.stats.of("target", k)
            entry["response"] = facts.stats.of("response", k)
            entry["relative_damage"] = float(facts.damage[k])
        control.append(entry)
    drives = []
    for j, a in enumerate(plant.inputs):
        entry = {"actuator": a, "unit": plant.input_units,
                 "rms": [float(v) for v in result.drives[:, j]]}
        if facts is not None:
            for q, name in enumerate(QUANTITIES):
                entry[f"peak_{name}"] = float(facts.limits.peak[q, j])
                lim = facts.limits.limit[q, j]
                entry[f"limit_{name}"] = float(lim) if np.isfinite(lim) else None
            if facts.reference_error is not None:
                entry["reference_rms"] = float(facts.reference_rms[j])
                entry["reference_error"] = float(facts.reference_error[j])
        drives.append(entry)
    report = {
        "target": target, "model": model, "plant": plant_deck, "frf": frf,
        "settings": settings_dict(settings),
        "taper_s": result.taper_s,
        "control": control,
        "drives": drives,
        **_directions(plant, result.unseen, result.redundant, result.redundant_unseen),
        "frf_updates": list(result.frf_updates),
        "response_rms": {n: float(v) for n, v in zip(plant.outputs, rms, strict=True)},
        "final_rms_error": _worst_and_median(result.rms_error[-1]),
        **({"uncontrolled": uncontrolled} if uncontrolled else {}),
    }  # fmt: skip
    if result.noise is not None:
        report["noise_floor"] = {"source": result.noise.source,
                                 "measured": result.noise.measured}
    if facts is not None:
        report["limits"] = _limits_dict(facts, plant)
        report["sn_slope"] = facts.sn_slope
    return report


def correction_dict(step: Correction, plant: RigPlant, settings: IterationSettings,
                    control: list[str], drives: list[np.ndarray],
                    responses: list[np.ndarray], dt: float, facts: IterationFacts, *,
                    target: str, model: str, frf: str) -> dict:  # fmt: skip
    """The JSON summary of one step of a physical rig's iteration, in the form of
    :func:`iteration_dict` (read by :func:`write_iteration_html`): per control channel its
    errors for each response given, in and outside the band; per drive its RMS for each
    drive played and the next one, and the next one's peaks against its limits."""
    p = step.prepared
    errors = [band_errors(p.target, r, dt, settings.band) for r in responses]
    out = []
    for k, name in enumerate(control):
        entry = {"channel": name, "rms_error": [float(e.in_band[k]) for e in errors],
                 "out_of_band_error": [float(e.out_of_band[k]) for e in errors],
                 "weight": float(p.channel_weight[k]),
                 "noise_floor": float(p.noise.fraction[k])}  # fmt: skip
        if responses:
            entry["target"] = facts.stats.of("target", k)
            entry["response"] = facts.stats.of("response", k)
            entry["relative_damage"] = float(facts.damage[k])
        out.append(entry)
    played = [*drives, step.drive]
    drive_rows = []
    for j, a in enumerate(plant.inputs):
        entry = {"actuator": a, "unit": plant.input_units,
                 "rms": [float(np.sqrt(np.mean(d[j] ** 2))) for d in played]}
        for q, name in enumerate(QUANTITIES):
            entry[f"peak_{name}"] = float(facts.limits.peak[q, j])
            lim = facts.limits.limit[q, j]
            entry[f"limit_{name}"] = float(lim) if np.isfinite(lim) else None
        drive_rows.append(entry)
    last = errors[-1].in_band if errors else np.full(len(control), np.nan)
    return {
        "target": target, "model": model, "plant": "the physical rig (by files)", "frf": frf,
        "settings": settings_dict(settings), "taper_s": p.taper_s, "next_drive": True,
        "control": out, "drives": drive_rows,
        **_directions(plant, step.unseen, p.redundant, step.redundant_unseen),
        "frf_updates": list(step.frf_updates),
        "final_rms_error": _worst_and_median(last),
        "noise_floor": {"source": p.noise.source, "measured": p.noise.measured},
        "limits": _limits_dict(facts, plant),
        "sn_slope": facts.sn_slope,
    }  # fmt: skip


def _worst_and_median(errors: np.ndarray) -> dict:
    """The worst and the median of the channels' errors that are defined (None if none is:
    every target held at zero)."""
    e = errors[np.isfinite(errors)]
    return {"worst": float(e.max()) if e.size else None,
            "median": float(np.median(e)) if e.size else None}


def _pct(x: float | None) -> str:
    """A fraction as a percentage with two decimals, '-' where it is not defined."""
    return f"{100 * x:.2f}" if x is not None and np.isfinite(x) else "-"


def _num(x: float | None, fmt: str) -> str:
    return format(x, fmt) if x is not None and np.isfinite(x) else "-"


def _jsonable(value):
    """``value`` with every NaN or infinite float as None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def write_iteration_json(path: str | os.PathLike[str], report: dict) -> Path:
    """The report as JSON (NaN, such as the relative error of a target held at zero, as
    null)."""
    return write_lines(path, [json.dumps(_jsonable(report), indent=1)])


def _figures(path: str | os.PathLike[str], figures: list[tuple[str, str, str]]) -> str:
    """The pictures (title, PNG file relative to the page's folder, caption), numbered and
    embedded."""
    folder = Path(path).parent
    return "".join(embedded_figure(title, folder / file, caption, number=k)
                   for k, (title, file, caption) in enumerate(figures, start=1))  # fmt: skip


def _header(report: dict, roles: list[tuple[str, str]]) -> str:
    """The page's header: version, date, command, and the report's files named by ``roles``
    (report key, role), each file once."""
    seen: set[str] = set()
    inputs = []
    for key, role in roles:
        name = report.get(key)
        if name and name not in seen and Path(name).is_file():
            seen.add(name)
            inputs.append(file_facts(role, name))
    return html_header(provenance(inputs))


def _settings_text(s: dict) -> str:
    """The iteration's settings in a sentence."""
    floor = ("measured on the target" if s.get("noise_floor", "measured") == "measured"
             else f"{s['noise_floor']:g} of each channel's RMS")  # fmt: skip
    parts = [f"{s['iterations']} corrections with gain {s['gain']:g}",
             f"drives in {s['band_hz'][0]:g}-{s['band_hz'][1]:g} Hz",
             f"noise floor {floor}"]  # fmt: skip
    if s.get("effort"):
        parts.append(f"drive-effort penalty {s['effort']:g}")
    if s.get("roll_off_hz"):
        parts.append(f"roll-off below {s['roll_off_hz']:g} Hz")
    parts.append("FRF updated from each step" if s.get("update_frf", False)
                 else "FRF kept as inverted")  # fmt: skip
    return "; ".join(parts)


def iteration_verdict(report: dict) -> tuple[list[list[str]], list[str]]:
    """What an engineer decides from, first on the page: (rows of [what, first step, last
    step], what to doubt: channels still off or made worse, quiet channels, drives over their
    limits, drive directions the control channels do not see, a drive unlike the reference)."""
    control = report["control"]
    steps = len(control[0]["rms_error"]) if control else 0
    rows: list[list[str]] = []
    doubts: list[str] = []
    if steps:
        first = _worst_and_median(np.array([c["rms_error"][0] for c in control], float))
        last = report["final_rms_error"]
        worst = max(control, key=lambda c: -np.inf if c["rms_error"][-1] is None
                    or not np.isfinite(c["rms_error"][-1]) else c["rms_error"][-1])
        rows += [["control error in the band, worst (% of the target's RMS)",
                  _pct(first["worst"]), f"{_pct(last['worst'])} ({worst['channel']})"],
                 ["control error in the band, median (%)", _pct(first["median"]),
                  _pct(last["median"])]]  # fmt: skip
        for c in control:
            e = c["rms_error"]
            if e[-1] is None or not np.isfinite(e[-1]):
                continue
            if e[-1] > STILL_OFF:
                grew = steps > 1 and e[-1] > e[0]
                doubts.append(f"{c['channel']}: still {_pct(e[-1])} % off after the last step"
                              + (f" (it was {_pct(e[0])} %: the iteration made it worse; "
                                 "the model's FRF is wrong there, or the channel is)"
                                 if grew else "") + ".")  # fmt: skip
    for c in control:
        if "status" in c:
            doubts.append(f"{c['channel']}: {c['status']}.")
    limits = report.get("limits")
    if limits and report["drives"] and "peak_stroke" in report["drives"][0]:
        rows.append(["drive peaks, largest share of a limit", "",
                     f"{100 * limits['worst_ratio']:.0f} %" if limits.get("worst_ratio")
                     is not None else "no limits given"])  # fmt: skip
        if limits["exceeded"]:
            doubts += list(limits["messages"])
    if report["drives"] and "reference_error" in report["drives"][0]:
        worst_ref = max(report["drives"], key=lambda d: d["reference_error"])
        rows.append(["drive against the reference drive, worst (%)", "",
                     f"{100 * worst_ref['reference_error']:.1f} ({worst_ref['actuator']})"])
        if worst_ref["reference_error"] > STILL_OFF:
            doubts.append(f"The drive differs from the reference drive by "
                          f"{100 * worst_ref['reference_error']:.1f} % at "
                          f"{worst_ref['actuator']}: responses matched with other drives "
                          "than the physical ones (the model, or an unseen direction).")
    if report.get("unseen"):
        doubts.append(f"{len(report['unseen'])} frequency band(s) where the control channels "
                      "do not see every drive direction above the noise: the drive is held "
                      "at its least effort there (see below).")
    return rows, doubts or ["Nothing stands out."]


def _verdict_block(rows: list[list[str]], head: list[str], doubts: list[str],
                   label: str = "What to doubt") -> str:  # fmt: skip
    esc = html.escape
    return ("<section id='verdict' class='verdict'><h2>Verdict</h2>"
            + (html_table(rows, head) if rows else "")
            + f"<p><b>{esc(label)}</b></p><ul class='doubt'>"
            + "".join(f"<li>{esc(d)}</li>" for d in doubts) + "</ul></section>")


def write_iteration_html(path: str | os.PathLike[str], report: dict,
                         figures: list[tuple[str, str, str]]) -> Path:  # fmt: skip
    """The page: a header (version, date, command, input files), what was iterated and how,
    each control channel's state, the error tables (in the band after each step, outside
    it), the channels' extremes and relative damage, the drives against their limits, the
    drive directions the control channels do not see, and the pictures (title, PNG file
    relative to the page's folder, caption), numbered and embedded."""
    esc = html.escape
    steps = len(report["control"][0]["rms_error"]) if report["control"] else 0
    head = ["control channel", "weight"] + [f"{k}" for k in range(steps)] + ["outside band"]
    rows = [[c["channel"], f"{c.get('weight', 1.0):g}",
             *(_pct(e) for e in c["rms_error"]),
             _pct(c["out_of_band_error"][-1]) if c.get("out_of_band_error") else "-"]
            for c in report["control"]]  # fmt: skip
    unit = report["drives"][0]["unit"] if report["drives"] else ""
    drives = [[d["actuator"], *(f"{v:.4g}" for v in d["rms"])] for d in report["drives"]]
    last = report["final_rms_error"]
    parts = []
    status = [c for c in report["control"] if "status" in c]
    if status:
        parts.append("<h2>State of each control channel</h2><ul>" + "".join(
            f"<li><b>{esc(c['channel'])}</b>: {esc(c['status'])}</li>" for c in status)
            + "</ul>")  # fmt: skip
    limits = report.get("limits")
    if limits:
        if limits["exceeded"]:
            what = {"warn": "written as found, with this warning",
                    "scale": f"scaled down by {limits['scale']:.3g} as a whole, then written",
                    "refuse": "<b>not written</b>"}[limits["action"]]  # fmt: skip
            parts.append(f"<p class=\"warn\"><b>The drive exceeds the actuators' limits</b> "
                         f"(--on-limit {esc(limits['action'])}: {what}):</p><ul>"
                         + "".join(f"<li>{esc(m)}</li>" for m in limits["messages"])
                         + "</ul>")  # fmt: skip
        elif limits.get("scale", 1.0) < 1.0:
            parts.append(f"<p class=\"warn\"><b>The drive found exceeded the actuators' "
                         f"limits</b> (--on-limit scale): it was scaled down by "
                         f"{limits['scale']:.3g} as a whole, and the last step's errors and "
                         "peaks are those of the drive written.</p>")
        elif any(d.get(f"limit_{q}") for d in report["drives"] for q in QUANTITIES):
            parts.append(f"<p>The drive stays within every limit given (at worst "
                         f"{100 * limits['worst_ratio']:.0f} % of one).</p>")
    if steps:
        parts.append("<h2>RMS error of each control channel in the drive band (% of the "
                     "target's RMS there) after each step; outside the band (% of the "
                     "target's whole RMS) after the last</h2>" + html_table(rows, head))
    if report["control"] and "target" in report["control"][0]:
        stat_rows = [[c["channel"], *(f"{c[w][k]:.4g}" for w in ("target", "response")
                                       for k in ("min", "max", "mean", "rms")),
                      _num(c["relative_damage"], ".3g")] for c in report["control"]]  # fmt: skip
        parts.append(f"<h2>Control channels: extremes, mean, RMS (mean included) and "
                     f"relative damage (S-N slope {report.get('sn_slope', 0):g})</h2>"
                     + html_table(stat_rows, [
                         "channel", "target min", "target max", "target mean", "target RMS",
                         "response min", "response max", "response mean", "response RMS",
                         "damage response / target"]))
    n_drive_steps = len(report["drives"][0]["rms"]) if report["drives"] else 0
    drive_head = [f"{k}" for k in range(n_drive_steps)]
    if report.get("next_drive"):
        drive_head[-1] = "next"
    parts.append(f"<h2>RMS of each drive ({esc(unit)}) after each step</h2>"
                 + html_table(drives, ["actuator", *drive_head]))
    if report["drives"] and "peak_stroke" in report["drives"][0]:
        units = (unit, f"{unit}/s", f"{unit}/s²")

        def cell(d: dict, q: str) -> str:
            lim = d[f"limit_{q}"]
            return f"{d[f'peak_{q}']:.4g}" + (f" / {lim:.4g}" if lim is not None else "")

        lim_rows = [[d["actuator"], *(cell(d, q) for q in QUANTITIES),
                     *([f"{d['reference_rms']:.4g}", f"{100 * d['reference_error']:.1f}"]
                       if "reference_error" in d else [])] for d in report["drives"]]
        lim_head = ["actuator", *(f"peak {q} ({u}) / limit" for q, u in zip(
            QUANTITIES, units, strict=True))]  # fmt: skip
        if report["drives"] and "reference_error" in report["drives"][0]:
            lim_head += [f"reference RMS ({unit})", "drive - reference in band (%)"]
        parts.append("<h2>Last drive: peaks against the actuators' limits</h2>"
                     + html_table(lim_rows, lim_head))
    unseen = report.get("unseen", [])
    if unseen:
        n_drives = len(report["drives"])
        rows_u = [[f"{u['low_hz']:.3g}-{u['high_hz']:.3g}", f"{u['directions']} of {n_drives}",
                   "all" if u["directions"] >= n_drives else esc(" ".join(
                       f"{v:+.2f} {a}" for a, v in sorted(u["pattern"].items(),
                                                          key=lambda kv: -abs(kv[1]))
                       if abs(v) >= 0.2))] for u in unseen]  # fmt: skip
        parts.append("<h2>Drive directions the control channels do not see above the "
                     "target's noise</h2><p>There the inverse keeps less than half of the "
                     "drive a direction would need: the drive is held near the least effort "
                     "(the minimal-warp drive, when the warp is the unseen direction) instead "
                     "of amplifying noise and model error. Control channels that see them "
                     "(LVDTs, load cells) release them.</p>"
                     + html_table(rows_u, ["band (Hz)", "directions", "weakest direction"]))
    redundant = report.get("redundant", [])
    if redundant:
        minimal = report["settings"].get("warp") == "minimal"
        items = []
        for k, r in enumerate(redundant):
            name = "The warp" if len(redundant) == 1 else f"Redundant combination {k + 1}"
            top = max(abs(v) for v in r["pattern"].values()) or 1.0
            what = " ".join(f"{v / top:+.2f} {a}" for a, v in r["pattern"].items()
                            if abs(v) >= 0.2 * top)  # fmt: skip
            if minimal:
                done = "held at its least everywhere (--warp minimal)"
            elif r["unseen_hz"]:
                done = ("not seen above the noise at " + ", ".join(
                    f"{a:.3g}-{b:.3g} Hz" for a, b in r["unseen_hz"])
                    + ": held at its least there")  # fmt: skip
            else:
                done = "seen by the control channels throughout the band"
            items.append(f"<li>{name} ({esc(what)}): {done}</li>")
        parts.append("<h2>Redundant actuators</h2><p>More actuators than the frame has "
                     "rigid-body motions: these drive combinations only deform it.</p><ul>"
                     + "".join(items) + "</ul>")
    noise = report.get("noise_floor")
    taper = report.get("taper_s", 0.0)
    v_rows, doubts = iteration_verdict(report)
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>femcal drive iteration</title><style>{_STYLE}</style></head><body>
<h1>femcal drive iteration</h1>
{_verdict_block(v_rows, ["", "first step", "last step"], doubts)}
<p>Target <code>{esc(report['target'])}</code>; FRF inverted: {esc(report['frf'])}
of <code>{esc(report['model'])}</code>; plant played: <code>{esc(report['plant'])}</code>.
{esc(_settings_text(report['settings']))}.{
f" The target's noise floor: {esc(noise['source'])}." if noise else ""}{
f" Its ends do not join: faded in and out over {taper:g} s." if taper else ""}</p>
<p><b>{f"After the last step the RMS error in the drive band is {_pct(last['worst'])} % of "
f"the target's at worst, {_pct(last['median'])} % median." if steps else
"No response measured yet: the drive is the first one."}</b></p>
{''.join(parts)}
{_figures(path, figures)}
<h2 id='provenance'>Provenance</h2>
{_header(report, [("target", "target"), ("model", "model deck"), ("plant", "plant deck")])}
</body></html>"""
    return write_lines(path, [page])


def write_comparison_html(path: str | os.PathLike[str], report: dict,
                          figures: list[tuple[str, str, str]]) -> Path:  # fmt: skip
    """The page of a comparison of models on the virtual rig: a header (version, date,
    command, the target file), each model's control error, drive errors against the
    reference drive, uncontrolled channels' errors, the pictures (title, PNG file relative to
    the page's folder, caption), numbered and embedded."""
    models = report["models"]
    names = [m["name"] for m in models]
    control = [[c, *(f"{100 * m['control_rms_error'][k]:.2f}" for m in models)]
               for k, c in enumerate(report["control"])]  # fmt: skip
    parts = [html_table(control, ["control channel (error %)", *names])]
    if models and "drive_rms_error" in models[0]:
        rows = [[a, *(f"{100 * m['drive_rms_error'][a]:.2f}" for m in models)]
                for a in report["actuators"]]  # fmt: skip
        parts += ["<h2>Drives: RMS of (model's drive - reference drive) in the band, % of the "
                  "reference's</h2>", html_table(rows, ["actuator", *names])]
    others = list(models[0]["uncontrolled_rms_error"]) if models else []
    if others:
        rows = [[c, *(f"{100 * m['uncontrolled_rms_error'][c]:.2f}" for m in models)]
                for c in others]  # fmt: skip
        parts += ["<h2>Uncontrolled channels: RMS of (predicted - measured), % of the "
                  "measured RMS</h2>", html_table(rows, ["channel", *names])]
    s = report["settings"]
    v_rows = [["control error, median (%)",
               *(f"{100 * np.nanmedian(m['control_rms_error']):.2f}" for m in models)],
              ["control error, worst (%)",
               *(f"{100 * np.nanmax(m['control_rms_error']):.2f}" for m in models)]]
    doubts = []
    if models and "drive_rms_error" in models[0]:
        v_rows.append(["drive - reference drive, worst (%)",
                       *(f"{100 * max(m['drive_rms_error'].values()):.2f}" for m in models)])
        best = min(models, key=lambda m: max(m["drive_rms_error"].values()))
        doubts.append(f"Nearest the physical drives: {best['name']} (worst actuator "
                      f"{100 * max(best['drive_rms_error'].values()):.1f} %).")
    if others:
        v_rows.append(["uncontrolled channels, median error (%)",
                       *(f"{100 * np.nanmedian(list(m['uncontrolled_rms_error'].values())):.2f}"
                         for m in models)])  # fmt: skip
        best = min(models, key=lambda m: np.nanmedian(list(m["uncontrolled_rms_error"]
                                                           .values())))
        doubts.append(f"Best prediction of the channels nobody controlled: {best['name']}.")
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>femcal: models on the virtual rig</title><style>{_STYLE}</style></head><body>
<h1>Models on the virtual rig</h1>
{_verdict_block(v_rows, ["", *names], doubts or ["Nothing stands out."], "Which model")}
<p>Target <code>{html.escape(report['target'])}</code>. Each model is its own plant: its FRF
inverted, its drives iterated on it ({s['iterations']} corrections, gain {s['gain']:g}, band
{s['band_hz'][0]:g}-{s['band_hz'][1]:g} Hz) until its control channels follow the target. A
model that stands in for the physical rig needs the rig's drives and predicts what the rig
measured on the channels nobody controlled.</p>
<h2>Control channels after the last step (RMS error, % of the target's)</h2>
{''.join(parts)}
{_figures(path, figures)}
<h2 id='provenance'>Provenance</h2>
{_header(report, [("target", "target")])}
</body></html>"""
    return write_lines(path, [page])
