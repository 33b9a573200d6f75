"""Channel screening before identification: how well each output channel is predicted by
the others.

FRFs of a structure over a band are close to a matrix of low rank: output o's FRFs are
``sum_r phi_or L_ir q_r(f)``, so the rows of X (outputs x (inputs, frequencies)) lie near a
space spanned by a few mode contributions. A sensor that is dead, wired to another channel,
from another measurement or with a wrong sign over part of the band is not in the space
the other sensors span. The *consistency error* of channel o is the part of its (RMS
normalised) row that the leading singular directions of the other rows leave unexplained:
about the noise level for a good channel, near 1 for a broken one.
"""

from __future__ import annotations

import numpy as np


def consistency_error(H: np.ndarray, *, relative_cutoff: float = 0.01) -> np.ndarray:
    """Leave-one-out consistency error (p,) of every output channel.

    Parameters
    ----------
    H : (p, m, K) FRFs over the band of interest.
    relative_cutoff : singular directions of the other rows kept when their singular value
        is at least this fraction of the largest (at most half the channels).

    Returns
    -------
    (p,) ``||x_o - P x_o|| / ||x_o||`` with P the projection on the kept directions of
    the other rows; 0 for an all-zero channel is not possible: such a channel gives 1.
    """
    p = H.shape[0]
    X = H.reshape(p, -1)
    norms = np.linalg.norm(X, axis=1)
    X = X / np.where(norms > 0, norms, 1.0)[:, None]
    G = X @ X.conj().T  # (p, p) Gram matrix of the normalised rows
    out = np.ones(p)
    for o in range(p):
        if norms[o] == 0:
            continue
        keep = np.arange(p) != o
        w, U = np.linalg.eigh(G[np.ix_(keep, keep)])
        w, U = w[::-1], U[:, ::-1]
        s = np.sqrt(np.maximum(w, 0.0))
        if len(s) == 0 or s[0] == 0:
            continue
        r = min(int((s >= relative_cutoff * s[0]).sum()), max(1, p // 2))
        c = (G[o, keep] @ U[:, :r]) / s[:r]  # coordinates of x_o on the right vectors
        out[o] = np.sqrt(max(1.0 - float(np.sum(np.abs(c) ** 2)), 0.0))
    return out


def outliers(errors: np.ndarray, factor: float, floor: float) -> np.ndarray:
    """(p,) True where an error exceeds both ``factor`` times the median and ``floor``."""
    return (errors > factor * np.median(errors)) & (errors > floor)
