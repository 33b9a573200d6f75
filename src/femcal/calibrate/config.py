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
    splits = [50.0, 80.0]                   #  FRFs are compared, and zeta0 must be given)
    orders = "auto"                         # or a number, or a list per part
    max_order = 24
    gamma = 1.43
    beta = 100.0

    [calibration]
    band = [10.0, 100.0]                    # Hz
    zeta0 = "median"                        # or a damping ratio
    samples_per_bandwidth = 3.0
    metric = "log-magnitude"                # or "complex-log"
    loss = "huber"                          # or "squared" (least squares): Huber's loss,
    huber_c = 2.0                           #  quadratic within huber_c robust standard
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
    starts = 8                              # Latin hypercube starts (the nominal is one)
    workers = 2                             # parallel processes for the starts
    seed = 1
    max_iterations = 30                     # per start and cycle
    max_cycles = 5                          # surrogate rebuilds
    settle = 1e-3                           # stop when no informed p moves more than this
    restarts = 2                            # the multi-start search runs again on the
    restart_fall = 0.01                     #  current surrogate (at most this many times)
                                            #  when a kept step lowers the full model's
                                            #  cost by less than this fraction, or when the
                                            #  cycles settle; its best start is the next
                                            #  candidate
    bounds_sigma = 3.0                      # the prior: the bounds lie this many standard
                                            #  deviations from the nominal (a parameter's
                                            #  confidence in the parameter file wins)
    noise_sigma = 0.0                       # > 0: the test's known noise (log10 units): the
                                            #  residuals are independent with this sigma;
                                            #  0: sigma and the residuals' effective number
                                            #  of independent observations come from the
                                            #  nominal model's residual
    hold_ratio = 0.99                       # parameters whose posterior standard deviation
                                            #  at the nominal stays at this fraction of the
                                            #  prior's or more are held at the nominal
    identifiable_ratio = 0.5                # posterior below this fraction of the prior:
                                            #  identifiable
    crlb_bands = [[10.0, 40.0], [40.0, 100.0]]  # the posterior from each band alone
                                            #  (optional)
    holdout = "auto"                        # validation on data the fit did not see:
                                            #  "inputs", "sensors", "configurations",
                                            #  "auto" or "none" (femcal.calibrate.holdout)
    holdout_folds = 4                       # groups of sensor positions for "sensors"
    exclude_suspect_channels = true

    [output]
    pictures = true                         # PNG pictures and mode renderings

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

import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .metric import METRICS

#: The hold-out validation's kinds (femcal.calibrate.holdout).
HOLDOUT_KINDS = ("auto", "inputs", "sensors", "configurations", "none")


@dataclass(frozen=True)
class IdentifySettings:
    band: tuple[float, float]
    splits: tuple[float, ...] = ()
    orders: object = None  # None (automatic), int, or list
    max_order: int = 24
    gamma: float = 1.43
    beta: float = 100.0


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
    exclude_suspect_channels: bool = True
    pictures: bool = True
    raw: dict = field(default_factory=dict)


def _band(v, where: str) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected [f_lo, f_hi] in Hz, found {v!r}") from None
    if not 0 < lo < hi:
        raise ValueError(f"{where}: expected 0 < f_lo < f_hi, found {v!r}")
    return lo, hi


def _number(section: dict, key: str, default, kind, where: str):
    """section[key] (or default) as int or float; ValueError naming the key otherwise."""
    value = section.get(key, default)
    if kind is int and isinstance(value, float) and not value.is_integer():
        raise ValueError(f"{where} {key} = {value!r}: expected a whole number")
    try:
        return kind(value)
    except (TypeError, ValueError):
        what = "a whole number" if kind is int else "a number"
        raise ValueError(f"{where} {key} = {value!r}: expected {what}") from None


#: Every key a configuration may hold, by section (a misspelt key is an error, not a default).
KEYS = {
    "": {"model", "test", "configuration", "calibration", "output"},
    "model": {"deck", "parameters", "units"},
    "test": {"frf", "model", "truth", "identify", "sensors", "inputs"},
    "test.identify": {"band", "splits", "orders", "max_order", "gamma", "beta"},
    "configuration": {"name", "deck", "parameters", "units", "frf", "model", "truth",
                      "identify", "band", "zeta0", "sensors", "inputs"},
    "calibration": {
        "band", "zeta0", "samples_per_bandwidth", "metric", "loss", "huber_c",
        "reduction_modes", "surrogate",
        "enrich_hz", "enrich_vectors", "residual", "modal_hz", "exact_gradient", "starts",
        "workers", "seed", "max_iterations", "max_cycles", "settle", "restarts",
        "restart_fall", "bounds_sigma", "noise_sigma", "hold_ratio", "identifiable_ratio",
        "crlb_bands", "holdout", "holdout_folds",
        "exclude_suspect_channels",
    },
    "output": {"pictures"},
}  # fmt: skip


#: Keys of earlier versions, and what took their place.
_REPLACED = {
    "identifiable_crlb": "identifiable_ratio (the posterior over the prior standard deviation "
                         "below which a parameter is identifiable)",
    "regularization": "the prior (bounds_sigma, or a parameter's confidence) and the likelihood "
                      "weighed from the test (noise_sigma)",
}  # fmt: skip


def _section(doc: dict, name: str, path: Path, where: str | None = None) -> dict:
    """doc[name] as a table (empty if absent); ValueError if it is something else."""
    value = doc.get(name, {})
    if not isinstance(value, dict):
        raise ValueError(f"{path}: {name} must be a [{where or name}] section")
    return value


def _known_keys(section: dict, kind: str, where: str, path: Path) -> None:
    """ValueError naming the first key of ``section`` that a ``kind`` section does not know."""
    if kind == "calibration":
        for old, new in _REPLACED.items():
            if old in section:
                raise ValueError(f"{path}: [calibration] {old} is replaced by {new}")
    unknown = sorted(set(section) - KEYS[kind])
    if unknown:
        raise ValueError(f"{path}: {where}: unknown key {unknown[0]!r} (expected one of "
                         f"{', '.join(sorted(KEYS[kind]))})")  # fmt: skip


def _positive(section: dict, key: str, default: float, where: str) -> float:
    """section[key] (or default) as a positive number; ValueError naming the key otherwise."""
    value = _number(section, key, default, float, where)
    if not value > 0:
        raise ValueError(f"{where} {key} = {value}: expected a positive number")
    return value


def _flag(section: dict, key: str, default: bool, where: str) -> bool:
    """section[key] (or default) as a TOML boolean; ValueError naming the key otherwise."""
    value = section.get(key, default)
    if not isinstance(value, bool):
        raise ValueError(f"{where} {key} = {value!r}: expected true or false")
    return value


def _identify(t: dict, at: str) -> IdentifySettings:
    """A [test.identify] (or [configuration.identify]) table."""
    orders = t.get("orders", "auto")
    if orders == "auto":
        orders = None
    elif isinstance(orders, list):
        orders = [None if o == "auto" else _number({"orders": o}, "orders", None, int, at)
                  for o in orders]  # fmt: skip
    else:
        orders = _number(t, "orders", None, int, at)
    splits = t.get("splits", [])
    if not isinstance(splits, list):
        raise ValueError(f"{at} splits = {splits!r}: expected a list of frequencies")
    return IdentifySettings(_band(t.get("band"), f"{at} band"),
                            tuple(_number({"splits": x}, "splits", None, float, at)
                                  for x in splits), orders,
                            _number(t, "max_order", 24, int, at),
                            _number(t, "gamma", 1.43, float, at),
                            _number(t, "beta", 100.0, float, at))  # fmt: skip


def _zeta0(section: dict, default, at: str, identified: bool) -> float | None:
    """zeta0: a damping ratio, or None for the identified median ("median")."""
    zeta0 = section.get("zeta0", default)
    if zeta0 == "median":
        if not identified:
            raise ValueError(f"{at} zeta0 = \"median\" needs an identified test model "
                             "([test.identify] or [test] model); give a number")  # fmt: skip
        return None
    zeta0 = _number({"zeta0": zeta0}, "zeta0", None, float, at)
    if not 0 < zeta0 < 1:
        raise ValueError(f"{at} zeta0 = {zeta0}: expected 0 < zeta0 < 1")
    return zeta0


def _configurations(doc: dict, cal: dict, path: Path) -> tuple[Configuration, ...]:
    """The configurations: the [model] and [test] sections, or the [[configuration]] list."""
    base = path.parent

    def file(section: dict, key: str, where: str, required: bool = True) -> Path | None:
        if key not in section:
            if required:
                raise ValueError(f"{path}: {where} needs {key}")
            return None
        p = (base / str(section[key])).resolve()
        if not p.is_file():
            raise FileNotFoundError(2, f"{where} {key}: no such file", str(p))
        return p

    if "configuration" in doc:
        if "model" in doc or "test" in doc:
            raise ValueError(f"{path}: give [model] and [test], or [[configuration]] entries, "
                             "not both")  # fmt: skip
        entries = doc["configuration"]
        if not isinstance(entries, list) or not entries or not all(
                isinstance(e, dict) for e in entries):
            raise ValueError(f"{path}: configuration must be a list of [[configuration]] "
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
            raise ValueError(f"{path}: {at_test} needs frf (an FRF file) or model (an "
                             "identified model)")  # fmt: skip
        settings = None
        if ident is not None:
            at = f"{path}: {where + ' [identify]' if where else '[test.identify]'}"
            if test_frf is None:
                raise ValueError(f"{at} needs the test's frf")
            settings = _identify(ident, at)
        at_cal = f"{path}: {where or '[calibration]'}"
        if "band" in own:
            band = _band(own["band"], f"{at_cal} band")
        elif "band" in cal:
            band = _band(cal["band"], f"{path}: [calibration] band")
        else:
            raise ValueError(f"{path}: [calibration] needs band = [f_lo, f_hi]")
        identified = settings is not None or test_model is not None
        zeta0 = (_zeta0(own, "median", at_cal, identified) if "zeta0" in own
                 else _zeta0(cal, "median", f"{path}: [calibration]", identified))  # fmt: skip
        name = str(model.get("name", deck.stem))
        if name in {c.name for c in out}:
            raise ValueError(f"{path}: {where}: a configuration named {name!r} is already "
                             "given; every configuration needs its own name")  # fmt: skip
        out.append(Configuration(name, deck, params, test_frf, test_model, settings, band,
                                 zeta0, model.get("units", "mm/s^2/N"), test_truth, sensors,
                                 inputs))  # fmt: skip
    return tuple(out)


def read_config(path: str | os.PathLike[str]) -> Config:
    """Read and check a configuration file.

    Raises
    ------
    ValueError
        Naming the file and key of anything missing or malformed.
    FileNotFoundError
        For the configuration file or a file it names that does not exist.
    """
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML ({e})") from None
    _known_keys(doc, "", "the top level", path)
    cal = _section(doc, "calibration", path)
    out = _section(doc, "output", path)
    _known_keys(cal, "calibration", "[calibration]", path)
    _known_keys(out, "output", "[output]", path)
    where = f"{path}: [calibration]"
    configurations = _configurations(doc, cal, path)
    metric = str(cal.get("metric", "log-magnitude"))
    if metric not in METRICS:
        raise ValueError(f"{path}: [calibration] metric = {metric!r}: expected one of "
                         f"{', '.join(METRICS)}")  # fmt: skip
    loss = str(cal.get("loss", "huber"))
    if loss not in ("huber", "squared"):
        raise ValueError(f"{where} loss = {loss!r}: expected \"huber\" or \"squared\"")
    sigma = _number(cal, "noise_sigma", 0.0, float, where)
    if sigma < 0:
        raise ValueError(f"{where} noise_sigma = {sigma}: expected 0 (estimate it) or the "
                         "noise's standard deviation in log10 units")  # fmt: skip
    surrogate = str(cal.get("surrogate", "exact"))
    if surrogate not in ("exact", "first-order"):
        raise ValueError(f"{path}: [calibration] surrogate = {surrogate!r}: expected \"exact\" "
                         "or \"first-order\"")  # fmt: skip
    defaults = (("reduction_modes", 100), ("starts", 8), ("workers", 2), ("seed", 1),
                ("max_iterations", 30), ("max_cycles", 5))
    ints = {k: _number(cal, k, d, int, where) for k, d in defaults}
    ints["enrich_vectors"] = _number(cal, "enrich_vectors", ints["reduction_modes"], int, where)
    for k in ("reduction_modes", "starts", "workers", "max_iterations", "max_cycles",
              "enrich_vectors"):
        if ints[k] < 1:
            raise ValueError(f"{path}: [calibration] {k} must be at least 1")
    exact_gradient = _flag(cal, "exact_gradient", True, where)
    # with the exact-gradient correction the derivative vectors are not needed (and, compressed,
    # they spoil the surrogate away from its centre: benchmarks/RESULTS.md)
    top = max(c.band[1] for c in configurations)
    enrich_hz = _number(cal, "enrich_hz", 0.0 if exact_gradient else 1.5 * top, float, where)
    if enrich_hz < 0:
        raise ValueError(f"{path}: [calibration] enrich_hz = {enrich_hz}: expected a frequency "
                         "in Hz, or 0 for no enrichment")  # fmt: skip
    restarts = _number(cal, "restarts", 2, int, where)
    if restarts < 0:
        raise ValueError(f"{path}: [calibration] restarts = {restarts}: expected 0 or more")
    restart_fall = _number(cal, "restart_fall", 0.01, float, where)
    if not 0 <= restart_fall < 1:
        raise ValueError(f"{path}: [calibration] restart_fall = {restart_fall}: expected a "
                         "fraction in [0, 1)")  # fmt: skip
    holdout = str(cal.get("holdout", "auto"))
    if holdout not in HOLDOUT_KINDS:
        raise ValueError(f"{where} holdout = {holdout!r}: expected one of "
                         f"{', '.join(repr(k) for k in HOLDOUT_KINDS)}")  # fmt: skip
    holdout_folds = _number(cal, "holdout_folds", 4, int, where)
    if holdout_folds < 2:
        raise ValueError(f"{where} holdout_folds = {holdout_folds}: expected 2 or more")
    if holdout == "configurations" and len(configurations) < 2:
        raise ValueError(f"{where} holdout = \"configurations\" needs two configurations or "
                         "more")  # fmt: skip
    modal_hz = _number(cal, "modal_hz", 0.0, float, where)
    if modal_hz < 0:
        raise ValueError(f"{path}: [calibration] modal_hz = {modal_hz}: expected a frequency "
                         "in Hz, or 0 for all reduction modes")  # fmt: skip
    return Config(
        path=path, configurations=configurations,
        samples_per_bandwidth=_number(cal, "samples_per_bandwidth", 3.0, float, where),
        metric=metric, loss=loss, huber_c=_positive(cal, "huber_c", 2.0, where),
        settle=_number(cal, "settle", 1e-3, float, where), surrogate=surrogate,
        enrich_hz=enrich_hz,
        bounds_sigma=_positive(cal, "bounds_sigma", 3.0, where),
        noise_sigma=float(sigma) if sigma else None,
        hold_ratio=_positive(cal, "hold_ratio", 0.99, where),
        identifiable_ratio=_positive(cal, "identifiable_ratio", 0.5, where),
        crlb_bands=tuple(_band(b, f"{path}: [calibration] crlb_bands")
                         for b in cal.get("crlb_bands", [])),
        holdout=holdout, holdout_folds=holdout_folds,
        exclude_suspect_channels=_flag(cal, "exclude_suspect_channels", True, where),
        residual=_flag(cal, "residual", False, where), modal_hz=modal_hz,
        exact_gradient=exact_gradient, restarts=restarts, restart_fall=restart_fall,
        pictures=_flag(out, "pictures", True, f"{path}: [output]"), raw=doc, **ints,
    )  # fmt: skip
