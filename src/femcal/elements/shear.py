"""CSHEAR shear panels: four-node panels that carry in-plane shear only.

The panel's shear strain is the bilinear field's engineering shear strain, in axes along side
G1-G2 and normal to it in the panel's plane, at the centroid
(one mode of deformation: a constant shear flow), so K = G t A b b^T with b mapping the
nodes' in-plane displacements to that strain; rigid motions give no strain. Mass: lumped,
(rho t + nsm) A / 4 on each node's translations. Extensional edge effectiveness (PSHEAR F1,
F2 above zero) is not modelled; callers refuse it.
"""

from __future__ import annotations

import numpy as np


def shear_panel_matrices(
    xyz: np.ndarray, G: np.ndarray, t: np.ndarray, mass_area: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of shear panels.

    Parameters
    ----------
    xyz : (n, 4, 3) corner grids in basic, NASTRAN order.
    G, t : (n,) shear modulus and thickness.
    mass_area : (n,) rho t + nsm, mass per area.

    Returns
    -------
    K, M : (n, 24, 24) in basic, DOF [T1 T2 T3 R1 R2 R3] per node.
    """
    n = len(xyz)
    d1 = xyz[:, 2] - xyz[:, 0]
    d2 = xyz[:, 3] - xyz[:, 1]
    normal = np.cross(d1, d2)
    two_area = np.linalg.norm(normal, axis=1)
    bad = np.flatnonzero(two_area <= 0.0)
    if len(bad):
        raise ValueError(f"shear panels with no area at positions {bad[:20].tolist()}")
    z = normal / two_area[:, None]
    e12 = xyz[:, 1] - xyz[:, 0]  # the panel's x axis: along side G1-G2, as NASTRAN's CSHEAR
    x = e12 / np.linalg.norm(e12, axis=1)[:, None]
    x = x - np.einsum("ni,ni->n", x, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1)[:, None]
    y = np.cross(z, x)
    R = np.stack([x, y, z], axis=1)  # rows: element axes in basic
    centre = xyz.mean(axis=1)
    local = np.einsum("nij,naj->nai", R, xyz - centre[:, None])[..., :2]  # (n, 4, 2)
    # bilinear shape derivatives at the centroid (xi = eta = 0)
    dxi = np.array([-1.0, 1.0, 1.0, -1.0]) / 4.0
    deta = np.array([-1.0, -1.0, 1.0, 1.0]) / 4.0
    J = np.stack([dxi @ local, deta @ local], axis=1)  # (n, 2, 2): rows d/dxi, d/deta
    detJ = np.linalg.det(J)
    Jinv = np.linalg.inv(J)
    dN = np.einsum("nij,ja->nia", Jinv, np.stack([dxi, deta]))  # (n, 2, 4): d/dx, d/dy
    b_local = np.zeros((n, 4, 2))  # gamma_xy = du/dy + dv/dx over (u_a, v_a)
    b_local[:, :, 0] = dN[:, 1]
    b_local[:, :, 1] = dN[:, 0]
    # to basic translations: u_local = R[:2] @ u_basic
    b = np.einsum("nak,nkj->naj", b_local, R[:, :2, :]).reshape(n, 12)
    area = 4.0 * detJ
    k12 = (G * t * area)[:, None, None] * np.einsum("ni,nj->nij", b, b)
    K = np.zeros((n, 24, 24))
    tr = (np.arange(4)[:, None] * 6 + np.arange(3)).ravel()
    K[:, tr[:, None], tr[None, :]] = k12
    M = np.zeros((n, 24, 24))
    M[:, tr, tr] = np.repeat(mass_area * area / 4.0, 12).reshape(n, 12)
    return K, M
