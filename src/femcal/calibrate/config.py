"""The calibration run's configuration file (TOML); paths are relative to the file.

::

    [model]
    deck = "hammer_frame.bdf"              # NASTRAN deck
    parameters = "hammer_frame.params.toml" # see femcal.calibrate.parameters
    units = "mm/s^2/N"                      # units of the model's FRFs (optional)

    [test]
    frf = "hammer_test.uff"                 # any FRF file femcal reads
    # model = "identified.npz"              # or an identified model (femcal identify)
    # truth = "hammer_test.truth.toml"      # a synthetic test's true parameter values
                                            #  (optional): the report sets each
                                            #  parameter's error against its posterior
    # sensors = "hammer_frame.sensors.csv"  # sensor and input positions (optional): their
    # inputs = "hammer_frame.inputs.csv"    #  names label the channels in the report

    [test.identify]                         # identify the test FRFs first (optional;
    band = [10.0, 120.0]                    #  without it and without test.model the raw
                                            #  FRFs are compared, and zeta0 must be given)
    # splits = [50.0, 80.0]                 # parts (default: chosen from the CMIF's peaks;
                                            #  increasing, inside the band)
    orders = "auto"                         # or a number >= 1, or a list, one per part
    # max_order = 40                        # 2..200 (default: from each part's peaks)
    method = "plscf"                        # or "subspace"
    gamma = 1.43                            # > 1: residual poles at gamma and beta times
    beta = 100.0                            #  each part's top (beta > gamma)

    [calibration]
    band = [10.0, 100.0]                    # Hz, 0 < f_lo < f_hi
    zeta0 = "median"                        # or a damping ratio, 0 < zeta0 < 1
    samples_per_bandwidth = 3.0             # in (0, 100]; with the band and zeta0 at most
                                            #  MAX_FREQUENCIES (100 000) frequencies
    metric = "log-magnitude"                # or "complex-log"
    loss = "huber"                          # or "squared" (least squares): Huber's loss,
    huber_c = 2.0                           #  quadratic within huber_c (> 0) robust standard
                                            #  deviations (femcal.calibrate.robust)
    reduction_modes = 100                   # modes of the surrogate's basis
    surrogate = "exact"                     # or "first-order" (FEMCali's)
    enrich_hz = 0.0                         # static eigenvector-derivative vectors of the
                                            #  modes up to this frequency join the basis
                                            #  (default none; 1.5 x the band's top with
                                            #  exact_gradient = false)
    enrich_vectors = 100                    # at most this many (default reduction_modes)
    residual = false                        # true: the FE FRFs add the residual flexibility
                                            #  of the modes they do not sum (needs a
                                            #  restrained model)
    modal_hz = 0.0                          # the FE FRFs sum the modes up to this frequency
                                            #  at the nominal model (0: all reduction_modes)
    exact_gradient = true                   # the full model's exact FRF Jacobian at each
                                            #  surrogate centre corrects the surrogate to
                                            #  first order there
    starts = 8                              # Latin hypercube starts (the nominal is one;
                                            #  1 to 10000)
    workers = 2                             # parallel processes for the starts (1 to 256)
    engine = "local"                        # or "dask": the starts, the surrogates of
                                            #  several configurations and the identification
                                            #  parts run on a Dask LocalCluster of `workers`
                                            #  processes, or on the scheduler below
    scheduler = ""                          # a running Dask scheduler (tcp://host:port;
                                            #  engine "dask" only)
    seed = 1                                # >= 0
    max_iterations = 30                     # per start and cycle
    max_cycles = 5                          # surrogates built (the first at the nominal);
                                            #  each later one checks the candidate before
                                            #  it on the full model, the last only checks;
                                            #  1 searches once and checks that candidate
                                            #  as 2 does (femcal.calibrate.workflow)
    settle = 1e-3                           # stop when no informed p moves more than this
                                            #  (0 < settle < 1)
    restarts = 2                            # the multi-start search runs again on the
    restart_fall = 0.01                     #  current surrogate (at most restarts >= 0
                                            #  times) when a kept step lowers the full
                                            #  model's cost by less than restart_fall (a
                                            #  fraction in [0, 1)), or when the cycles
                                            #  settle; its best start is the next candidate
    bounds_sigma = 3.0                      # the prior: the bounds lie this many standard
                                            #  deviations from the nominal (a parameter's
                                            #  confidence in the parameter file wins)
    noise_sigma = 0.0                       # > 0: the test's known noise (log10 units): the
                                            #  residuals are independent with this sigma;
                                            #  0: sigma and the residuals' effective number
                                            #  of independent observations come from the
                                            #  nominal model's residual
    hold_ratio = 0.99                       # in (0, 1]: parameters whose posterior std
                                            #  at the nominal stays at this fraction of the
                                            #  prior's or more are held at the nominal
    identifiable_ratio = 0.5                # posterior below this fraction of the prior:
                                            #  identifiable (in (0, hold_ratio])
    crlb_bands = [[10.0, 40.0], [40.0, 100.0]]  # the posterior from each band alone
                                            #  (optional)
    holdout = "auto"                        # validation on data the fit did not see:
                                            #  "inputs", "sensors", "configurations",
                                            #  "auto" or "none" (femcal.calibrate.holdout)
    holdout_folds = 4                       # groups of sensor positions for "sensors"
                                            #  (>= 2)
    augment_fall = 0.1                      # after a model-form warning, the element the
                                            #  search names is added to the deck as a
                                            #  parameter and the calibration runs again,
                                            #  when it removes at least this fraction of
                                            #  the deviation (in [0, 1); 0: never;
                                            #  femcal.calibrate.augment)
    exclude_suspect_channels = true

    [output]
    pictures = true                         # PNG pictures and mode renderings

Every table is checked whole: a key a table does not know is an error that names it, the
table, the keys it knows and the nearest of them; every value must be of its kind (a TOML
number, not a string; whole numbers where counts are asked; finite) and in the range the
comments give (counts at least 1 unless said; ``reduction_modes``, ``enrich_vectors``,
``max_iterations``; bounds_sigma > 0; noise_sigma, enrich_hz, modal_hz >= 0), and every file
named must exist. The errors (:class:`ConfigError`) name the file, the table and key, what
was found and what was expected.

Several configurations of the structure (the hammer frame on its bellows and the same frame
on the rig, say) are calibrated at once by listing them instead of ``[model]`` and
``[test]``; parameters of the same name are one parameter, shared by every configuration
that names it (its nominal value, bounds and confidence must agree)::

    [[configuration]]
    name = "hammer"                         # optional: the deck's stem
    deck = "hammer_frame.bdf"
    parameters = "hammer_frame.params.toml"
    units = "mm/s^2/N"
    frf = "hammer_test.uff"                 # or model = ...; truth = ... as in [test]
    band = [10.0, 100.0]                    # optional: [calibration] band
    zeta0 = "median"                        # optional: [calibration] zeta0

    [configuration.identify]                # as [test.identify]
    band = [10.0, 120.0]

    [[configuration]]
    name = "rig"
    deck = "rig_frame.bdf"
    parameters = "hammer_frame.params.toml" # the same ids: the same parameters
    frf = "rig_test.uff"
"""

from __future__ import annotations

import difflib
import errno
import math
import os
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ConfigError
from ..identify.workflow import MAX_ORDER, METHODS
from ..parallel.cluster import ENGINES, EngineKind
from .metric import METRICS

#: The hold-out validation's kinds (femcal.calibrate.holdout).
HOLDOUT_KINDS = ("auto", "inputs", "sensors", "configurations", "none")


@dataclass(frozen=True)
class IdentifySettings:
    band: tuple[float, float]
    splits: tuple[float, ...] | None = None  # None: chosen from the CMIF
    orders: object = None  # None (automatic), int, or list
    max_order: int | None = None  # None: from each part's peaks
    gamma: float = 1.43
    beta: float = 100.0
    method: str = "plscf"


@dataclass(frozen=True)
class Configuration:
    """One configuration of the structure: its deck, its parameters and its test.

    band : Hz, the metric's band for this test. zeta0 : the equalised damping ratio, or None
    for the identified median. test_truth : a synthetic test's known values (report only).
    sensors, inputs : the test's sensor and input position files
    (:mod:`femcal.testdata.points`), whose names label the channels in the report.
    """

    name: str
    deck: Path
    parameters: Path
    test_frf: Path | None
    test_model: Path | None
    identify: IdentifySettings | None
    band: tuple[float, float]
    zeta0: float | None = None
    model_units: str | None = "mm/s^2/N"
    test_truth: Path | None = None
    sensors: Path | None = None
    inputs: Path | None = None

    @property
    def sources(self) -> tuple[Path, ...]:
        """The files besides the deck whose content decides a calibration's starts: the
        parameter, test, sensor and input files (the deck and its INCLUDEs are the model's
        own list, :attr:`femcal.model.model.Model.files`; the truth only annotates the
        report)."""
        return tuple(f for f in (self.parameters, self.test_frf, self.test_model,
                                 self.sensors, self.inputs) if f is not None)  # fmt: skip


@dataclass(frozen=True)
class Config:
    """A calibration run (see the module docstring for the keys and defaults):
    ``configurations`` (at least one) and the settings they share."""

    path: Path
    configurations: tuple[Configuration, ...]
    samples_per_bandwidth: float = 3.0
    metric: str = "log-magnitude"
    loss: str = "huber"
    huber_c: float = 2.0
    reduction_modes: int = 100
    surrogate: str = "exact"
    enrich_hz: float = 0.0
    enrich_vectors: int = 100
    residual: bool = False
    modal_hz: float = 0.0
    exact_gradient: bool = True
    starts: int = 8
    workers: int = 2
    engine: EngineKind = "local"
    scheduler: str | None = None
    seed: int = 1
    max_iterations: int = 30
    max_cycles: int = 5
    settle: float = 1e-3
    restarts: int = 2
    restart_fall: float = 0.01
    bounds_sigma: float = 3.0
    noise_sigma: float | None = None
    hold_ratio: float = 0.99
    identifiable_ratio: float = 0.5
    crlb_bands: tuple[tuple[float, float], ...] = ()
    holdout: str = "auto"
    holdout_folds: int = 4
    augment_fall: float = 0.1
    exclude_suspect_channels: bool = True
    pictures: bool = True
    raw: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Setting:
    """A numeric ``[calibration]`` key: its kind (int or float), its default, the values it
    accepts and how the error message says so."""

    kind: type
    default: float
    accepts: Callable[[float], bool]
    expected: str


def _count(default: int, most: int | None = None, why: str = "") -> Setting:
    """A count: a whole number of at least 1 (and at most ``most``, for ``why``)."""
    if most is None:
        return Setting(int, default, lambda v: v >= 1, "a whole number of at least 1")
    return Setting(int, default, lambda v: 1 <= v <= most,
                   f"a whole number from 1 to {most} ({why})")


#: The numeric ``[calibration]`` keys, their defaults and ranges (``enrich_hz`` and
#: ``enrich_vectors`` default to values that depend on other keys: see read_config).
SETTINGS: dict[str, Setting] = {
    "samples_per_bandwidth": Setting(float, 3.0, lambda v: 0 < v <= 100,
                                     "a number in (0, 100]: frequencies per half-power "
                                     "bandwidth"),
    "huber_c": Setting(float, 2.0, lambda v: v > 0, "a positive number"),
    "reduction_modes": _count(100),
    "enrich_hz": Setting(float, 0.0, lambda v: v >= 0,
                         "a frequency in Hz, or 0 for no enrichment"),
    "enrich_vectors": _count(100),
    "modal_hz": Setting(float, 0.0, lambda v: v >= 0,
                        "a frequency in Hz, or 0 for all reduction modes"),
    "starts": _count(8, 10_000, "each start is a Levenberg-Marquardt run"),
    "workers": _count(2, 256, "each worker is a process"),
    "seed": Setting(int, 1, lambda v: v >= 0, "a whole number, 0 or more"),
    "max_iterations": _count(30),
    "max_cycles": _count(5),
    "settle": Setting(float, 1e-3, lambda v: 0 < v < 1,
                      "a positive change of p below 1, e.g. 1e-3"),
    "restarts": Setting(int, 2, lambda v: v >= 0, "0 or more"),
    "restart_fall": Setting(float, 0.01, lambda v: 0 <= v < 1, "a fraction in [0, 1)"),
    "bounds_sigma": Setting(float, 3.0, lambda v: v > 0, "a positive number"),
    "noise_sigma": Setting(float, 0.0, lambda v: v >= 0,
                           "0 (estimate it) or the noise's standard deviation in log10 units"),
    "hold_ratio": Setting(float, 0.99, lambda v: 0 < v <= 1, "a fraction in (0, 1]"),
    "identifiable_ratio": Setting(float, 0.5, lambda v: 0 < v <= 1, "a fraction in (0, 1]"),
    "holdout_folds": Setting(int, 4, lambda v: v >= 2, "2 or more"),
    "augment_fall": Setting(float, 0.1, lambda v: 0 <= v < 1,
                            "a fraction in [0, 1): 0 never adds the element the model-form "
                            "search names"),
}  # fmt: skip

#: The most frequencies a configuration's metric may have (the residuals, and the Jacobian
#: of each, grow with them): a band, a damping ratio zeta0 and samples_per_bandwidth that
#: ask for more are refused rather than left to exhaust the memory.
MAX_FREQUENCIES = 100_000


def n_frequencies(band: tuple[float, float], zeta0: float, per_bandwidth: float) -> float:
    """How many frequencies :func:`femcal.calibrate.metric.log_frequencies` places over
    ``band``: equal logarithmic steps of ratio 1 + 2 zeta0 / per_bandwidth (inf where that
    ratio rounds to 1)."""
    step = math.log1p(2.0 * zeta0 / per_bandwidth)
    return math.log(band[1] / band[0]) / step + 1 if step > 0 else math.inf


#: The choices of the ``[calibration]`` keys that take a word.
CHOICES: dict[str, tuple[str, ...]] = {
    "metric": tuple(METRICS),
    "loss": ("huber", "squared"),
    "surrogate": ("exact", "first-order"),
    "holdout": HOLDOUT_KINDS,
    "engine": ENGINES,
}

#: The ``[calibration]`` keys that take true or false, and their defaults.
FLAGS = {"residual": False, "exact_gradient": True, "exclude_suspect_channels": True}


def _is_number(value: object) -> bool:
    """A TOML integer or float (a boolean is neither)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def _finite(value: float) -> bool:
    """A finite float, or an integer within 64 bits (TOML integers have no bound, and
    ``math.isfinite`` overflows on one past double precision)."""
    return abs(value) < 2**63 if isinstance(value, int) else math.isfinite(value)


def _number(section: dict, key: str, default, kind, where: str):
    """section[key] (or default) as a finite int or float; ConfigError naming the key
    otherwise (a string or boolean is not a number; a float is a whole number only if it
    has no fraction)."""
    value = section.get(key, default)
    what = "a whole number" if kind is int else "a number"
    if not _is_number(value) or not _finite(value):
        raise ConfigError(f"{where} {key} = {value!r}: expected {what}")
    if kind is int and isinstance(value, float) and not value.is_integer():
        raise ConfigError(f"{where} {key} = {value!r}: expected {what}")
    return kind(value)


def _setting(section: dict, key: str, where: str, default=None):
    """A numeric ``[calibration]`` key of :data:`SETTINGS`, its kind and range checked."""
    s = SETTINGS[key]
    value = _number(section, key, s.default if default is None else default, s.kind, where)
    if not s.accepts(value):
        raise ConfigError(f"{where} {key} = {value!r}: expected {s.expected}")
    return value


def _band(v, where: str) -> tuple[float, float]:
    """A frequency band [f_lo, f_hi] in Hz, 0 < f_lo < f_hi, both finite."""
    if (not isinstance(v, list) or len(v) != 2 or not all(_is_number(x) for x in v)
            or not all(_finite(x) for x in v)):  # fmt: skip
        raise ConfigError(f"{where}: expected [f_lo, f_hi] in Hz, found {v!r}")
    lo, hi = float(v[0]), float(v[1])
    if not 0 < lo < hi:
        raise ConfigError(f"{where}: expected 0 < f_lo < f_hi, found {v!r}")
    return lo, hi


#: Every key a configuration may hold, by section (a misspelt key is an error, not a default).
KEYS = {
    "": {"model", "test", "configuration", "calibration", "output"},
    "model": {"deck", "parameters", "units"},
    "test": {"frf", "model", "truth", "identify", "sensors", "inputs"},
    "test.identify": {"band", "splits", "orders", "max_order", "gamma", "beta", "method"},
    "configuration": {"name", "deck", "parameters", "units", "frf", "model", "truth",
                      "identify", "band", "zeta0", "sensors", "inputs"},
    "calibration": {"band", "zeta0", "crlb_bands", "scheduler", *SETTINGS, *CHOICES, *FLAGS},
    "output": {"pictures"},
}  # fmt: skip


#: Keys of earlier versions, and what took their place.
_REPLACED = {
    "identifiable_crlb": "identifiable_ratio (the posterior over the prior standard deviation "
                         "below which a parameter is identifiable)",
    "regularization": "the prior (bounds_sigma, or a parameter's confidence) and the likelihood "
                      "weighed from the test (noise_sigma)",
}  # fmt: skip


def unknown_key_message(key: str, known: set[str] | tuple[str, ...]) -> str:
    """``unknown key 'x' (expected one of ...)``, with the nearest known key (difflib) when
    one is close: ``; did you mean 'y'?``."""
    near = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
    hint = f"; did you mean {near[0]!r}?" if near else ""
    return f"unknown key {key!r} (expected one of {', '.join(sorted(known))}){hint}"


def _section(doc: dict, name: str, path: Path, where: str | None = None) -> dict:
    """doc[name] as a table (empty if absent); ConfigError if it is something else."""
    value = doc.get(name, {})
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: {name} = {value!r}: expected a [{where or name}] table")
    return value


def _known_keys(section: dict, kind: str, where: str, path: Path) -> None:
    """ConfigError naming the first key of ``section`` that a ``kind`` section does not know,
    the keys it does know and the nearest of them."""
    if kind == "calibration":
        for old, new in _REPLACED.items():
            if old in section:
                raise ConfigError(f"{path}: [calibration] {old} is replaced by {new}")
    unknown = sorted(set(section) - KEYS[kind])
    if unknown:
        raise ConfigError(f"{path}: {where}: {unknown_key_message(unknown[0], KEYS[kind])}")


def _flag(section: dict, key: str, default: bool, where: str) -> bool:
    """section[key] (or default) as a TOML boolean; ConfigError naming the key otherwise."""
    value = section.get(key, default)
    if not isinstance(value, bool):
        raise ConfigError(f"{where} {key} = {value!r}: expected true or false")
    return value


def _word(section: dict, key: str, default: str, where: str) -> str:
    """section[key] (or default), one of :data:`CHOICES`; ConfigError naming them otherwise."""
    value = section.get(key, default)
    if value not in CHOICES[key]:
        raise ConfigError(f"{where} {key} = {value!r}: expected {_choices(CHOICES[key])}")
    return value


def _choices(choices: tuple[str, ...]) -> str:
    """``"a" or "b"``, or ``one of 'a', 'b', 'c'``."""
    if len(choices) == 2:
        return f"\"{choices[0]}\" or \"{choices[1]}\""
    return "one of " + ", ".join(repr(c) for c in choices)


def _positive_whole(value: object, key: str, at: str) -> int:
    """A model order: a whole number of at least 1."""
    n = _number({key: value}, key, None, int, at)
    if n < 1:
        raise ConfigError(f"{at} {key} = {n}: expected a whole number of at least 1")
    return n


def _identify(t: dict, at: str) -> IdentifySettings:
    """A [test.identify] (or [configuration.identify]) table: band, splits strictly inside
    it and increasing, orders ("auto", a number, or one per part), max_order >= 1, residual
    poles at gamma > 1 and beta > gamma times the top of each part."""
    if "band" not in t:
        raise ConfigError(f"{at} needs band = [f_lo, f_hi] (Hz)")
    band = _band(t["band"], f"{at} band")
    splits = t.get("splits")
    if splits is not None:
        if not isinstance(splits, list):
            raise ConfigError(f"{at} splits = {splits!r}: expected a list of frequencies")
        splits = [_number({"splits": x}, "splits", None, float, at) for x in splits]
        if any(not band[0] < x < band[1] for x in splits) or splits != sorted(set(splits)):
            raise ConfigError(f"{at} splits = {splits!r}: expected increasing frequencies "
                              f"inside the band {band[0]:g}-{band[1]:g} Hz")  # fmt: skip
    orders = t.get("orders", "auto")
    if orders == "auto":
        orders = None
    elif isinstance(orders, list):
        if splits is None:
            raise ConfigError(f"{at} orders = {orders!r}: a list of orders needs splits (one "
                              "order per part); expected a number or \"auto\"")  # fmt: skip
        if len(orders) != len(splits) + 1:
            raise ConfigError(f"{at} orders = {orders!r}: expected one order per part, "
                              f"{len(splits) + 1} (the splits make {len(splits) + 1} parts)")
        orders = [None if o == "auto" else _positive_whole(o, "orders", at) for o in orders]
    else:
        orders = _positive_whole(orders, "orders", at)
    max_order = t.get("max_order")
    if max_order is not None:
        max_order = _positive_whole(max_order, "max_order", at)
        if not 2 <= max_order <= MAX_ORDER:
            raise ConfigError(f"{at} max_order = {max_order}: expected a whole number from 2 "
                              f"to {MAX_ORDER}")  # fmt: skip
    method = t.get("method", "plscf")
    if method not in METHODS:
        raise ConfigError(f"{at} method = {method!r}: expected "
                          + " or ".join(f'"{m}"' for m in METHODS))  # fmt: skip
    gamma = _number(t, "gamma", 1.43, float, at)
    if not gamma > 1:
        raise ConfigError(f"{at} gamma = {gamma!r}: expected a number above 1 (the residual "
                          "pole lies at gamma times the top of each part)")  # fmt: skip
    beta = _number(t, "beta", 100.0, float, at)
    if not beta > gamma:
        raise ConfigError(f"{at} beta = {beta!r}: expected a number above gamma ({gamma:g})")
    return IdentifySettings(band, None if splits is None else tuple(splits), orders, max_order,
                            gamma, beta, method)  # fmt: skip


def _zeta0(section: dict, default, at: str, identified: bool) -> float | None:
    """zeta0: a damping ratio, or None for the identified median ("median")."""
    zeta0 = section.get("zeta0", default)
    if zeta0 == "median":
        if not identified:
            raise ConfigError(f"{at} zeta0 = \"median\" needs an identified test model "
                              "([test.identify] or [test] model); give a number")  # fmt: skip
        return None
    if not _is_number(zeta0):
        raise ConfigError(f"{at} zeta0 = {zeta0!r}: expected \"median\" or a damping ratio "
                          "0 < zeta0 < 1")  # fmt: skip
    zeta0 = _number({"zeta0": zeta0}, "zeta0", None, float, at)
    if not 0 < zeta0 < 1:
        raise ConfigError(f"{at} zeta0 = {zeta0}: expected 0 < zeta0 < 1")
    return zeta0


def _text(section: dict, key: str, default: str | None, where: str) -> str | None:
    """section[key] (or default) as a string; ConfigError naming the key otherwise."""
    value = section.get(key, default)
    if value is not None and not isinstance(value, str):
        raise ConfigError(f"{where} {key} = {value!r}: expected a string")
    return value


def _configurations(doc: dict, cal: dict, path: Path) -> tuple[Configuration, ...]:
    """The configurations: the [model] and [test] sections, or the [[configuration]] list."""
    base = path.parent

    def file(section: dict, key: str, where: str, required: bool = True) -> Path | None:
        if key not in section:
            if required:
                raise ConfigError(f"{path}: {where} needs {key}")
            return None
        name = section[key]
        if not isinstance(name, str) or not name.strip() or "\0" in name:
            raise ConfigError(f"{path}: {where} {key} = {name!r}: expected a file name")
        p = (base / name).resolve()
        if p.is_dir():
            raise IsADirectoryError(errno.EISDIR, f"{path}: {where} {key}: a folder, not a "
                                    "file", str(p))  # fmt: skip
        if not p.is_file():
            raise FileNotFoundError(errno.ENOENT, f"{path}: {where} {key}: no such file", str(p))
        return p

    if "configuration" in doc:
        if "model" in doc or "test" in doc:
            raise ConfigError(f"{path}: give [model] and [test], or [[configuration]] entries, "
                              "not both")  # fmt: skip
        entries = doc["configuration"]
        if not isinstance(entries, list) or not entries or not all(
                isinstance(e, dict) for e in entries):
            raise ConfigError(f"{path}: configuration must be a list of [[configuration]] "
                              "tables")  # fmt: skip
        tables = []
        for k, e in enumerate(entries):
            where = f"[[configuration]] {k + 1}"
            _known_keys(e, "configuration", where, path)
            ident = _section(e, "identify", path, "configuration.identify")
            _known_keys(ident, "test.identify", f"{where} [identify]", path)
            tables.append((where, e, e, e, e.get("identify")))
    else:
        model = _section(doc, "model", path)
        test = _section(doc, "test", path)
        ident = _section(test, "identify", path, "test.identify")
        _known_keys(model, "model", "[model]", path)
        _known_keys(test, "test", "[test]", path)
        _known_keys(ident, "test.identify", "[test.identify]", path)
        tables = [("", model, test, cal, test.get("identify"))]
    out: list[Configuration] = []
    for where, model, test, own, ident in tables:
        at_model, at_test = (f"{where}" or "[model]"), (f"{where}" or "[test]")
        deck = file(model, "deck", at_model)
        params = file(model, "parameters", at_model)
        test_frf = file(test, "frf", at_test, required=False)
        test_model = file(test, "model", at_test, required=False)
        test_truth = file(test, "truth", at_test, required=False)
        sensors = file(test, "sensors", at_test, required=False)
        inputs = file(test, "inputs", at_test, required=False)
        if test_frf is None and test_model is None:
            raise ConfigError(f"{path}: {at_test} needs frf (an FRF file) or model (an "
                              "identified model)")  # fmt: skip
        settings = None
        if ident is not None:
            at = f"{path}: {where + ' [identify]' if where else '[test.identify]'}"
            if test_frf is None:
                raise ConfigError(f"{at} needs the test's frf")
            settings = _identify(ident, at)
        at_cal = f"{path}: {where or '[calibration]'}"
        if "band" in own:
            band = _band(own["band"], f"{at_cal} band")
        elif "band" in cal:
            band = _band(cal["band"], f"{path}: [calibration] band")
        else:
            raise ConfigError(f"{path}: [calibration] needs band = [f_lo, f_hi]")
        identified = settings is not None or test_model is not None
        zeta0 = (_zeta0(own, "median", at_cal, identified) if "zeta0" in own
                 else _zeta0(cal, "median", f"{path}: [calibration]", identified))  # fmt: skip
        name = _text(model, "name", deck.stem, f"{path}: {at_model}")
        if not name:
            raise ConfigError(f"{path}: {at_model} name = '': expected a name")
        if name in {c.name for c in out}:
            raise ConfigError(f"{path}: {where}: a configuration named {name!r} is already "
                              "given; every configuration needs its own name")  # fmt: skip
        units = _text(model, "units", "mm/s^2/N", f"{path}: {at_model}")
        out.append(Configuration(name, deck, params, test_frf, test_model, settings, band,
                                 zeta0, units, test_truth, sensors, inputs))  # fmt: skip
    return tuple(out)


def read_config(path: str | os.PathLike[str]) -> Config:
    """Read and check a configuration file: every table's keys, every value's type and
    range (see the module docstring).

    Raises
    ------
    ConfigError
        Naming the file, the table and key of anything missing, unknown or malformed, and
        what was expected (a ValueError too).
    FileNotFoundError, IsADirectoryError
        For the configuration file or a file it names that does not exist, or is a folder.
    """
    path = Path(path)
    text = path.read_bytes()
    try:
        doc = tomllib.loads(text.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not a text file in UTF-8 (byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML ({e})") from None
    _known_keys(doc, "", "the top level", path)
    cal = _section(doc, "calibration", path)
    out = _section(doc, "output", path)
    _known_keys(cal, "calibration", "[calibration]", path)
    _known_keys(out, "output", "[output]", path)
    where = f"{path}: [calibration]"
    configurations = _configurations(doc, cal, path)
    words = {k: _word(cal, k, getattr(Config, k), where) for k in CHOICES}
    flags = {k: _flag(cal, k, d, where) for k, d in FLAGS.items()}
    numbers = {k: _setting(cal, k, where) for k in SETTINGS
               if k not in ("enrich_hz", "enrich_vectors")}  # fmt: skip
    numbers["enrich_vectors"] = _setting(cal, "enrich_vectors", where,
                                         numbers["reduction_modes"])  # fmt: skip
    # with the exact-gradient correction the derivative vectors are not needed (and, compressed,
    # they spoil the surrogate away from its centre: benchmarks/RESULTS.md)
    top = max(c.band[1] for c in configurations)
    numbers["enrich_hz"] = _setting(cal, "enrich_hz", where,
                                    0.0 if flags["exact_gradient"] else 1.5 * top)  # fmt: skip
    bands = cal.get("crlb_bands", [])
    if not isinstance(bands, list):
        raise ConfigError(f"{where} crlb_bands = {bands!r}: expected a list of bands, e.g. "
                          "[[10.0, 40.0], [40.0, 100.0]]")  # fmt: skip
    sigma = numbers.pop("noise_sigma")
    scheduler = _text(cal, "scheduler", "", where) or None
    cfg = Config(path=path, configurations=configurations, **words, **flags, **numbers,
                 noise_sigma=float(sigma) if sigma else None, scheduler=scheduler,
                 crlb_bands=tuple(_band(b, f"{where} crlb_bands") for b in bands),
                 pictures=_flag(out, "pictures", True, f"{path}: [output]"), raw=doc)
    check_config(cfg)
    return cfg


def check_config(cfg: Config) -> None:
    """Check the settings of a :class:`Config` however it was made (read, or built and
    changed in code): every number in its range (:data:`SETTINGS`), every word one of its
    choices, at least one configuration, and what the settings need of each other.

    Raises
    ------
    ConfigError
        Naming the configuration file and key (``[calibration] max_cycles = 0: expected a
        whole number of at least 1``).
    """
    where = f"{cfg.path}: [calibration]"
    if not cfg.configurations:
        raise ConfigError(f"{cfg.path}: no configuration to calibrate ([model] and [test], or "
                          "[[configuration]] entries)")  # fmt: skip
    for key, s in SETTINGS.items():
        value = getattr(cfg, key)
        if key == "noise_sigma" and value is None:
            continue
        if (not _is_number(value) or not _finite(value)
                or (s.kind is int and not float(value).is_integer()) or not s.accepts(value)):
            raise ConfigError(f"{where} {key} = {value!r}: expected {s.expected}")
    for key, choices in CHOICES.items():
        if getattr(cfg, key) not in choices:
            raise ConfigError(f"{where} {key} = {getattr(cfg, key)!r}: expected "
                              f"{_choices(choices)}")  # fmt: skip
    if cfg.scheduler is not None and cfg.engine != "dask":
        raise ConfigError(f"{where} scheduler = {cfg.scheduler!r} needs engine = \"dask\" "
                          f"(engine is {cfg.engine!r})")  # fmt: skip
    if cfg.identifiable_ratio > cfg.hold_ratio:
        raise ConfigError(f"{where} identifiable_ratio = {cfg.identifiable_ratio!r}: expected "
                          f"at most hold_ratio ({cfg.hold_ratio!r}): a parameter the test "
                          "informs that little is held, not identifiable")  # fmt: skip
    for conf in cfg.configurations:
        if conf.zeta0 is not None and n_frequencies(conf.band, conf.zeta0,
                                                    cfg.samples_per_bandwidth) > MAX_FREQUENCIES:
            raise ConfigError(f"{cfg.path}: configuration {conf.name}: zeta0 = {conf.zeta0!r} "
                              f"with band {conf.band[0]:g}-{conf.band[1]:g} Hz and "
                              f"samples_per_bandwidth = {cfg.samples_per_bandwidth!r} needs "
                              f"more than {MAX_FREQUENCIES} frequencies: expected a larger "
                              "zeta0 (a structure's damping ratio, e.g. 0.01), fewer samples "
                              "or a narrower band")  # fmt: skip
    if cfg.holdout == "configurations" and len(cfg.configurations) < 2:
        raise ConfigError(f"{where} holdout = \"configurations\" needs two configurations or "
                          "more")  # fmt: skip
