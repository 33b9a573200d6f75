"""Stabilisation diagrams and the automatic choice of the physical poles, for any estimator.

An estimator (the subspace method, :mod:`femcal.identify.subspace`, or pLSCF,
:mod:`femcal.identify.plscf`) gives models of increasing order. A physical mode shows as a
pole that returns at nearly the same frequency, damping and vector (the shape at the
outputs for the subspace method, the participation of the references for pLSCF) as the order
grows: a vertical column in the diagram. Noise and computational poles wander, drift slowly
along diagonals, or settle for a few orders only.

**Stable poles** (the diagram's symbols). A pole of one order is *stable* when a pole of the
previous order lies within ``tol_frequency`` in frequency, within ``tol_damping`` (relative)
in damping and (with vectors longer than one) has a vector MAC of at least ``tol_mac``;
*frequency-stable* when only the frequency agrees. The damping of a mode narrower than the
frequency resolution (a lightly damped structure: a resonance one to three lines wide)
cannot be resolved better than about the line spacing, so the damping tolerances are never
taken below half a line over the frequency in absolute terms.

**Columns, not one order.** Instead of choosing one model order and the poles of that order,
the stable poles of all orders are grouped into columns, as an engineer reads the diagram
(and as the automatic pickers of commercial curve fitters do). A column is seeded at the
stable pole with the most orders within its reach and gathers, from each other order, the
stable pole nearest it within the reach. The reach is what a mode's estimates scatter
over: in frequency the widest of ``column_min`` (0.1 %), ``bandwidth_share`` of the
damping ratio (half the half-power bandwidth: a heavily damped mode is known to a fraction
of its bandwidth, not to a permille) and ``column_lines`` lines (a mode one line wide is
known to a line or two); in damping ``column_damping`` (50 %, relative); in vector the MAC.
A column is a *physical mode* when it holds at least ``min_stable`` orders and
``min_orders_share`` of the diagram's orders, and at least ``min_share`` of the orders from
its lowest to the highest: a physical pole, once found, stays; a computational pole drifting
along a diagonal passes through a column's reach in a few orders, and a pole that settles
only near the top of the diagram has too few orders. The mode's pole is the median
(frequency and damping separately) of its column. Close modes make two columns, since a
column takes one pole per order; but two columns less than a frequency line apart are one
mode (the data cannot split it: an estimator sometimes doubles a sharp resonance at high
orders), the column of more orders kept.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..correlate.shapes import mac
from ..response.statespace import modal_to_poles, poles_to_modal


@dataclass(frozen=True)
class Criteria:
    """Stability and selection criteria (defaults as in the module docstring).

    tol_frequency : relative frequency change allowed between orders.
    tol_damping : relative damping change allowed between orders.
    tol_mac : least vector MAC between orders.
    min_stable, min_orders_share : least number of orders of a mode's column: min_stable,
        and min_orders_share of the diagram's orders (so that a pole that settles only at
        the last few orders of a long diagram is not taken for a mode).
    min_share : least share of the orders from a column's lowest to the highest that it
        holds.
    zeta_max : poles damped more than this are not physical.
    bandwidth_share, column_min, column_lines : a column's reach in frequency, relative:
        the widest of ``bandwidth_share`` times the damping ratio, ``column_min`` and
        ``column_lines`` frequency lines.
    column_damping : a column's reach in damping, relative (with the resolution floor).
    """

    tol_frequency: float = 0.01
    tol_damping: float = 0.2
    tol_mac: float = 0.95
    min_stable: int = 3
    min_orders_share: float = 0.4
    min_share: float = 0.5
    zeta_max: float = 0.2
    bandwidth_share: float = 0.5
    column_damping: float = 0.5
    column_min: float = 0.001
    column_lines: float = 2.0


@dataclass(frozen=True)
class OrderPoles:
    """The physical-looking poles of one order: Im > 0, inside the band, damping in
    (0, zeta_max).

    Attributes
    ----------
    order : the model order (the subspace method's number of states; pLSCF's polynomial
        order, whose model has order x references poles).
    poles : (k,) complex, rad/s, ascending frequency.
    frequency_hz, damping_ratio : (k,).
    vectors : (d, k) complex: shapes at the outputs (subspace) or participation of the
        references (pLSCF).
    stable : (k,) stable in frequency, damping and vector against the previous order.
    stable_frequency : (k,) stable in frequency against the previous order.
    mode : (k,) the mode whose column each pole joined, -1 for none.
    """

    order: int
    poles: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    vectors: np.ndarray
    stable: np.ndarray
    stable_frequency: np.ndarray
    mode: np.ndarray


@dataclass(frozen=True)
class Stabilization:
    """A stabilisation diagram and the modes chosen from it.

    Attributes
    ----------
    band : (f_lo, f_hi) Hz. method : the estimator ("subspace" or "plscf").
    orders : per order its :class:`OrderPoles`, ascending order.
    modes : (k,) the chosen physical poles (rad/s, Im > 0), ascending frequency.
    support : (k,) how many orders each mode's column holds.
    n_orders_seen : (k,) how many orders there are from each column's lowest to the
        highest.
    singular_values : of the subspace step (empty for pLSCF).
    """

    band: tuple[float, float]
    method: str
    orders: list[OrderPoles]
    modes: np.ndarray
    support: np.ndarray
    n_orders_seen: np.ndarray
    singular_values: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def modes_hz(self) -> np.ndarray:
        """(k,) the chosen modes' natural frequencies, Hz."""
        return poles_to_modal(self.modes)[0]

    @property
    def max_order(self) -> int:
        return self.orders[-1].order if self.orders else 0


def physical(poles: np.ndarray, band: tuple[float, float], zeta_max: float) -> np.ndarray:
    """Indices of the poles with Im > 0 inside the band and damping in (0, zeta_max),
    ascending in frequency."""
    poles = np.asarray(poles, complex)
    finite = np.isfinite(poles)
    f, z = poles_to_modal(np.where(finite, poles, 0.0))
    keep = (finite & (poles.imag > 0) & (f >= band[0]) & (f <= band[1])
            & (z > 0) & (z < zeta_max))  # fmt: skip
    idx = np.flatnonzero(keep)
    return idx[np.argsort(f[idx])]


def _agree(f1, z1, v1, f2, z2, v2, c: Criteria, z_floor: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(k1, k2) agreement of two orders' poles in frequency, and in frequency, damping and
    vector."""
    df = np.abs(f1[:, None] / f2[None, :] - 1.0)
    dz = np.abs(z1[:, None] - z2[None, :])
    z_tol = np.maximum(c.tol_damping * z2[None, :], z_floor[:, None])
    ok_f = df < c.tol_frequency
    ok = ok_f & (dz < z_tol)
    if v1.shape[0] > 1:
        ok &= mac(v1, v2) > c.tol_mac
    return ok_f, ok


def stable_columns(raw: list[tuple[int, np.ndarray, np.ndarray]], band: tuple[float, float],
                method: str, resolution_hz: float, criteria: Criteria | None = None,
                singular_values: np.ndarray | None = None) -> Stabilization:  # fmt: skip
    """The stabilisation diagram and its physical modes from each order's poles.

    Parameters
    ----------
    raw : per order (ascending): (order, all poles (n,) rad/s, vectors (d, n)).
    band : (f_lo, f_hi) Hz: only poles inside count.
    method : the estimator's name, kept with the diagram.
    resolution_hz : the frequency line spacing (for the damping tolerance's floor).
    """
    c = criteria or Criteria()
    orders: list[OrderPoles] = []
    for n, poles, vectors in raw:
        idx = physical(np.asarray(poles), band, c.zeta_max)
        lam = np.asarray(poles)[idx]
        vec = np.asarray(vectors)[:, idx]
        fr, z = poles_to_modal(lam)
        k = len(lam)
        stable = np.zeros(k, bool)
        stable_f = np.zeros(k, bool)
        if orders and k and len(orders[-1].poles):
            prev = orders[-1]
            ok_f, ok = _agree(fr, z, vec, prev.frequency_hz, prev.damping_ratio,
                                 prev.vectors, c, _floor(fr, resolution_hz))  # fmt: skip
            stable_f = ok_f.any(axis=1)
            stable = ok.any(axis=1)
        orders.append(OrderPoles(int(n), lam, fr, z, vec, stable, stable_f, np.full(k, -1)))
    modes, support, seen = _clusters(orders, c, resolution_hz)
    return Stabilization(band, method, orders, modes, support, seen,
                         np.zeros(0) if singular_values is None else singular_values)


def _floor(f: np.ndarray, resolution_hz: float) -> np.ndarray:
    """The damping ratio a resolution of ``resolution_hz`` cannot resolve below: half a
    line over the frequency."""
    return 0.5 * resolution_hz / np.maximum(f, 1e-300)


def _clusters(orders: list[OrderPoles], c: Criteria, resolution_hz: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The modes of a diagram: columns of stable poles (see the module docstring). Each
    order's ``mode`` is set to the mode its pole joined (-1: none). Returns the modes'
    poles, how many orders each column holds and how many orders there are from its lowest
    to the top."""
    pos = np.concatenate([np.full(int(op.stable.sum()), k) for k, op in enumerate(orders)]
                         or [np.zeros(0, int)]).astype(int)  # fmt: skip
    if len(pos) == 0:
        return np.zeros(0, complex), np.zeros(0, int), np.zeros(0, int)
    at = np.concatenate([np.flatnonzero(op.stable) for op in orders])
    f = np.concatenate([op.frequency_hz[op.stable] for op in orders])
    z = np.concatenate([op.damping_ratio[op.stable] for op in orders])
    lam = np.concatenate([op.poles[op.stable] for op in orders])
    vec = np.concatenate([op.vectors[:, op.stable] for op in orders], axis=1)
    # neighbours: another order, within a column's reach of the point in frequency,
    # damping and vector
    reach = np.maximum.reduce([np.full(len(f), c.column_min), c.bandwidth_share * z,
                               c.column_lines * resolution_hz / f])
    near = np.abs(f[None, :] / f[:, None] - 1.0) < reach[:, None]
    z_tol = np.maximum(c.column_damping * z, _floor(f, resolution_hz))
    near &= np.abs(z[None, :] - z[:, None]) < z_tol[:, None]
    if vec.shape[0] > 1:
        near &= mac(vec, vec) > c.tol_mac
    near &= pos[None, :] != pos[:, None]
    n_pos = len(orders)
    least = max(c.min_stable, int(np.ceil(c.min_orders_share * n_pos)))
    free = np.ones(len(pos), bool)
    tried = np.zeros(len(pos), bool)
    found: list[tuple[complex, int, int]] = []
    while True:
        cand = np.flatnonzero(free & ~tried)
        if len(cand) == 0:
            break
        counts = np.array([1 + len(np.unique(pos[near[i] & free])) for i in cand])
        best = int(np.argmax(counts))
        seed = int(cand[best])
        if counts[best] < least:
            break
        members = [seed]
        for k in np.unique(pos[near[seed] & free]):
            js = np.flatnonzero(near[seed] & free & (pos == k))
            members.append(int(js[np.argmin(np.abs(f[js] - f[seed]))]))
        members = np.array(members)
        seen = n_pos - int(pos[members].min())
        if len(members) < c.min_share * seen:
            tried[seed] = True
            continue
        free[members] = False
        mode = len(found)
        for j in members:
            orders[pos[j]].mode[at[j]] = mode
        found.append((_median_pole(lam[members]), len(members), seen))
    if not found:
        return np.zeros(0, complex), np.zeros(0, int), np.zeros(0, int)
    # two columns less than a line apart are one mode the data cannot split (an estimator
    # sometimes doubles a sharp resonance at high orders): the one of more orders stays
    hz = np.array([abs(p) / (2 * np.pi) for p, _, _ in found])
    drop: set[int] = set()
    for a in sorted(range(len(found)), key=lambda k: -found[k][1]):
        if a in drop:
            continue
        for b in range(len(found)):
            if b != a and b not in drop and abs(hz[b] - hz[a]) < resolution_hz:
                drop.add(b)
                for op in orders:
                    op.mode[op.mode == b] = -1
    if drop:
        keep = [k for k in range(len(found)) if k not in drop]
        renumber = {k: n for n, k in enumerate(keep)}
        for op in orders:
            op.mode[:] = [renumber.get(int(t), -1) if t >= 0 else -1 for t in op.mode]
        found = [found[k] for k in keep]
    order = np.argsort([abs(p) for p, _, _ in found])
    remap = np.empty(len(found), int)
    remap[order] = np.arange(len(found))
    for op in orders:
        op.mode[op.mode >= 0] = remap[op.mode[op.mode >= 0]]
    poles, support, seen = zip(*[found[k] for k in order], strict=True)
    return np.array(poles, complex), np.array(support, int), np.array(seen, int)


def _median_pole(members: np.ndarray) -> complex:
    f, z = poles_to_modal(np.asarray(members))
    return complex(modal_to_poles(np.array([np.median(f)]), np.array([np.median(z)]))[0])
