"""The rig's redundant actuators: drive combinations that move the frame as no rigid body
does.

An actuator along unit direction ``e_j`` at the frame point ``p_j`` moves by ``e_j . (u +
theta x p_j)`` when the frame moves rigidly by the translation ``u`` and small rotation
``theta``: the drives of the rigid-body motions are the columns of ``J`` (n_drives, 6),
row ``j`` being ``[e_j, p_j x e_j]``. Drives outside the range of ``J`` must deform the
frame: the left null space of ``J``, ``n_drives - rank J`` directions. A 7-post rig (four
vertical, two lateral and one longitudinal actuator on six rigid-body motions) has one, the
warp: the four vertical posts pushing diagonally opposite corners up and the others down
(the lateral ones joining in as the frame's geometry asks). At low frequency an
accelerometer barely sees it, so a drive iteration either holds it at its least (the
minimal-warp drive) or sees it through displacement or force channels (LVDTs, load cells).
"""

from __future__ import annotations

import numpy as np

from .plant import RigPlant


def rigid_body_drives(plant: RigPlant) -> np.ndarray:
    """``J`` (n_drives, 6): each actuator's stroke per unit rigid translation (X, Y, Z) and
    rotation (about X, Y, Z through the actuators' centroid) of the frame."""
    if not plant.actuators:
        raise ValueError("the rig's actuators are not known (a plant built without them)")
    p = np.array([a.position for a in plant.actuators])
    e = np.array([a.direction for a in plant.actuators])
    p = p - p.mean(axis=0)
    return np.hstack([e, np.cross(p, e)])


def redundant_drives(plant: RigPlant) -> np.ndarray:
    """(n_drives, k) orthonormal drive combinations that move no rigid body (the left null
    space of :func:`rigid_body_drives`; k = 0 for a statically determinate rig), each with
    its largest entry positive."""
    J = rigid_body_drives(plant)
    U, s, _ = np.linalg.svd(J, full_matrices=True)
    rank = int((s > 1e-9 * max(s.max(), 1.0)).sum()) if s.size else 0
    W = U[:, rank:]
    for k in range(W.shape[1]):
        j = int(np.argmax(np.abs(W[:, k])))
        if W[j, k] < 0:
            W[:, k] = -W[:, k]
    return W
