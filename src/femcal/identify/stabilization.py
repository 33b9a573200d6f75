"""Stabilisation diagram and automatic model order for subspace identification.

Models of increasing order come cheaply from one subspace basis (each order takes the next
singular vectors). A physical mode shows as a pole that returns at nearly the same
frequency, damping and shape as the order grows; noise poles wander. A pole is *stable* when
the previous order had one within ``tol_frequency`` in frequency, ``tol_damping`` (relative)
in damping and with a shape MAC of at least ``tol_mac``.

The automatic order: stable poles of all orders are grouped by frequency; a group seen
stable in at least ``min_share`` of the orders from where it first appears, and in three
orders at least, is a physical mode. From the lowest order at which every physical mode has
a stable pole, the order chosen is the lowest whose least-squares misfit is within 10 % of
the best of the higher orders (more states improve a fit only while they model something,
out-of-band modes for one). The poles kept at that order are the ones nearest the physical
modes; the others fit noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..correlate.shapes import mac
from ..response.statespace import poles_to_modal
from ..testdata.data import FRFError
from .lsq import lsfd
from .subspace import default_block_rows, model_of_order, subspace_basis


@dataclass(frozen=True)
class OrderPoles:
    """The physical-looking poles (Im > 0, inside the band, 0 < zeta < zeta_max) of one order.

    frequency_hz, damping_ratio : (k,); shapes : (p, k) complex (C times eigenvectors);
    stable : (k,) bool as defined in the module docstring.
    fit_error : relative misfit ``||H - H_fit|| / ||H||`` of all the order's poles (inside
        and outside the band) with residues and feedthrough by least squares.
    """

    order: int
    poles: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    stable: np.ndarray
    fit_error: float = np.nan


@dataclass(frozen=True)
class Stabilization:
    """The diagram's content and the automatic order.

    band : (f_lo, f_hi) Hz; orders : per order the :class:`OrderPoles`;
    modes_hz : (k,) frequency of each physical mode group (mean of its stable poles);
    auto_order : the chosen order; singular_values : of the subspace step.
    """

    band: tuple[float, float]
    orders: list[OrderPoles]
    modes_hz: np.ndarray
    auto_order: int
    singular_values: np.ndarray


def physical_poles(A: np.ndarray, C: np.ndarray, band: tuple[float, float],
                   zeta_max: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Poles (k,) with Im > 0 inside the band and damping in (0, zeta_max), ascending in
    frequency, and their shapes C v (p, k)."""
    lam, V = np.linalg.eig(A)
    f, z = poles_to_modal(lam)
    keep = (lam.imag > 0) & (f >= band[0]) & (f <= band[1]) & (z > 0) & (z < zeta_max)
    idx = np.flatnonzero(keep)
    idx = idx[np.argsort(f[idx])]
    return lam[idx], C @ V[:, idx]


def stabilization(freq_hz: np.ndarray, H: np.ndarray, band: tuple[float, float], *,
                  orders: range | list[int] = range(2, 31, 2), q: int | None = None,
                  zeta_max: float = 0.2, tol_frequency: float = 0.01,
                  tol_damping: float = 0.2, tol_mac: float = 0.95,
                  min_share: float = 0.5, stable_system: bool = True) -> Stabilization:  # fmt: skip
    """Identify models of each order in ``orders`` from H (p, m, K) on the band's
    frequencies and classify their poles (see the module docstring); orders the data cannot
    support are left out.

    Raises
    ------
    FRFError
        When the data support not even the lowest order (too few frequencies and outputs).
    """
    f = np.asarray(freq_hz, float)
    sel = (f >= band[0]) & (f <= band[1])
    orders = sorted(set(int(n) for n in orders))
    if not orders or orders[0] < 1:
        raise ValueError("orders must be positive")
    p = H.shape[0]
    q = q or default_block_rows(orders[-1], p)
    Hb = H[:, :, sel]
    s_k = 2j * np.pi * f[sel]
    basis = subspace_basis(f[sel], Hb, q)
    if orders[0] > basis.max_order():
        raise FRFError(f"band {band[0]:g}-{band[1]:g} Hz: {int(sel.sum())} frequencies and "
                       f"{p} output(s) allow models up to order {basis.max_order()}; the "
                       f"stabilisation diagram needs order {orders[0]}: expected more "
                       "frequencies (or outputs) in the band")  # fmt: skip
    orders = [n for n in orders if n <= basis.max_order()]
    result: list[OrderPoles] = []
    prev = None
    for n in orders:
        A, C = model_of_order(basis, n, stable=stable_system)
        lam, shapes = physical_poles(A, C, band, zeta_max)
        fr, z = poles_to_modal(lam)
        stable = np.zeros(len(lam), bool)
        if prev is not None and len(prev.poles) and len(lam):
            df = np.abs(fr[:, None] / prev.frequency_hz[None, :] - 1.0)
            dz = np.abs(z[:, None] / prev.damping_ratio[None, :] - 1.0)
            mm = mac(shapes, prev.shapes)
            stable = ((df < tol_frequency) & (dz < tol_damping) & (mm > tol_mac)).any(axis=1)
        prev = OrderPoles(n, lam, fr, z, shapes, stable, _misfit(A, s_k, Hb))
        result.append(prev)
    modes = _mode_groups(result, tol_frequency, min_share)
    auto = _auto_order(result, modes, tol_frequency)
    return Stabilization(band, result, modes, auto, basis.singular_values)


def _misfit(A: np.ndarray, s: np.ndarray, H: np.ndarray) -> float:
    """Relative misfit of the least-squares residues of A's complex poles (with D); infinite
    when the fit cannot be made (a pole on a data frequency makes its regressor infinite: an
    order with such a pole is never the automatic one)."""
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    if len(lam) == 0:
        return 1.0
    with np.errstate(all="ignore"):
        g = 1.0 / (s[None, :] - lam[:, None])
        g2 = 1.0 / (s[None, :] - np.conj(lam)[:, None])
        if not (np.isfinite(g).all() and np.isfinite(g2).all()):
            return np.inf
        try:
            residues, D = lsfd(s, H, lam)
        except np.linalg.LinAlgError:
            return np.inf
        Hf = np.einsum("jpm,jk->pmk", residues, g) + np.einsum("jpm,jk->pmk", residues.conj(), g2)
        misfit = float(np.linalg.norm(Hf + D[:, :, None] - H) / np.linalg.norm(H))
    return misfit if np.isfinite(misfit) else np.inf


def _mode_groups(result: list[OrderPoles], tol: float, min_share: float) -> np.ndarray:
    """Frequencies of the groups of stable poles seen in at least min_share of the orders
    from their first appearance on."""
    pts = [(fr, k) for k, op in enumerate(result) for fr in op.frequency_hz[op.stable]]
    if not pts:
        return np.zeros(0)
    pts.sort()
    groups: list[list[tuple[float, int]]] = [[pts[0]]]
    for fr, k in pts[1:]:
        centre = np.mean([g[0] for g in groups[-1]])
        if abs(fr / centre - 1.0) < tol:
            groups[-1].append((fr, k))
        else:
            groups.append([(fr, k)])
    modes = []
    for g in groups:
        seen = {k for _, k in g}
        span = len(result) - min(seen)
        if len(seen) >= max(3, min_share * span):
            modes.append(float(np.mean([fr for fr, _ in g])))
    return np.array(modes)


def _auto_order(result: list[OrderPoles], modes: np.ndarray, tol: float) -> int:
    """The order: from the lowest order with a stable pole at every physical mode (within
    tol), the lowest whose misfit is within 10 % of the best misfit from there on (more
    states keep improving a fit only while they model something: out-of-band modes, for
    one); the highest order if no order has all the modes."""
    first = None
    for k, op in enumerate(result):
        fr = op.frequency_hz[op.stable]
        if len(fr) and all((np.abs(fr / fm - 1.0) < tol).any() for fm in modes):
            first = k
            break
    if first is None:
        return result[-1].order
    rest = result[first:]
    best = min(op.fit_error for op in rest)
    for op in rest:
        has_all = all((np.abs(op.frequency_hz / fm - 1.0) < tol).any() for fm in modes)
        if op.fit_error <= 1.1 * best and has_all:
            return op.order
    return rest[0].order


def poles_at_modes(op: OrderPoles, modes: np.ndarray, tol: float = 0.01) -> np.ndarray:
    """Indices into ``op``'s poles of the pole nearest each mode group (within tol), one per
    group, ascending; groups without such a pole are skipped."""
    out = []
    for fm in modes:
        if len(op.frequency_hz) == 0:
            break
        rel = np.abs(op.frequency_hz / fm - 1.0)
        j = int(np.argmin(rel))
        if rel[j] < tol and j not in out:
            out.append(j)
    return np.array(sorted(out), int)
