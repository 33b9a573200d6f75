"""Synthetic hammer test: lab-like FRF data made from a deck the calibration will not see.

The "real" frame differs from the FE model in three ways, as a test article does:

* a hidden parameter set: every calibration parameter (PSHELL T, PBAR A, MAT1 E ...) drawn
  uniformly within ``spread`` times its bounds around the nominal (P = P0 (1 + p));
* a model-form difference the FE model does not have: a cross support near a cross member
  that adds rotational stiffness (``support_stiffness`` N mm/rad about X and Z at the two
  rail webs' mid-height nodes nearest ``support_x``);
* per-mode damping drawn between 0.5 % and 2 %.

It is then "measured" as the study did: the sensor positions are visited a few triaxial
sensors at a time, once per hammer input; every run gets its own noise (a fraction of each
FRF's magnitude, plus a floor), and the runs are assembled into one MIMO set
(:func:`femcal.testdata.runs.assemble_runs`). Accelerance (mm/s^2/N) from 0.05 Hz to 150 Hz in
0.05 Hz steps by default.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..assembly import Options, assemble
from ..model import EigenRequest
from ..model.build import load_model
from ..response.frf import modal_frf, point_matrix
from ..solve.normal_modes import solve_normal_modes
from ..testdata.data import FRFData
from ..testdata.points import point_label, read_points
from ..testdata.runs import assemble_runs

#: Parameter tables and the column each field lives in.
_FIELDS = {("PSHELL", "T"): ("properties", "pid", "t"), ("PBAR", "A"): ("properties", "pid", "a"),
           ("MAT1", "E"): ("materials", "mid", "e"), ("MAT1", "RHO"): ("materials", "mid", "rho"),
           ("PBAR", "I1"): ("properties", "pid", "i1"), ("PBAR", "I2"): ("properties", "pid", "i2"),
           ("PBAR", "J"): ("properties", "pid", "j")}  # fmt: skip


@dataclass(frozen=True)
class SynthSettings:
    """How the synthetic test is made (see the module docstring)."""

    seed: int = 2019
    spread: float = 0.5  # fraction of each parameter's bounds the hidden values may use
    support_x: float = 2475.0  # mm, where the cross support acts (near cross member 3)
    support_stiffness: float = 2.0e8  # N mm/rad, about X and Z, at each rail
    damping: tuple[float, float] = (0.005, 0.02)
    f_max: float = 150.0
    df: float = 0.05
    sensors_per_run: int = 7
    noise: float = 0.02  # of each FRF's magnitude
    noise_floor: float = 1e-3  # of the median magnitude
    modes_to: float = 400.0  # Hz, modes summed


@dataclass(frozen=True)
class SynthTest:
    """The measured set and what made it (the truth a calibration should find)."""

    data: FRFData
    parameters: list[dict]  # name, card, id, field, nominal, true, p
    damping: np.ndarray  # (k,) per mode
    frequencies_hz: np.ndarray  # (k,) of the "real" frame
    settings: SynthSettings


def hidden_frame(deck_path: str | Path, params_path: str | Path, settings: SynthSettings,
                 rng: np.random.Generator):  # fmt: skip
    """The "real" frame: the deck with hidden parameter values drawn from ``rng`` and the
    cross support, solved to ``settings.modes_to``.

    Returns
    -------
    (model, modes, truth): the model with the hidden values, its modes
    (:class:`femcal.solve.normal_modes.Modes`) and per parameter a dict (name, card, id, field,
    nominal, true, p). With ``rng = np.random.default_rng(settings.seed)`` this is the frame behind
    :func:`make_hammer_test`'s data (it draws the parameters first).
    """
    s = settings
    model = load_model(deck_path)
    params = tomllib.loads(Path(params_path).read_text()).get("parameter", [])
    truth = []
    for n, p in enumerate(params, start=1):
        need = ("name", "card", "id", "field", "nominal", "lower", "upper")
        if any(k not in p for k in need):
            raise ValueError(f"{params_path}: parameter {n} needs {', '.join(need)}; it has "
                             f"{', '.join(p)}")  # fmt: skip
        if (p["card"], p["field"]) not in _FIELDS:
            known = ", ".join(f"{c} {f}" for c, f in _FIELDS)
            raise ValueError(f"{params_path}: parameter {p['name']}: {p['card']} {p['field']} "
                             f"is not a parameter field femcal knows ({known})")  # fmt: skip
        where, key, column = _FIELDS[(p["card"], p["field"])]
        table = getattr(model, where)[p["card"]]
        rows = np.flatnonzero(table[key] == p["id"])
        if len(rows) != 1:
            raise ValueError(f"{params_path}: parameter {p['name']}: {p['card']} {p['id']} is "
                             "not in the deck")  # fmt: skip
        lo = p["lower"] / p["nominal"] - 1.0
        hi = p["upper"] / p["nominal"] - 1.0
        rel = float(rng.uniform(s.spread * lo, s.spread * hi))
        true = p["nominal"] * (1.0 + rel)
        table[column][rows[0]] = true
        truth.append({"name": p["name"], "card": p["card"], "id": p["id"], "field": p["field"],
                      "nominal": p["nominal"], "true": true, "p": rel})  # fmt: skip
    mats = assemble(model, Options())
    K = mats.K.copy()
    for side in (1.0, -1.0):  # the cross support: rotational springs at the rail webs
        target = np.array([s.support_x, side * 430.0, 0.0])
        node = int(np.argmin(np.linalg.norm(model.xyz - target, axis=1)))
        for comp in (3, 5):  # R1 and R3 (0-based 3 and 5)
            d = int(model.dof_start[node]) + comp
            K[d, d] = K[d, d] + s.support_stiffness
    mats = replace(mats, K=K.tocsr())
    modes, _ = solve_normal_modes(model, matrices=mats,
                            request=EigenRequest(v2=s.modes_to, nd=None))  # fmt: skip
    return model, modes, truth


def make_hammer_test(deck_path: str | Path, params_path: str | Path,
                     sensors_path: str | Path, inputs_path: str | Path,
                     settings: SynthSettings | None = None) -> SynthTest:  # fmt: skip
    """Build the synthetic test (see the module docstring)."""
    s = settings or SynthSettings()
    rng = np.random.default_rng(s.seed)
    sensors = read_points(sensors_path)  # before the solution, so bad files fail at once
    inputs = read_points(inputs_path)
    model, modes, truth = hidden_frame(deck_path, params_path, s, rng)
    zeta = rng.uniform(*s.damping, size=len(modes.radians))
    f = s.df * np.arange(1, round(s.f_max / s.df) + 1)
    positions = list(dict.fromkeys((lab, g) for lab, g, _ in sensors))
    runs, maps = [], []
    for _, g_in, c_in in inputs:
        B = point_matrix(model, [(g_in, abs(c_in))]).T * np.sign(c_in)
        for start in range(0, len(positions), s.sensors_per_run):
            group = positions[start : start + s.sensors_per_run]
            chans = [(g, c) for _, g in group for c in (1, 2, 3)]
            C = point_matrix(model, chans)
            H = modal_frf(modes.shapes, modes.radians, C, B, f, zeta, "accelerance")
            scale = s.noise * np.abs(H) + s.noise_floor * np.median(np.abs(H))
            noise = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
            local = [f"ch{k + 1}" for k in range(len(chans))]
            runs.append(FRFData.from_labels(f, H + scale * noise, local, ["hammer"],
                                            "accelerance", "mm/s^2/N"))  # fmt: skip
            cmap = {lab: point_label(g, c) for lab, (g, c) in zip(local, chans, strict=True)}
            cmap["hammer"] = point_label(g_in, c_in)
            maps.append(cmap)
    data = assemble_runs(runs, maps)
    return SynthTest(data, truth, zeta, modes.frequencies_hz, s)


def truth_toml(test: SynthTest) -> list[str]:
    """The hidden truth as TOML lines (parameters, modes and damping, settings)."""
    s = test.settings
    lines = ["# The hidden truth behind the synthetic hammer test: for tests only, not for the",
             "# calibration (which must find it from the FRFs).", "",
             f"seed = {s.seed}", f"spread = {s.spread!r}",
             f"support_x_mm = {s.support_x!r}", f"support_stiffness_nmm_per_rad = "
             f"{s.support_stiffness!r}", f"noise = {s.noise!r}", f"noise_floor = {s.noise_floor!r}",
             "", "[modes]",
             "frequency_hz = [" + ", ".join(f"{v:.6f}" for v in test.frequencies_hz) + "]",
             "damping_ratio = [" + ", ".join(f"{v:.6f}" for v in test.damping) + "]"]  # fmt: skip
    for p in test.parameters:
        lines += ["", "[[parameter]]"]
        for k in ("name", "card", "id", "field", "nominal", "true", "p"):
            v = p[k]
            lines.append(f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}")
    return lines
