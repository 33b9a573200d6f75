"""The actuators' limits and a drive's peaks against them.

Each actuator has a stroke (the largest displacement either way from mid-stroke), a
largest velocity (what its servo-valve flows) and a largest acceleration; a drive beyond
any of them hits the stops or cannot be followed. They come from the actuators CSV (columns
``stroke``, ``velocity``, ``acceleration`` beside label, grid and direction; a blank cell
is no limit) or a limits CSV of the same columns, in the model's length unit per second
and per second squared; options may set one value for every actuator.

A drive's velocity and acceleration are its sixth-order central differences
(:func:`femcal.rig.simulate.derivatives`), wrapped around for a looped drive.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from .simulate import derivatives

#: The limited quantities, in the order of the arrays below, with their CSV columns.
QUANTITIES = ("stroke", "velocity", "acceleration")


@dataclass(frozen=True)
class ActuatorLimits:
    """Limits per actuator, ``inf`` where none is given.

    Attributes
    ----------
    values : (3, n_drives) stroke (length), velocity (length/s), acceleration (length/s^2).
    source : where they came from, per quantity (a file, an option, or "none").
    """

    values: np.ndarray
    source: tuple[str, str, str] = ("none", "none", "none")

    @classmethod
    def none(cls, n_drives: int) -> ActuatorLimits:
        return cls(np.full((3, n_drives), np.inf))

    @property
    def any(self) -> bool:
        return bool(np.isfinite(self.values).any())

    def overridden(self, stroke: float | None = None, velocity: float | None = None,
                   acceleration: float | None = None, *,
                   where: str = "option") -> ActuatorLimits:  # fmt: skip
        """These limits with one value for every actuator where given (ValueError for one
        that is not a positive number)."""
        values = self.values.copy()
        source = list(self.source)
        for q, (name, v) in enumerate(zip(QUANTITIES, (stroke, velocity, acceleration),
                                          strict=True)):  # fmt: skip
            if v is None:
                continue
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} limit {v!r}: expected a positive number")
            values[q] = v
            source[q] = where
        return ActuatorLimits(values, tuple(source))  # type: ignore[arg-type]


def read_limits(path: str | Path, labels: Sequence[str], *,
                required: bool = False) -> ActuatorLimits:  # fmt: skip
    """The limits of the actuators ``labels`` from a CSV with a ``label`` column and any of
    ``stroke``, ``velocity``, ``acceleration`` (an actuators CSV may carry them). Without
    those columns: no limits (or, with ``required``, an error: a limits file must have one).

    Raises
    ------
    ConfigError
        Naming the file and line: a missing label column, an actuator with no row (when
        the file has limit columns), a label given twice, or a cell that is not a positive
        number.
    """
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:  # a BOM is no column name
            reader = csv.DictReader(fh)
            fields = [c.strip().lower() for c in reader.fieldnames or []]
            reader.fieldnames = fields
            cols = [q for q in QUANTITIES if q in fields]
            if "label" not in fields:
                raise ConfigError(f"{path}:1: no label column; expected label and any of "
                                  f"{', '.join(QUANTITIES)}")  # fmt: skip
            if not cols:
                if required:
                    raise ConfigError(f"{path}:1: no limit column; expected any of "
                                      f"{', '.join(QUANTITIES)} beside label")  # fmt: skip
                return ActuatorLimits.none(len(labels))
            rows: dict[str, tuple[int, dict[str, str]]] = {}
            for row in reader:
                if not any((v or "").strip() for k, v in row.items() if k is not None):
                    continue  # a blank row, as spreadsheets write them
                if any(row.get(c) is None for c in cols):
                    raise ConfigError(f"{path}:{reader.line_num}: a short row; expected a "
                                      f"cell for each of label, {', '.join(cols)} (blank "
                                      "for no limit)")  # fmt: skip
                label = (row.get("label") or "").strip()
                if label in rows:
                    raise ConfigError(f"{path}:{reader.line_num}: actuator {label!r} given "
                                      f"twice (first on line {rows[label][0]})")  # fmt: skip
                rows[label] = (reader.line_num, row)
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text (byte {e.start}): expected a CSV table") \
            from None
    except csv.Error as e:
        raise ConfigError(f"{path}: {e}: expected a CSV table") from None
    values = np.full((3, len(labels)), np.inf)
    for j, label in enumerate(labels):
        if label not in rows:
            raise ConfigError(f"{path}: no row for actuator {label!r}; expected one per "
                              f"actuator ({', '.join(labels)})")  # fmt: skip
        line, row = rows[label]
        for q, name in enumerate(QUANTITIES):
            if name not in cols:
                continue
            text = (row.get(name) or "").strip()
            if not text:
                continue
            try:
                v = float(text)
            except ValueError:
                v = float("nan")
            if not (np.isfinite(v) and v > 0):
                raise ConfigError(f"{path}:{line}: actuator {label!r}, {name} {text!r}: "
                                  "expected a positive number or a blank cell (no limit)")
            values[q, j] = v
    source = tuple(str(path) if name in cols else "none" for name in QUANTITIES)
    return ActuatorLimits(values, source)  # type: ignore[arg-type]


@dataclass(frozen=True)
class LimitCheck:
    """A drive's peaks against the limits.

    Attributes
    ----------
    peak : (3, n_drives) the largest absolute displacement, velocity and acceleration.
    limit : (3, n_drives) the limits (``inf``: none).
    """

    peak: np.ndarray
    limit: np.ndarray

    @property
    def ratio(self) -> np.ndarray:
        """(3, n_drives) peak over limit (0 where there is no limit)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(np.isfinite(self.limit), self.peak / self.limit, 0.0)

    @property
    def exceeded(self) -> bool:
        return bool((self.ratio > 1).any())

    @property
    def worst(self) -> float:
        """The largest peak-over-limit ratio (0 with no limits)."""
        return float(self.ratio.max()) if self.ratio.size else 0.0

    def messages(self, names: Sequence[str], unit: str) -> list[str]:
        """One line per limit exceeded: actuator, quantity, peak and limit."""
        units = (unit, f"{unit}/s", f"{unit}/s^2")
        out = []
        for q, j in zip(*np.nonzero(self.ratio > 1), strict=True):
            out.append(f"{names[j]}: {QUANTITIES[q]} {self.peak[q, j]:.4g} {units[q]} "
                       f"beyond its limit {self.limit[q, j]:.4g} {units[q]} "
                       f"({self.ratio[q, j]:.2f} times)")  # fmt: skip
        return out


def check_limits(drive: np.ndarray, dt: float, limits: ActuatorLimits, *,
                 periodic: bool = True) -> LimitCheck:  # fmt: skip
    """The peaks of ``drive`` (n_drives, n) sampled every ``dt`` s against ``limits``."""
    velocity, acceleration = derivatives(drive, dt, periodic)
    peak = np.stack([np.abs(x).max(axis=1) if x.shape[1] else np.zeros(x.shape[0])
                     for x in (drive, velocity, acceleration)])  # fmt: skip
    return LimitCheck(peak, limits.values)


def scale_into_limits(drive: np.ndarray, check: LimitCheck) -> tuple[np.ndarray, float]:
    """The drive scaled down as a whole (every actuator by one factor, so that the drive's
    direction and the actuators' phases are kept) until no limit is exceeded, and the
    factor (1 when none was)."""
    worst = check.worst
    factor = 1.0 / worst if worst > 1 else 1.0
    return drive * factor, factor
