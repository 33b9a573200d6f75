"""Synthetic rig test: lab-like time histories of the frame on its 7-post rig, made from a
deck the calibration will not see, as the study's rig test was run.

The "real" frame differs from the FE model as the synthetic hammer test's does
(:mod:`femcal.jobs.synthetic_test`): hidden parameter values (drawn within ``spread`` of
each parameter's bounds, or taken from a truth file so that the rig frame and the hammer
frame share them), the cross support the model lacks, and per-mode damping between 0.5 %
and 2 %.

The rig drives each actuator in displacement with its own periodic random signal: a
multisine with a flat displacement spectrum over ``drive_band`` and random phases, the same
every period, scaled to ``drive_rms``. The frame's steady response to it is exact for the
band-limited periodic drive (:func:`femcal.rig.simulate.periodic_response`, the modes up to
``modes_to`` and the static part of the others). Every channel is then "measured" over
``cycles`` periods with its own white noise (``noise`` times the channel's RMS): each
actuator's displacement (the drive as the LVDT reads it) and force (the load cell), and the
accelerometers of the sensors file in their directions; 7 + 7 + 7 channels on the study's
rig (24 with the battery box's triaxial sensor).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..assembly import Options, assemble
from ..errors import ConfigError
from ..model.build import load_model
from ..rig.plant import RigPlant, build_plant
from ..rig.simulate import periodic_response
from ..testdata.points import read_points
from ..testdata.timedata import TimeData
from .synthetic_test import hidden_values, truth_tail, with_cross_support


@dataclass(frozen=True)
class RigTestSettings:
    """How the synthetic rig test is made (see the module docstring); lengths in the
    model's unit (mm), times in s, frequencies in Hz."""

    seed: int = 2019
    spread: float = 0.5
    support_x: float = 2475.0
    support_stiffness: float = 2.0e8  # N mm/rad
    damping: tuple[float, float] = (0.005, 0.02)
    rate_hz: float = 512.0
    period_s: float = 136.0
    cycles: int = 30
    drive_band: tuple[float, float] = (0.5, 40.0)
    drive_rms: float = 0.2  # mm per actuator
    noise: float = 0.02  # of each channel's RMS
    modes_to: float = 200.0

    def __post_init__(self) -> None:
        """Check every setting's range (ValueError naming it)."""
        nyquist = self.rate_hz / 2
        checks = (
            ("seed", self.seed, isinstance(self.seed, int) and self.seed >= 0,
             "a whole number, 0 or more"),
            ("spread", self.spread, 0 <= self.spread <= 1, "a fraction in [0, 1]"),
            ("support_stiffness", self.support_stiffness, self.support_stiffness >= 0,
             "0 or more"),
            ("damping", self.damping, len(self.damping) == 2
             and 0 < self.damping[0] <= self.damping[1] < 1, "0 < low <= high < 1"),
            ("rate_hz", self.rate_hz, np.isfinite(self.rate_hz) and self.rate_hz > 0,
             "a positive sampling rate"),
            ("period_s", self.period_s, np.isfinite(self.period_s) and self.period_s > 0
             and round(self.period_s * self.rate_hz) >= 16,
             "a positive period of 16 samples or more"),
            ("cycles", self.cycles, isinstance(self.cycles, int) and self.cycles >= 1,
             "a whole number, 1 or more"),
            ("drive_band", self.drive_band, len(self.drive_band) == 2
             and 0 < self.drive_band[0] < self.drive_band[1] < nyquist
             and (self.drive_band[1] - self.drive_band[0]) * self.period_s >= 1,
             f"0 < low < high below the Nyquist frequency {nyquist:g} Hz, holding a "
             "harmonic of the period"),
            ("drive_rms", self.drive_rms, np.isfinite(self.drive_rms) and self.drive_rms > 0,
             "a positive displacement"),
            ("noise", self.noise, np.isfinite(self.noise) and self.noise >= 0, "0 or more"),
            ("modes_to", self.modes_to, np.isfinite(self.modes_to) and self.modes_to > 0,
             "a positive frequency"),
        )  # fmt: skip
        for name, value, ok, expected in checks:
            if not ok:
                raise ValueError(f"synthetic rig test: {name} = {value!r}: expected {expected}")

    @property
    def period_samples(self) -> int:
        return round(self.period_s * self.rate_hz)


@dataclass(frozen=True)
class RigTest:
    """The measured time histories and what made them.

    Attributes
    ----------
    data : every channel over every cycle, with noise.
    drive : (n_in, period) one period of the drives, without noise (mm).
    plant : the "real" frame on its rig (hidden values, cross support, damping).
    parameters : per parameter a dict (name, card, id, field, nominal, true, p).
    settings : how it was made.
    support_x, support_stiffness : the cross support used (mm, N mm/rad): the settings'
        or the truth file's.
    """

    data: TimeData
    drive: np.ndarray
    plant: RigPlant
    parameters: list[dict]
    settings: RigTestSettings
    support_x: float
    support_stiffness: float

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.plant.omega / (2 * np.pi)


def read_truth(path: str | Path) -> tuple[dict[str, float], dict[str, float]]:
    """The hidden values of a truth file (``[[parameter]]`` name and true) and its
    settings (support_x_mm, support_stiffness_nmm_per_rad when present).

    Raises
    ------
    ConfigError
        Naming the file: not TOML, or a parameter without a name or a numeric true value.
    """
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not a TOML file ({e})") from None
    values = {}
    for k, p in enumerate(doc.get("parameter", []), 1):
        name, true = p.get("name"), p.get("true")
        if not isinstance(name, str) or isinstance(true, bool) or not isinstance(true, int | float):
            raise ConfigError(f"{path}: [[parameter]] {k}: expected a name and a numeric "
                              "true value")  # fmt: skip
        values[name] = float(true)
    settings = {k: float(doc[k]) for k in ("support_x_mm", "support_stiffness_nmm_per_rad")
                if isinstance(doc.get(k), int | float)}  # fmt: skip
    return values, settings


def periodic_random(n_in: int, n: int, dt: float, band: tuple[float, float], rms: float,
                    rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """(n_in, n) periodic random drives: each a multisine of the period's harmonics in
    ``band`` (Hz) with equal amplitudes and its own random phases, scaled to ``rms``."""
    f = np.fft.rfftfreq(n, dt)
    lines = (f >= band[0]) & (f <= band[1])
    spectrum = np.zeros((n_in, len(f)), complex)
    spectrum[:, lines] = np.exp(2j * np.pi * rng.uniform(size=(n_in, int(lines.sum()))))
    drive = np.fft.irfft(spectrum, n, axis=1)
    return drive * (rms / np.sqrt(np.mean(drive**2, axis=1, keepdims=True)))


def make_rig_test(deck_path: str | Path, params_path: str | Path, actuators_path: str | Path,
                  sensors_path: str | Path, settings: RigTestSettings | None = None, *,
                  truth_path: str | Path | None = None,
                  progress=None) -> RigTest:  # fmt: skip
    """Build the synthetic rig test (see the module docstring).

    ``truth_path`` (a truth file of :func:`femcal.jobs.synthetic_test.truth_toml`) gives
    the hidden parameter values and the cross support instead of drawing them.

    Raises
    ------
    ConfigError
        For a parameter, actuator, sensor or truth file that is refused (naming it).
    ModelError
        For actuators the deck does not hold (see :func:`femcal.rig.plant.find_actuators`).
    """
    s = settings or RigTestSettings()
    rng = np.random.default_rng(s.seed)
    actuators = read_points(actuators_path)
    sensors = read_points(sensors_path)
    given, from_truth = read_truth(truth_path) if truth_path is not None else (None, {})
    support_x = from_truth.get("support_x_mm", s.support_x)
    support_k = from_truth.get("support_stiffness_nmm_per_rad", s.support_stiffness)
    model, truth = hidden_values(load_model(deck_path), params_path, s.spread, rng, given)
    mats = with_cross_support(model, assemble(model, Options()), support_x, support_k)
    plant = build_plant(model, actuators, sensors, modes_to=s.modes_to, matrices=mats,
                        progress=progress)  # fmt: skip
    plant = plant.with_damping(rng.uniform(*s.damping, size=plant.n_modes))
    dt, n = 1.0 / s.rate_hz, s.period_samples
    drive = periodic_random(len(actuators), n, dt, s.drive_band, s.drive_rms, rng)
    if progress is not None:
        progress(f"steady response of {plant.n_modes} modes to one {n}-sample period")
    cycle = periodic_response(plant, drive, dt)
    values = np.tile(cycle, (1, s.cycles))
    rms = np.sqrt(np.mean(cycle**2, axis=1, keepdims=True))
    values += s.noise * rms * rng.standard_normal(values.shape)
    header = {"TIME_TYPE": "RESPONSE"}
    data = TimeData(dt, values, plant.outputs, plant.output_units, header)
    return RigTest(data, drive, plant, truth, s, support_x, support_k)


def rig_truth_toml(test: RigTest, command: str = "") -> list[str]:
    """The hidden truth as TOML lines (settings, modes and damping, parameters), with the
    command that made the test as a comment when given."""
    s = test.settings
    made = [f"# made by: {command}"] if command else []
    lines = ["# The hidden truth behind the synthetic rig test: for tests only, not for the",
             "# calibration (which must find it from the data).", *made, "",
             f"seed = {s.seed}", f"spread = {s.spread!r}",
             f"support_x_mm = {test.support_x!r}",
             f"support_stiffness_nmm_per_rad = {test.support_stiffness!r}",
             f"noise = {s.noise!r}", f"rate_hz = {s.rate_hz!r}", f"period_s = {s.period_s!r}",
             f"cycles = {s.cycles}",
             f"drive_band_hz = [{s.drive_band[0]!r}, {s.drive_band[1]!r}]",
             f"drive_rms_mm = {s.drive_rms!r}", ""]  # fmt: skip
    return lines + truth_tail(test.frequencies_hz, test.plant.zeta, test.parameters)
