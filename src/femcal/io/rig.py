"""A drive iteration on disk: the JSON summary and the HTML page (RMS error of each control
channel at each iteration, the drives, the pictures). Each page is one file that can be sent
on: a header (femcal's version, when, the command, the input files with their sizes and
SHA-256 digests) and its pictures numbered, captioned and embedded as PNG data URIs (the PNG
files beside it stay, for other tools). Files are written atomically."""

from __future__ import annotations

import html
import json
import os
from pathlib import Path

import numpy as np

from ..atomic import write_lines
from ..rig.iterate import Iteration, IterationSettings
from ..rig.plant import RigPlant
from .html import HEADER_STYLE, embedded_figure, file_facts, html_header, html_table, provenance

_STYLE = ("body{font-family:sans-serif;margin:2em;max-width:1400px}"
          "table{border-collapse:collapse;margin:1em 0}"
          "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}th{background:#eee}"
          "img{max-width:100%;display:block;margin:0.5em 0}"
          "figcaption{color:#333;font-size:0.95em}" + HEADER_STYLE)


def iteration_dict(result: Iteration, plant: RigPlant, settings: IterationSettings, *,
                   target: str, model: str, plant_deck: str, frf: str,
                   uncontrolled: dict[str, float] | None = None) -> dict:  # fmt: skip
    """The JSON summary: settings, files, per control channel the RMS error (fraction of the
    target's RMS) after each step, each drive's RMS after each step, and each output's RMS
    in the last response."""
    names = [plant.outputs[c] for c in result.control]
    rms = np.sqrt(np.mean(result.response**2, axis=1))
    return {
        "target": target, "model": model, "plant": plant_deck, "frf": frf,
        "settings": {"iterations": settings.iterations, "gain": settings.gain,
                     "rcond": settings.rcond, "band_hz": list(settings.band)},
        "control": [{"channel": n, "rms_error": [float(e) for e in result.rms_error[:, k]]}
                    for k, n in enumerate(names)],
        "drives": [{"actuator": a, "unit": plant.input_units,
                    "rms": [float(v) for v in result.drives[:, j]]}
                   for j, a in enumerate(plant.inputs)],
        "response_rms": {n: float(v) for n, v in zip(plant.outputs, rms, strict=True)},
        "final_rms_error": {"worst": float(result.rms_error[-1].max()),
                            "median": float(np.median(result.rms_error[-1]))},
        **({"uncontrolled": uncontrolled} if uncontrolled else {}),
    }  # fmt: skip


def write_iteration_json(path: str | os.PathLike[str], report: dict) -> Path:
    return write_lines(path, [json.dumps(report, indent=1)])


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


def write_iteration_html(path: str | os.PathLike[str], report: dict,
                         figures: list[tuple[str, str, str]]) -> Path:  # fmt: skip
    """The page: a header (version, date, command, input files), what was iterated, the
    error table (channel x iteration), the drives' RMS, the pictures (title, PNG file
    relative to the page's folder, caption), numbered and embedded."""
    steps = len(report["control"][0]["rms_error"]) if report["control"] else 0
    head = ["control channel"] + [f"{k}" for k in range(steps)]
    rows = [[c["channel"], *(f"{100 * e:.2f}" for e in c["rms_error"])]
            for c in report["control"]]  # fmt: skip
    drives = [[d["actuator"], *(f"{v:.4g}" for v in d["rms"])] for d in report["drives"]]
    s = report["settings"]
    last = report["final_rms_error"]
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<title>femcal drive iteration</title><style>{_STYLE}</style></head><body>
<h1>femcal drive iteration</h1>
{_header(report, [("target", "target"), ("model", "model deck"), ("plant", "plant deck")])}
<p>Target <code>{html.escape(report['target'])}</code>; FRF inverted: {html.escape(report['frf'])}
of <code>{html.escape(report['model'])}</code>; plant played: <code>{
html.escape(report['plant'])}</code>. {s['iterations']} corrections with gain {s['gain']:g}, the
FRF's singular values below {s['rcond']:g} of the largest left out, drives in
{s['band_hz'][0]:g}-{s['band_hz'][1]:g} Hz.</p>
<p><b>After the last step the RMS error is {100 * last['worst']:.2f} % of the target's RMS at
worst, {100 * last['median']:.2f} % median.</b></p>
<h2>RMS error of each control channel (% of its target's RMS) after each step</h2>
{html_table(rows, head)}
<h2>RMS of each drive ({html.escape(report['drives'][0]['unit'] if report['drives'] else '')})
after each step</h2>
{html_table(drives, ["actuator"] + [f"{k}" for k in range(steps)])}
{_figures(path, figures)}
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
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<title>femcal: models on the virtual rig</title><style>{_STYLE}</style></head><body>
<h1>Models on the virtual rig</h1>
{_header(report, [("target", "target")])}
<p>Target <code>{html.escape(report['target'])}</code>. Each model is its own plant: its FRF
inverted, its drives iterated on it ({s['iterations']} corrections, gain {s['gain']:g}, band
{s['band_hz'][0]:g}-{s['band_hz'][1]:g} Hz) until its control channels follow the target. A
model that stands in for the physical rig needs the rig's drives and predicts what the rig
measured on the channels nobody controlled.</p>
<h2>Control channels after the last step (RMS error, % of the target's)</h2>
{''.join(parts)}
{_figures(path, figures)}
</body></html>"""
    return write_lines(path, [page])
