"""Mode indicator functions, the peaks an engineer sees in them, and the band's partition.

- **CMIF** (complex mode indicator function, Shih, Tsuei, Allemang and Brown, MSSP 2 (1988)):
  the singular values of the FRF matrix (outputs x references) at each frequency. Each mode
  peaks in one of them; close modes in different ones when there are several references.
  With one reference it is the root sum of squares of the FRFs.
- **MIF** (the multivariate mode indicator function, Williams, Crowley and Vold, IMAC 3
  (1985)): the eigenvalues ``v`` of ``Re(H)^T Re(H) x = v (Re(H)^T Re(H) + Im(H)^T Im(H)) x``
  at each frequency, with H turned into a receptance (divided by ``i w`` for mobility, by
  ``-w^2`` for accelerance). At an undamped normal mode the response is in quadrature with
  the force, so the smallest value dips towards 0: one dip per mode, a second dip in the
  next value for a repeated root. 1 where the response is in phase with the force.

**Peaks.** The peaks of the first CMIF curve whose prominence, in decades, stands out from
the curve's own scatter: a peak must rise ``min_prominence`` decades above its surroundings
and ``scatter_factor`` times the local scatter (a robust spread of the log curve about its
running median, taken over five windows around the peak so that its own flanks do not
count), so that the noise of a noise floor does not count; not within half a window of the
band's ends, where the curve is cut rather than peaked. A resonance one line
wide counts as well as a broad one. The lower curves are drawn, not searched: where two
modes cross over, a lower curve peaks between them although no mode is there, and a close
mode's peak in a lower curve lies on the first curve's.

**Partition.** A band with more peaks than a part should hold is split at the CMIF's lowest
point between the two peaks nearest the middle of its peaks, recursively, so that each part
holds at most ``part_modes`` peaks and its splits lie as far from modes as the data allow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter, median_filter
from scipy.signal import find_peaks

#: FRF quantity -> the power of i w that turns it into a receptance.
_TO_RECEPTANCE = {"receptance": 0, "mobility": 1, "accelerance": 2}


def cmif(H: np.ndarray) -> np.ndarray:
    """(r, K) singular values of H[:, :, k] (p, m, K), descending, r = min(p, m)."""
    p, m, _ = H.shape
    if m == 1 or p == 1:
        return np.sqrt(np.sum(np.abs(H) ** 2, axis=(0, 1)))[None, :]
    return np.linalg.svd(np.moveaxis(H, 2, 0), compute_uv=False).T


def mif(freq_hz: np.ndarray, H: np.ndarray, quantity: str) -> np.ndarray:
    """(m, K) multivariate mode indicator values, ascending, of H (p, m, K), p >= m."""
    w = 2 * np.pi * np.asarray(freq_hz, float)
    power = _TO_RECEPTANCE.get(quantity, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        X = H / ((1j * w) ** power)[None, None, :]
    X = np.where(np.isfinite(X), X, 0.0)
    Xk = np.moveaxis(X, 2, 0)  # (K, p, m)
    re = np.einsum("kpi,kpj->kij", Xk.real, Xk.real)
    total = re + np.einsum("kpi,kpj->kij", Xk.imag, Xk.imag)
    m = H.shape[1]
    out = np.ones((m, len(w)))
    if m == 1:
        t = total[:, 0, 0]
        ok = t > 0
        out[0, ok] = re[ok, 0, 0] / t[ok]
        return out
    scale = np.trace(total, axis1=1, axis2=2) / m
    ok = scale > 0
    reg = total[ok] + 1e-12 * scale[ok, None, None] * np.eye(m)
    L = np.linalg.cholesky(reg)
    Li = np.linalg.inv(L)
    out[:, ok] = np.clip(np.linalg.eigvalsh(Li @ re[ok] @ np.swapaxes(Li, 1, 2)), 0, 1).T
    return out


@dataclass(frozen=True)
class Peaks:
    """Peaks of the CMIF in a band.

    frequency_hz : (k,) ascending. index : (k,) into the frequencies the CMIF was given at.
    prominence : (k,) decades.
    """

    frequency_hz: np.ndarray
    index: np.ndarray
    prominence: np.ndarray


def scatter(curve: np.ndarray, window: int) -> np.ndarray:
    """The local scatter (K,) of log10 of a positive curve (K,), in decades: the running
    median, over ``window`` lines, of the absolute difference between the log curve and its
    running median. About 0 where the curve is smooth (a resonance is a few lines out of a
    window, so it does not count); the noise's spread on a noise floor."""
    L = np.log10(np.maximum(curve, np.finfo(float).tiny))
    size = max(3, window | 1)
    trend = median_filter(L, size=size, mode="nearest")
    return 1.4826 * median_filter(np.abs(L - trend), size=size, mode="nearest")


def find_cmif_peaks(freq_hz: np.ndarray, S: np.ndarray, *, min_prominence: float = 0.05,
                    scatter_factor: float = 15.0) -> Peaks:  # fmt: skip
    """The peaks of the first CMIF curve S[0] (S: (r, K) at freq_hz (K,)) as the module
    docstring says."""
    f = np.asarray(freq_hz, float)
    window = max(31, len(f) // 100)
    L = np.log10(np.maximum(S[0], np.finfo(float).tiny))
    # the noise's scatter about a peak: over five windows, so that the peak's own flanks
    # (which lift the scatter of the window they fill) do not raise the bar it must pass
    # (and the largest of that within a window each side, so that where a noise floor
    # begins its first spikes meet the floor's bar, not the quiet side's)
    noise = maximum_filter(median_filter(scatter(S[0], window), size=5 * window | 1,
                                         mode="nearest"), size=2 * window + 1, mode="nearest")
    need = np.maximum(min_prominence, scatter_factor * noise)
    idx, props = find_peaks(L, prominence=(None, None))
    # within half a window of the band's ends the curve is cut, not peaked, and its scatter
    # is measured on one side only
    inner = (idx >= window // 2) & (idx < len(f) - window // 2)
    keep = (props["prominences"] >= need[idx]) & inner
    k = idx[keep].astype(int)
    return Peaks(f[k], k, props["prominences"][keep].astype(float))


def line_noise(curve: np.ndarray, window: int) -> np.ndarray:
    """The running estimate (K,) of a positive curve's line-to-line noise, in decades: the
    median absolute third difference of its log over ``window`` lines, scaled to a standard
    deviation for white noise (a third difference of white noise has 20 times its
    variance). A smooth curve's third differences are small, also across resonances a few
    lines wide, and a peak one line wide moves the median of a window little."""
    L = np.log10(np.maximum(curve, np.finfo(float).tiny))
    d3 = np.zeros_like(L)
    if len(L) >= 4:
        d3[2:-1] = np.abs(np.diff(L, 3))
        d3[:2], d3[-1] = d3[2], d3[-2]
    return median_filter(d3, size=max(3, window | 1), mode="nearest") / (0.6745 * np.sqrt(20))


def noisy_regions(freq_hz: np.ndarray, S: np.ndarray, *, level: float = 0.02,
                  min_share: float = 0.02) -> list[tuple[float, float]]:  # fmt: skip
    """The stretches (Hz) where the first CMIF curve is noise-like: its line-to-line noise
    (:func:`line_noise`) above ``level`` decades (about 5 %), over at least ``min_share``
    of the lines and a window; a measurement's noise floor."""
    f = np.asarray(freq_hz, float)
    window = max(31, len(f) // 100)
    noisy = line_noise(S[0], window) > level
    quiet = np.flatnonzero(np.diff(np.concatenate([[1], noisy.astype(int), [1]])))
    for a, b in zip(quiet[::2], quiet[1::2], strict=True):  # short gaps joined
        if b - a < window and a > 0 and b < len(f):
            noisy[a:b] = True
    edges = np.flatnonzero(np.diff(np.concatenate([[0], noisy.astype(int), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if b - a >= max(window, min_share * len(f)):
            out.append((float(f[a]), float(f[b - 1])))
    return out


def partition(freq_hz: np.ndarray, s1: np.ndarray, peaks_hz: np.ndarray,
              band: tuple[float, float], part_modes: int, min_lines: int = 16
              ) -> list[float]:  # fmt: skip
    """Split frequencies inside ``band`` so that each part holds at most ``part_modes`` of
    ``peaks_hz``, each split at the lowest point of the first CMIF curve ``s1`` (K,) between
    the two peaks nearest the middle of a part's peaks; parts keep ``min_lines`` lines at
    least (a split that would leave fewer is not made)."""
    f = np.asarray(freq_hz, float)
    lo, hi = band
    inside = np.sort(peaks_hz[(peaks_hz > lo) & (peaks_hz < hi)])
    if len(inside) <= part_modes:
        return []
    mid = len(inside) // 2
    a, b = inside[mid - 1], inside[mid]
    gap = np.flatnonzero((f > a) & (f < b))
    if len(gap) == 0:
        return []
    split = float(f[gap[np.argmin(s1[gap])]])
    if (np.sum((f >= lo) & (f <= split)) < min_lines
            or np.sum((f >= split) & (f <= hi)) < min_lines):  # fmt: skip
        return []
    return [*partition(f, s1, inside[:mid], (lo, split), part_modes, min_lines), split,
            *partition(f, s1, inside[mid:], (split, hi), part_modes, min_lines)]
