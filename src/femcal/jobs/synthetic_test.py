"""Synthetic hammer test: lab-like FRF data made from a deck the calibration will not see.

The "real" frame differs from the FE model in up to four ways, as a test article does:

* a hidden parameter set: every calibration parameter (PSHELL T, PBAR A, MAT1 E ...) drawn
  uniformly within ``spread`` (at most 1) times its bounds around the nominal
  (P = P0 (1 + p)), so within the bounds;
* a model-form difference the FE model does not have: a cross support near a cross member
  that adds rotational stiffness (``support_stiffness`` N mm/rad about X and Z at the two
  rail webs' mid-height nodes nearest ``support_x``; none at zero stiffness);
* optionally a second kind, a mass the FE model lacks (a component, a bracket, cabling):
  ``added_mass`` in the deck's mass unit on the three translations of the grid nearest
  ``added_mass_at``;
* per-mode damping drawn between 0.5 % and 2 %.

It is then "measured" as the study did: the sensor positions are visited a few triaxial
sensors at a time, once per hammer input; every run gets its own noise (a fraction of each
FRF's magnitude, plus a floor), and the runs are assembled into one MIMO set
(:func:`femcal.testdata.runs.assemble_runs`). Accelerance (mm/s^2/N) from 0.05 Hz to 150 Hz in
0.05 Hz steps by default.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..assembly import Options, assemble
from ..calibrate.parameters import read_parameters, with_values
from ..model import EigenRequest
from ..model.build import load_model
from ..response.frf import modal_frf, point_matrix
from ..solve.normal_modes import solve_normal_modes
from ..testdata.data import FRFData
from ..testdata.points import point_label, read_points
from ..testdata.runs import assemble_runs


@dataclass(frozen=True)
class SynthSettings:
    """How the synthetic test is made (see the module docstring)."""

    seed: int = 2019
    spread: float = 0.5  # fraction of each parameter's bounds the hidden values may use
    support_x: float = 2475.0  # mm, where the cross support acts (near cross member 3)
    support_stiffness: float = 2.0e8  # N mm/rad, about X and Z, at each rail
    added_mass: float = 0.0  # in the deck's mass unit (tonne for the bundled frame)
    added_mass_at: tuple[float, float, float] = (1800.0, -430.0, 0.0)  # mm, nearest grid
    damping: tuple[float, float] = (0.005, 0.02)
    f_max: float = 150.0
    df: float = 0.05
    sensors_per_run: int = 7
    noise: float = 0.02  # of each FRF's magnitude
    noise_floor: float = 1e-3  # of the median magnitude
    modes_to: float = 400.0  # Hz, modes summed

    def __post_init__(self) -> None:
        """Check every setting's range (ValueError naming it)."""
        checks = (
            ("seed", self.seed, isinstance(self.seed, int) and self.seed >= 0,
             "a whole number, 0 or more"),
            ("spread", self.spread, 0 <= self.spread <= 1,
             "a fraction in [0, 1] of each parameter's bounds (beyond 1 the hidden values "
             "would leave them)"),
            ("damping", self.damping, len(self.damping) == 2
             and 0 < self.damping[0] <= self.damping[1] < 1, "0 < low <= high < 1"),
            ("f_max", self.f_max, self.f_max > 0, "a positive frequency"),
            ("df", self.df, 0 < self.df <= self.f_max, "a positive step up to f_max"),
            ("sensors_per_run", self.sensors_per_run, self.sensors_per_run >= 1, "1 or more"),
            ("noise", self.noise, self.noise >= 0, "0 or more"),
            ("noise_floor", self.noise_floor, self.noise_floor >= 0, "0 or more"),
            ("modes_to", self.modes_to, self.modes_to > 0, "a positive frequency"),
            ("support_x", self.support_x, bool(np.isfinite(self.support_x)),
             "a position along the frame (mm)"),
            ("support_stiffness", self.support_stiffness,
             np.isfinite(self.support_stiffness) and self.support_stiffness >= 0,
             "a stiffness, 0 or more"),
            ("added_mass", self.added_mass,
             np.isfinite(self.added_mass) and self.added_mass >= 0, "a mass, 0 or more"),
            ("added_mass_at", self.added_mass_at, len(self.added_mass_at) == 3
             and bool(np.all(np.isfinite(self.added_mass_at))), "three coordinates (x, y, z)"),
        )  # fmt: skip
        for name, value, ok, expected in checks:
            if not ok:
                raise ValueError(f"synthetic test: {name} = {value!r}: expected {expected}")


@dataclass(frozen=True)
class SynthTest:
    """The measured set and what made it (the truth a calibration should find)."""

    data: FRFData
    parameters: list[dict]  # name, card, id, field, nominal, true, p
    damping: np.ndarray  # (k,) per mode
    frequencies_hz: np.ndarray  # (k,) of the "real" frame
    settings: SynthSettings


def hidden_values(model, params_path: str | Path, spread: float, rng: np.random.Generator,
                  given: dict[str, float] | None = None):  # fmt: skip
    """The model with hidden parameter values, and per parameter a dict (name, card, id,
    field, nominal, true, p).

    The parameter file is read as a calibration reads it
    (:func:`femcal.calibrate.parameters.read_parameters`: any parameter field, bounds
    absolute or relative, the nominal the deck's). Each hidden value is ``given[name]``
    when ``given`` names the parameter (as a truth file records it), else drawn uniformly
    within ``spread`` times its bounds around the nominal, so it lies within them.

    Raises
    ------
    ConfigError
        Naming the parameter file and parameter (a ValueError too), for a file a
        calibration would refuse: bounds inverted, equal or not holding the nominal, an
        unknown key or field, a card not in the deck.
    ValueError
        For a given value that is not finite and positive, or a parameter ``given`` lacks
        (when ``given`` is not None).
    """
    params = read_parameters(params_path, model)  # checked: bounds hold the deck's nominal
    truth, values = [], []
    for par in params:
        if given is not None:
            if par.name not in given:
                raise ValueError(f"{params_path}: parameter {par.name!r} has no hidden value "
                                 "in the truth file; expected one for every parameter")
            value = float(given[par.name])
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"hidden value of {par.name!r}: {value!r}; expected a "
                                 "positive number")  # fmt: skip
            rel = value / par.nominal - 1.0
        else:
            # within spread times the bounds around the nominal: inside the bounds, as
            # p_lower <= 0 <= p_upper and spread <= 1
            rel = float(rng.uniform(spread * par.p_lower, spread * par.p_upper))
            value = par.value(rel)
        values.append(value)
        truth.append({"name": par.name, "card": par.card, "id": par.id, "field": par.field,
                      "nominal": par.nominal, "true": value, "p": rel})  # fmt: skip
    return with_values(model, params, np.array(values)), truth


def with_cross_support(model, mats, support_x: float, stiffness: float):
    """The matrices with the cross support the FE model lacks: rotational springs of
    ``stiffness`` (N mm/rad) about X and Z at the rail webs' mid-height nodes nearest
    (``support_x``, +-430, 0) mm."""
    K = mats.K.copy()
    for side in (1.0, -1.0):
        target = np.array([support_x, side * 430.0, 0.0])
        node = int(np.argmin(np.linalg.norm(model.xyz - target, axis=1)))
        for comp in (3, 5):  # R1 and R3 (0-based 3 and 5)
            d = int(model.dof_start[node]) + comp
            K[d, d] = K[d, d] + stiffness
    return replace(mats, K=K.tocsr())


def with_added_mass(model, mats, at: tuple[float, float, float], mass: float):
    """The matrices with a point mass the FE model lacks: ``mass`` (the deck's mass unit) on
    the three translations of the grid nearest ``at`` (basic coordinates); unchanged for no
    mass."""
    if mass == 0:
        return mats
    grids = np.flatnonzero(model.is_grid)
    node = int(grids[np.argmin(np.linalg.norm(model.xyz[grids] - np.asarray(at, float),
                                              axis=1))])  # fmt: skip
    d = int(model.dof_start[node]) + np.arange(3)
    extra = sp.csr_matrix((np.full(3, float(mass)), (d, d)), shape=mats.M.shape)
    return replace(mats, M=(mats.M + extra).tocsr())


def hidden_frame(deck_path: str | Path, params_path: str | Path, settings: SynthSettings,
                 rng: np.random.Generator):  # fmt: skip
    """The "real" frame: the deck with hidden parameter values drawn from ``rng``
    (:func:`hidden_values`), the cross support (:func:`with_cross_support`) and the added mass
    (:func:`with_added_mass`), solved to
    ``settings.modes_to``.

    Returns
    -------
    (model, modes, truth): the model with the hidden values, its modes
    (:class:`femcal.solve.normal_modes.Modes`) and per parameter a dict (name, card, id, field,
    nominal, true, p). With ``rng = np.random.default_rng(settings.seed)`` this is the frame behind
    :func:`make_hammer_test`'s data (it draws the parameters first).

    Raises
    ------
    ConfigError
        As :func:`hidden_values`.
    """
    s = settings
    model, truth = hidden_values(load_model(deck_path), params_path, s.spread, rng)
    mats = with_cross_support(model, assemble(model, Options()), s.support_x,
                              s.support_stiffness)  # fmt: skip
    mats = with_added_mass(model, mats, s.added_mass_at, s.added_mass)
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
             ""]  # fmt: skip
    if s.added_mass:
        at = ", ".join(repr(float(x)) for x in s.added_mass_at)
        lines[-1:-1] = [f"added_mass = {s.added_mass!r}", f"added_mass_at_mm = [{at}]"]
    return lines + truth_tail(test.frequencies_hz, test.damping, test.parameters)


def truth_tail(frequencies_hz: np.ndarray, damping: np.ndarray,
               parameters: list[dict]) -> list[str]:  # fmt: skip
    """A truth file's ``[modes]`` table (frequencies in Hz, damping ratios) and its
    ``[[parameter]]`` tables (name, card, id, field, nominal, true, p), as TOML lines."""
    lines = ["[modes]",
             "frequency_hz = [" + ", ".join(f"{v:.6f}" for v in frequencies_hz) + "]",
             "damping_ratio = [" + ", ".join(f"{v:.6f}" for v in damping) + "]"]  # fmt: skip
    for p in parameters:
        lines += ["", "[[parameter]]"]
        for k in ("name", "card", "id", "field", "nominal", "true", "p"):
            v = p[k]
            lines.append(f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}")
    return lines
