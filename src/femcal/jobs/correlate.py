"""Test-FE correlation without calibration: an FE model's modes against a test's, at the
test's channels (``femcal correlate``).

1. **FE modes**: a NASTRAN deck solved for every root from 0 Hz to ``FE_RATIO`` times the top
   of the band (or the lowest ``n_modes``), or the modes a ``femcal solve --out`` run wrote
   (``modes.npz``; the lowest ``n_modes`` of them, if given); modes are numbered from 1 in
   the order solved, as ``femcal solve`` prints them. The modes that can pair (frequencies
   within ``FE_RATIO`` of the band: ``[F1 / FE_RATIO, F2 x FE_RATIO]``) enter the
   correlation; rigid-body and far modes do not.
2. **Test modes**: FRFs of any format femcal reads, identified as ``femcal identify`` does
   (parts split at ``splits``, automatic or given orders) over the band widened by
   ``IDENTIFY_MARGIN`` on each side (within the data; or over a given identification band),
   so that a mode near an edge is identified with its neighbours beyond it rather than
   bent by them; or an identified model written by ``femcal identify --out``
   (``model.npz``). The test modes in the band are kept. Channels the identification calls
   suspect are left out of the shapes (as the calibration does).
3. **Channels**: each test output is placed on the FE model: a label ``GRID:DIR`` names the
   grid and a signed basic axis (``+X``, ``-RZ``) or a component 1-6 of the grid's
   displacement frame; with a sensors file (``label,grid,...,directions``,
   :mod:`femcal.testdata.points`) a label ``NAME:+X`` names the sensor ``NAME``'s grid and a
   bare ``NAME`` a one-direction sensor. A channel that names no grid of the FE model is an
   error naming it, found before any identification or solution.
4. **Pairing** by MAC and frequency (:func:`femcal.correlate.pair_modes`: MAC at least
   ``min_mac``, frequencies within a factor ``FE_RATIO``, each FE mode at most once).

:func:`run_correlation` does it all from files and writes ``correlation.csv`` (the paired
table), ``mac.csv`` (the MAC matrix, labelled) and ``correlation.html`` (self-contained: the
verdict, the tables, the pictures embedded as PNG and the paired shapes in an interactive 3-D
viewer, :func:`shape_viewer`). The
library returns data and reports progress through a callback; it prints nothing.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import os
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..atomic import write_atomic, write_lines
from ..correlate import comac, in_scale_of, mac, mac_text, pair_modes, sign_agreement
from ..errors import FemcalError, message
from ..identify.layout import Layout
from ..identify.workflow import IdentifiedModel, Settings, identify
from ..model.analysis import EigenRequest
from ..model.ids import IdIndex
from ..response.frf import channel_matrix
from ..testdata.data import Channel, FRFData
from ..testdata.points import channel_names, point_label, read_points

#: FE modes within this factor of the band's edges can pair with a test mode (the pairing's
#: largest frequency ratio), and the deck is solved up to this factor times the band's top.
FE_RATIO = 1.5
#: FRFs are identified over the band widened by this factor on each side (F1 / margin to
#: F2 x margin, within the data), unless an identification band is given: a mode next to an
#: edge is identified poorly when its neighbour beyond the edge is left to the residual poles
#: (on the shipped hammer test, the 96.9 Hz mode's MAC with the FE model falls from 0.9998 to
#: 0.985 when 103.3 Hz is left out).
IDENTIFY_MARGIN = 1.2
#: Keys of a ``femcal solve --out`` modes file (:func:`femcal.io.modes.write_npz`).
MODES_KEYS = ("frequencies_hz", "shapes", "node_ids", "dof_start", "is_grid", "xyz", "cd_frames")
#: Keys that make an NPZ file an identified model rather than FRFs.
IDENTIFIED_KEYS = ("A", "poles", "shapes", "output_labels")


class CorrelationError(FemcalError, ValueError):
    """Inputs that cannot be correlated: a test channel the FE model does not have, a band
    without test or FE modes, a file that is neither what it should be. The message names
    the file, the channel or option, and what was expected."""


# ----------------------------------------------------------------------------- inputs


@dataclass(frozen=True)
class FEModes:
    """FE normal modes and the layout of their shapes (what :func:`channel_matrix` needs).

    Attributes
    ----------
    frequencies_hz : (k,) Hz, in the order solved (mode ``j + 1`` is column ``j``).
    shapes : (n_dof, k) mass-normalised shapes on the g-set, in the nodes' displacement
        frames (model units: mm per sqrt(tonne) for the truck frame).
    node_ids, is_grid, dof_start : (n_nodes,) the g-set layout.
    xyz : (n_nodes, 3) positions in the basic frame (model length unit).
    cd_frames : (n_nodes, 3, 3) columns = the displacement frame's axes in basic.
    source : the deck or modes file they come from.
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    node_ids: np.ndarray
    is_grid: np.ndarray
    dof_start: np.ndarray
    xyz: np.ndarray
    cd_frames: np.ndarray
    source: str = ""

    @property
    def n_dof(self) -> int:
        return int(self.shapes.shape[0])

    def node_index(self, ids: np.ndarray | list[int] | int) -> np.ndarray:
        """0-based node indices of ids; -1 where an id is not a node."""
        return IdIndex(self.node_ids).rows(ids)


@dataclass(frozen=True)
class MeasuredModes:
    """Identified test modes.

    Attributes
    ----------
    frequency_hz, damping_ratio : (k,) Hz and fraction of critical, ascending frequency.
    shapes : (p, k) complex shapes at ``outputs`` (any scale).
    outputs : (p,) the test's output channels as labelled in its file.
    suspect : (p,) channels the identification suspects (left out of the correlation).
    band : (F1, F2) Hz, the band the modes were kept in.
    source : the file they come from; identified : the whole identified model.
    """

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    outputs: tuple[Channel, ...]
    suspect: np.ndarray
    band: tuple[float, float]
    source: str = ""
    identified: IdentifiedModel | None = field(default=None, repr=False)


@dataclass(frozen=True)
class PairedMode:
    """One row of the correlation table: a test mode and the FE mode paired with it, or a
    test mode no FE mode pairs with (FE fields None), or an FE mode in the band no test mode
    pairs with (test fields None). Modes are numbered from 1: test modes in frequency order
    within the band, FE modes as solved."""

    test_mode: int | None
    test_hz: float | None
    damping_ratio: float | None
    fe_mode: int | None
    fe_hz: float | None
    frequency_difference: float | None  # (test - FE) / FE, %
    mac: float | None


@dataclass(frozen=True)
class Correlation:
    """Test modes against FE modes.

    Attributes
    ----------
    test, fe : the modes correlated (all the test's modes in the band, all the FE modes
        solved).
    channels : (p,) the test channels used (suspect ones left out), as labelled in the test.
    placed : (p,) the same channels on the FE model (``GRID:DIR``).
    excluded : the suspect channels left out.
    names : each used channel's label -> its name (the sensor's and the direction, ``L01
        +X``, with a sensors file; else the label); the pictures name the sensors by it.
    test_shapes : (p, kt) complex test shapes at the channels.
    fe_index : (kf,) 0-based columns of ``fe`` that can pair (in the window of the band).
    fe_shapes : (p, kf) those FE shapes at the channels.
    mac : (kt, kf) MAC of every test mode against every FE mode of ``fe_index``.
    rows : the paired table: each test mode (paired or not) in order, then the FE modes in
        the band that no test mode pairs with.
    min_mac : the lowest MAC of a pair.
    """

    test: MeasuredModes
    fe: FEModes
    channels: tuple[Channel, ...]
    placed: tuple[Channel, ...]
    excluded: tuple[Channel, ...]
    names: dict[str, str]
    test_shapes: np.ndarray
    fe_index: np.ndarray
    fe_shapes: np.ndarray
    mac: np.ndarray
    rows: tuple[PairedMode, ...]
    min_mac: float = 0.4

    @property
    def pairs(self) -> tuple[PairedMode, ...]:
        return tuple(r for r in self.rows if r.test_mode is not None and r.fe_mode is not None)

    @property
    def unpaired_test(self) -> tuple[PairedMode, ...]:
        return tuple(r for r in self.rows if r.fe_mode is None)

    @property
    def unpaired_fe(self) -> tuple[PairedMode, ...]:
        return tuple(r for r in self.rows if r.test_mode is None)

    @property
    def band(self) -> tuple[float, float]:
        return self.test.band


#: A channel is suspect where its CoMAC over the pairs is below this ...
COMAC_LOW = 0.5
#: ... or it moves against the FE model (sign agreement below minus this).
AGAINST = 0.5
#: CoMAC and the sign agreement need at least this many pairs to say anything.
MIN_PAIRS = 3
#: Two test modes the sensors can hardly tell apart: AutoMAC over this.
ALIKE = 0.5


@dataclass(frozen=True)
class ChannelVerdict:
    """A test channel the paired shapes call into doubt: its index in
    :attr:`Correlation.channels`, label and name, CoMAC and sign agreement over the pairs
    (:func:`femcal.correlate.comac`, :func:`femcal.correlate.sign_agreement`) and the likely
    reason."""

    index: int
    label: str
    name: str
    comac: float
    sign: float
    reason: str

    def describe(self) -> str:
        who = f"{self.name} ({self.label})" if self.name and self.name != self.label \
            else self.label  # fmt: skip
        return f"{who}: CoMAC {self.comac:.2f}, sign agreement {self.sign:+.2f}; {self.reason}"


@dataclass(frozen=True)
class Checks:
    """What the correlation page and console judge beyond the pairs.

    comac, sign : (p,) per channel over the pairs (NaN with fewer than :data:`MIN_PAIRS`).
    automac : (kt, kt) MAC of the test modes against each other.
    alike : (test mode, test mode, AutoMAC), 1-based, of modes the sensors can hardly tell
        apart (AutoMAC over :data:`ALIKE`).
    suspects : the channels in doubt.
    """

    comac: np.ndarray
    sign: np.ndarray
    automac: np.ndarray
    alike: tuple[tuple[int, int, float], ...]
    suspects: tuple[ChannelVerdict, ...]


def checks_of(result: Correlation) -> Checks:
    """CoMAC and sign agreement per channel over the pairs, the test modes' AutoMAC, and the
    channels and modes in doubt."""
    p = len(result.channels)
    pairs = result.pairs
    auto = mac(result.test_shapes, result.test_shapes)
    kt = auto.shape[0]
    alike = tuple((i + 1, j + 1, float(auto[i, j])) for i in range(kt) for j in range(i + 1, kt)
                  if auto[i, j] > ALIKE)  # fmt: skip
    if len(pairs) < MIN_PAIRS:
        nan = np.full(p, np.nan)
        return Checks(nan, nan, auto, alike, ())
    shapes = [_pair_shapes(result, r) for r in pairs]
    T = np.stack([t for t, _ in shapes], axis=1)
    A = np.stack([a for _, a in shapes], axis=1)
    co, sg = comac(T, A), sign_agreement(T, A)
    suspects = []
    for i in range(p):
        if sg[i] < -AGAINST:
            why = ("likely sign: it moves against the FE model in most pairs (a sensor "
                   "mounted reversed, or a sign lost in the geometry)")
        elif co[i] < COMAC_LOW:
            why = ("it moves unlike the FE model over the pairs: a wrong direction or grid, "
                   "a loose sensor, or a local feature the model lacks")
        else:
            continue
        label = result.channels[i].label
        suspects.append(ChannelVerdict(i, label, result.names.get(label, ""), float(co[i]),
                                       float(sg[i]), why))  # fmt: skip
    return Checks(co, sg, auto, alike, tuple(sorted(suspects, key=lambda v: v.comac)))


#: A pair is doubted when its test mode's MAC with another FE mode is higher by this much.
BETTER_ELSEWHERE = 0.02


def _better_elsewhere(result: Correlation) -> list[str]:
    """Pairs whose test mode correlates better with another FE mode (which the pairing
    gave to a test mode it correlates with better still): close FE modes whose shapes the
    test mixes, or an order the model has wrong."""
    out = []
    for r in result.pairs:
        row = result.mac[r.test_mode - 1]
        col = int(np.argmax(row))
        j = int(result.fe_index[col]) + 1
        if j == r.fe_mode or row[col] <= r.mac + BETTER_ELSEWHERE:
            continue
        other = next((p for p in result.pairs if p.fe_mode == j), None)
        out.append(f"Test mode {r.test_mode} ({r.test_hz:.2f} Hz) pairs with FE mode "
                   f"{r.fe_mode} (MAC {mac_text(r.mac)}), though its MAC with FE mode {j} "
                   f"({result.fe.frequencies_hz[j - 1]:.2f} Hz) is higher "
                   f"({mac_text(float(row[col]))})"
                   + (f", which pairs with test mode {other.test_mode} (MAC "
                      f"{mac_text(other.mac)})" if other else "")
                   + ": the test may mix the shapes of close modes, or the model orders them "
                   "differently; look at both in the shapes' viewer.")  # fmt: skip
    return out


def _left_out(result: Correlation) -> list[str]:
    """Each channel left out as suspect, with the identification's reason and its band."""
    from ..io.identify_page import suspect_reason

    ident = result.test.identified
    out = []
    for c in result.excluded:
        name = result.names.get(c.label)
        who = f"{c.label} ({name})" if name and name != c.label else c.label
        labels = [x.label for x in ident.shape_channels] if ident is not None else []
        if c.label in labels:
            lo, hi = ident.band
            out.append(f"Channel {who} is left out: the identification over {lo:g}-{hi:g} Hz "
                       f"calls it suspect: {suspect_reason(ident, labels.index(c.label))}.")
        else:
            out.append(f"Channel {who} is left out: the test's modes mark it suspect.")
    return out


def verdict_sentence(result: Correlation, n_doubts: int) -> str:
    """The verdict in one plain sentence: how many test modes pair, how close their
    frequencies and shapes are, how many points to doubt."""
    f1, f2 = result.band
    n = len(result.test.frequency_hz)
    pairs = result.pairs
    said = ("nothing stands out" if not n_doubts
            else f"{n_doubts} point{'s' * (n_doubts > 1)} to doubt, below")
    if not pairs:
        return f"None of the {n} test modes in {f1:g}-{f2:g} Hz pairs with an FE mode; {said}."
    d = np.abs([p.frequency_difference for p in pairs])
    macs = [p.mac for p in pairs]
    return (f"{len(pairs)} of {n} test modes in {f1:g}-{f2:g} Hz pair with FE modes: "
            f"frequencies within {d.max():.2f} % (mean {d.mean():.2f} %), shapes with MAC "
            f"{mac_text(min(macs))} or more (mean {mac_text(float(np.mean(macs)))}); "
            f"{said}.")


def verdict_lines(result: Correlation, checks: Checks | None = None) -> list[str]:
    """What to doubt, in sentences: FE modes in the band without a test partner, test modes
    without an FE partner, test modes the sensors can hardly tell apart, pairs whose test
    mode correlates better with another FE mode, the channels left out as suspect and why,
    suspect channels by CoMAC."""
    checks = checks or checks_of(result)
    out = []
    if result.unpaired_fe:
        out.append(f"{len(result.unpaired_fe)} FE mode(s) in the band have no test partner: "
                   + ", ".join(f"{r.fe_mode} ({r.fe_hz:.2f} Hz)" for r in result.unpaired_fe[:8])
                   + ": the test missed them, or its sensors and inputs cannot see them.")
    if result.unpaired_test:
        out.append(f"{len(result.unpaired_test)} test mode(s) pair with no FE mode: "
                   + ", ".join(f"{r.test_mode} ({r.test_hz:.2f} Hz)"
                               for r in result.unpaired_test)
                   + ": a mode the model lacks or places far off, or a spurious test mode.")
    if checks.alike:
        out.append("Test modes the sensors can hardly tell apart (AutoMAC over "
                   f"{ALIKE:g}): " + ", ".join(f"{i} and {j} ({v:.2f})"
                                               for i, j, v in checks.alike)
                   + ": too few or badly placed sensors for these shapes; their MAC with the "
                   "FE modes is weaker evidence.")  # fmt: skip
    out += _better_elsewhere(result)
    out += _left_out(result)
    out += [f"Suspect channel: {v.describe()}." for v in checks.suspects]
    if len(result.pairs) < MIN_PAIRS:
        out.append(f"CoMAC is not judged: fewer than {MIN_PAIRS} pairs.")
    return out


def _check_band(band: tuple[float, float] | None) -> tuple[float, float] | None:
    if band is None:
        return None
    f1, f2 = float(band[0]), float(band[1])
    if not (np.isfinite(f1) and np.isfinite(f2) and 0 < f1 < f2):
        raise CorrelationError(f"band {f1:g}-{f2:g} Hz: expected 0 < F1 < F2 (Hz, finite)")
    return f1, f2


def is_identified_file(path: str | os.PathLike[str]) -> bool:
    """True for an NPZ file holding an identified model of ``femcal identify --out``."""
    return _npz_has(path, IDENTIFIED_KEYS)


def _npz_has(path: str | os.PathLike[str], keys: Sequence[str]) -> bool:
    if Path(path).suffix.lower() != ".npz" or not Path(path).is_file():
        return False
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            return all(k in z.files for k in keys)
    except (OSError, ValueError, zipfile.BadZipFile):
        return False


def read_fe_modes(path: str | os.PathLike[str]) -> FEModes:
    """The modes a ``femcal solve --out`` run wrote (``modes.npz``).

    Raises
    ------
    CorrelationError
        Naming the file and the keys it lacks, or arrays that do not fit together.
    """
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            missing = [k for k in MODES_KEYS if k not in z.files]
            if missing:
                raise CorrelationError(f"{path}: not a modes file of femcal solve --out "
                                       f"(missing {', '.join(missing)})")  # fmt: skip
            arrays = {k: np.asarray(z[k]) for k in MODES_KEYS}
    except (ValueError, zipfile.BadZipFile) as e:
        if isinstance(e, CorrelationError):
            raise
        raise CorrelationError(f"{path}: not an NPZ archive of arrays; expected the modes.npz "
                               "of femcal solve --out") from None  # fmt: skip
    f, shapes = arrays["frequencies_hz"].astype(float), arrays["shapes"]
    n = len(arrays["node_ids"])
    if (shapes.ndim != 2 or shapes.shape[1] != len(f) or arrays["xyz"].shape != (n, 3)
            or arrays["cd_frames"].shape != (n, 3, 3) or len(arrays["is_grid"]) != n
            or len(arrays["dof_start"]) != n):  # fmt: skip
        raise CorrelationError(f"{path}: shapes {shapes.shape} for {len(f)} frequencies and "
                               f"{n} nodes do not fit together; expected the file femcal "
                               "solve --out writes")  # fmt: skip
    return FEModes(f, shapes.astype(float), arrays["node_ids"].astype(np.int64),
                   arrays["is_grid"].astype(bool), arrays["dof_start"].astype(np.int64),
                   arrays["xyz"].astype(float), arrays["cd_frames"].astype(float),
                   str(path))  # fmt: skip


def solve_fe_modes(model, band: tuple[float, float], n_modes: int | None = None, *,
                   source: str = "", progress: Callable[[str], None] | None = None
                   ) -> FEModes:  # fmt: skip
    """A model's modes for a correlation over ``band``: every root from 0 to ``FE_RATIO``
    times its top (or the lowest ``n_modes``), mass-normalised."""
    from ..solve.normal_modes import solve_normal_modes

    if n_modes is not None:
        if int(n_modes) < 1:
            raise CorrelationError(f"{n_modes} modes: expected a number of modes >= 1")
        request = EigenRequest(v1=None, v2=None, nd=int(n_modes))
    else:
        request = EigenRequest(v1=None, v2=FE_RATIO * band[1], nd=None)
    modes, _ = solve_normal_modes(model, request=request, progress=progress)
    return FEModes(np.asarray(modes.frequencies_hz, float), modes.shapes, model.node_ids,
                   model.is_grid, model.dof_start, model.xyz, model.cd_frames,
                   source)  # fmt: skip


def modes_in_band(ident: IdentifiedModel, band: tuple[float, float] | None = None, *,
                  source: str = "") -> MeasuredModes:  # fmt: skip
    """An identified model's modes in ``band`` (default: the model's own band).

    Raises
    ------
    CorrelationError
        For a band that holds no identified mode.
    """
    b = _check_band(band) or (float(ident.band[0]), float(ident.band[1]))
    f = np.asarray(ident.frequency_hz, float)
    sel = (f >= b[0]) & (f <= b[1])
    if not sel.any():
        found = ", ".join(f"{x:.2f}" for x in f) or "none"
        at = f"{source}: " if source else ""
        raise CorrelationError(f"{at}no identified test mode lies in {b[0]:g}-{b[1]:g} Hz "
                               f"(the modes: {found} Hz)")  # fmt: skip
    return MeasuredModes(f[sel], np.asarray(ident.damping_ratio, float)[sel],
                     np.asarray(ident.shapes)[:, sel], tuple(ident.shape_channels),
                     np.asarray(ident.suspect, bool), b, source, ident)  # fmt: skip


def identification_band(data: FRFData, band: tuple[float, float],
                        identify_band: tuple[float, float] | None = None
                        ) -> tuple[float, float]:  # fmt: skip
    """The band FRFs are identified over: ``identify_band`` as given, or ``band`` widened by
    :data:`IDENTIFY_MARGIN` on each side within the data's frequencies.

    Raises
    ------
    CorrelationError
        For a band outside the data, or an identification band that does not hold it.
    """
    b = _check_band(band)
    f = np.asarray(data.frequency_hz, float)
    if identify_band is not None:
        ib = _check_band(identify_band)
        if not (ib[0] <= b[0] and b[1] <= ib[1]):
            raise CorrelationError(f"identification band {ib[0]:g}-{ib[1]:g} Hz: expected it "
                                   f"to hold the band {b[0]:g}-{b[1]:g} Hz")  # fmt: skip
        return ib
    if b[0] < f[0] * (1 - 1e-12) or b[1] > f[-1] * (1 + 1e-12):
        raise CorrelationError(f"band {b[0]:g}-{b[1]:g} Hz: outside the data's "
                               f"{f[0]:g}-{f[-1]:g} Hz")  # fmt: skip
    return max(b[0] / IDENTIFY_MARGIN, float(f[0])), min(b[1] * IDENTIFY_MARGIN, float(f[-1]))


def identify_test(data: FRFData, band: tuple[float, float], *,
                  identify_band: tuple[float, float] | None = None,
                  splits: Sequence[float] | None = None,
                  orders: int | Sequence[int | None] | None = None, source: str = "",
                  method: str = "plscf",
                  progress: Callable[[str], None] | None = None) -> MeasuredModes:  # fmt: skip
    """Identify FRFs as ``femcal identify`` does (default settings, parts split at
    ``splits``, automatic or given orders) over :func:`identification_band` and keep the
    modes in ``band``.

    Raises
    ------
    CorrelationError
        Naming ``source``: data that cannot be identified over the band, splits outside it,
        no mode in ``band``.
    """
    at = f"{source}: " if source else ""
    try:
        ib = identification_band(data, band, identify_band)
        ident = identify(data, ib, splits=splits, orders=orders,
                         settings=Settings(method=method),
                         progress=progress)  # fmt: skip
    except ValueError as e:
        raise CorrelationError(f"{at}{message(e)}") from None
    return modes_in_band(ident, band, source=source)


# ----------------------------------------------------------------------------- channels


@dataclass(frozen=True)
class Sensors:
    """A sensors file: each sensor label -> its grid, and its direction codes."""

    grids: dict[str, int]
    codes: dict[str, list[int]]
    names: dict[str, str]
    path: str = ""

    @classmethod
    def read(cls, path: str | os.PathLike[str]) -> Sensors:
        """Raises ConfigError naming the file and line of a bad row."""
        grids: dict[str, int] = {}
        codes: dict[str, list[int]] = {}
        for label, grid, code in read_points(path):
            grids.setdefault(label, grid)
            codes.setdefault(label, []).append(code)
        return cls(grids, codes, channel_names(path), str(path))


def place_channels(outputs: Sequence[Channel], fe: FEModes, sensors: Sensors | None = None, *,
                   test: str = "", deck: str = "") -> tuple[Channel, ...]:  # fmt: skip
    """Each test output channel as ``GRID:DIR`` on the FE model (see the module docstring).

    Raises
    ------
    CorrelationError
        Naming the test file, the channel (and how many others fail alike) and what was
        expected: a label that names no grid (nor, with a sensors file, a sensor), or a grid
        or direction the FE model does not have.
    """
    at = f"{test}: " if test else ""
    where = deck or fe.source or "the FE model"
    placed: list[Channel] = []
    unnamed: list[int] = []
    for k, ch in enumerate(outputs):
        c = _placed(ch, sensors)
        if c is None:
            unnamed.append(k)
        placed.append(c if c is not None else ch)
    if unnamed:
        k = unnamed[0]
        more = f" (and {len(unnamed) - 1} more such channels)" if len(unnamed) > 1 else ""
        if sensors is not None:
            known = sorted(sensors.grids)
            listed = ", ".join(known[:8]) + (" ..." if len(known) > 8 else "")
            expected = (f"GRID:DIRECTION (e.g. 1001:+Z) or LABEL:+X|+Y|+Z with a label of "
                        f"{sensors.path} ({listed})")
        else:
            expected = ("GRID:DIRECTION (e.g. 1001:+Z or 1001:3), or sensor names with "
                        "--sensors CSV placing them")
        raise CorrelationError(f"{at}channel {outputs[k].label!r} (output {k + 1} of "
                               f"{len(outputs)}) names no grid{more}; expected {expected}")
    idx = fe.node_index([c.grid for c in placed])
    missing = [k for k in range(len(placed)) if idx[k] < 0]
    if missing:
        k = missing[0]
        grids = sorted({placed[j].grid for j in missing})
        more = (f" (and {len(missing) - 1} more channels, grids "
                f"{', '.join(map(str, grids[:10]))}{' ...' if len(grids) > 10 else ''})"
                if len(missing) > 1 else "")  # fmt: skip
        via = (f" (placed by {sensors.path} as {placed[k].label})"
               if placed[k].label != outputs[k].label else "")
        raise CorrelationError(f"{at}channel {outputs[k].label!r} (output {k + 1} of "
                               f"{len(outputs)}){via}: no GRID {placed[k].grid} in {where}"
                               f"{more}; expected the test's channels on grids of the FE "
                               "model")  # fmt: skip
    for k, c in enumerate(placed):
        try:
            channel_matrix(fe, [c])
        except ValueError as e:
            raise CorrelationError(f"{at}channel {outputs[k].label!r} (output {k + 1} of "
                                   f"{len(outputs)}): {e}") from None  # fmt: skip
    return tuple(placed)


def _placed(ch: Channel, sensors: Sensors | None) -> Channel | None:
    """``ch`` as a grid and direction, or None where it names none."""
    if sensors is not None:
        name, sep, what = ch.label.rpartition(":")
        if sep and name.strip() in sensors.grids:
            c = Channel.parse(f"{sensors.grids[name.strip()]}:{what.strip()}")
            if c.grid is not None:
                return c
        bare = ch.label.strip()
        if bare in sensors.grids and len(sensors.codes[bare]) == 1:
            return Channel.parse(point_label(sensors.grids[bare], sensors.codes[bare][0]))
    return ch if ch.grid is not None and ch.direction is not None else None


# ----------------------------------------------------------------------------- correlation


def correlate_modes(test: MeasuredModes, fe: FEModes, placed: Sequence[Channel], *,
                    names: dict[str, str] | None = None, min_mac: float = 0.4,
                    exclude_suspects: bool = True) -> Correlation:  # fmt: skip
    """Pair the test modes with the FE modes at the test's channels (``placed``: each of
    ``test.outputs`` on the FE model, :func:`place_channels`).

    Raises
    ------
    CorrelationError
        For no FE mode near the band, or fewer than two channels left.
    """
    if len(placed) != len(test.outputs):
        raise CorrelationError(f"{len(placed)} placed channels for {len(test.outputs)} test "
                               "outputs; expected one each")  # fmt: skip
    keep = ~test.suspect if exclude_suspects and (~test.suspect).sum() >= 2 else (
        np.ones(len(test.outputs), bool))  # fmt: skip
    channels = tuple(c for c, k in zip(test.outputs, keep, strict=True) if k)
    used = tuple(c for c, k in zip(placed, keep, strict=True) if k)
    excluded = tuple(c for c, k in zip(test.outputs, keep, strict=True) if not k)
    if len(used) < 2:
        raise CorrelationError(f"{len(used)} test channel(s) to correlate; expected at least 2")
    f1, f2 = test.band
    f_fe = fe.frequencies_hz
    fe_index = np.flatnonzero((f_fe >= f1 / FE_RATIO) & (f_fe <= f2 * FE_RATIO))
    if not len(fe_index):
        found = (f"{f_fe.min():.4g}-{f_fe.max():.4g} Hz" if len(f_fe) else "none")
        raise CorrelationError(f"{fe.source}: no FE mode within {f1 / FE_RATIO:.4g}-"
                               f"{f2 * FE_RATIO:.4g} Hz, near the band {f1:g}-{f2:g} Hz (the "
                               f"modes solved: {found}); expected more modes, or another "
                               "band")  # fmt: skip
    C = channel_matrix(fe, used)
    fe_shapes = np.asarray(C @ fe.shapes[:, fe_index])
    test_shapes = np.asarray(test.shapes)[keep]
    M = mac(test_shapes, fe_shapes)
    pairs = {p.test: p for p in pair_modes(test_shapes, test.frequency_hz, fe_shapes,
                                           f_fe[fe_index], min_mac=min_mac,
                                           max_frequency_ratio=FE_RATIO)}  # fmt: skip
    rows = []
    for k, (f, z) in enumerate(zip(test.frequency_hz, test.damping_ratio, strict=True)):
        p = pairs.get(k)
        j = int(fe_index[p.fe]) if p else None
        rows.append(PairedMode(k + 1, float(f), float(z), None if j is None else j + 1,
                               None if j is None else float(f_fe[j]),
                               p.frequency_difference if p else None,
                               p.mac if p else None))  # fmt: skip
    paired_fe = {int(fe_index[p.fe]) for p in pairs.values()}
    for j in fe_index:
        if int(j) not in paired_fe and f1 <= f_fe[j] <= f2:
            rows.append(PairedMode(None, None, None, int(j) + 1, float(f_fe[j]), None, None))
    given = names or {}
    shown = {c.label: given.get(p.label, given.get(c.label, c.label))
             for c, p in zip(channels, used, strict=True)}  # fmt: skip
    return Correlation(test, fe, channels, used, excluded, shown, test_shapes, fe_index,
                       fe_shapes, M, tuple(rows), float(min_mac))  # fmt: skip


# ----------------------------------------------------------------------------- the job


@dataclass(frozen=True)
class CorrelationFiles:
    """What :func:`run_correlation` wrote."""

    table: Path
    mac: Path
    html: Path


def run_correlation(deck: str | os.PathLike[str], test: str | os.PathLike[str], *,
                    sensors: str | os.PathLike[str] | None = None,
                    band: tuple[float, float] | None = None, n_modes: int | None = None,
                    identify_band: tuple[float, float] | None = None,
                    splits: Sequence[float] | None = None,
                    orders: int | Sequence[int | None] | None = None, min_mac: float = 0.4,
                    method: str = "plscf",
                    out: str | os.PathLike[str] | None = None,
                    progress: Callable[[str], None] | None = None
                    ) -> tuple[Correlation, CorrelationFiles | None]:  # fmt: skip
    """Correlate a deck (or a ``femcal solve --out`` modes file) with a test (an FRF file
    to identify, :func:`identify_test`, or a ``femcal identify --out`` model) over ``band``
    (for a model, default its own band); with ``out``, write ``correlation.csv``,
    ``mac.csv`` and ``correlation.html`` there.

    The cheap checks come first: the band, the files, the test's channels on the FE model;
    then the identification and the FE solution.

    Raises
    ------
    CorrelationError
        For a band missing (FRFs to identify) or bad, a channel the FE model lacks, no test
        or FE mode near the band; DeckError, ModelError, FRFError and ConfigError name the
        deck, test or sensors file.
    """
    say = progress or (lambda _m: None)
    band = _check_band(band)
    if n_modes is not None and int(n_modes) < 1:
        raise CorrelationError(f"{n_modes} modes: expected a number of modes >= 1")
    deck, test = Path(deck), Path(test)
    sens = Sensors.read(sensors) if sensors is not None else None
    # the FE side: a solved modes file, or a deck (read now, solved once the test is known)
    model = fe = None
    if deck.suffix.lower() in (".uff", ".unv", ".mat"):
        raise CorrelationError(f"{deck}: test data, not an FE model; expected a NASTRAN deck "
                               "or the modes.npz of femcal solve --out first, then the "
                               "test")  # fmt: skip
    if deck.suffix.lower() == ".npz":
        fe = read_fe_modes(deck)
        if n_modes is not None and int(n_modes) < len(fe.frequencies_hz):
            fe = replace(fe, frequencies_hz=fe.frequencies_hz[: int(n_modes)],
                         shapes=fe.shapes[:, : int(n_modes)])  # fmt: skip
        say(f"read {deck}: {len(fe.frequencies_hz)} FE modes, "
            f"{fe.frequencies_hz.min():.4g}-{fe.frequencies_hz.max():.4g} Hz")
        layout = fe
    else:
        from ..model.build import load_model

        say(f"reading {deck}")
        model = load_model(deck)
        say(f"{model.n_grids} grids, {sum(len(b) for b in model.elements.values())} elements, "
            f"{model.n_dof} DOF")  # fmt: skip
        layout = FEModes(np.zeros(0), np.zeros((model.n_dof, 0)), model.node_ids,
                         model.is_grid, model.dof_start, model.xyz, model.cd_frames,
                         str(deck))  # fmt: skip
    # the test side: an identified model, or FRFs (identified once the channels are placed)
    data = None
    if is_identified_file(test):
        from ..io.identified import read_model

        try:
            ident = read_model(test)
        except (KeyError, ValueError) as e:
            raise CorrelationError(message(e)) from None
        modes = modes_in_band(ident, band, source=str(test))
        outputs = modes.outputs
        say(f"read {test}: identified model, {len(ident.frequency_hz)} modes in "
            f"{ident.band[0]:g}-{ident.band[1]:g} Hz, {len(modes.frequency_hz)} in "
            f"{modes.band[0]:g}-{modes.band[1]:g} Hz")  # fmt: skip
    else:
        from ..testdata.formats import read_frf

        try:
            data = read_frf(test)
        except (KeyError, ValueError) as e:
            if isinstance(e, FemcalError):
                raise
            raise CorrelationError(message(e)) from None
        say(f"read {test}: {len(data.outputs)} outputs x {len(data.inputs)} inputs x "
            f"{len(data.frequency_hz)} frequencies ({data.quantity}, "
            f"{data.units or 'no unit'})")  # fmt: skip
        if band is None:
            raise CorrelationError(f"{test}: FRFs to identify need a band (--band F1 F2, Hz, "
                                   f"within the data's {data.frequency_hz[0]:g}-"
                                   f"{data.frequency_hz[-1]:g} Hz)")  # fmt: skip
        outputs = Layout.of(data.outputs, data.inputs).roving  # where the shapes will be
    placed = place_channels(outputs, layout, sens, test=str(test), deck=str(deck))
    say(f"{len(placed)} test channels placed on {len(np.unique([c.grid for c in placed]))} "
        "grids of the FE model")  # fmt: skip
    if data is not None:
        try:
            ib = identification_band(data, band, identify_band)
        except CorrelationError as e:
            raise CorrelationError(f"{test}: {e}") from None
        say(f"identifying the test FRFs over {ib[0]:g}-{ib[1]:g} Hz")
        modes = identify_test(data, band, identify_band=ib, splits=splits, orders=orders,
                              source=str(test), progress=say, method=method)  # fmt: skip
        say(f"{len(modes.frequency_hz)} test modes in the band: "
            + ", ".join(f"{f:.2f}" for f in modes.frequency_hz) + " Hz")
    if fe is None:
        what = (f"the lowest {n_modes} modes" if n_modes is not None
                else f"the modes up to {FE_RATIO * modes.band[1]:g} Hz")  # fmt: skip
        say(f"solving {what}")
        fe = solve_fe_modes(model, modes.band, n_modes, source=str(deck), progress=say)
        say(f"{len(fe.frequencies_hz)} FE modes"
            + (f", {fe.frequencies_hz[0]:.4g}-{fe.frequencies_hz[-1]:.4g} Hz"
               if len(fe.frequencies_hz) else ""))  # fmt: skip
    result = correlate_modes(modes, fe, placed, names=sens.names if sens else None,
                             min_mac=min_mac)  # fmt: skip
    if result.excluded:
        say("suspect test channels left out: " + ", ".join(c.label for c in result.excluded))
    files = None
    if out is not None:
        files = write_correlation(result, out, deck=str(deck), test=str(test),
                                  sensors=None if sensors is None else str(sensors),
                                  model=model, progress=say)  # fmt: skip
    return result, files


# ----------------------------------------------------------------------------- output


def _num(v: float | None, spec: str) -> str:
    return "" if v is None else format(v, spec)


TABLE_HEAD = ("test_mode", "test_hz", "test_damping_pct", "fe_mode", "fe_hz",
              "frequency_difference_pct", "mac")  # fmt: skip


def table_rows(result: Correlation) -> list[list[str]]:
    """The rows of ``correlation.csv`` (:data:`TABLE_HEAD`; blank where a side is unpaired)."""
    return [[_num(r.test_mode, "d"), _num(r.test_hz, ".6f"),
             _num(None if r.damping_ratio is None else 100 * r.damping_ratio, ".4f"),
             _num(r.fe_mode, "d"), _num(r.fe_hz, ".6f"), _num(r.frequency_difference, ".6f"),
             _num(r.mac, ".6f")] for r in result.rows]  # fmt: skip


def _csv_text(rows: list[Sequence[object]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerows(rows)
    return buf.getvalue()


def fe_label(result: Correlation, col: int) -> str:
    """``FE 7 (13.951 Hz)`` for column ``col`` of the MAC matrix."""
    j = int(result.fe_index[col])
    return f"FE {j + 1} ({result.fe.frequencies_hz[j]:.3f} Hz)"


def write_correlation(result: Correlation, out: str | os.PathLike[str], *, deck: str = "",
                      test: str = "", sensors: str | None = None, model=None,
                      progress: Callable[[str], None] | None = None
                      ) -> CorrelationFiles:  # fmt: skip
    """``out/correlation.csv`` (the table, :data:`TABLE_HEAD`), ``out/mac.csv`` (test modes
    by row, FE modes by column, each labelled with its number and frequency) and
    ``out/correlation.html`` (self-contained); each written atomically."""
    say = progress or (lambda _m: None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table = out / "correlation.csv"
    text = _csv_text([list(TABLE_HEAD), *table_rows(result)])
    write_atomic(table, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    head = ["test_mode", "test_hz", *(fe_label(result, c) for c in range(len(result.fe_index)))]
    rows = [[k + 1, f"{f:.6f}", *(f"{v:.6f}" for v in result.mac[k])]
            for k, f in enumerate(result.test.frequency_hz)]  # fmt: skip
    mac_path = out / "mac.csv"
    text_mac = _csv_text([head, *rows])
    write_atomic(mac_path, lambda tmp: Path(tmp).write_text(text_mac, encoding="utf-8"))
    say(f"drawing the MAC matrix and the {len(result.pairs)} paired shapes")
    page = write_lines(out / "correlation.html",
                       [correlation_html(result, deck=deck, test=test, sensors=sensors,
                                         model=model)])  # fmt: skip
    say(f"wrote {table}, {mac_path}, {page}")
    return CorrelationFiles(table, mac_path, page)


def summary_lines(result: Correlation) -> list[str]:
    """A few lines for people: each pair, each unpaired mode, and the totals."""
    lines = [f"{'test':>4} {'Hz':>9} {'damp %':>7}   {'FE':>4} {'Hz':>9} {'diff %':>8} "
             f"{'MAC':>6}"]  # fmt: skip
    for r in result.rows:
        if r.test_mode is not None and r.fe_mode is not None:
            lines.append(f"{r.test_mode:4d} {r.test_hz:9.3f} {100 * r.damping_ratio:7.3f} ~ "
                         f"{r.fe_mode:4d} {r.fe_hz:9.3f} {r.frequency_difference:+8.2f} "
                         f"{mac_text(r.mac):>6}")  # fmt: skip
        elif r.test_mode is not None:
            lines.append(f"{r.test_mode:4d} {r.test_hz:9.3f} {100 * r.damping_ratio:7.3f}   "
                         "no FE mode pairs with it")  # fmt: skip
        else:
            lines.append(f"{'':4} {'':9} {'':7}   {r.fe_mode:4d} {r.fe_hz:9.3f} no test mode "
                         "pairs with it")  # fmt: skip
    pairs = result.pairs
    f1, f2 = result.band
    if pairs:
        diffs = np.abs([p.frequency_difference for p in pairs])
        lines.append(f"{len(pairs)} of {len(result.test.frequency_hz)} test modes in "
                     f"{f1:g}-{f2:g} Hz paired; frequency difference mean {diffs.mean():.2f} "
                     f"%, worst {diffs.max():.2f} %; lowest MAC "
                     f"{mac_text(min(p.mac for p in pairs))}")  # fmt: skip
    else:
        lines.append(f"none of the {len(result.test.frequency_hz)} test modes in {f1:g}-{f2:g} "
                     "Hz pairs with an FE mode")  # fmt: skip
    return lines + verdict_lines(result)


# ----------------------------------------------------------------------------- the page


def _png(fig) -> str:
    """A matplotlib figure as a ``data:`` URI (PNG, base64); the figure is closed."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    try:
        if not any(ax.name == "3d" for ax in fig.axes):
            fig.tight_layout()
        fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    finally:
        plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def correlation_html(result: Correlation, *, deck: str = "", test: str = "",
                     sensors: str | None = None, model=None) -> str:  # fmt: skip
    """The self-contained page: the verdict, what was correlated, the paired table, the
    unpaired modes, the frequency scatter, the MAC matrix (picture and numbers), AutoMAC and
    CoMAC, the paired shapes in the 3-D viewer on ``model`` (:func:`shape_viewer`) and the
    provenance; every picture embedded (no external reference)."""
    from ..io.html import html_figure, html_number, html_table
    from ..io.identify_page import OWN_BANDS

    f1, f2 = result.band
    rows = [[html_number(r.test_mode, "d"), html_number(r.test_hz, ".3f"),
             html_number(None if r.damping_ratio is None else 100 * r.damping_ratio, ".3f"),
             html_number(r.fe_mode, "d"), html_number(r.fe_hz, ".3f"),
             html_number(r.frequency_difference, "+.2f"),
             "-" if r.mac is None else mac_text(r.mac)]
            for r in result.rows]  # fmt: skip
    head = ["test mode", "test Hz", "damping %", "FE mode", "FE Hz", "frequency difference %",
            "MAC"]  # fmt: skip
    mac_rows = [[f"{k + 1} ({f:.2f} Hz)", *(f"{v:.2f}" for v in result.mac[k])]
                for k, f in enumerate(result.test.frequency_hz)]  # fmt: skip
    # short headers that wrap ("FE 9 83.3 Hz"), so that many FE modes fit the page's width
    mac_head = ["test \\ FE", *(f"FE {j + 1} {result.fe.frequencies_hz[j]:.1f} Hz"
                                 for j in result.fe_index)]  # fmt: skip
    figures = [html_figure(
        "MAC matrix", _png(mac_figure(result)),
        f"MAC of each test mode (rows) against each FE mode within {f1 / FE_RATIO:.3g}-"
        f"{f2 * FE_RATIO:.3g} Hz (columns), at the {len(result.channels)} test channels; "
        "values over 0.3 printed, paired modes framed in red.")]  # fmt: skip
    if result.pairs:
        figures.append(html_figure(
            "Paired shapes, component against component", _png(vector_figure(result)),
            "For each pair: every channel of the test shape (made real and scaled to the FE "
            "shape by the modal scale factor) against the FE shape's; points on the diagonal "
            "agree."))  # fmt: skip
    checks = checks_of(result)
    extra = [html_figure(
        "Frequencies: test against FE", _png(frequency_figure(result)),
        "Each pair's test frequency against its FE frequency (Hz), numbered by test mode and "
        "coloured by MAC; the diagonal is agreement, the grey band +-5 %. Points above the "
        "diagonal: the structure is stiffer than the model there.")]  # fmt: skip
    extra.append(html_figure(
        "AutoMAC of the test modes", _png(automac_figure(result, checks)),
        "MAC of each test mode against every other at the test channels (no unit): "
        f"off-diagonal values over {ALIKE:g} mean the sensors can hardly tell those modes "
        "apart."))  # fmt: skip
    if len(result.pairs) >= MIN_PAIRS:
        extra.append(html_figure(
            "CoMAC per channel", _png(comac_figure(result, checks)),
            f"Each channel's CoMAC over the {len(result.pairs)} pairs (no unit, 1: it moves "
            "as the FE model in every pair) and its sign agreement (-1: against it in every "
            f"pair); red: suspect (CoMAC below {COMAC_LOW:g} or sign agreement below "
            f"{-AGAINST:g})."))  # fmt: skip
    unpaired_t = ", ".join(f"{r.test_mode} ({r.test_hz:.2f} Hz)" for r in result.unpaired_test)
    unpaired_f = ", ".join(f"{r.fe_mode} ({r.fe_hz:.2f} Hz)" for r in result.unpaired_fe)
    excluded = ", ".join(c.label for c in result.excluded)
    pairs = result.pairs
    esc = html.escape
    if pairs:
        d = np.abs([p.frequency_difference for p in pairs])
        macs = [p.mac for p in pairs]
        worst = pairs[int(np.argmax(d))]
        low = pairs[int(np.argmin(macs))]
        key = [["test modes paired", f"{len(pairs)} of {len(result.test.frequency_hz)}"],
               ["frequency difference, mean |.|", f"{d.mean():.2f} %"],
               ["frequency difference, worst", f"{worst.frequency_difference:+.2f} % (test "
                                                f"mode {worst.test_mode})"],
               ["MAC, lowest", f"{mac_text(low.mac)} (test mode {low.test_mode})"],
               ["MAC, mean", mac_text(float(np.mean(macs)))]]  # fmt: skip
    else:
        key = [["test modes paired", f"0 of {len(result.test.frequency_hz)}"]]
    if np.isfinite(checks.comac).any():
        i = int(np.nanargmin(checks.comac))
        key.append(["CoMAC, lowest channel", f"{checks.comac[i]:.2f} "
                    f"({result.names.get(result.channels[i].label, result.channels[i].label)})"])
    off = checks.automac - np.eye(len(checks.automac))
    if off.size > 1:
        i, j = np.unravel_index(int(np.argmax(off)), off.shape)
        key.append(["AutoMAC, largest off-diagonal", f"{off[i, j]:.2f} (test modes {i + 1} "
                                                     f"and {j + 1})"])
    found = verdict_lines(result, checks)
    sentence = verdict_sentence(result, len(found))
    doubts = found or ["Nothing stands out."]
    ident = result.test.identified
    identified = ("" if ident is None else
                  f", identified over {ident.band[0]:g}-{ident.band[1]:g} Hz ({OWN_BANDS})")
    from ..io.html import PAGE_STYLE, file_facts, html_header, provenance
    from ..viz.webview import viewer_assets

    viewer = ""
    if pairs:
        style, script = viewer_assets()
        viewer = (f"{style}<p>Each pair animated on the FE model "
                  f"({'its elements' if model is not None else 'its grids'}, coloured by the "
                  "deflection drawn): the test shape at the sensors in red, made real and "
                  "scaled to the FE shape by the modal scale factor, and the FE shape as the "
                  "same channels see it in blue, both to the model's scale; each sensor "
                  "joined to its two nearest. Choose the pair above the drawing; drag to "
                  "turn, click a sensor or grid for its motion.</p>\n"
                  f"{shape_viewer(result, model)}\n{script}")  # fmt: skip

    facts = [file_facts(role, path) for role, path in
             (("deck", deck), ("test", test), ("sensors", sensors)) if path]  # fmt: skip
    return f"""<!DOCTYPE html><html><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>femcal correlation</title><style>{PAGE_STYLE}</style></head><body>
<h1>Test-FE correlation</h1>
<section id='verdict' class='verdict'><h2>Verdict</h2>
<p class='sentence'>{esc(sentence)}</p>
{html_table(key, ["measure", "value"])}
<p><b>What to doubt</b></p><ul class='doubt'>{"".join(f"<li>{esc(x)}</li>" for x in doubts)}</ul>
</section>
<p>FE modes of <code>{esc(deck or result.fe.source)}</code>
({len(result.fe.frequencies_hz)} solved, {len(result.fe_index)} within
{f1 / FE_RATIO:.3g}-{f2 * FE_RATIO:.3g} Hz); test modes of <code>{esc(test or
result.test.source)}</code> in {f1:g}-{f2:g} Hz ({len(result.test.frequency_hz)}){
esc(identified)};
{len(result.channels)} test channels{
f" placed by <code>{esc(sensors)}</code>" if sensors else ""}{
f"; suspect channels left out: {esc(excluded)}" if excluded else ""}.
Pairs: MAC at least {result.min_mac:g}, frequencies within a factor {FE_RATIO:g}, each FE
mode once, the highest MAC first; frequency difference (test - FE) / FE.</p>
<h2>Paired modes</h2>
{html_table(rows, head)}
<p>Test modes no FE mode pairs with: {esc(unpaired_t) or "none"}.<br>
FE modes in {f1:g}-{f2:g} Hz no test mode pairs with: {esc(unpaired_f) or "none"}.</p>
{extra[0]}
<h2>MAC matrix</h2>
{figures[0]}
<div class='matrix'>{html_table(mac_rows, mac_head)}</div>
<h2>AutoMAC and CoMAC</h2>
{''.join(extra[1:])}
<h2>Shapes</h2>
{viewer}
{''.join(figures[1:])}
<h2 id='provenance'>Provenance</h2>
{html_header(provenance(facts))}
</body></html>"""


# ----------------------------------------------------------------------------- pictures


def frequency_figure(result: Correlation):
    """Test against FE frequency of each pair (Hz), the diagonal and a +-5 % band."""
    from ..viz.figures import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 5.0))
    pairs = result.pairs
    lo, hi = result.band
    ax.fill_between([lo, hi], [lo * 0.95, hi * 0.95], [lo * 1.05, hi * 1.05], color="0.9",
                    label="+-5 %")  # fmt: skip
    ax.plot([lo, hi], [lo, hi], color="0.4", lw=1, label="test = FE")
    if pairs:
        fe = np.array([p.fe_hz for p in pairs])
        te = np.array([p.test_hz for p in pairs])
        sc = ax.scatter(fe, te, c=[p.mac for p in pairs], cmap="viridis", vmin=0, vmax=1,
                        zorder=3, edgecolor="k")  # fmt: skip
        for p, x, y in zip(pairs, fe, te, strict=True):
            ax.annotate(str(p.test_mode), (x, y), xytext=(4, -10), textcoords="offset points",
                        fontsize=9)  # fmt: skip
        fig.colorbar(sc, ax=ax, fraction=0.05, label="MAC (no unit)")
    ax.set_xlabel("FE frequency (Hz)")
    ax.set_ylabel("test frequency (Hz)")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.legend(loc="upper left", fontsize=9)
    ax.set_title("paired modes: test against FE")
    return fig


def automac_figure(result: Correlation, checks: Checks):
    """The test modes' AutoMAC as a picture, values printed."""
    from ..viz.figures import mac_image, pyplot

    plt = pyplot()
    M = checks.automac
    k = len(M)
    fig, ax = plt.subplots(figsize=(max(4.5, 0.5 * k + 2.5), max(4.0, 0.45 * k + 2.0)))
    im = mac_image(ax, M, printed_above=0.1, fontsize=9, aspect="equal")
    ticks = [f"{i + 1}: {f:.1f}" for i, f in enumerate(result.test.frequency_hz)]
    ax.set_xticks(range(k), ticks, rotation=90, fontsize=9)
    ax.set_yticks(range(k), ticks, fontsize=9)
    ax.set_xlabel("test mode: frequency (Hz)")
    ax.set_ylabel("test mode: frequency (Hz)")
    fig.colorbar(im, ax=ax, fraction=0.04, label="MAC (no unit)")
    ax.set_title("AutoMAC of the test modes")
    return fig


def comac_figure(result: Correlation, checks: Checks):
    """Each channel's CoMAC and sign agreement over the pairs, suspects in red."""
    from ..viz.figures import pyplot

    plt = pyplot()
    p = len(result.channels)
    names = [result.names.get(c.label, c.label) for c in result.channels]
    bad = {v.index for v in checks.suspects}
    colours = ["tab:red" if i in bad else "tab:blue" for i in range(p)]
    fig, axes = plt.subplots(2, 1, figsize=(max(8.0, 0.16 * p + 2.0), 6.0), sharex=True)
    axes[0].bar(range(p), checks.comac, color=colours)
    axes[0].axhline(COMAC_LOW, color="tab:red", lw=0.8, ls="--")
    axes[0].set_ylabel("CoMAC (no unit)")
    axes[0].set_ylim(0, 1.02)
    axes[1].bar(range(p), checks.sign, color=colours)
    axes[1].axhline(-AGAINST, color="tab:red", lw=0.8, ls="--")
    axes[1].set_ylabel("sign agreement (no unit)")
    axes[1].set_ylim(-1.05, 1.05)
    axes[1].set_xticks(range(p), names, rotation=90, fontsize=6 if p > 40 else 8)
    axes[1].set_xlabel("test channel")
    axes[0].set_title(f"channels over {len(result.pairs)} paired modes; red: suspect")
    return fig


def mac_figure(result: Correlation):
    """The MAC matrix as a picture (a matplotlib figure): test modes by row, FE modes by
    column, values over 0.3 printed, pairs framed."""
    from ..viz.figures import mac_image, pyplot

    plt = pyplot()
    M = result.mac
    kt, kf = M.shape
    fig, ax = plt.subplots(figsize=(max(5.0, 0.55 * kf + 2.5), max(3.5, 0.45 * kt + 1.8)))
    im = mac_image(ax, M, printed_above=0.3, fontsize=9)
    f_fe = result.fe.frequencies_hz
    ax.set_xticks(range(kf), [f"{j + 1}: {f_fe[j]:.1f}" for j in result.fe_index],
                  rotation=90, fontsize=9)  # fmt: skip
    ax.set_yticks(range(kt), [f"{k + 1}: {f:.1f}" for k, f in
                              enumerate(result.test.frequency_hz)], fontsize=9)  # fmt: skip
    ax.set_xlabel("FE mode: frequency (Hz)")
    ax.set_ylabel("test mode: frequency (Hz)")
    ax.set_title("MAC")
    col = {int(j): c for c, j in enumerate(result.fe_index)}
    for p in result.pairs:
        c = col[p.fe_mode - 1]
        ax.add_patch(plt.Rectangle((c - 0.5, p.test_mode - 1.5), 1, 1, fill=False,
                                   edgecolor="tab:red", lw=1.5))  # fmt: skip
    fig.colorbar(im, ax=ax, fraction=0.04, label="MAC (no unit)")
    return fig


def _pair_shapes(result: Correlation, r: PairedMode) -> tuple[np.ndarray, np.ndarray]:
    """(test, FE) shapes (p,) of a pair at the channels: the FE shape as solved, the test
    shape real in the FE shape's phase and scale (modal scale factor)."""
    col = int(np.flatnonzero(result.fe_index == r.fe_mode - 1)[0])
    a = result.fe_shapes[:, col]
    return in_scale_of(result.test_shapes[:, r.test_mode - 1], a), a


def fe_translations(fe: FEModes, columns: Sequence[int]) -> np.ndarray:
    """(k, P, 3) the translations in basic of the FE modes ``columns`` (0-based) at every
    grid, in the order of ``fe.node_ids``' grids."""
    from ..io.modes import grid_motions

    moved = grid_motions(fe.shapes[:, list(columns)], fe.is_grid, fe.dof_start, fe.cd_frames)
    return np.transpose(moved, (2, 0, 1))


def shape_viewer(result: Correlation, model=None) -> str:
    """The 3-D viewer of the paired modes (:mod:`femcal.viz.pair_view`), as HTML: the FE
    model (its elements' faces and lines from ``model``, else its grids as points) animated
    in each paired FE mode, the test shape drawn over it at the sensors (red) beside the FE
    shape as the same channels see it (blue)."""
    from ..viz.pair_view import ShapePair, paired_modes_block
    from ..viz.webview import grid_cloud, viewer_mesh

    fe = result.fe
    g = np.flatnonzero(fe.is_grid)
    mesh = viewer_mesh(model) if model is not None else grid_cloud(fe.xyz[g], fe.node_ids[g])
    column = {c: n for n, c in enumerate(result.fe_index.tolist())}
    pairs = [ShapePair(r.test_mode, r.test_hz, r.fe_mode, r.fe_hz, r.mac,
                       result.test_shapes[:, r.test_mode - 1],
                       result.fe_shapes[:, column[r.fe_mode - 1]])
             for r in result.pairs]  # fmt: skip
    return paired_modes_block(mesh, fe.cd_frames[g], lambda cols: fe_translations(fe, cols),
                              fe.frequencies_hz, result.placed, pairs, result.names,
                              title=Path(fe.source).name if fe.source else "FE model")  # fmt: skip


def vector_figure(result: Correlation):
    """Test against FE shape, channel by channel, one panel per pair."""
    from ..viz.figures import pyplot, shape_scatter

    plt = pyplot()
    pairs = result.pairs
    cols = min(len(pairs), 5)
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.3 * rows), squeeze=False)
    for n, r in enumerate(pairs):
        ax = axes[divmod(n, cols)]
        t, a = _pair_shapes(result, r)
        shape_scatter(ax, a, t)
        ax.set_title(f"test {r.test_mode} ({r.test_hz:.1f} Hz) / FE {r.fe_mode} "
                     f"({r.fe_hz:.1f} Hz)\nMAC {mac_text(r.mac)}", fontsize=8)  # fmt: skip
        ax.set_xlabel("FE shape (mass-normalised)", fontsize=8)
        ax.set_ylabel("test shape, scaled by the MSF", fontsize=8)
    for n in range(len(pairs), rows * cols):
        axes[divmod(n, cols)].set_visible(False)
    return fig
