"""A design study (``femcal study``): a model generator, or a deck as a template, run over a
set of values of a design variable, each point solved for its normal modes, the modes tracked
across the points by MAC, and the frequencies written as a table and a plot against the
variable.

The configuration (TOML)::

    [model]
    generator = "truck-frame"      # the bundled truck ladder frame (femcal.examples)
    variant = "hammer"             # hammer, rig or rig-battery
    [[variable]]
    name = "cross_x_3"             # the third cross member's x (mm)
    values = [2475, 2375, 2275]
    [solve]
    band = [5, 120]                # elastic modes in this band (Hz); or: modes = N
    [pairing]
    min_mac = 0.8
    reference = 0                  # the point (0-based) whose modes are tracked

or, with a deck of one's own as the template::

    [model]
    deck = "frame.bdf"             # relative to the configuration file
    [[variable]]
    name = "t_rail"
    unit = "mm"
    fields = [["PSHELL", 1, "T"], ["PSHELL", 9, "T"]]   # (card, id, field): each set to the value
    values = [8.0, 7.2, 6.4]

Each point of a deck study is the deck's own text with those fields changed
(:mod:`femcal.deck.edit`: in each card's format, its INCLUDEs kept resolving), read back and
solved; every value is tried on the fields when the configuration is read, so a card or field
missing from the deck, or a value that does not fit its field, is named (file, card, id,
field) before any solve. A field may be any real field the deck's card layouts name (a
thickness, a modulus, an area, a spring rate, a mass, a grid coordinate).

**Common stations.** The generator puts grid lines at the cross members, so the meshes of
two points differ. Shapes are compared at a fixed set of stations the generator names (the
truck frame: the two rails' top-flange centre lines every :data:`STATION_STEP` mm), each
point's nearest grid to each station standing for it; the translations there, in the basic
frame, are the shape vector MAC is computed on. A deck study's points share the deck's
grids: shapes are compared at all of them.

**Elastic modes.** Modes below ``rigid_below`` Hz (default :data:`RIGID_BELOW`: the frame's
six suspension modes on its soft bellows are at 1-4 Hz) are left out; so is anything below the
band's bottom.

**Tracking.** The tracked modes are the reference point's elastic modes in the band (or its
lowest N). Points are visited outwards from the reference, and each is paired to its
neighbour nearer the reference (not to the reference itself), so that a shape which drifts
slowly along the sweep is still followed (:func:`femcal.correlate.pair_modes`: greedy by falling
MAC, each mode at most once, MAC >= ``min_mac``; by shape alone, or with frequencies within a
factor ``max_frequency_ratio`` when the configuration gives one). Neighbours
are solved to :data:`BAND_MARGIN` times the band's top so that a mode leaving the band is
still found. A track lost at a point (no partner with MAC >= ``min_mac``) stays lost beyond
it; modes of other points that pair to no tracked mode are counted, not tracked.

The points are independent and may be solved side by side, in local worker processes or
on a Dask cluster (:func:`run_study`'s ``engine``; ``femcal study --workers N``,
``--engine dask``, ``--scheduler ADDRESS``). The library never prints: progress goes to a
``progress`` callback (a :class:`~femcal.parallel.progress.Step` per point solved).
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import tempfile
import time
import tomllib
from collections.abc import Callable, Sequence
from concurrent.futures import as_completed
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..atomic import write_atomic, write_lines
from ..calibrate.config import unknown_key_message
from ..correlate.shapes import pair_modes
from ..errors import ConfigError
from ..model.analysis import EigenRequest
from ..model.model import Model
from ..parallel.cluster import Engine, one_blas_thread, result_of
from ..parallel.progress import Progress, Step

__all__ = [
    "GENERATORS",
    "Point",
    "StudyConfig",
    "StudyResult",
    "Track",
    "read_study_config",
    "run_study",
    "study_config",
    "write_study",
]

#: Modes below this frequency (Hz) are rigid-body or suspension modes, not tracked.
RIGID_BELOW = 5.0
#: Station spacing (mm) along the rails.
STATION_STEP = 100.0
#: Neighbours are solved to this factor times the band's top (a mode leaving the band is
#: still paired).
BAND_MARGIN = 1.2
#: With ``modes = N``, the solve asks for N plus this many roots (the rigid-body ones).
EXTRA_ROOTS = 12


# ----------------------------------------------------------------------------- generators


@dataclass(frozen=True)
class Generator:
    """A model generator: its variants, its variables (name -> unit, description) and a
    function ``build(variant, {name: value}) -> (Model, stations (n, 3))``."""

    name: str
    variants: tuple[str, ...]
    variables: dict[str, tuple[str, str]]
    build: Callable[[str, dict[str, float]], tuple[Model, np.ndarray]]
    check: Callable[[str, str, float], str]  # variant, name, value -> "" or what is wrong


def _truck_dims(variant: str):
    from ..examples import truck_frame as tf

    return {"hammer": tf.FrameDimensions(), "rig": tf.RIG, "rig-battery": tf.RIG_BATTERY}[variant]


def _truck_check(variant: str, name: str, value: float) -> str:
    """Why ``value`` of cross_x_K cannot be built ("" if it can): it must stay between the
    neighbouring cross members (100 mm clear) and inside the frame; then the frame is built
    and must hold together: the cross members' end plates (or cast brackets) may not
    overlap, every bolt must land on the plies it joins, and no grid may belong to two bolt
    spiders."""
    from ..examples import truck_frame as tf

    d = _truck_dims(variant)
    k = int(name.rsplit("_", 1)[1]) - 1
    if not 0 <= k < len(d.cross_x):
        return f"the {variant} frame has {len(d.cross_x)} cross members (cross_x_1 to " \
               f"cross_x_{len(d.cross_x)})"  # fmt: skip
    lo = d.cross_x[k - 1] + 100.0 if k > 0 else 100.0
    hi = d.cross_x[k + 1] - 100.0 if k + 1 < len(d.cross_x) else d.length - 100.0
    if not (math.isfinite(value) and lo <= value <= hi):
        return f"expected {lo:g} <= x <= {hi:g} mm (100 mm clear of the neighbouring cross " \
               "members and the frame's ends)"  # fmt: skip
    cross = [*d.cross_x]
    cross[k] = float(value)
    d = replace(d, cross_x=tuple(cross))
    feet = [(x + tf.CROSS_KINDS[kind].plate_x[0], x + tf.CROSS_KINDS[kind].plate_x[1])
            for x, kind in zip(d.cross_x, d.cross_kinds, strict=True)]  # fmt: skip
    for i in range(len(feet) - 1):
        if feet[i][1] > feet[i + 1][0]:
            return (f"cross member {i + 1}'s end plates (x {feet[i][0]:g} to {feet[i][1]:g} "
                    f"mm) overlap cross member {i + 2}'s ({feet[i + 1][0]:g} to "
                    f"{feet[i + 1][1]:g} mm)")  # fmt: skip
    try:
        frame = tf.build_frame(d)
    except KeyError:  # a bolt's point is not on the mesh of a ply it joins
        return (f"the frame cannot be built there: a bolt of the cross member lands off the "
                f"plies it joins (the inner liner runs from x {d.liner_x[0]:g} to "
                f"{d.liner_x[1]:g} mm)")  # fmt: skip
    except RuntimeError as e:  # a bolt spider without enough rim nodes
        return f"the frame cannot be built there: {e}"
    seen: dict[int, int] = {}
    for centre, ring in frame.rbe2:
        for g in ring:
            if seen.setdefault(g, centre) != centre:
                return (f"two bolt spiders share grid {g} (bolts at grids {seen[g]} and "
                        f"{centre}): the cross member is too close to another bolt")  # fmt: skip
    return ""


def _truck_build(variant: str, values: dict[str, float]) -> tuple[Model, np.ndarray]:
    from ..examples import truck_frame as tf
    from ..model.build import load_model

    d = _truck_dims(variant)
    cross = list(d.cross_x)
    for name, v in values.items():
        cross[int(name.rsplit("_", 1)[1]) - 1] = float(v)
    d = replace(d, cross_x=tuple(cross))
    frame = tf.build_frame(d)
    # the deck reader reads files: the point's deck goes through a temporary folder
    with tempfile.TemporaryDirectory(prefix="femcal-study-") as tmp:
        deck = write_lines(Path(tmp) / "point.bdf", tf.deck_lines(frame, "design study point"))
        model = load_model(deck)
    xs = np.arange(STATION_STEP / 2, d.length, STATION_STEP)
    y, z = d.half_width - d.flange / 2, d.web / 2  # top flange's centre line
    stations = np.array([(x, s * y, z) for s in (1.0, -1.0) for x in xs])
    return model, stations


GENERATORS: dict[str, Generator] = {
    "truck-frame": Generator(
        "truck-frame", ("hammer", "rig", "rig-battery"),
        {f"cross_x_{k}": ("mm", f"x of cross member {k} (from the front end)")
         for k in range(1, 6)},
        _truck_build, _truck_check,
    ),
}  # fmt: skip


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class StudyConfig:
    """A design study: ``generator`` (of :data:`GENERATORS`) and its ``variant``, or a
    ``deck`` whose ``fields`` ((card, id, field name), each set to the variable's value) are
    the design variable; the variable ``variable`` (its ``unit``) and its ``values``;
    ``band`` (Hz) or ``n_modes``; ``min_mac`` and ``reference`` (0-based index into
    ``values``); ``rigid_below`` (Hz); ``max_frequency_ratio``: paired modes' frequencies
    within this factor (None: paired by shape alone, however far a mode moves between
    points)."""

    generator: str
    variant: str
    variable: str
    values: tuple[float, ...]
    unit: str = ""
    band: tuple[float, float] | None = (RIGID_BELOW, 120.0)
    n_modes: int | None = None
    min_mac: float = 0.8
    reference: int = 0
    rigid_below: float = RIGID_BELOW
    deck: Path | None = None
    fields: tuple[tuple[str, int, str], ...] = ()
    max_frequency_ratio: float | None = None

    @property
    def source(self) -> str:
        """What is studied, for titles: the deck's name, or the generator and variant."""
        return self.deck.name if self.deck is not None else f"{self.generator} ({self.variant})"


def _deck_edits(cfg_fields: Sequence[tuple[str, int, str]], name: str,
                value: float) -> list:  # fmt: skip
    from ..deck.edit import FieldEdit

    return [FieldEdit(card, ident, field, value, note=name) for card, ident, field in cfg_fields]


def _deck_fields(var: dict, bad: Callable[[str, str], ConfigError]) -> tuple:
    """A deck study's ``fields``: a non-empty list of [card, id, field] (e.g. ["PSHELL",
    7, "T"])."""
    fields = var.get("fields")
    ok = isinstance(fields, list) and fields and all(
        isinstance(f, list) and len(f) == 3 and isinstance(f[0], str)
        and isinstance(f[1], int) and not isinstance(f[1], bool) and isinstance(f[2], str)
        for f in fields)  # fmt: skip
    if not ok:
        raise bad("variable.fields", f"expected a list of [card, id, field], e.g. "
                  f"[[\"PSHELL\", 7, \"T\"]], got {fields!r}")  # fmt: skip
    return tuple((f[0].upper(), int(f[1]), f[2].upper()) for f in fields)


def _deck_check(deck: Path, fields: tuple, name: str, value: float) -> str:
    """Why the deck's ``fields`` cannot take ``value`` ("" if they can): a card or field
    not in the deck, or a value that does not fit its field (file:line, card, id, field)."""
    from ..deck.edit import edit_deck
    from ..errors import FemcalError

    try:
        edit_deck(deck, _deck_edits(fields, name, value))
    except FemcalError as e:
        return str(e)
    return ""


#: The keys each section of a study configuration knows.
SECTION_KEYS = {"model": {"deck", "generator", "variant"},
                "variable": {"name", "unit", "values", "fields"},
                "solve": {"band", "modes", "rigid_below"},
                "pairing": {"min_mac", "reference", "max_frequency_ratio"}}  # fmt: skip


def _known_keys(table: dict, known: set[str], section: str, bad) -> None:
    """A :class:`ConfigError` for a key the section does not know (a misspelt key would
    otherwise run the study on the default), with the nearest known one."""
    for key in table:
        if key not in known:
            raise bad(f"{section}.{key}", unknown_key_message(key, known))


def study_config(data: dict, where: str = "study", folder: str | Path = ".") -> StudyConfig:
    """A :class:`StudyConfig` from parsed TOML; :class:`ConfigError` naming the key that is
    wrong (``where``: the file's name for the messages; ``folder``: where a ``deck`` path is
    relative to)."""

    def bad(key: str, text: str) -> ConfigError:
        return ConfigError(f"{where}: {key}: {text}")

    def table(name: str) -> dict:
        t = data.get(name, {})
        if not isinstance(t, dict):
            raise bad(name, "expected a table")
        _known_keys(t, SECTION_KEYS[name], name, bad)
        return t

    known = {"model", "variable", "solve", "pairing"}
    for k in data:
        if k not in known:
            raise bad(k, f"unknown section; expected one of {', '.join(sorted(known))}")
    model = table("model")
    deck: Path | None = None
    if "deck" in model:
        if "generator" in model or "variant" in model:
            raise bad("model", "give a generator (and its variant) or a deck, not both")
        if not isinstance(model["deck"], str):
            raise bad("model.deck", f"expected a file name, got {model['deck']!r}")
        deck = (Path(folder) / model["deck"]).resolve()
        if not deck.is_file():
            raise bad("model.deck", f"no such file: {deck}")
        gen_name, variant = "", ""
    else:
        gen_name = model.get("generator")
        if gen_name not in GENERATORS:
            raise bad("model.generator", f"unknown generator {gen_name!r}; expected one of "
                      f"{', '.join(repr(g) for g in GENERATORS)}, or a deck")  # fmt: skip
        gen = GENERATORS[gen_name]
        variant = model.get("variant", gen.variants[0])
        if variant not in gen.variants:
            raise bad("model.variant", f"unknown {gen_name} variant {variant!r}; expected one "
                      f"of {', '.join(repr(v) for v in gen.variants)}")  # fmt: skip
    variables = data.get("variable")
    if not isinstance(variables, list) or not variables:
        raise bad("variable", "expected one [[variable]] table (name, values)")
    if len(variables) > 1:
        raise bad("variable", f"{len(variables)} variables; a study sweeps one (for now)")
    var = variables[0]
    if not isinstance(var, dict):
        raise bad("variable", "expected a [[variable]] table (name, values)")
    _known_keys(var, SECTION_KEYS["variable"], "variable", bad)
    name = var.get("name")
    fields: tuple = ()
    if deck is not None:
        if not isinstance(name, str) or not name.strip():
            raise bad("variable.name", f"expected a name for the variable, got {name!r}")
        unit = var.get("unit", "")
        if not isinstance(unit, str):
            raise bad("variable.unit", f"expected a unit name, got {unit!r}")
        fields = _deck_fields(var, bad)
    elif name not in gen.variables:
        raise bad("variable.name", f"unknown {gen_name} variable {name!r}; expected one of "
                  f"{', '.join(gen.variables)}")  # fmt: skip
    else:
        unit = gen.variables[name][0]
    values = var.get("values")
    if not isinstance(values, list) or not values:
        raise bad("variable.values", f"expected a non-empty list of numbers for {name}")
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        raise bad("variable.values", f"expected numbers, got {values!r}")
    values = tuple(float(v) for v in values)
    if len(set(values)) != len(values):
        raise bad("variable.values", "a value is repeated")
    solve = table("solve")
    band, n_modes = None, None
    if "band" in solve and "modes" in solve:
        raise bad("solve", "give band or modes, not both")
    if "modes" in solve:
        n_modes = solve["modes"]
        if not isinstance(n_modes, int) or isinstance(n_modes, bool) or n_modes < 1:
            raise bad("solve.modes", f"expected a number of modes >= 1, got {n_modes!r}")
    else:
        b = solve.get("band", [RIGID_BELOW, 120.0])
        if not (isinstance(b, list) and len(b) == 2
                and all(isinstance(x, int | float) for x in b)
                and math.isfinite(b[0]) and math.isfinite(b[1]) and 0 <= b[0] < b[1]):
            raise bad("solve.band", f"expected [F1, F2] Hz with 0 <= F1 < F2, got {b!r}")
        band = (float(b[0]), float(b[1]))
    rigid_below = solve.get("rigid_below", RIGID_BELOW)
    if not (isinstance(rigid_below, int | float) and rigid_below >= 0):
        raise bad("solve.rigid_below", f"expected a frequency >= 0 Hz, got {rigid_below!r}")
    if band is not None and band[1] <= rigid_below:
        raise bad("solve.band", f"[{band[0]:g}, {band[1]:g}] Hz lies below rigid_below = "
                  f"{rigid_below:g} Hz, where modes are taken as rigid-body modes and left "
                  "out")  # fmt: skip
    pairing = table("pairing")
    min_mac = pairing.get("min_mac", 0.8)
    if not (isinstance(min_mac, int | float) and 0 <= min_mac <= 1):
        raise bad("pairing.min_mac", f"expected a MAC in [0, 1], got {min_mac!r}")
    ref = pairing.get("reference", 0)
    if not (isinstance(ref, int) and not isinstance(ref, bool) and 0 <= ref < len(values)):
        raise bad("pairing.reference", f"expected a point index 0 to {len(values) - 1}, got "
                  f"{ref!r}")  # fmt: skip
    ratio = pairing.get("max_frequency_ratio")
    if ratio is not None and not (isinstance(ratio, int | float) and not isinstance(ratio, bool)
                                  and math.isfinite(ratio) and ratio > 1):
        raise bad("pairing.max_frequency_ratio", f"expected a factor > 1 (or no key: pair by "
                  f"shape alone), got {ratio!r}")  # fmt: skip
    for v in values:  # last: each value's model is built to check it
        why = (_deck_check(deck, fields, name, v) if deck is not None
               else gen.check(variant, name, v))  # fmt: skip
        if why:
            raise bad("variable.values", f"{name} = {v:g}: {why}")
    return StudyConfig(gen_name, variant, name, values, unit, band, n_modes, float(min_mac),
                       ref, float(rigid_below), deck, fields,
                       None if ratio is None else float(ratio))  # fmt: skip


def read_study_config(path: str | Path) -> StudyConfig:
    """Read a study's TOML file (:func:`study_config`)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML: {e}") from None
    return study_config(data, str(path), path.parent)


# ----------------------------------------------------------------------------- the run


@dataclass(frozen=True)
class Point:
    """One point of the study: the variable's ``value``, its elastic modes' ``frequencies``
    (Hz) and ``shapes`` at the stations (3 n_stations, k), the model's size and the time its
    build and solution took (s)."""

    value: float
    frequencies: np.ndarray
    shapes: np.ndarray
    n_dof: int
    seconds: float


@dataclass
class Track:
    """A tracked mode: its elastic mode number at the reference (1-based), ``modes`` its
    index among each point's elastic modes (-1 where lost), ``frequencies`` (NaN where lost)
    and ``mac`` to the neighbour it was paired with (NaN at the reference and where lost)."""

    reference_mode: int
    modes: list[int] = field(default_factory=list)
    frequencies: list[float] = field(default_factory=list)
    mac: list[float] = field(default_factory=list)


@dataclass(frozen=True)
class StudyResult:
    config: StudyConfig
    points: list[Point]
    tracks: list[Track]
    untracked: list[int]  # per point: elastic modes in the band paired to no track
    seconds: float


def _request(cfg: StudyConfig) -> EigenRequest:
    if cfg.n_modes is not None:
        return EigenRequest(v1=None, v2=None, nd=cfg.n_modes + EXTRA_ROOTS)
    return EigenRequest(v1=None, v2=cfg.band[1] * BAND_MARGIN, nd=None)


def _station_shapes(model: Model, modes, stations: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Translations (basic frame) of modes ``keep`` at each station's nearest grid:
    (3 n_stations, k)."""
    grid = np.nonzero(model.is_grid)[0]
    xyz = model.xyz[grid]
    near = np.array([grid[np.argmin(np.linalg.norm(xyz - s, axis=1))] for s in stations])
    return _translations(model, modes, near, keep)


def _translations(model: Model, modes, near: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Translations (basic frame) of modes ``keep`` at the nodes ``near`` (indices):
    (3 n, k)."""
    frames = model.cd_frames[near]  # (n, 3, 3): columns are the CD axes in basic
    dof = model.dof_start[near][:, None] + np.arange(3)
    u = modes.shapes[dof][:, :, keep]  # (n, 3, k) in CD frames
    return np.einsum("nij,njk->nik", frames, u).reshape(3 * len(near), len(keep))


def solve_point(cfg: StudyConfig, value: float) -> Point:
    """Build and solve one point; its elastic modes (above ``rigid_below`` and the band's
    bottom, up to :data:`BAND_MARGIN` x its top) at the generator's stations."""
    from ..solve.normal_modes import solve_normal_modes

    t0 = time.perf_counter()
    if cfg.deck is not None:
        model = _deck_point(cfg, value)
    else:
        model, stations = GENERATORS[cfg.generator].build(cfg.variant, {cfg.variable: value})
    modes, _ = solve_normal_modes(model, request=_request(cfg))
    hz = modes.frequencies_hz
    lo = max(cfg.rigid_below, cfg.band[0] if cfg.band else 0.0)
    keep = np.nonzero(hz >= lo)[0]
    if cfg.deck is not None:  # the same grids at every point: compare at all of them
        grids = np.nonzero(model.is_grid)[0]
        shapes = _translations(model, modes, grids[np.argsort(model.node_ids[grids])], keep)
    else:
        shapes = _station_shapes(model, modes, stations, keep)
    return Point(value, hz[keep].copy(), shapes, model.n_dof, time.perf_counter() - t0)


def _deck_point(cfg: StudyConfig, value: float) -> Model:
    """The study's deck with its fields set to ``value``: the deck's own text with those
    fields changed (:mod:`femcal.deck.edit`), written to a temporary folder (its INCLUDEs
    kept resolving) and read back."""
    from ..deck.edit import edit_deck, write_edited_deck
    from ..model.build import load_model

    assert cfg.deck is not None
    edited = edit_deck(cfg.deck, _deck_edits(cfg.fields, cfg.variable, value))
    with tempfile.TemporaryDirectory(prefix="femcal-study-") as tmp:
        deck = write_edited_deck(edited, Path(tmp) / cfg.deck.name, tag="study")[0]
        return load_model(deck)


def _tracked(cfg: StudyConfig, ref: Point) -> np.ndarray:
    if cfg.n_modes is not None:
        return np.arange(min(cfg.n_modes, len(ref.frequencies)))
    return np.nonzero(ref.frequencies <= cfg.band[1])[0]


def _check_reference_has_modes(cfg: StudyConfig, ref: Point) -> None:
    """Refuse a study whose reference point has no elastic mode to track: a band that
    holds none, or every mode below ``rigid_below``.

    Raises
    ------
    ConfigError
        Naming the band (or ``modes``), the reference point and what it does have.
    """
    if len(_tracked(cfg, ref)):
        return
    unit = f" {cfg.unit}" if cfg.unit else ""
    at = f"the reference point ({cfg.variable} = {ref.value:g}{unit})"
    lo = max(cfg.rigid_below, cfg.band[0] if cfg.band else 0.0)
    if cfg.n_modes is not None:
        raise ConfigError(f"solve.modes = {cfg.n_modes}: {at} has no elastic mode above "
                          f"{lo:g} Hz (solve.rigid_below = {cfg.rigid_below:g} Hz)")
    band = f"solve.band = [{cfg.band[0]:g}, {cfg.band[1]:g}] Hz"
    above = (f"its lowest above {lo:g} Hz is at {ref.frequencies[0]:.4g} Hz"
             if len(ref.frequencies) else
             f"it has none from {lo:g} to {cfg.band[1] * BAND_MARGIN:g} Hz")
    raise ConfigError(f"{band}: {at} has no elastic mode in the band ({above})")


def track_modes(cfg: StudyConfig, points: Sequence[Point]) -> tuple[list[Track], list[int]]:
    """Tracks of the reference's modes across the points (see the module docstring), and
    per point the number of its modes in the band that no track reached."""
    n, r = len(points), cfg.reference
    tracked = _tracked(cfg, points[r])
    tracks = [Track(int(j) + 1, [-1] * n, [math.nan] * n, [math.nan] * n) for j in tracked]
    for t, j in zip(tracks, tracked, strict=True):
        t.modes[r], t.frequencies[r] = int(j), float(points[r].frequencies[j])
    order = [(k, k + 1) for k in range(r - 1, -1, -1)] + [(k, k - 1) for k in range(r + 1, n)]
    for k, nb in order:
        a, b = points[nb], points[k]
        pairs = pair_modes(a.shapes, a.frequencies, b.shapes, b.frequencies,
                           min_mac=cfg.min_mac,
                           max_frequency_ratio=cfg.max_frequency_ratio or np.inf)
        partner = {p.test: p for p in pairs}
        for t in tracks:
            p = partner.get(t.modes[nb]) if t.modes[nb] >= 0 else None
            if p is not None:
                t.modes[k], t.frequencies[k], t.mac[k] = p.fe, float(b.frequencies[p.fe]), p.mac
    untracked = []
    for k, pt in enumerate(points):
        in_band = set(_tracked(cfg, pt).tolist())
        untracked.append(len(in_band - {t.modes[k] for t in tracks}))
    return tracks, untracked


def point_key(cfg: StudyConfig, value: float, model: list | None = None) -> str:
    """A hash of everything that decides the point at ``value``: the study's model
    (``model``, :func:`model_key`'s, computed when not given), the variable, the value, the
    solve's settings, and femcal's version."""
    from .. import __version__

    text = json.dumps([__version__, model if model is not None else model_key(cfg),
                       cfg.variable, repr(float(value)), cfg.band, cfg.n_modes,
                       cfg.rigid_below, STATION_STEP, BAND_MARGIN, EXTRA_ROOTS])  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()


def model_key(cfg: StudyConfig) -> list:
    """What the study's models are made from, for :func:`point_key`: the generator and its
    variant with the source of the generator's modules, or the content of the deck's files
    (with its INCLUDEs) and the fields the variable sets."""
    from ..calibrate.workflow import file_digest

    if cfg.deck is not None:
        from ..deck import read_deck

        model = [cfg.deck.name, *(file_digest(f) for f in read_deck(cfg.deck).files),
                 *(list(f) for f in cfg.fields)]  # fmt: skip
    else:
        build = GENERATORS[cfg.generator].build
        model = [cfg.generator, cfg.variant, file_digest(inspect.getfile(build)),
                 *(file_digest(inspect.getfile(m)) for m in _generator_modules(cfg))]  # fmt: skip
    return model


def _generator_modules(cfg: StudyConfig) -> list:
    """The modules a generator's models come from (their source enters a point's key)."""
    from ..examples import truck_frame

    return [truck_frame] if cfg.generator == "truck-frame" else []


def _saved_point(folder: Path, k: int, key: str) -> Point | None:
    """Point k as an earlier run wrote it with the same key, or None."""
    f = folder / f"point_{k + 1:03d}.npz"
    if not f.is_file():
        return None
    try:
        with np.load(f, allow_pickle=False) as z:
            if str(z["key"]) != key:
                return None
            return Point(float(z["value"]), z["frequencies"].copy(), z["shapes"].copy(),
                         int(z["n_dof"]), float(z["seconds"]))  # fmt: skip
    except (OSError, KeyError, ValueError):  # another run's, or a file that does not read
        return None


def _save_point(folder: Path, k: int, key: str, pt: Point) -> None:
    def dump(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, key=key, value=pt.value, frequencies=pt.frequencies,
                     shapes=pt.shapes, n_dof=pt.n_dof, seconds=pt.seconds)  # fmt: skip

    write_atomic(folder / f"point_{k + 1:03d}.npz", dump)


def run_study(cfg: StudyConfig, *, engine: Engine | None = None,
              state: str | Path | None = None,
              progress: Progress | None = None) -> StudyResult:  # fmt: skip
    """Solve every point of the study and track the modes. The points are independent:
    with ``engine`` (:class:`~femcal.parallel.cluster.Engine`: local worker processes or a
    Dask cluster) they are solved side by side, each with one BLAS thread; by default one
    after another here. With ``state`` (a folder), each solved point is kept there
    (``point_NNN.npz``, written whole or not at all, with :func:`point_key`), and a run
    solves only the points not kept with their own key: a stopped study resumes.

    Raises
    ------
    FemcalError
        When a point's worker process ended without its result, its Dask workers died more
        often than the scheduler allows, or the scheduler went away
        (:func:`~femcal.parallel.cluster.result_of`).
    """
    say = progress or (lambda s: None)
    t0 = time.perf_counter()
    engine = engine or Engine()
    task = f"study: {len(cfg.values)} points"
    solved: dict[int, Point] = {}

    folder = Path(state) if state is not None else None
    made_of = model_key(cfg) if folder is not None else []
    keys = [point_key(cfg, v, made_of) for v in cfg.values] if folder is not None else []

    def keep(i: int, pt: Point, earlier: bool = False) -> None:
        solved[i] = pt
        if folder is not None and not earlier:
            _save_point(folder, i, keys[i], pt)
        say(Step(f"{cfg.variable} = {pt.value:g} {cfg.unit}: {len(pt.frequencies)} elastic "
                 f"modes, {pt.n_dof} DOF, " + ("solved earlier" if earlier else
                                                f"{pt.seconds:.1f} s"),
                 task=task, done=len(solved), total=len(cfg.values)))  # fmt: skip

    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
        for i in range(len(cfg.values)):
            pt = _saved_point(folder, i, keys[i])
            if pt is not None:
                keep(i, pt, earlier=True)
    todo = [i for i in range(len(cfg.values)) if i not in solved]
    if todo and (engine.kind == "dask" or (engine.parallel and len(todo) > 1)):
        with engine.open() as pool:
            jobs = {pool.submit(one_blas_thread, solve_point, cfg, cfg.values[i]): i
                    for i in todo}  # fmt: skip
            for job in as_completed(jobs):
                i = jobs[job]
                keep(i, result_of(job, f"the study's point {cfg.variable} = "
                                       f"{cfg.values[i]:g}"))  # fmt: skip
    else:
        for i in todo:
            keep(i, solve_point(cfg, cfg.values[i]))
    points = [solved[i] for i in range(len(cfg.values))]
    _check_reference_has_modes(cfg, points[cfg.reference])
    tracks, untracked = track_modes(cfg, points)
    return StudyResult(cfg, points, tracks, untracked, time.perf_counter() - t0)


# ----------------------------------------------------------------------------- output


def _num(x: float, fmt: str) -> str:
    return "" if not math.isfinite(x) else format(x, fmt)


def csv_lines(res: StudyResult) -> list[str]:
    """One row per tracked mode: its frequency at each point and the MAC to the neighbour
    it was paired with (empty where lost; at the reference, the mode itself)."""
    cfg = res.config
    head = ["track", "reference_mode"]
    head += [f"f_hz@{cfg.variable}={v:g}" for v in cfg.values]
    head += [f"mac@{cfg.variable}={v:g}" for v in cfg.values]
    rows = [",".join(head)]
    for i, t in enumerate(res.tracks, start=1):
        cells = [str(i), str(t.reference_mode)]
        cells += [_num(f, ".4f") for f in t.frequencies]
        cells += [_num(m, ".4f") for m in t.mac]
        rows.append(",".join(cells))
    return rows


def _json_value(x: float) -> float | None:
    return x if math.isfinite(x) else None


def result_json(res: StudyResult) -> dict:
    cfg = res.config
    return {
        "config": {**asdict(cfg), "deck": str(cfg.deck) if cfg.deck is not None else None},
        "points": [{"value": p.value, "n_dof": p.n_dof, "seconds": round(p.seconds, 3),
                    "elastic_frequencies_hz": [float(f) for f in p.frequencies],
                    "untracked": u}
                   for p, u in zip(res.points, res.untracked, strict=True)],
        "tracks": [{"reference_mode": t.reference_mode,
                    "modes": [m + 1 if m >= 0 else None for m in t.modes],
                    "frequencies_hz": [_json_value(f) for f in t.frequencies],
                    "mac": [_json_value(m) for m in t.mac]} for t in res.tracks],
        "seconds": round(res.seconds, 3),
    }  # fmt: skip


def plot_frequencies(res: StudyResult, path: Path) -> Path:
    """Frequency against the variable, one line per tracked mode."""
    from ..viz.figures import pyplot, save_figure

    plt = pyplot()
    cfg = res.config
    fig, ax = plt.subplots(figsize=(7, 5))
    x = np.array(cfg.values)
    for t in res.tracks:
        ax.plot(x, t.frequencies, "o-", label=f"mode {t.reference_mode}")
    unit = f" ({cfg.unit})" if cfg.unit else ""
    ax.set_xlabel(f"{cfg.variable}{unit}")
    ax.set_ylabel("frequency (Hz)")
    ax.set_title(f"{cfg.source}: elastic modes, tracked by MAC >= {cfg.min_mac:g}")
    ax.grid(True, alpha=0.3)
    if res.tracks:
        ax.legend(fontsize="small", loc="best")
    save_figure(fig, path)
    return Path(path)


def write_study(res: StudyResult, out: str | Path) -> list[Path]:
    """Write ``study.csv``, ``study.json`` and ``frequencies.png`` into ``out`` (each
    atomically); returns their paths."""
    out = Path(out)
    paths = [write_lines(out / "study.csv", csv_lines(res))]
    text = json.dumps(result_json(res), indent=1)

    def dump(tmp: str) -> None:
        Path(tmp).write_text(text + "\n", encoding="utf-8")

    paths.append(write_atomic(out / "study.json", dump))
    paths.append(plot_frequencies(res, out / "frequencies.png"))
    return paths


def summary_lines(res: StudyResult) -> list[str]:
    """The tracked modes as a small table for the console."""
    cfg = res.config
    lines = [f"{'mode':>4}  " + "  ".join(f"{v:>9g}" for v in cfg.values)
             + f"   ({cfg.variable}, {cfg.unit}; Hz)"]
    for t in res.tracks:
        lines.append(f"{t.reference_mode:>4}  "
                     + "  ".join(f"{f:9.2f}" if math.isfinite(f) else f"{'-':>9}"
                                 for f in t.frequencies))  # fmt: skip
    return lines
