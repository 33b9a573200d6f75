"""A :class:`~femcal.model.model.Model` built in code, without a deck.

The builder collects nodes, materials, sections, elements, constraints and the eigenvalue
request, checks the references, and makes the same model a deck with the equivalent cards
would give (``femcal.model.build``): a bar is a CBAR with a PBAR, a plate a CQUAD4 or CTRIA3
with a PSHELL, and so on, so everything downstream (assembly, normal modes, FRFs,
calibration parameters such as ``PSHELL T``) works on it unchanged. Units are the caller's;
every node is placed and displaced in the basic frame.

>>> b = ModelBuilder()
>>> b.grids([1, 2], [[0.0, 0, 0], [1000.0, 0, 0]])
>>> b.material(1, E=210000.0, nu=0.3, rho=7.85e-9)
>>> b.bar_section(1, 1, A=100.0, I1=833.3, I2=833.3, J=1406.0)
>>> b.bars([1], 1, [[1, 2]], orientation=[0.0, 0.0, 1.0])
>>> b.fix([1])
>>> b.eigen(nd=4)
>>> model = b.build()
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..errors import ModelError
from ..markers import INT_BLANK
from .analysis import EigenRequest, EigenSetup, Params
from .constraints import Constraints, RigidLink
from .coords import BASIC
from .element_types import ELEMENT_PROPERTIES
from .model import ElementBlock, Model

#: Components given as text or an iterable of 1-6: ``"123456"``, ``"123"``, ``(1, 2, 3)``.
Components = str | Sequence[int]


def _components(c: Components, where: str) -> tuple[int, ...]:
    """0-based components of ``c``, checked."""
    digits = [int(x) for x in str(c)] if isinstance(c, str) else [int(x) for x in c]
    if not digits or any(not 1 <= d <= 6 for d in digits) or len(set(digits)) != len(digits):
        raise ModelError(f"{where}: components {c!r}: expected distinct digits 1-6")
    return tuple(sorted(d - 1 for d in digits))


def _ids(ids, where: str) -> np.ndarray:
    out = np.atleast_1d(np.asarray(ids, dtype=np.int64))
    if out.ndim != 1 or (out <= 0).any():
        raise ModelError(f"{where}: ids {out.tolist()[:10]}: expected positive integers")
    return out


def _unique(ids: np.ndarray, what: str) -> None:
    """ModelError naming the first id given twice."""
    s = np.sort(np.asarray(ids))
    twice = np.flatnonzero(s[1:] == s[:-1])
    if len(twice):
        raise ModelError(f"{what} {int(s[twice[0]])} is defined twice", [int(s[twice[0]])])


def _shaped(values, shape: tuple[int, ...], where: str, what: str,
            dtype: type = float) -> np.ndarray:  # fmt: skip
    """``values`` as an array of ``shape`` (a single row or value broadcast to it)."""
    try:
        a = np.asarray(values, dtype=dtype)
        return np.broadcast_to(a.reshape(shape) if a.size == np.prod(shape) else a, shape).copy()
    except ValueError:
        raise ModelError(f"{where}: {what} of shape {np.shape(values)}; expected "
                         f"{shape} (or one row for all)") from None


def _column(values, n: int, where: str, default: float = 0.0) -> np.ndarray:
    """(n,) reals from one value or n values (None: ``default``)."""
    v = np.asarray(default if values is None else values, dtype=float)
    if v.ndim == 0:
        return np.full(n, float(v))
    if v.shape != (n,):
        raise ModelError(f"{where}: {v.shape[0]} values for {n} items")
    return v.copy()


class ModelBuilder:
    """Collects a model's parts; :meth:`build` makes the :class:`Model`.

    Methods taking ``ids`` accept one id or a sequence, with per-item values as scalars (the
    same for all) or sequences of the same length.
    """

    def __init__(self) -> None:
        self._grids: list[tuple[np.ndarray, np.ndarray]] = []
        self._materials: list[tuple[int, float, float, float, float]] = []
        self._props: dict[str, list[dict[str, float]]] = {}
        self._elements: dict[str, list[dict[str, np.ndarray]]] = {}
        self._fixed: list[tuple[int, tuple[int, ...]]] = []
        self._rigid: list[tuple[int, int, tuple[int, ...], tuple[int, ...]]] = []
        self._eigen: EigenRequest | None = None
        self._params = Params()

    # ------------------------------------------------------------------ nodes, materials

    def grids(self, ids, xyz) -> None:
        """Nodes ``ids`` (n,) at ``xyz`` (n, 3) in the basic frame."""
        ids = _ids(ids, "grids")
        self._grids.append((ids, _shaped(xyz, (len(ids), 3), "grids", "positions")))

    def material(self, mid: int, *, E: float, nu: float, rho: float,
                 G: float | None = None) -> None:  # fmt: skip
        """An isotropic material (MAT1); G defaults to E / (2 (1 + nu))."""
        g = E / (2.0 * (1.0 + nu)) if G is None else G
        self._materials.append((int(mid), float(E), float(g), float(nu), float(rho)))

    # ------------------------------------------------------------------ sections

    def _prop(self, card: str, pid: int, **values: float) -> None:
        self._props.setdefault(card, []).append({"pid": int(pid), **values})

    def bar_section(self, pid: int, mid: int, *, A: float, I1: float, I2: float, J: float,
                    I12: float = 0.0, K1: float | None = None, K2: float | None = None,
                    nsm: float = 0.0) -> None:  # fmt: skip
        """A uniform bar section (PBAR): area, moments of inertia about the element z (I1)
        and y (I2) axes, product I12, torsion constant J; shear factors K1, K2 (None: no
        shear flexibility); non-structural mass per length."""
        self._prop("PBAR", pid, mid=mid, a=A, i1=I1, i2=I2, i12=I12, j=J,
                   k1=np.nan if K1 is None else K1, k2=np.nan if K2 is None else K2,
                   nsm=nsm)  # fmt: skip

    def rod_section(self, pid: int, mid: int, *, A: float, J: float = 0.0,
                    nsm: float = 0.0) -> None:  # fmt: skip
        """A rod section (PROD): area, torsion constant, non-structural mass per length."""
        self._prop("PROD", pid, mid=mid, a=A, j=J, nsm=nsm)

    def shell_section(self, pid: int, mid: int, *, t: float, nsm: float = 0.0) -> None:
        """A homogeneous shell (PSHELL with MID1 = MID2 = MID3, 12I/T^3 = 1, TS/T = 5/6):
        thickness, non-structural mass per area."""
        self._prop("PSHELL", pid, mid1=mid, t=t, mid2=mid, bk=1.0, mid3=mid, tst=0.833333,
                   nsm=nsm, mid4=INT_BLANK)  # fmt: skip

    def solid_section(self, pid: int, mid: int) -> None:
        """A solid's material (PSOLID, basic material axes)."""
        self._prop("PSOLID", pid, mid=mid, cordm=0)

    # ------------------------------------------------------------------ elements

    def _add(self, etype: str, ids, pids, nodes, nodes_per: int, **data) -> np.ndarray:
        ids = _ids(ids, etype)
        n = len(ids)
        cols = {"ids": ids, "nodes": _shaped(nodes, (n, nodes_per), etype, "nodes", np.int64),
                "pids": _shaped(pids, (n,), etype, "section ids", np.int64)}  # fmt: skip
        cols.update({key: np.asarray(v) for key, v in data.items()})
        self._elements.setdefault(etype, []).append(cols)
        return ids

    def bars(self, ids, pid, nodes, *, orientation: Sequence[float]) -> None:
        """Bars (CBAR) between node pairs ``nodes`` (n, 2); ``orientation`` (3,) or (n, 3) is
        the vector in the basic frame that fixes the element y axis (NASTRAN's v)."""
        n = len(np.atleast_1d(ids))
        v = _shaped(orientation, (n, 3), "CBAR", "orientation")
        zero = np.zeros(n)
        self._add("CBAR", ids, pid, nodes, 2, x1=v[:, 0], x2=v[:, 1], x3=v[:, 2],
                  g0=np.full(n, INT_BLANK), offt=np.full(n, "", object),
                  pa=np.full(n, INT_BLANK), pb=np.full(n, INT_BLANK), w1a=zero, w2a=zero,
                  w3a=zero, w1b=zero, w2b=zero, w3b=zero)  # fmt: skip

    def rods(self, ids, pid, nodes) -> None:
        """Rods (CROD) between node pairs ``nodes`` (n, 2)."""
        self._add("CROD", ids, pid, nodes, 2)

    def _shells(self, etype: str, ids, pid, nodes, k: int) -> None:
        n = len(np.atleast_1d(ids))
        blank = np.full(n, np.nan)
        t = {f"t{i}": blank for i in range(1, k + 1)}
        self._add(etype, ids, pid, nodes, k, theta=blank, mcid=np.full(n, INT_BLANK),
                  zoffs=blank, tflag=np.full(n, INT_BLANK), **t)  # fmt: skip

    def quads(self, ids, pid, nodes) -> None:
        """Four-node shells (CQUAD4), nodes (n, 4) in order round the element."""
        self._shells("CQUAD4", ids, pid, nodes, 4)

    def trias(self, ids, pid, nodes) -> None:
        """Three-node shells (CTRIA3), nodes (n, 3)."""
        self._shells("CTRIA3", ids, pid, nodes, 3)

    def hexas(self, ids, pid, nodes) -> None:
        """Eight-node bricks (CHEXA), nodes (n, 8) as NASTRAN orders them."""
        self._add("CHEXA", ids, pid, nodes, 8)

    def tetras(self, ids, pid, nodes) -> None:
        """Four-node tetrahedra (CTETRA), nodes (n, 4)."""
        self._add("CTETRA", ids, pid, nodes, 4)

    def masses(self, ids, nodes, mass, *, offset: Sequence[float] = (0.0, 0.0, 0.0),
               inertia: Sequence[float] = (0.0,) * 6) -> None:  # fmt: skip
        """Concentrated masses (CONM2) at ``nodes`` (n,): mass (n,), the centre's offset
        from the node (3,) and the inertia I11 I21 I22 I31 I32 I33 about it (6,), basic."""
        n = len(np.atleast_1d(ids))
        off = _shaped(offset, (n, 3), "CONM2", "offset")
        inn = _shaped(inertia, (n, 6), "CONM2", "inertia")
        names = ("i11", "i21", "i22", "i31", "i32", "i33")
        self._add("CONM2", ids, -1, nodes, 1, m=_column(mass, n, "CONM2 mass"),
                  cid=np.zeros(n, np.int64), x1=off[:, 0], x2=off[:, 1], x3=off[:, 2],
                  **{k: inn[:, i] for i, k in enumerate(names)})  # fmt: skip

    def spring(self, eid: int, k: float, a: tuple[int, int],
               b: tuple[int, int] | None = None) -> None:  # fmt: skip
        """A scalar spring (CELAS2) of stiffness ``k`` between DOF ``a`` = (node, component
        1-6) and ``b``, or from ``a`` to ground."""
        ends = [a, b] if b else [a]
        for node, c in ends:
            _components([c], f"spring {eid} at node {node}")
        nodes = [a[0], b[0] if b else -1]
        comps = np.array([[a[1], b[1] if b else 0]], np.int64)
        self._add("CELAS2", eid, -1, [nodes], 2, k=np.array([float(k)]), components=comps,
                  ge=np.zeros(1), s=np.zeros(1))  # fmt: skip

    # ------------------------------------------------------------------ constraints, request

    def fix(self, nodes, components: Components = "123456") -> None:
        """Fix ``components`` of ``nodes`` (a single-point constraint)."""
        comps = _components(components, "fix")
        for node in np.atleast_1d(nodes):
            self._fixed.append((int(node), comps))

    def rigid(self, eid: int, independent: int, dependent: Sequence[int],
              components: Components = "123456") -> None:  # fmt: skip
        """A rigid link (RBE2): ``components`` of the ``dependent`` nodes follow the
        ``independent`` node as a rigid body."""
        self._rigid.append((int(eid), int(independent), tuple(int(d) for d in dependent),
                            _components(components, f"rigid {eid}")))  # fmt: skip

    def eigen(self, *, nd: int | None = 10, v1: float | None = None, v2: float | None = None,
              norm: str = "MASS") -> None:  # fmt: skip
        """The eigenvalue request: at most ``nd`` roots in [v1, v2] Hz (EIGRL)."""
        if norm not in ("MASS", "MAX"):
            raise ModelError(f"eigen: norm {norm!r}: expected 'MASS' or 'MAX'")
        self._eigen = EigenRequest(v1, v2, nd, norm)

    def params(self, params: Params) -> None:
        """The analysis PARAMs (coupled mass, WTMASS, K6ROT, AUTOSPC)."""
        self._params = params

    # ------------------------------------------------------------------ the model

    def build(self) -> Model:
        """The model.

        Raises
        ------
        ModelError
            For a node, section or material an element names that does not exist, an id
            given twice, or a model without nodes.
        """
        if not self._grids:
            raise ModelError("the model has no nodes (grids)")
        ids = np.concatenate([g[0] for g in self._grids])
        xyz = np.concatenate([g[1] for g in self._grids])
        _unique(ids, "node")
        order = np.argsort(ids, kind="stable")
        ids, xyz = ids[order], xyz[order]
        n = len(ids)
        zeros = np.zeros(n, np.int64)
        model = Model(ids, np.ones(n, bool), xyz, zeros, zeros.copy(), zeros.copy(),
                      np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), 6 * np.arange(n),
                      6 * n, {0: BASIC}, elements={}, properties={}, materials={},
                      files=["<code>"])  # fmt: skip
        materials = self._material_table()
        properties = self._property_tables(materials)
        elements = {t: self._block(model, t, parts, properties)
                    for t, parts in self._elements.items()}  # fmt: skip
        _unique(np.concatenate([b.ids for b in elements.values()] or [np.zeros(0)]), "element")
        constraints = Constraints(self._fixed_dofs(model), tuple(
            RigidLink(eid, self._node(model, ind, f"rigid {eid}"),
                      tuple(self._node(model, d, f"rigid {eid}") for d in dep), comps)
            for eid, ind, dep, comps in self._rigid))  # fmt: skip
        eigen = EigenSetup({1: self._eigen}, "1") if self._eigen else EigenSetup()
        return dataclasses.replace(model, elements=elements, properties=properties,
                                   materials=materials, params=self._params,
                                   constraints=constraints, eigen=eigen)  # fmt: skip

    @staticmethod
    def _node(model: Model, node_id: int, where: str) -> int:
        i = int(model.node_index(node_id)[0])
        if i < 0:
            raise ModelError(f"{where}: node {node_id} does not exist", [node_id])
        return i

    def _material_table(self) -> dict[str, dict[str, np.ndarray]]:
        if not self._materials:
            return {}
        m = np.array(self._materials)
        mids = m[:, 0].astype(np.int64)
        _unique(mids, "material")
        return {"MAT1": {"mid": mids, "e": m[:, 1], "g": m[:, 2], "nu": m[:, 3],
                         "rho": m[:, 4]}}  # fmt: skip

    def _property_tables(self, materials: dict) -> dict[str, dict[str, np.ndarray]]:
        out: dict[str, dict[str, np.ndarray]] = {}
        known = set(materials.get("MAT1", {}).get("mid", np.zeros(0)).tolist())
        pids: list[int] = []
        for card, rows in self._props.items():
            table = {k: np.array([r[k] for r in rows]) for k in rows[0]}
            for k in ("pid", "mid", "mid1", "mid2", "mid3", "mid4", "cordm"):
                if k in table:
                    table[k] = table[k].astype(np.int64)
            for r in rows:
                for k in ("mid", "mid1"):
                    if k in r and r[k] not in known:
                        raise ModelError(f"{card} {r['pid']}: material {r[k]} is not defined",
                                         [r["pid"], r[k]])  # fmt: skip
            pids += table["pid"].tolist()
            out[card] = table
        _unique(np.array(pids, np.int64), "section (property)")
        return out

    def _block(self, model: Model, etype: str, parts: list[dict],
               properties: dict) -> ElementBlock:  # fmt: skip
        cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        ids, raw = cols.pop("ids"), cols.pop("nodes")
        pids = cols.pop("pids")
        comps = cols.pop("components", None)
        nodes = np.where(raw < 0, -1, model.node_index(raw))
        missing = (nodes < 0) & (raw >= 0)
        if missing.any():
            bad = sorted(set(raw[missing].tolist()))
            raise ModelError(f"{etype}: nodes {bad[:20]} do not exist", bad[:20])
        cards = ELEMENT_PROPERTIES[etype]
        if cards is not None:
            have = np.concatenate([properties[c]["pid"] for c in cards if c in properties]
                                  or [np.zeros(0, np.int64)])  # fmt: skip
            bad = sorted(set(pids[~np.isin(pids, have)].tolist()))
            if bad:
                raise ModelError(f"{etype}: sections {bad} are not defined (expected "
                                 f"{' or '.join(cards)})", bad)  # fmt: skip
        n = len(ids)
        return ElementBlock(etype, ids, pids, nodes, comps, cols, np.zeros(n, np.int64),
                            np.zeros(n, np.int64))  # fmt: skip

    def _fixed_dofs(self, model: Model) -> np.ndarray:
        dofs = {int(model.dof_start[self._node(model, node, "fix")]) + c
                for node, comps in self._fixed for c in comps}  # fmt: skip
        return np.array(sorted(dofs), dtype=np.int64)
