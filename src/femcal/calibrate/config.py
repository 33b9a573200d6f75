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
                                            #  parameter's error against its CRLB

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
    exclude_suspect_channels = true

    [output]
    pictures = true                         # PNG pictures and mode renderings
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .metric import METRICS


@dataclass(frozen=True)
class IdentifySettings:
    band: tuple[float, float]
    splits: tuple[float, ...] = ()
    orders: object = None  # None (automatic), int, or list
    max_order: int = 24
    gamma: float = 1.43
    beta: float = 100.0


@dataclass(frozen=True)
class Config:
    """A calibration run (see the module docstring for the keys and defaults)."""

    path: Path
    deck: Path
    parameters: Path
    test_frf: Path | None
    test_model: Path | None
    identify: IdentifySettings | None
    band: tuple[float, float]
    model_units: str | None = "mm/s^2/N"
    zeta0: float | None = None
    samples_per_bandwidth: float = 3.0
    metric: str = "log-magnitude"
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
    exclude_suspect_channels: bool = True
    test_truth: Path | None = None
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
    "": {"model", "test", "calibration", "output"},
    "model": {"deck", "parameters", "units"},
    "test": {"frf", "model", "truth", "identify"},
    "test.identify": {"band", "splits", "orders", "max_order", "gamma", "beta"},
    "calibration": {
        "band", "zeta0", "samples_per_bandwidth", "metric", "reduction_modes", "surrogate",
        "enrich_hz", "enrich_vectors", "residual", "modal_hz", "exact_gradient", "starts",
        "workers", "seed", "max_iterations", "max_cycles", "settle", "restarts",
        "restart_fall", "bounds_sigma", "noise_sigma", "hold_ratio", "identifiable_ratio",
        "crlb_bands",
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


def _no_unknown_keys(doc: dict, path: Path) -> None:
    """ValueError naming the first key (or section) the configuration does not know."""
    sections = [("", doc)]
    for name in ("model", "test", "calibration", "output"):
        section = doc.get(name, {})
        if not isinstance(section, dict):
            raise ValueError(f"{path}: {name} must be a [{name}] section")
        sections.append((name, section))
    identify = doc.get("test", {}).get("identify", {})
    if not isinstance(identify, dict):
        raise ValueError(f"{path}: [test] identify must be a [test.identify] section")
    sections.append(("test.identify", identify))
    for name, section in sections:
        for old, new in _REPLACED.items():
            if name == "calibration" and old in section:
                raise ValueError(f"{path}: [calibration] {old} is replaced by {new}")
        unknown = sorted(set(section) - KEYS[name])
        if unknown:
            where = f"[{name}]" if name else "the top level"
            raise ValueError(f"{path}: {where}: unknown key {unknown[0]!r} (expected one of "
                             f"{', '.join(sorted(KEYS[name]))})")  # fmt: skip


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
    base = path.parent

    def file(section: dict, key: str, where: str, required: bool = True) -> Path | None:
        if key not in section:
            if required:
                raise ValueError(f"{path}: [{where}] needs {key}")
            return None
        p = (base / str(section[key])).resolve()
        if not p.is_file():
            raise FileNotFoundError(2, f"[{where}] {key}: no such file", str(p))
        return p

    _no_unknown_keys(doc, path)
    model = doc.get("model", {})
    test = doc.get("test", {})
    cal = doc.get("calibration", {})
    where = f"{path}: [calibration]"
    out = doc.get("output", {})
    deck = file(model, "deck", "model")
    params = file(model, "parameters", "model")
    test_frf = file(test, "frf", "test", required=False)
    test_model = file(test, "model", "test", required=False)
    test_truth = file(test, "truth", "test", required=False)
    if test_frf is None and test_model is None:
        raise ValueError(f"{path}: [test] needs frf (an FRF file) or model (an identified model)")
    ident = None
    if "identify" in test:
        if test_frf is None:
            raise ValueError(f"{path}: [test.identify] needs [test] frf")
        t = test["identify"]
        at = f"{path}: [test.identify]"
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
        ident = IdentifySettings(_band(t.get("band"), f"{at} band"),
                                 tuple(_number({"splits": x}, "splits", None, float, at)
                                       for x in splits), orders,
                                 _number(t, "max_order", 24, int, at),
                                 _number(t, "gamma", 1.43, float, at),
                                 _number(t, "beta", 100.0, float, at))  # fmt: skip
    if "band" not in cal:
        raise ValueError(f"{path}: [calibration] needs band = [f_lo, f_hi]")
    band = _band(cal["band"], f"{path}: [calibration] band")
    zeta0 = cal.get("zeta0", "median")
    if zeta0 == "median":
        if ident is None and test_model is None:
            raise ValueError(f"{path}: [calibration] zeta0 = \"median\" needs an identified test "
                             "model ([test.identify] or [test] model); give a number")  # fmt: skip
        zeta0 = None
    else:
        zeta0 = _number(cal, "zeta0", None, float, where)
        if not 0 < zeta0 < 1:
            raise ValueError(f"{path}: [calibration] zeta0 = {zeta0}: expected 0 < zeta0 < 1")
    metric = str(cal.get("metric", "log-magnitude"))
    if metric not in METRICS:
        raise ValueError(f"{path}: [calibration] metric = {metric!r}: expected one of "
                         f"{', '.join(METRICS)}")  # fmt: skip
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
    enrich_hz = _number(cal, "enrich_hz", 0.0 if exact_gradient else 1.5 * band[1], float, where)
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
    modal_hz = _number(cal, "modal_hz", 0.0, float, where)
    if modal_hz < 0:
        raise ValueError(f"{path}: [calibration] modal_hz = {modal_hz}: expected a frequency "
                         "in Hz, or 0 for all reduction modes")  # fmt: skip
    return Config(
        path=path, deck=deck, parameters=params, test_frf=test_frf, test_model=test_model,
        identify=ident, band=band, model_units=model.get("units", "mm/s^2/N"), zeta0=zeta0,
        samples_per_bandwidth=_number(cal, "samples_per_bandwidth", 3.0, float, where),
        metric=metric, settle=_number(cal, "settle", 1e-3, float, where), surrogate=surrogate,
        enrich_hz=enrich_hz,
        bounds_sigma=_positive(cal, "bounds_sigma", 3.0, where),
        noise_sigma=float(sigma) if sigma else None,
        hold_ratio=_positive(cal, "hold_ratio", 0.99, where),
        identifiable_ratio=_positive(cal, "identifiable_ratio", 0.5, where),
        crlb_bands=tuple(_band(b, f"{path}: [calibration] crlb_bands")
                         for b in cal.get("crlb_bands", [])),
        exclude_suspect_channels=bool(cal.get("exclude_suspect_channels", True)),
        residual=_flag(cal, "residual", False, where), modal_hz=modal_hz,
        exact_gradient=exact_gradient, restarts=restarts, restart_fall=restart_fall,
        test_truth=test_truth,
        pictures=bool(out.get("pictures", True)), raw=doc, **ints,
    )  # fmt: skip
