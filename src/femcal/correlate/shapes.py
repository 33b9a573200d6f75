"""Correlation of test and FE modes: MAC, mode pairing, frequency differences,
pseudo-orthogonality with the mass reduced to the sensors.

Shapes are columns of (n_sensors, k) arrays at the same sensor channels (the FE shapes taken
to the sensor directions with :func:`femcal.response.frf.channel_matrix`); test shapes may be
complex.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Modal assurance criterion between the columns of a (p, ka) and b (p, kb):
    ``|a^H b|^2 / ((a^H a)(b^H b))`` as (ka, kb)."""
    a = np.asarray(a)
    b = np.asarray(b)
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.einsum("pk,pk->k", a.conj(), a).real, np.einsum("pk,pk->k", b.conj(), b).real)
    return num / np.where(den > 0, den, 1.0)


def comac(test_shapes: np.ndarray, fe_shapes: np.ndarray) -> np.ndarray:
    """Coordinate modal assurance criterion of each channel over paired modes: the columns of
    test (p, k) and FE (p, k) shapes are pairs, each made unit length; channel i's CoMAC is
    ``(sum_j |t_ij a_ij|)^2 / (sum_j |t_ij|^2 sum_j |a_ij|^2)`` (Lieven and Ewins, 1988),
    (p,) in [0, 1]: near 1 where the channel moves alike in test and FE over the pairs, low
    where it does not (a wrong sensor, or a local feature the model lacks). A channel that
    moves in no mode gets 0."""
    t = np.asarray(test_shapes)
    a = np.asarray(fe_shapes)
    t = t / np.where((n := np.linalg.norm(t, axis=0)) > 0, n, 1.0)
    a = a / np.where((n := np.linalg.norm(a, axis=0)) > 0, n, 1.0)
    num = np.sum(np.abs(t * a.conj()), axis=1) ** 2
    den = np.sum(np.abs(t) ** 2, axis=1) * np.sum(np.abs(a) ** 2, axis=1)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def sign_agreement(test_shapes: np.ndarray, fe_shapes: np.ndarray) -> np.ndarray:
    """(p,) in [-1, 1] per channel: ``sum_j t_ij a_ij / sum_j |t_ij a_ij|`` over paired real
    shapes, the test's in the FE shape's scale (:func:`in_scale_of`): 1 where the channel
    moves with the FE model in every pair, -1 where it moves against it in every pair (a
    sensor mounted reversed, which CoMAC cannot see), 0 for a channel that never moves."""
    t, a = np.real(test_shapes), np.real(fe_shapes)
    den = np.sum(np.abs(t * a), axis=1)
    return np.where(den > 0, np.sum(t * a, axis=1) / np.where(den > 0, den, 1.0), 0.0)


def frequency_difference(f_test: np.ndarray, f_fe: np.ndarray) -> np.ndarray:
    """(f_test - f_FE) / f_FE x 100 %."""
    f_test, f_fe = np.asarray(f_test, float), np.asarray(f_fe, float)
    return (f_test - f_fe) / f_fe * 100.0


@dataclass(frozen=True)
class Pair:
    """A test mode paired with an FE mode (0-based indices), their MAC and the frequency
    difference (test - FE) / FE in %."""

    test: int
    fe: int
    mac: float
    frequency_difference: float


def pair_modes(test_shapes: np.ndarray, test_hz: np.ndarray, fe_shapes: np.ndarray,
               fe_hz: np.ndarray, *, min_mac: float = 0.4, max_frequency_ratio: float = 1.5
               ) -> list[Pair]:  # fmt: skip
    """Pair test modes with FE modes by MAC, each FE mode at most once.

    Candidates are pairs with MAC at least ``min_mac`` and frequencies within a factor
    ``max_frequency_ratio``; they are taken in order of falling MAC, ties (MAC within 0.02)
    broken by the smaller frequency difference. Test modes without a candidate stay
    unpaired. Returns the pairs in test-mode order.
    """
    M = mac(test_shapes, fe_shapes)
    ft, ff = np.asarray(test_hz, float), np.asarray(fe_hz, float)
    ratio = np.maximum(ft[:, None] / ff[None, :], ff[None, :] / ft[:, None])
    cand = [(M[i, j], -abs(np.log(ratio[i, j])), i, j)
            for i in range(M.shape[0]) for j in range(M.shape[1])
            if M[i, j] >= min_mac and ratio[i, j] <= max_frequency_ratio]  # fmt: skip
    cand.sort(key=lambda c: (round(c[0] / 0.02), c[1]), reverse=True)
    used_t: set[int] = set()
    used_f: set[int] = set()
    pairs = []
    for m, _, i, j in cand:
        if i in used_t or j in used_f:
            continue
        used_t.add(i)
        used_f.add(j)
        pairs.append(Pair(i, j, float(m), float(frequency_difference(ft[i], ff[j]))))
    return sorted(pairs, key=lambda p: p.test)


def real_shapes(shapes: np.ndarray) -> np.ndarray:
    """Complex shapes (p, k) rotated to their best real approximation: each column turned by
    the phase that maximises its real part's norm, then the real part."""
    Z = np.asarray(shapes)
    if not np.iscomplexobj(Z):
        return Z.astype(float)
    # the angle of the principal axis of the points in the complex plane
    theta = 0.5 * np.angle(np.sum(Z**2, axis=0))
    return (Z * np.exp(-1j * theta)[None, :]).real


def serep_mass(fe_sensor_shapes: np.ndarray) -> np.ndarray:
    """Mass matrix (p, p) reduced to the sensors by SEREP (O'Callahan 1989) from
    mass-normalised FE shapes at the sensors (p, r), r <= p: ``pinv(Phi_s)^T pinv(Phi_s)``."""
    P = np.linalg.pinv(np.asarray(fe_sensor_shapes, float))
    return P.T @ P


def pseudo_orthogonality(test_shapes: np.ndarray, fe_shapes: np.ndarray,
                         reduced_mass: np.ndarray) -> np.ndarray:  # fmt: skip
    """Pseudo-orthogonality ``Phi_T^T M_s Phi_FE`` (kt, kf) with test shapes made real and
    scaled to unit modal mass in the reduced mass M_s (p, p), FE shapes as given
    (mass-normalised); close to the identity, up to the sign of each test shape, for
    well-correlated modes."""
    T = real_shapes(test_shapes)
    mt = np.einsum("pk,pq,qk->k", T, reduced_mass, T)
    T = T / np.sqrt(np.where(mt > 0, mt, 1.0))[None, :]
    P = T.T @ reduced_mass @ np.asarray(fe_shapes, float)
    return P


def modal_scale_factor(test_shape: np.ndarray, fe_shape: np.ndarray) -> complex:
    """The factor s minimising ``|test - s fe|``: ``fe^H test / fe^H fe``."""
    a = np.asarray(fe_shape)
    return complex(np.vdot(a, test_shape) / np.vdot(a, a))


def in_scale_of(test_shape: np.ndarray, fe_shape: np.ndarray) -> np.ndarray:
    """The test shape (p,) real, in the FE shape's scale and phase: divided by the modal scale
    factor; a test shape with no part along the FE shape (factor 0) rotated to its best real
    approximation (:func:`real_shapes`) instead."""
    t = np.asarray(test_shape)
    s = modal_scale_factor(t, fe_shape)
    return (t / s).real if abs(s) > 0 else real_shapes(t[:, None])[:, 0]


#: A shape is a rigid-body motion when a rigid motion explains at least this share of it.
RIGID_SHARE = 0.95


def rigid_share(xyz: np.ndarray, translations: np.ndarray) -> np.ndarray:
    """The share of each shape's translations that a rigid-body motion explains, (k,) in
    [0, 1]: ``1 - |u - u_r|^2 / |u|^2`` with ``u_r = t + theta x (x - c)`` the least-squares
    rigid motion (translation ``t``, small rotation ``theta`` about the points' centre ``c``).

    ``xyz`` (P, 3) the points, ``translations`` (k, P, 3) each shape's translations there
    (any frame common to both, any scale). Near 1 for a free body's rigid modes and for a
    stiff body swinging on soft mounts (a frame on air springs); well below 1 for modes that
    deform it. A shape that does not move gets 1."""
    xyz = np.asarray(xyz, float)
    u = np.asarray(translations, float)
    k, p = u.shape[0], xyz.shape[0]
    r = xyz - xyz.mean(axis=0)
    a = np.zeros((p, 3, 6))
    a[:, [0, 1, 2], [0, 1, 2]] = 1.0
    # theta x r = -r x theta: the rows of -[r]x
    a[:, 0, 4], a[:, 0, 5] = r[:, 2], -r[:, 1]
    a[:, 1, 3], a[:, 1, 5] = -r[:, 2], r[:, 0]
    a[:, 2, 3], a[:, 2, 4] = r[:, 1], -r[:, 0]
    a = a.reshape(3 * p, 6)
    b = u.reshape(k, 3 * p).T
    fit = a @ np.linalg.lstsq(a, b, rcond=None)[0]
    total = np.einsum("ij,ij->j", b, b)
    left = np.einsum("ij,ij->j", b - fit, b - fit)
    return np.where(total > 0, 1.0 - left / np.where(total > 0, total, 1.0), 1.0)


def mac_text(value: float, digits: int = 3) -> str:
    """A MAC (or another 0-1 correlation) to ``digits`` decimals, rounded down so that
    0.9995 reads 0.999: "1.000" is kept for shapes that agree exactly."""
    scale = 10.0**digits
    return f"{np.floor(value * scale + 1e-9) / scale:.{digits}f}"
