"""A start for the calibration of an engineer's own deck (``femcal init``): a proposal of its
parameters and a commented calibration configuration, written beside each other.

:func:`propose` reads the deck, the sensor and input positions and the test, and proposes:

1. **Parameters** (:mod:`femcal.calibrate.parameters`): every PSHELL's T and every MAT1's E
   that at least one element uses, and, where the deck has them and the elements use them,
   each PBAR's and PROD's A, and each PBUSH's and PELAS's positive stiffnesses (K1-K6, K):
   the cards that stand for a section or a connection, the usual places where a model and
   its structure differ. Bounds are relative to the deck's value (:data:`RULES`: T and A
   +-20 %, E +-10 %, spring stiffnesses +-50 %), proposals for the engineer to narrow or
   widen. Not proposed: MAT1 RHO and CONM2 M (masses are weighed, and a uniform change of
   RHO and E moves no frequency at all), PBAR I1/I2/J (with A they describe one section).
   Each parameter's description names the card, what the deck's comment above it calls it
   (``$ PSHELL 1: side rail``, HyperMesh ``$HMNAME``, Femap and Patran comments), the elements
   that use it (types and counts), its share of the structural mass and how much the FE
   modes in the band move with it. They are ordered by the last: the largest
   ``|d ln f / d ln P|`` of the flexible FE modes in the band (a parameter that moves no
   mode there is one the test cannot inform), largest first.
2. **The band**: the FE model's modes are solved up to the test's top (at most
   :data:`MAX_MODES`, the calibration's surrogate basis). Rigid-body modes, and support
   modes (half or more of their strain energy in springs: CELAS, CBUSH), are not the
   structure's; the band runs from :data:`LOW_FACTOR` times the first flexible mode (its
   resonance whole in the band) to the test's top over :data:`TOP_FACTOR` (room above for
   the identification and the test's poorer edge; below the basis's top mode over the same
   factor when the solve hit :data:`MAX_MODES`), within the test's range, rounded to two
   significant digits. The test is identified from the band's bottom to :data:`IDENTIFY_MARGIN`
   times its top, in parts of at most :data:`PART_MODES` FE modes, split in the widest gaps
   between FE modes.
3. **Checks**: every sensor and input row names a GRID of the deck (errors name the file,
   line and grid), every test channel is ``GRID:DIRECTION`` on a grid of the deck; the
   deck's units (mm, tonne, s, N or SI) are told from its materials (speed of sound and
   modulus of the structural materials), for the FE FRFs' units and the descriptions.

:func:`write_init` writes ``DIR/<stem>.params.toml`` and ``DIR/<stem>_calibration.toml``
(paths relative to ``DIR``, a comment on every key), each checked by the calibration's own
readers before it is renamed into place, never over an existing file unless forced.
:func:`run_init` does both. The library prints nothing; progress goes to a callback.
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import re
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..errors import FemcalError
from ..model.model import Model
from ..model.units import length_unit

#: (card, field) -> (relative lower bound, relative upper bound, what it is, why these
#: bounds): the fields femcal init proposes, in this order of kinds.
RULES: dict[tuple[str, str], tuple[float, float, str, str]] = {
    ("PSHELL", "T"): (-0.2, 0.2, "shell thickness",
                      "sheet tolerance plus what a mid-surface shell idealises (radii, "
                      "welds, offsets)"),
    ("MAT1", "E"): (-0.1, 0.1, "Young's modulus",
                    "a metal's modulus is known to a few per cent; the rest is joints and "
                    "idealisation the modulus stands in for"),
    ("PBAR", "A"): (-0.2, 0.2, "bar area", "a bar often models a bolt or a joint, whose "
                    "effective section is uncertain"),
    ("PROD", "A"): (-0.2, 0.2, "rod area", "a rod often models a link or a joint"),
    **{("PBUSH", f"K{i}"): (-0.5, 0.5, "bush stiffness",
                            "mounts (rubber, air springs) change with preload, amplitude and "
                            "frequency") for i in range(1, 7)},
    ("PELAS", "K"): (-0.5, 0.5, "spring stiffness", "springs stand for mounts and joints"),
}  # fmt: skip

#: Units of each field by the deck's length unit (force in N, time in s).
_UNITS = {
    "mm": {"T": "mm", "E": "MPa", "A": "mm^2", "K": "N/mm"},
    "m": {"T": "m", "E": "Pa", "A": "m^2", "K": "N/m"},
}

#: Spring elements: a mode with this share of its strain energy in them or more is a support
#: mode (the structure moving on its mounts), not a flexible mode of the structure.
SPRING_TYPES = ("CELAS1", "CELAS2", "CELAS3", "CELAS4", "CBUSH")
SUPPORT_SHARE = 0.5
#: Eigenvalues below this fraction of the largest solved are rigid-body modes.
RIGID_RATIO = 1e-6
#: The band starts at this fraction of the first flexible FE mode ...
LOW_FACTOR = 0.7
#: ... and ends at the test's top over this factor (the reference study: 150 Hz -> 100 Hz).
TOP_FACTOR = 1.5
#: The test is identified up to this factor above the band's top (femcal correlate's).
IDENTIFY_MARGIN = 1.2
#: At most this many FE modes in each part of the identification.
PART_MODES = 4
#: The FE modes solved: at most the calibration's surrogate basis (reduction_modes).
MAX_MODES = 100
#: Relative step of the central differences of K and M in each parameter.
STEP = 1e-3


class InitError(FemcalError, ValueError):
    """Inputs ``femcal init`` cannot propose from: a sensor, input or test channel on a grid
    the deck lacks, a test that holds no flexible FE mode, an output file in the way. The
    message names the file (and line), the grid or channel, and what was expected."""


@dataclass(frozen=True)
class ProposedParameter:
    """One proposed parameter (a ``[[parameter]]`` table of the parameter file).

    Attributes
    ----------
    name, card, id, field : as :class:`femcal.calibrate.parameters.Parameter`.
    nominal : the deck's value.
    lower_rel, upper_rel : the proposed bounds as fractions of the nominal.
    description : the card, its name in the deck, its users, mass share, sensitivity.
    label : what the deck's comment above the card calls it ("" where none).
    source : (file, line) of the card, None where unknown.
    uses : element type -> number of elements whose matrices depend on it.
    mass_share : the mass of those elements over the model's structural mass.
    sensitivity : the largest ``|d ln f / d ln P|`` of the flexible FE modes in the band.
    unit : the field's unit ("" where the deck's units are not known).
    """

    name: str
    card: str
    id: int
    field: str
    nominal: float
    lower_rel: float
    upper_rel: float
    description: str
    label: str
    source: tuple[str, int] | None
    uses: dict[str, int]
    mass_share: float
    sensitivity: float
    unit: str = ""

    @property
    def where(self) -> str:
        """``file:line`` of the card ("" where unknown)."""
        return f"{self.source[0]}:{self.source[1]}" if self.source else ""

    @property
    def lower(self) -> float:
        return self.nominal * (1.0 + self.lower_rel)

    @property
    def upper(self) -> float:
        return self.nominal * (1.0 + self.upper_rel)


@dataclass(frozen=True)
class BandProposal:
    """The proposed bands and what they come from.

    Attributes
    ----------
    test_range : (f_lo, f_hi) Hz, the test's frequencies.
    band : the calibration's band; identify_band : the identification's; splits : its parts.
    flexible_hz : the flexible FE modes solved (Hz); support_hz : the rigid-body and
    support modes solved; band_modes_hz : the flexible modes in the band.
    capped : the solve stopped at :data:`MAX_MODES` modes below the test's top.
    reason : how the band was chosen, one sentence.
    """

    test_range: tuple[float, float]
    band: tuple[float, float]
    identify_band: tuple[float, float]
    splits: tuple[float, ...]
    flexible_hz: tuple[float, ...]
    support_hz: tuple[float, ...]
    band_modes_hz: tuple[float, ...]
    capped: bool
    reason: str


@dataclass(frozen=True)
class Proposal:
    """What :func:`propose` found and proposes.

    Attributes
    ----------
    deck, test, sensors, inputs : the files (sensors and inputs may be None).
    parameters : the proposed parameters, most sensitive first.
    band : the bands.
    length_unit : ``mm`` or ``m``, as told from the deck's materials, or None.
    frf_units : the FE FRFs' units for the configuration (``[model] units``).
    quantity : the test's quantity (accelerance, mobility, receptance); test_units : its
    units as the file says.
    n_outputs, n_inputs : the test's channels.
    restrained : the FE model has no rigid-body mode (residual flexibility is possible).
    skipped : cards not proposed and why (unused properties, non-positive values).
    notes : what the engineer should check (the test's channels and the sensor files
    disagree, the units could not be told, ...).
    model : the deck's model (the parameter file is checked against it).
    """

    deck: Path
    test: Path
    sensors: Path | None
    inputs: Path | None
    parameters: tuple[ProposedParameter, ...]
    band: BandProposal
    length_unit: str | None
    frf_units: str
    quantity: str
    test_units: str
    n_outputs: int
    n_inputs: int
    restrained: bool
    skipped: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    model: Model | None = field(default=None, repr=False, compare=False)

    @property
    def stem(self) -> str:
        return self.deck.stem


@dataclass(frozen=True)
class InitFiles:
    """What :func:`write_init` wrote."""

    parameters: Path
    config: Path

    @property
    def next_command(self) -> str:
        """The command that runs the calibration on the written files."""
        return f"femcal calibrate {self.config} --out {self.config.parent / 'out'}"


def output_paths(deck: str | os.PathLike[str], out: str | os.PathLike[str]) -> InitFiles:
    """The files ``femcal init`` writes for ``deck`` into ``out``."""
    stem = Path(deck).stem
    return InitFiles(Path(out) / f"{stem}.params.toml", Path(out) / f"{stem}_calibration.toml")


def check_outputs(files: InitFiles, force: bool = False) -> None:
    """InitError naming the first output file that exists (unless ``force``) or is a
    folder."""
    for path in (files.parameters, files.config):
        if path.is_dir():
            raise InitError(f"{path}: a folder; expected the file femcal init writes there")
        if path.exists() and not force:
            raise InitError(f"{path}: already exists and is left as it is (--force replaces "
                            "it)")  # fmt: skip


# ----------------------------------------------------------------------------- checks


def _point_rows(path: Path) -> list[tuple[int, str, int]]:
    """(line, label, grid) of each row of a sensors or inputs CSV, after
    :func:`femcal.testdata.points.read_points` checked the file."""
    from ..testdata.points import read_points

    read_points(path)  # ConfigError naming the file and line of a bad row
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        return [(reader.line_num, row["label"], int(row["grid"])) for row in reader]


def check_points(path: str | os.PathLike[str], model: Model, deck: str, what: str
                 ) -> list[tuple[int, str, int]]:  # fmt: skip
    """The rows of a sensors (``what = "sensor"``) or inputs CSV, each on a GRID of the
    model.

    Raises
    ------
    InitError
        Naming the file, line, row and grid: a grid the deck lacks, a scalar point, no rows.
    ConfigError
        From :func:`femcal.testdata.points.read_points`, for a malformed file.
    """
    path = Path(path)
    rows = _point_rows(path)
    if not rows:
        raise InitError(f"{path}: no rows; expected a CSV table of label, grid and directions "
                        f"with a row per {what}")  # fmt: skip
    idx = model.node_index([g for _, _, g in rows])
    for (line, label, grid), i in zip(rows, idx, strict=True):
        if i < 0:
            raise InitError(f"{path}:{line}: {what} {label!r}: no GRID {grid} in {deck}; "
                            "expected a grid of the FE model")  # fmt: skip
        if not model.is_grid[i]:
            raise InitError(f"{path}:{line}: {what} {label!r}: {grid} is a scalar point "
                            f"(SPOINT) in {deck}; expected a GRID")  # fmt: skip
    return rows


def check_channels(data, model: Model, test: str, deck: str) -> None:
    """Every output and input of the test names a grid and direction of the model.

    Raises
    ------
    InitError
        Naming the test file, the channel, its place and the grid.
    """
    from ..response.frf import channel_matrix

    for kind, channels in (("output", data.outputs), ("input", data.inputs)):
        n = len(channels)
        for k, ch in enumerate(channels):
            at = f"{test}: channel {ch.label!r} ({kind} {k + 1} of {n})"
            if ch.grid is None or ch.direction is None:
                raise InitError(f"{at} names no grid; expected GRID:DIRECTION (e.g. 1001:+Z "
                                "or 1001:3), by which the calibration places channels")
            if model.node_index(ch.grid)[0] < 0:
                raise InitError(f"{at}: no GRID {ch.grid} in {deck}; expected the test's "
                                "channels on grids of the FE model")  # fmt: skip
            try:
                channel_matrix(model, [ch])
            except ValueError as e:
                raise InitError(f"{at}: {e}") from None


# ----------------------------------------------------------------------------- units


def frf_units(quantity: str, unit: str | None) -> str | None:
    """The FE FRFs' units of a quantity in the deck's length unit (``mm/s^2/N``)."""
    if unit is None:
        return None
    per = {"receptance": "/N", "mobility": "/s/N", "accelerance": "/s^2/N"}.get(quantity)
    return None if per is None else unit + per


# ----------------------------------------------------------------------------- the deck's names


_HMNAME = re.compile(r'^\$\s*HMNAME\s+\w+\s+\d+\s*"([^"]*)"', re.IGNORECASE)
_FEMAP = re.compile(r"^\$\s*Femap\s+(?:with\s+NX\s+Nastran\s+)?(?:Property|Material)\s+\d+\s*:"
                    r"\s*(.*)$", re.IGNORECASE)  # fmt: skip
_PATRAN = re.compile(r"^\$\s*(?:Elements\s+and\s+Element\s+Properties\s+for\s+region|"
                     r"Material\s+Record)\s*:\s*(.*)$", re.IGNORECASE)  # fmt: skip


def comment_label(comment: str, card: str, ident: int) -> str:
    """What a comment line just above a card calls it, or "": ``$ PSHELL 1: side rail``
    (the card and its id, then the name), HyperMesh's ``$HMNAME PROP 1"side rail"``, Femap's
    ``$ Femap Property 1 : side rail``, Patran's ``$ Elements and Element Properties for
    region : side_rail``. Other comments (section headers) name no card and give ""."""
    text = comment.rstrip()
    for pattern in (_HMNAME, _FEMAP, _PATRAN):
        m = pattern.match(text)
        if m:
            return _clean(m.group(1))
    m = re.match(rf"^\$+\s*{re.escape(card)}\s*,?\s*{ident}\b\s*[:=,-]?\s*(.*)$", text,
                 re.IGNORECASE)  # fmt: skip
    return _clean(m.group(1)) if m else ""


def _clean(text: str) -> str:
    """A name as a description holds it: one line, at most 60 characters."""
    text = " ".join(text.replace("_", " ").split()).strip(" :;,-")
    if not re.search(r"[A-Za-z]", text):
        return ""
    return text if len(text) <= 60 else text[:57].rstrip() + "..."


def card_locations(deck, card: str) -> dict[int, tuple[int, int]]:
    """id -> (file index, line) of a card's entries (the first of an id)."""
    out: dict[int, tuple[int, int]] = {}
    if card in deck.tables:
        t = deck.tables[card]
        key = "mid" if card.startswith("MAT") else "pid"
        if key not in t.columns:
            return out
        for i, f, ln in zip(t.columns[key], t.file, t.line, strict=True):
            out.setdefault(int(i), (int(f), int(ln)))
    else:
        recs = deck.records_of(card)
        for r, f, ln in zip(recs.items, recs.file, recs.line, strict=True):
            out.setdefault(int(r.pid), (int(f), int(ln)))
    return out


def _lines_before(files: Sequence[str], wanted: dict[int, set[int]]) -> dict[tuple[int, int], str]:
    """(file index, line) -> the text of the line before it, for the lines wanted."""
    out: dict[tuple[int, int], str] = {}
    for f, lines in wanted.items():
        before = {ln - 1 for ln in lines if ln > 1}
        try:
            with open(files[f], encoding="utf-8", errors="replace") as fh:
                for n, text in enumerate(fh, start=1):
                    if n in before:
                        out[(f, n + 1)] = text
                        before.discard(n)
                        if not before:
                            break
        except OSError:
            continue
    return out


# ----------------------------------------------------------------------------- modes and band


def _nice(x: float, up: bool = False, digits: int = 2) -> float:
    """x rounded down (or up) to ``digits`` significant digits, as a float that prints
    short (9.765 -> 9.7)."""
    if x <= 0:
        return x
    e = math.floor(math.log10(x)) - (digits - 1)
    k = x / 10.0**e if e >= 0 else x * 10.0**-e
    k = math.ceil(k - 1e-9) if up else math.floor(k + 1e-9)
    return float(k * 10**e) if e >= 0 else k / 10**-e


def _split_parts(modes: list[float], lo: float, hi: float) -> list[float]:
    """Split frequencies so that no part of [lo, hi] holds more than :data:`PART_MODES` of
    ``modes``: each time in the widest gap (frequency ratio) between neighbouring modes that
    leaves two modes or more on each side (any gap where none does)."""
    if len(modes) <= PART_MODES:
        return []
    gaps = [(modes[i + 1] / modes[i], i) for i in range(len(modes) - 1)]
    balanced = [g for g in gaps if 2 <= g[1] + 1 <= len(modes) - 2]
    _, i = max(balanced or gaps)
    a, b = modes[i], modes[i + 1]
    mid = math.sqrt(a * b)
    split = next((s for s in (_nice(mid, digits=d) for d in (2, 3, 4)) if a < s < b), mid)
    if not lo < split < hi:
        return []
    return [*_split_parts(modes[: i + 1], lo, split), split,
            *_split_parts(modes[i + 1:], split, hi)]  # fmt: skip


def propose_band(freq: np.ndarray, flexible: np.ndarray, test_range: tuple[float, float],
                 capped: bool, source: str = "") -> BandProposal:  # fmt: skip
    """The bands for FE modes ``freq`` (Hz, ascending; ``flexible`` marks the structure's
    own) and a test over ``test_range`` (see the module docstring).

    Raises
    ------
    InitError
        When the test's range holds no flexible FE mode with room for the band around it.
    """
    at = f"{source}: " if source else ""
    t_lo, t_hi = test_range
    flex = [float(f) for f, k in zip(freq, flexible, strict=True) if k]
    support = tuple(float(f) for f, k in zip(freq, flexible, strict=True) if not k)
    if not flex:
        found = (f"{freq.min():.4g}-{freq.max():.4g} Hz" if len(freq) else "none")
        raise InitError(f"{at}the FE model has no flexible mode below the test's top "
                        f"({t_hi:g} Hz; its modes there: {found}, all rigid-body or support "
                        "modes); expected a test that covers the structure's modes")
    first = flex[0]
    lo = _nice(max(t_lo, LOW_FACTOR * first))
    if lo < t_lo:
        lo = _nice(t_lo, up=True, digits=3)
    top = t_hi / TOP_FACTOR
    if capped:
        top = min(top, float(freq[-1]) / TOP_FACTOR)
    hi = _nice(top)
    in_band = tuple(f for f in flex if lo <= f <= hi)
    if not (lo < hi and in_band):
        raise InitError(f"{at}the test's {t_lo:g}-{t_hi:g} Hz hold no flexible FE mode with "
                        f"room around it (the first flexible mode is at {first:.4g} Hz; the "
                        f"band would be {lo:g}-{hi:g} Hz); expected a test reaching "
                        f"{TOP_FACTOR:g} times above the modes to calibrate")  # fmt: skip
    id_hi = min(t_hi, _nice(IDENTIFY_MARGIN * hi))
    id_modes = [f for f in flex if lo <= f <= id_hi]
    splits = tuple(_split_parts(id_modes, lo, id_hi))
    why_top = (f"the highest of the {MAX_MODES} FE modes solved ({freq[-1]:.4g} Hz) / "
               f"{TOP_FACTOR:g}" if capped and top < t_hi / TOP_FACTOR
               else f"the test's top ({t_hi:g} Hz) / {TOP_FACTOR:g}")  # fmt: skip
    reason = (f"from {LOW_FACTOR:g} x the first flexible FE mode ({first:.4g} Hz) to {why_top}, "
              f"within the test's {t_lo:g}-{t_hi:g} Hz")  # fmt: skip
    return BandProposal((t_lo, t_hi), (lo, hi), (lo, id_hi), splits, tuple(flex), support,
                        in_band, capped, reason)  # fmt: skip


def _quad(Phi: np.ndarray, A) -> np.ndarray:
    """diag(Phi^T A Phi), (k,)."""
    return np.einsum("ij,ij->j", Phi, np.asarray(A @ Phi))


# ----------------------------------------------------------------------------- proposal


def _uses_text(uses: dict[str, int]) -> str:
    return ", ".join(f"{n:,} {t}".replace(",", " ") for t, n in uses.items())


def _candidates(model: Model) -> tuple[list[tuple[str, int, str, float]], list[str]]:
    """(card, id, field, nominal) of every field :data:`RULES` proposes that the model has,
    and what was skipped (field not positive)."""
    out, skipped = [], []
    for (card, fld), _rule in RULES.items():
        kind = "material" if card.startswith("MAT") else "property"
        tables = model.materials if kind == "material" else model.properties
        table = tables.get(card)
        if table is None:
            continue
        if isinstance(table, dict):
            key = "mid" if kind == "material" else "pid"
            col = {"T": "t", "E": "e", "A": "a", "K": "k"}[fld]
            rows = [(int(i), float(v)) for i, v in zip(table[key], table[col], strict=True)]
        else:  # PBUSH records: K1-K6
            n = int(fld[1:]) - 1
            rows = [(int(r.pid), float(r.k[n])) for r in table]
        for ident, value in rows:
            if card == "PBUSH" and value == 0.0:
                continue  # a bush without that stiffness: nothing to calibrate
            if not (np.isfinite(value) and value > 0):
                skipped.append(f"{card} {ident} {fld} = {value:g} (a parameter needs a "
                               "positive value)")  # fmt: skip
                continue
            out.append((card, ident, fld, value))
    return out, skipped


#: Sensitivities closer than this fraction of the largest are one tie: the same physics
#: (two mirror-image parts) computed in another order of floating-point operations differs in
#: the last digits, and which of the two comes first must not depend on the processor.
SENSITIVITY_TIE = 1e-9


def _by_sensitivity(proposed: list[ProposedParameter]) -> list[ProposedParameter]:
    """``proposed`` by falling sensitivity; parameters whose sensitivities tie (within
    :data:`SENSITIVITY_TIE` of the largest) by kind (the order of :data:`RULES`) and id."""
    kinds = list(RULES)
    ranked = sorted(proposed, key=lambda q: -q.sensitivity)
    tie = SENSITIVITY_TIE * max((q.sensitivity for q in ranked), default=0.0)
    groups: list[list[ProposedParameter]] = []
    for q in ranked:
        if groups and groups[-1][-1].sensitivity - q.sensitivity <= tie:
            groups[-1].append(q)
        else:
            groups.append([q])
    return [q for g in groups for q in sorted(g, key=lambda q: (kinds.index((q.card, q.field)),
                                                                 q.id))]  # fmt: skip


def propose(deck: str | os.PathLike[str], test: str | os.PathLike[str], *,
            sensors: str | os.PathLike[str] | None = None,
            inputs: str | os.PathLike[str] | None = None,
            progress: Callable[[str], None] | None = None) -> Proposal:  # fmt: skip
    """Propose the parameters and bands of a calibration of ``deck`` against ``test`` (see
    the module docstring). The cheap checks come first (the deck, the sensor and input
    files, the test's channels), then the FE solution and the parameters' sensitivities.

    Raises
    ------
    InitError
        For a sensor, input or channel on a grid the deck lacks, or a test without flexible
        FE modes in its range; DeckError, ModelError, ConfigError and FRFError name the
        deck, the CSV files and the test.
    """
    from ..assembly.matrices import Options, assemble
    from ..calibrate.parameters import Parameter, affected_elements, subset, with_values
    from ..deck import read_deck
    from ..model.analysis import EigenRequest
    from ..model.build import build_model
    from ..solve.normal_modes import solve_normal_modes
    from ..testdata.formats import read_frf

    say = progress or (lambda _m: None)
    deck, test = Path(deck), Path(test)
    sensors = Path(sensors) if sensors is not None else None
    inputs = Path(inputs) if inputs is not None else None
    parsed = read_deck(deck)
    model = build_model(parsed)
    say(f"read {deck}: {model.n_grids} grids, {sum(len(b) for b in model.elements.values())} "
        "elements")  # fmt: skip
    notes: list[str] = []
    points = {}
    for path, what in ((sensors, "sensor"), (inputs, "input")):
        if path is not None:
            points[what] = check_points(path, model, str(deck), what)
    data = read_frf(test)
    check_channels(data, model, str(test), str(deck))
    f_test = np.asarray(data.frequency_hz, float)
    f_test = f_test[f_test > 0]
    if not len(f_test):
        raise InitError(f"{test}: no positive frequency; expected FRFs over a band in Hz")
    t_range = (float(f_test[0]), float(f_test[-1]))
    say(f"read {test}: {len(data.outputs)} outputs x {len(data.inputs)} inputs, "
        f"{t_range[0]:g}-{t_range[1]:g} Hz ({data.quantity}"
        f"{', ' + data.units if data.units else ''})")  # fmt: skip
    for what, channels in (("sensor", data.outputs), ("input", data.inputs)):
        if what in points:
            listed = {g for _, _, g in points[what]}
            off = sorted({c.grid for c in channels} - listed)
            if off:
                path = sensors if what == "sensor" else inputs
                notes.append(f"{len(off)} grid(s) of the test's {what}s are not in {path} "
                             f"({', '.join(map(str, off[:6]))}{' ...' if len(off) > 6 else ''})"
                             ": the report names those channels by grid")  # fmt: skip

    # the FE modes up to the test's top
    mats = assemble(model, Options())
    say(f"solving the FE modes up to {t_range[1]:g} Hz (at most {MAX_MODES})")
    modes, _ = solve_normal_modes(model, matrices=mats,
                                  request=EigenRequest(v1=None, v2=t_range[1], nd=MAX_MODES))
    freq = np.asarray(modes.frequencies_hz, float)
    lam = np.asarray(modes.eigenvalues, float)
    Phi = np.asarray(modes.shapes, float)
    capped = len(freq) >= MAX_MODES
    rigid = lam <= RIGID_RATIO * max(float(lam.max(initial=0.0)), 0.0)
    springs = {t: np.arange(len(b)) for t, b in model.elements.items() if t in SPRING_TYPES}
    spring_share = np.zeros(len(freq))
    if springs and len(freq):
        K_spring = assemble(subset(model, springs), Options()).K
        with np.errstate(divide="ignore", invalid="ignore"):
            spring_share = np.where(rigid, 0.0, _quad(Phi, K_spring) / np.where(rigid, 1, lam))
    flexible = ~rigid & (spring_share < SUPPORT_SHARE)
    band = propose_band(freq, flexible, t_range, capped, str(deck))
    say(f"FE modes: {int((~flexible).sum())} rigid-body or support, first flexible at "
        f"{band.flexible_hz[0]:.4g} Hz; band {band.band[0]:g}-{band.band[1]:g} Hz "
        f"({len(band.band_modes_hz)} FE modes)")  # fmt: skip
    in_band = flexible & (freq >= band.band[0]) & (freq <= band.band[1])
    Phi_b, lam_b = Phi[:, in_band], lam[in_band]

    # the parameters
    unit = length_unit(model)
    if unit is None:
        notes.append("the deck's units could not be told from its materials (mm, tonne, s, N "
                     "or SI): check [model] units in the configuration")  # fmt: skip
    units = _UNITS.get(unit or "", {})
    total_mass = float(sum(mats.element_mass.values())) or 1.0
    candidates, skipped = _candidates(model)
    where = {card: card_locations(parsed, card) for card in {c for c, *_ in candidates}}
    proposed: list[ProposedParameter] = []
    work = []
    for card, ident, fld, value in candidates:
        lo_rel, hi_rel, _what, _why = RULES[(card, fld)]
        par = Parameter(f"{fld}_{card}_{ident}", card, ident, fld, value,
                        value * (1 + lo_rel), value * (1 + hi_rel))  # fmt: skip
        rows = affected_elements(model, par)
        rows = {t: r for t, r in rows.items() if len(r)}
        if not rows:
            skipped.append(f"{card} {ident} {fld} (no element uses {card} {ident})")
            continue
        work.append((par, rows))
    say(f"{len(work)} parameters: their share of the mass and the band's sensitivity to each")
    wanted: dict[int, set[int]] = {}
    for par, _ in work:
        loc = where[par.card].get(par.id)
        if loc:
            wanted.setdefault(loc[0], set()).add(loc[1])
    before = _lines_before(parsed.files, wanted)
    for par, rows in work:
        sub = subset(model, rows)
        K, M, mass = [], [], []
        for p in (STEP, -STEP):
            m = assemble(with_values(sub, [par], np.array([par.nominal * (1 + p)])), Options())
            K.append(m.K)
            M.append(m.M)
            mass.append(sum(m.element_mass.values()))
        if len(lam_b):
            dk = _quad(Phi_b, (K[0] - K[1]) / (2 * STEP))
            dm = _quad(Phi_b, (M[0] - M[1]) / (2 * STEP))
            sens = float(np.abs(0.5 * (dk - lam_b * dm) / lam_b).max())
        else:
            sens = 0.0
        share = 0.5 * (mass[0] + mass[1]) / total_mass
        loc = where[par.card].get(par.id)
        at = (parsed.files[loc[0]], loc[1]) if loc else None
        label = comment_label(before.get(loc, ""), par.card, par.id) if loc else ""
        uses = {t: len(r) for t, r in rows.items()}
        u = units.get(par.field[0], "")
        text = f"{par.card} {par.id} {par.field}{f' ({u})' if u else ''}"
        if label:
            text += f", {label}"
        via = ""
        if par.card == "MAT1":
            pids = sorted({int(p) for t, r in rows.items() for p in model.elements[t].pids[r]
                           if p >= 0})  # fmt: skip
            via = f" (property {', '.join(map(str, pids[:8]))}{' ...' if len(pids) > 8 else ''})"
        text += (f": {_uses_text(uses)}{via}; {100 * share:.3g} % of the mass; the band's FE "
                 f"modes move up to {sens:.3g} % per 1 % change")  # fmt: skip
        lo_rel, hi_rel = RULES[(par.card, par.field)][:2]
        proposed.append(ProposedParameter(par.name, par.card, par.id, par.field, par.nominal,
                                          lo_rel, hi_rel, text, label, at, uses, share, sens,
                                          u))  # fmt: skip
    proposed = _by_sensitivity(proposed)
    if not proposed:
        raise InitError(f"{deck}: no PSHELL T, MAT1 E, PBAR or PROD A, PBUSH or PELAS K that "
                        "an element uses; expected a deck with properties to calibrate")
    quantity = data.quantity
    units_fe = frf_units(quantity, unit)
    if units_fe is None:
        from ..testdata.data import quantity_of_units

        units_fe = (data.units if data.units and quantity_of_units(data.units) == quantity
                    and not data.units.lower().startswith("g/") else "mm/s^2/N")  # fmt: skip
    return Proposal(deck, test, sensors, inputs, tuple(proposed), band, unit, units_fe,
                    quantity, data.units, len(data.outputs), len(data.inputs),
                    bool(len(lam) and not rigid.any()), tuple(skipped), tuple(notes), model)


# ----------------------------------------------------------------------------- the files


def toml_string(text: str) -> str:
    """A TOML basic string of ``text`` (JSON's escapes are TOML's; DEL escaped too)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _relative(path: Path, folder: Path) -> str:
    """``path`` relative to ``folder`` (POSIX separators), absolute where it cannot be."""
    try:
        return Path(os.path.relpath(path.resolve(), folder.resolve())).as_posix()
    except ValueError:  # another drive
        return path.resolve().as_posix()


def _line(key: str, value: str, comment: str, width: int = 30) -> str:
    text = f"{key} = {value}"
    return f"{text:<{width}}# {comment}" if len(text) < width else f"{text}  # {comment}"


def _fmt(x: float) -> str:
    """A float as TOML writes it, short where exact (100.0, 9.7, 0.001)."""
    return repr(float(x))


def _pct(x: float) -> str:
    return f"{100 * x:+g} %"


def _comment(text: str, width: int = 96) -> list[str]:
    """``text`` as comment lines of at most ``width`` characters after the ``# ``."""
    return [f"# {line}" for line in textwrap.wrap(text, width, break_long_words=False,
                                                  break_on_hyphens=False)]  # fmt: skip


def parameters_text(proposal: Proposal, folder: str | os.PathLike[str]) -> str:
    """The parameter file's text (:mod:`femcal.calibrate.parameters`), every key commented."""
    from .. import __version__

    folder = Path(folder)
    b = proposal.band
    kinds: dict[str, int] = {}
    for q in proposal.parameters:
        k = f"{q.card} {q.field if q.card != 'PBUSH' else 'K'}"
        kinds[k] = kinds.get(k, 0) + 1
    rules: dict[str, tuple[float, float, str]] = {}
    for q in proposal.parameters:
        lo, hi, what, why = RULES[(q.card, q.field)]
        rules.setdefault(what, (lo, hi, why))
    out = [
        *_comment(f"Calibration parameters proposed by `femcal init` (femcal {__version__}) "
                  f"for {_relative(proposal.deck, folder)}: a start for the engineer, not a "
                  "verdict. Format: femcal.calibrate.parameters (docs/calibration.md): P = "
                  "nominal (1 + p), p within [lower_rel, upper_rel]; the nominal is the "
                  "deck's value and is checked against it. Delete a [[parameter]] table to "
                  "keep that value as the deck has it; narrow or widen the bounds where you "
                  "know better, or give `confidence` (the standard deviation of p, a fraction "
                  "of the nominal)."),
        *_comment(f"Proposed: {', '.join(f'{n} {k}' for k, n in kinds.items())}: each one "
                  "that elements use. Bounds (proposals): "
                  + "; ".join(f"{w} {_pct(lo)} / {_pct(hi)} ({why})"
                              for w, (lo, hi, why) in rules.items()) + "."),
        *_comment(f"Order: how much the {len(b.band_modes_hz)} flexible FE modes in the band "
                  f"{b.band[0]:g}-{b.band[1]:g} Hz move with each value (the largest |d ln f "
                  "/ d ln P|: % per 1 % change), largest first; the test can hardly inform "
                  "those at the end, and the calibration will likely hold them at the "
                  "nominal."),
        *_comment("Not proposed: MAT1 RHO and CONM2 M (weigh the structure instead; a uniform "
                  "change of RHO and E moves no frequency), PBAR I1/I2/J (one section with "
                  "A)."),
    ]  # fmt: skip
    for s in proposal.skipped:
        out += _comment(f"Skipped: {s}.")
    for n, q in enumerate(proposal.parameters, start=1):
        what = RULES[(q.card, q.field)][2]
        unit = f" {q.unit}" if q.unit else ""
        out += [
            "",
            f"# {n}. {q.card} {q.id} {q.field}{f' ({q.label})' if q.label else ''}: the "
            f"band's modes move up to {q.sensitivity:.3g} % per 1 %",
            "[[parameter]]",
            _line("name", toml_string(q.name), "unique; the report names it so, and "
                  "configurations share it by it"),
            _line("description", toml_string(q.description), "what it is and what uses it"),
            _line("card", toml_string(q.card), "the card, its id and field: "
                  f"{_relative(Path(q.source[0]), folder)}:{q.source[1]}" if q.source
                  else "the card, its id and field"),
            _line("id", str(q.id), f"the {'material' if q.card == 'MAT1' else 'property'} id"),
            _line("field", toml_string(q.field), what if q.card != "PBUSH"
                  else f"{what} {q.field}"),
            _line("nominal", _fmt(q.nominal), "the deck's value (checked against it)"),
            _line("lower_rel", _fmt(q.lower_rel), f"lower bound {q.lower:.6g}{unit} "
                  f"({_pct(q.lower_rel)}), a proposal"),
            _line("upper_rel", _fmt(q.upper_rel), f"upper bound {q.upper:.6g}{unit} "
                  f"({_pct(q.upper_rel)}), a proposal"),
        ]  # fmt: skip
    return "\n".join(out) + "\n"


def config_text(proposal: Proposal, folder: str | os.PathLike[str], parameters: str) -> str:
    """The calibration configuration's text (:mod:`femcal.calibrate.config`): every key,
    what it means, its default and why this value; paths relative to ``folder``."""
    from .. import __version__
    from ..calibrate.config import FLAGS, SETTINGS, Config

    folder = Path(folder)
    b = proposal.band
    d = {k: s.default for k, s in SETTINGS.items()}
    words = {k: getattr(Config, k) for k in ("metric", "loss", "surrogate", "holdout")}
    n_p = len(proposal.parameters)
    f_lo, f_hi = b.band
    support = (f"{len(b.support_hz)} rigid-body or support mode(s) at "
               f"{min(b.support_hz):.3g}-{max(b.support_hz):.3g} Hz are not the structure's"
               if b.support_hz else "the model has no rigid-body or support mode")  # fmt: skip
    modes = ", ".join(f"{f:.4g}" for f in b.band_modes_hz)
    system = "mm, tonne, s, N" if proposal.length_unit == "mm" else "SI (m, kg, s, N)"
    units_why = (f"the deck is in {system} (told from its materials) and the test is "
                 f"{proposal.quantity}" if proposal.length_unit else "femcal could not tell "
                 "the deck's units from its materials: CHECK that these are the FE "
                 "model's")  # fmt: skip
    conv = (f"; the test's {proposal.test_units} are converted to them"
            if proposal.test_units and proposal.test_units != proposal.frf_units else "")
    deck, test = _relative(proposal.deck, folder), _relative(proposal.test, folder)
    name = f"{proposal.stem}_calibration.toml"
    flag = {k: "true" if v else "false" for k, v in FLAGS.items()}

    def key(key: str, value: str, comment: str) -> list[str]:
        return [*_comment(comment), f"{key} = {value}"]

    out = [
        *_comment(f"Calibration of {deck} against {test}, proposed by `femcal init` (femcal "
                  f"{__version__}). Run it from this folder with `femcal calibrate {name} "
                  "--out out`. Paths are relative to this file. Every key is explained where "
                  "it is set: what it means, its default and why it has this value "
                  "(femcal.calibrate.config and docs/calibration.md have the whole method); a "
                  "key left out takes its default."),
        *(line for n in proposal.notes for line in _comment(f"NOTE: {n}.")),
        "",
        "[model]",
        *key("deck", toml_string(deck), "The NASTRAN deck (its INCLUDEs follow)."),
        *key("parameters", toml_string(parameters),
             f"What to calibrate: {n_p} proposed parameters; edit that file."),
        *key("units", toml_string(proposal.frf_units),
             f"Units of the FE model's FRFs (default \"mm/s^2/N\"): {units_why}{conv}."),
        "",
        "[test]",
        *key("frf", toml_string(test),
             f"The measured FRFs ({proposal.n_outputs} outputs x {proposal.n_inputs} inputs, "
             f"{b.test_range[0]:g}-{b.test_range[1]:g} Hz, {proposal.quantity}); instead, "
             "`model = \"model.npz\"` takes an identified model of `femcal identify --out`."),
    ]  # fmt: skip
    for key_, path, what in (("sensors", proposal.sensors, "sensor"),
                             ("inputs", proposal.inputs, "input")):  # fmt: skip
        text = (f"The {what} positions (label, grid, ..., directions; optional): their names "
                "label the channels in the report.")
        if path is not None:
            out += key(key_, toml_string(_relative(path, folder)), text)
        else:
            out += [*_comment(text), f"# {key_} = \"{what}s.csv\""]
    out += [
        *_comment("A synthetic test's true values (optional): the report sets each "
                  "parameter's error against its posterior."),
        "# truth = \"test.truth.toml\"",
        "",
        "[test.identify]",
        *_comment("Identify the test first (as `femcal identify`): the test side becomes a "
                  "modal model whose poles all get the damping zeta0, and suspect channels "
                  "are found. Without this table (and without [test] model) the measured FRFs "
                  "are compared as they are, and zeta0 must be a number."),
        *key("band", f"[{_fmt(b.identify_band[0])}, {_fmt(b.identify_band[1])}]",
             f"Hz, no default: from the calibration band's bottom to {IDENTIFY_MARGIN:g} x its "
             "top, within the test (a mode near the top is identified poorly without its "
             "neighbour above)."),
        *key("method", "\"plscf\"", "The estimator (default \"plscf\", the poly-reference "
             "least-squares complex frequency-domain method, PolyMAX), or \"subspace\"."),
        *_comment(f"Parts (default: chosen from the CMIF's peaks, at most {PART_MODES} a "
                  "part). The FE modes would split here, in the widest gaps between them:"),
        "# splits = [" + ", ".join(_fmt(s) for s in b.splits) + "]",
        *key("orders", "\"auto\"", "Model order of each part (default \"auto\": the "
             "stable columns of each part's stabilisation diagram), a number, or a list with "
             "one per part (with splits)."),
        *_comment("The highest order of the diagrams (default: from each part's peaks)."),
        "# max_order = 40",
        *key("gamma", "1.43", "Residual poles at gamma times each part's top (default 1.43, "
             "the reference study's) ..."),
        *key("beta", "100.0", "... and at beta times it (default 100)."),
        "",
        "[calibration]",
        *key("band", f"[{_fmt(f_lo)}, {_fmt(f_hi)}]",
             f"Hz, no default: where the FE and test FRFs are compared; {b.reason}. FE modes "
             f"in it: {modes} Hz; {support}."),
        *key("zeta0", "\"median\"", "Damping ratio of every mode, test and FE (default "
             "\"median\": the identified modes' median), or a number."),
        *key("samples_per_bandwidth", _fmt(d["samples_per_bandwidth"]),
             "Frequencies per half-power bandwidth 2 zeta0 w, in equal logarithmic steps "
             f"(default {d['samples_per_bandwidth']:g})."),
        *key("metric", "\"complex-log\"",
             f"\"{words['metric']}\" (default) or \"complex-log\", the reference study's "
             "choice: the phase tells apart modes that magnitudes alone confuse, and the "
             "complex logarithm does not jump at opposite phase."),
        *key("loss", toml_string(words["loss"]),
             "\"huber\" (default) or \"squared\": near antiresonances a few residuals are "
             "huge, and Huber's loss keeps them from setting the parameters."),
        *key("huber_c", _fmt(d["huber_c"]), "Huber's threshold in robust standard deviations "
             f"(default {d['huber_c']:g})."),
        *key("reduction_modes", str(d["reduction_modes"]),
             f"Modes of the surrogate's basis (default {d['reduction_modes']}); the band's top "
             "lies well below the highest of them."),
        *key("surrogate", toml_string(words["surrogate"]),
             "\"exact\" (default: every polynomial term) or \"first-order\" (FEMCali's)."),
        *key("enrich_hz", _fmt(d["enrich_hz"]),
             "Static eigenvector-derivative vectors of the modes up to here join the basis "
             "(default 0, none, with exact_gradient: the exact Jacobian makes them "
             "unnecessary)."),
        *key("enrich_vectors", str(d["enrich_vectors"]),
             "At most this many of them (default reduction_modes)."),
        *key("residual", flag["residual"],
             "true: the modes the FRFs do not sum enter as residual flexibility (default "
             "false; needs a restrained model: "
             + ("this one is, it has no rigid-body mode)." if proposal.restrained
                else "this one has rigid-body modes, so keep false).")),
        *key("modal_hz", _fmt(d["modal_hz"]), "The FE FRFs sum the modes up to here (default "
             "0: all reduction_modes)."),
        *key("exact_gradient", flag["exact_gradient"],
             "The full model's exact FRF Jacobian corrects the surrogate at each centre "
             "(default true)."),
        *key("starts", "24", f"Latin hypercube starts, the nominal among them (default "
             f"{d['starts']}); the reference study's 24 for 30 parameters, {n_p} here; "
             "`femcal calibrate --starts N` overrides it."),
        *key("workers", str(d["workers"]), f"Processes for the starts (default "
             f"{d['workers']}), each holding the surrogate in memory; `femcal calibrate "
             "--workers N` overrides it."),
        *key("engine", '"local"', "Where the starts run: \"local\", this machine's "
             "processes (the default), or \"dask\", a Dask LocalCluster of `workers` "
             "processes or the scheduler below; every start gives the same numbers on "
             "either. `femcal calibrate --engine dask` overrides it."),
        *_comment("A running Dask scheduler to run the starts on (with engine = \"dask\"; "
                  "`femcal calibrate --scheduler ADDRESS` gives it on the command line)."),
        '# scheduler = "tcp://localhost:8786"',
        *key("seed", str(d["seed"]), f"Seed of the starts (default {d['seed']})."),
        *key("max_iterations", str(d["max_iterations"]),
             "Levenberg-Marquardt iterations per start and cycle (default "
             f"{d['max_iterations']})."),
        *key("max_cycles", "10", f"Surrogates built, the first at the nominal (default "
             f"{d['max_cycles']}); the reference study's 10: room for the trust-region "
             "cycles, which stop when they settle."),
        *key("settle", _fmt(d["settle"]), "Stop when no informed p moves more than this "
             f"(default {d['settle']:g})."),
        *key("restarts", str(d["restarts"]), "The multi-start search runs again on the "
             f"current surrogate at most this many times (default {d['restarts']}) ..."),
        *key("restart_fall", _fmt(d["restart_fall"]), "... when a kept step lowers the cost "
             f"by less than this fraction (default {d['restart_fall']:g}), or the cycles "
             "settle."),
        *key("bounds_sigma", _fmt(d["bounds_sigma"]), "The prior: the bounds lie this many "
             f"standard deviations from the nominal (default {d['bounds_sigma']:g}; a "
             "parameter's confidence wins)."),
        *key("noise_sigma", _fmt(d["noise_sigma"]), "The test's known noise in log10 units "
             "(default 0: estimated from the nominal model's residual, as for a real test)."),
        *key("hold_ratio", _fmt(d["hold_ratio"]), "A parameter whose posterior standard "
             "deviation stays at this fraction of its prior's or more is held at the nominal "
             f"(default {d['hold_ratio']:g}) ..."),
        *key("identifiable_ratio", _fmt(d["identifiable_ratio"]), "... below this fraction "
             f"it is identifiable (default {d['identifiable_ratio']:g})."),
    ]  # fmt: skip
    inside = [s for s in b.splits if f_lo < s < f_hi]
    edges = [f_lo, *inside, f_hi] if inside else [f_lo, _nice(math.sqrt(f_lo * f_hi)), f_hi]
    bands = ", ".join(f"[{_fmt(a)}, {_fmt(c)}]" for a, c in itertools.pairwise(edges))
    out += [
        *_comment("The posterior from each band alone (optional; default none): which band "
                  "informs what."),
        f"# crlb_bands = [{bands}]",
        *key("holdout", toml_string(words["holdout"]),
             "Validation on held-out data (default \"auto\": each input in turn with several "
             f"inputs, {proposal.n_inputs} here): \"inputs\", \"sensors\", \"configurations\""
             ", \"auto\" or \"none\"."),
        *key("holdout_folds", str(d["holdout_folds"]), "Groups of sensor positions for "
             f"\"sensors\" (default {d['holdout_folds']})."),
        *key("augment_fall", f"{d['augment_fall']:g}", "After a model-form warning, the "
             "element the search names is added to the deck as a parameter and the "
             "calibration runs again into augmented/, when it removes at least this fraction "
             f"of the deviation (default {d['augment_fall']:g}; 0: never)."),
        *key("exclude_suspect_channels", flag["exclude_suspect_channels"],
             "Leave out the channels the identification calls suspect (default true)."),
        "",
        "[output]",
        *key("pictures", "true", "PNG pictures, mode renderings and report.html's figures "
             "(default true)."),
    ]  # fmt: skip
    return "\n".join(out) + "\n"


def _write_checked(path: Path, text: str, check: Callable[[Path], None]) -> Path:
    """Write ``text`` atomically, ``check`` reading the temporary file before it is renamed
    into place (a file the calibration would refuse is never written)."""

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
        check(Path(tmp))

    return write_atomic(path, write)


def write_init(proposal: Proposal, out: str | os.PathLike[str], *, force: bool = False
               ) -> InitFiles:  # fmt: skip
    """Write the parameter file and the configuration of a proposal into ``out``, each
    checked by the calibration's readers before it is renamed into place:
    :func:`femcal.calibrate.parameters.read_parameters` against the proposal's model (the
    deck read again if it has none) and :func:`femcal.calibrate.config.read_config`.

    Raises
    ------
    InitError
        For an output file that exists (unless ``force``).
    """
    from ..calibrate.config import read_config
    from ..calibrate.parameters import read_parameters
    from ..model.build import load_model

    out = Path(out)
    files = output_paths(proposal.deck, out)
    check_outputs(files, force)
    out.mkdir(parents=True, exist_ok=True)
    model = proposal.model if proposal.model is not None else load_model(proposal.deck)
    _write_checked(files.parameters, parameters_text(proposal, out),
                   lambda p: read_parameters(p, model))  # fmt: skip
    _write_checked(files.config, config_text(proposal, out, files.parameters.name),
                   read_config)  # fmt: skip
    return files


def run_init(deck: str | os.PathLike[str], test: str | os.PathLike[str],
             out: str | os.PathLike[str], *, sensors: str | os.PathLike[str] | None = None,
             inputs: str | os.PathLike[str] | None = None, force: bool = False,
             progress: Callable[[str], None] | None = None
             ) -> tuple[Proposal, InitFiles]:  # fmt: skip
    """Propose (:func:`propose`) and write (:func:`write_init`): the output files are
    checked first, so that an existing one stops the job before any work.

    Raises
    ------
    InitError, DeckError, ModelError, ConfigError, FRFError
        As :func:`propose` and :func:`write_init`.
    """
    check_outputs(output_paths(deck, out), force)
    proposal = propose(deck, test, sensors=sensors, inputs=inputs, progress=progress)
    return proposal, write_init(proposal, out, force=force)


__all__ = ["BandProposal", "InitError", "InitFiles", "Proposal", "ProposedParameter",
           "check_channels", "check_points", "comment_label", "config_text", "length_unit",
           "output_paths", "parameters_text", "propose", "propose_band", "run_init",
           "write_init"]  # fmt: skip
