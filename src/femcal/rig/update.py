"""The system FRF updated from the iteration's own drives and responses, as RPC Pro updates
its system model: a model FRF far from the plant (a resonance put elsewhere, a stiffer
frame) still converges.

At each line the step from one played drive to the next, ``dD`` (n_drives,), and the
change of the measured response it made, ``dR`` (n_control,), say how the plant answers in
the direction ``dD``. Broyden's update (Broyden, Math. Comp. 19, 1965; the "good" update:
Dennis and Schnabel, Numerical Methods for Unconstrained Optimization and Nonlinear
Equations, SIAM 1996, sec. 8.1) puts that answer into the FRF and changes nothing in the
directions orthogonal to it::

    H <- H + (dR - H dD) dD^H / (dD^H dD).

The first drive's pair is taken against the rig at rest (``dD = D_0``, ``dR = R_0``). A
line is updated only where the step's predicted response stands well clear of the noise
(``sum_c W_c |H dD|_c^2 > 10 n_control``, with ``W`` the inverse's weights, the inverse
noise per line): there a measured response says something about the plant; elsewhere the
update would fit noise.
"""

from __future__ import annotations

import numpy as np

#: How far (in noise power per channel) a step's response must stand above the noise.
MIN_SNR = 10.0


def broyden_update(Hf: np.ndarray, dD: np.ndarray, dR: np.ndarray,
                   weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The updated FRF (n_lines, n_control, n_drives) from ``Hf`` and one step: drive change
    ``dD`` (n_drives, n_lines), response change ``dR`` (n_control, n_lines), weights
    ``weight`` (n_control,) (inverse noise per line); and the mask (n_lines,) of the lines
    updated."""
    predicted = np.einsum("foi,if->of", Hf, dD)
    size = np.sum(np.abs(dD) ** 2, axis=0)
    snr = weight @ np.abs(predicted) ** 2
    ok = (size > 0) & (snr > MIN_SNR * len(weight))
    step = np.zeros_like(Hf)
    step[ok] = np.einsum("of,if->foi", (dR - predicted)[:, ok], dD[:, ok].conj()) / size[ok, None,
                                                                                       None]
    return Hf + step, ok
