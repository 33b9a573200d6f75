"""Material and section stiffness for shells and solids: MAT1, MAT2, MAT8, MAT9; PSHELL and
PCOMP/PCOMPG resultants (A, B, D, transverse shear S) in an element's frame.

Conventions: in-plane Voigt order xx, yy, xy (engineering shear), transverse shear xz, yz;
solids xx, yy, zz, xy, yz, zx. Angles in degrees, measured from the element x axis towards y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..model.ids import IdIndex


def mat1_moduli(
    E: np.ndarray, G: np.ndarray, nu: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MAT1's completion rules (QRG MAT1 remarks): two given -> the third from E = 2(1+NU)G;
    only E -> G = NU = 0; only G -> E = NU = 0. NaN marks a blank field."""
    e_, g_, n_ = ~np.isnan(E), ~np.isnan(G), ~np.isnan(nu)
    E2 = np.where(e_, E, np.where(g_ & n_, 2.0 * (1.0 + nu) * G, 0.0))
    G2 = np.where(g_, G, np.where(e_ & n_, E / (2.0 * (1.0 + nu)), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        nu2 = np.where(n_, nu, np.where(e_ & g_, E / (2.0 * G) - 1.0, 0.0))
    return E2, G2, nu2


@dataclass(frozen=True)
class IsotropicMaterial:
    """Isotropic materials (MAT1) of n elements: E, G, NU and RHO, each (n,)."""

    E: np.ndarray
    G: np.ndarray
    nu: np.ndarray
    rho: np.ndarray


@dataclass(frozen=True)
class PlaneMaterial:
    """Plane-stress stiffness of materials, looked up by id.

    Attributes
    ----------
    Q : (n, 3, 3) in-plane stiffness (material axes).
    Gt : (n, 2, 2) transverse shear moduli (xz, yz), zero where the card gives none.
    rho : (n,) density.
    isotropic : (n,) True for MAT1 (frame-independent).
    """

    Q: np.ndarray
    Gt: np.ndarray
    rho: np.ndarray
    isotropic: np.ndarray


class MaterialTables:
    """Lookup of MAT1 / MAT2 / MAT8 / MAT9 tables from ``Model.materials``."""

    #: Material cards in the order a material id is looked up.
    CARDS = ("MAT1", "MAT2", "MAT8", "MAT9")

    def __init__(self, materials: dict[str, dict[str, np.ndarray]]):
        self.tables = materials
        self._index = {card: IdIndex(materials[card]["mid"]) for card in self.CARDS
                       if card in materials}  # fmt: skip

    def where(self, mid: int) -> tuple[str, int]:
        """(card, row) of material ``mid``; ("", 0) if no card defines it."""
        for card, index in self._index.items():
            row = int(index.rows(mid)[0])
            if row >= 0:
                return card, row
        return "", 0

    def mat1(self, mids: np.ndarray, who: str, eids: np.ndarray) -> IsotropicMaterial:
        """Moduli and density of MAT1 materials ``mids`` (n,), with NASTRAN's rules for a
        blank E, G or NU; ``who`` and ``eids`` name the elements in errors.

        Raises
        ------
        ModelError
            If a material is not a MAT1 (or the model has none).
        """
        table = self.tables.get("MAT1")
        if table is None:
            raise ModelError(f"{who} elements need MAT1 materials; the deck has none", eids[:20])
        rows = self._index["MAT1"].rows(mids)
        if (rows < 0).any():
            bad = np.flatnonzero(rows < 0)
            raise ModelError(
                f"{who} elements {eids[bad][:20].tolist()} refer to materials "
                f"{np.unique(mids[bad])[:20].tolist()} that are not MAT1",
                eids[bad][:20],
            )
        E, G, nu = mat1_moduli(table["e"][rows], table["g"][rows], table["nu"][rows])
        return IsotropicMaterial(E, G, nu, table["rho"][rows])

    def plane(self, mids: np.ndarray, who: str) -> PlaneMaterial:
        """Plane-stress data of materials ``mids`` (n,), for shells."""
        uniq, inv = np.unique(np.asarray(mids), return_inverse=True)
        u = self._plane_unique(uniq, who)
        return PlaneMaterial(u.Q[inv], u.Gt[inv], u.rho[inv], u.isotropic[inv])

    def _plane_unique(self, mids: np.ndarray, who: str) -> PlaneMaterial:
        n = len(mids)
        Q = np.zeros((n, 3, 3))
        Gt = np.zeros((n, 2, 2))
        rho = np.zeros(n)
        iso = np.zeros(n, bool)
        for i, mid in enumerate(np.asarray(mids).tolist()):
            card, row = self.where(mid)
            t = self.tables.get(card)
            if card == "MAT1":
                E, G, nu = _mat1_row(t, row)
                c = E / (1.0 - nu * nu)
                Q[i] = [[c, nu * c, 0.0], [nu * c, c, 0.0], [0.0, 0.0, G]]
                Gt[i] = G * np.eye(2)
                iso[i] = True
            elif card == "MAT2":
                g = {k: float(t[k][row]) for k in ("g11", "g12", "g13", "g22", "g23", "g33")}
                Q[i] = [[g["g11"], g["g12"], g["g13"]], [g["g12"], g["g22"], g["g23"]],
                        [g["g13"], g["g23"], g["g33"]]]  # fmt: skip
                # as MID3, MAT2's G11, G12, G22 are the transverse shear moduli (QRG PSHELL)
                Gt[i] = [[g["g11"], g["g12"]], [g["g12"], g["g22"]]]
            elif card == "MAT8":
                e1, e2, nu12, g12 = (float(t[k][row]) for k in ("e1", "e2", "nu12", "g12"))
                nu21 = nu12 * e2 / e1
                d = 1.0 - nu12 * nu21
                Q[i] = [[e1 / d, nu12 * e2 / d, 0.0], [nu12 * e2 / d, e2 / d, 0.0], [0, 0, g12]]
                g1z, g2z = float(t["g1z"][row]), float(t["g2z"][row])
                Gt[i] = np.diag([0.0 if np.isnan(g1z) else g1z, 0.0 if np.isnan(g2z) else g2z])
            else:
                raise ModelError(
                    f"{who}: material {mid} is {card or 'not defined'}; shells take MAT1, MAT2 "
                    "or MAT8",
                    [mid],
                )
            rho[i] = float(t["rho"][row])
        return PlaneMaterial(Q, Gt, rho, iso)

    def solid(self, mids: np.ndarray, who: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C (n, 6, 6), rho (n,), isotropic (n,)) of solid materials (MAT1 or MAT9)."""
        uniq, inv = np.unique(np.asarray(mids), return_inverse=True)
        C, rho, iso = self._solid_unique(uniq, who)
        return C[inv], rho[inv], iso[inv]

    def _solid_unique(
        self, mids: np.ndarray, who: str
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = len(mids)
        C = np.zeros((n, 6, 6))
        rho = np.zeros(n)
        iso = np.zeros(n, bool)
        for i, mid in enumerate(np.asarray(mids).tolist()):
            card, row = self.where(mid)
            t = self.tables.get(card)
            if card == "MAT1":
                E, G, nu = _mat1_row(t, row)
                if nu == 0.5:  # the Guide allows it; the Lame constant below is infinite
                    raise ModelError(f"{who}: MAT1 {mid} has NU = 0.5 (incompressible); "
                                     "femcal's solid elements need NU below 0.5", [mid])
                C[i] = isotropic_3d(E, nu, G)
                iso[i] = True
            elif card == "MAT9":
                names = ["g11", "g12", "g13", "g14", "g15", "g16", "g22", "g23", "g24", "g25",
                         "g26", "g33", "g34", "g35", "g36", "g44", "g45", "g46", "g55", "g56",
                         "g66"]  # fmt: skip
                k = 0
                for a in range(6):
                    for b in range(a, 6):
                        C[i, a, b] = C[i, b, a] = float(t[names[k]][row])
                        k += 1
            else:
                raise ModelError(
                    f"{who}: material {mid} is {card or 'not defined'}; solids take MAT1 or MAT9",
                    [mid],
                )
            rho[i] = float(t["rho"][row])
        return C, rho, iso


def _mat1_row(t: dict[str, np.ndarray], row: int) -> tuple[float, float, float]:
    """E, G, NU of one MAT1 row after the completion rules."""
    E, G, nu = mat1_moduli(t["e"][row : row + 1], t["g"][row : row + 1], t["nu"][row : row + 1])
    return float(E[0]), float(G[0]), float(nu[0])


def isotropic_3d(E: float, nu: float, G: float) -> np.ndarray:
    """6 x 6 isotropic stiffness (xx, yy, zz, xy, yz, zx) with the shear modulus given."""
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[[0, 1, 2], [0, 1, 2]] = lam + 2.0 * E / (2.0 * (1.0 + nu))
    C[[3, 4, 5], [3, 4, 5]] = G
    return C


def rotate_plane(Q: np.ndarray, theta_deg: np.ndarray) -> np.ndarray:
    """In-plane stiffness (n, 3, 3) of material axes at angle theta from the element x axis,
    expressed in the element axes: Q_elem = T^T Q T with T the engineering-strain rotation."""
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    T = np.zeros((len(t), 3, 3))
    T[:, 0] = np.stack([c * c, s * s, c * s], axis=1)
    T[:, 1] = np.stack([s * s, c * c, -c * s], axis=1)
    T[:, 2] = np.stack([-2 * c * s, 2 * c * s, c * c - s * s], axis=1)
    return np.swapaxes(T, 1, 2) @ Q @ T


def rotate_shear(G: np.ndarray, theta_deg: np.ndarray) -> np.ndarray:
    """Transverse shear stiffness (n, 2, 2) of material axes at theta, in element axes."""
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    R = np.stack([np.stack([c, s], axis=1), np.stack([-s, c], axis=1)], axis=1)
    return np.swapaxes(R, 1, 2) @ G @ R
