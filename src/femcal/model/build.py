"""Deck -> Model: resolve coordinates, number nodes and DOF, index elements, check references,
and turn constraints, PARAMs and eigenvalue requests into the model's typed values.

>>> from femcal.model.build import load_model
>>> model = load_model("models/truck_frame/hammer_frame.bdf")
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from ..deck.deck import Deck
from ..deck.reader import read_deck
from ..deck.spec import Table
from ..errors import ModelError
from ..markers import INT_BLANK
from .build_analysis import eigen_of, params_of, unsupported_of
from .build_checks import check_solid_poisson, check_values
from .build_constraints import constraints_of
from .coords import BASIC, CoordSystem, axes_from_points, displacement_frames, to_basic
from .element_types import ELEMENT_PROPERTIES
from .ids import IdIndex
from .model import ElementBlock, Model

#: Node columns of each element card.
ELEMENT_NODES: dict[str, tuple[str, ...]] = {
    "CQUAD4": ("g1", "g2", "g3", "g4"),
    "CQUADR": ("g1", "g2", "g3", "g4"),
    "CSHEAR": ("g1", "g2", "g3", "g4"),
    "CTRIA3": ("g1", "g2", "g3"),
    "CTRIAR": ("g1", "g2", "g3"),
    "CQUAD8": tuple(f"g{i}" for i in range(1, 9)),
    "CTRIA6": tuple(f"g{i}" for i in range(1, 7)),
    "CHEXA": tuple(f"g{i}" for i in range(1, 21)),
    "CPENTA": tuple(f"g{i}" for i in range(1, 16)),
    "CTETRA": tuple(f"g{i}" for i in range(1, 11)),
    "CPYRAM": tuple(f"g{i}" for i in range(1, 14)),
    "CBAR": ("ga", "gb"),
    "CBEAM": ("ga", "gb"),
    "CROD": ("g1", "g2"),
    "CONROD": ("g1", "g2"),
    "CTUBE": ("g1", "g2"),
    "CBUSH": ("ga", "gb"),
    "CONM1": ("g",),
    "CONM2": ("g",),
    "CELAS1": ("g1", "g2"),
    "CELAS2": ("g1", "g2"),
    "CELAS3": ("s1", "s2"),
    "CELAS4": ("s1", "s2"),
    "CMASS1": ("g1", "g2"),
    "CMASS2": ("g1", "g2"),
    "CMASS3": ("s1", "s2"),
    "CMASS4": ("s1", "s2"),
}
#: Elements whose nodes may be missing (ground or omitted midside nodes): first optional column.
_OPTIONAL_FROM = {
    "CQUAD8": 4, "CTRIA6": 3, "CHEXA": 8, "CPENTA": 6, "CTETRA": 4, "CPYRAM": 5, "CBUSH": 1,
    "CELAS1": 0, "CELAS2": 0, "CELAS3": 0, "CELAS4": 0,
    "CMASS1": 0, "CMASS2": 0, "CMASS3": 0, "CMASS4": 0,
}  # fmt: skip
_SCALAR_COMPONENTS = {
    "CELAS1": ("c1", "c2"), "CELAS2": ("c1", "c2"), "CMASS1": ("c1", "c2"), "CMASS2": ("c1", "c2"),
}  # fmt: skip
_SCALAR_POINTS_ONLY = ("CELAS3", "CELAS4", "CMASS3", "CMASS4")

PROPERTY_CARDS = (
    "PSHELL", "PCOMP", "PCOMPG", "PSHEAR", "PSOLID", "PBAR", "PBARL", "PBEAM", "PBEAML",
    "PROD", "PTUBE", "PBUSH", "PELAS", "PMASS",
)  # fmt: skip
MATERIAL_CARDS = ("MAT1", "MAT2", "MAT8", "MAT9")
#: Material cards each property's material fields may reference.
_PROPERTY_MATERIALS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "PSHELL": (("mid1", "mid2", "mid3", "mid4"), ("MAT1", "MAT2", "MAT8")),
    "PSHEAR": (("mid",), ("MAT1",)),
    "PSOLID": (("mid",), ("MAT1", "MAT9")),
    "PBAR": (("mid",), ("MAT1",)),
    "PROD": (("mid",), ("MAT1",)),
    "PTUBE": (("mid",), ("MAT1",)),
}


class _Problems:
    """Collects model errors and raises them together."""

    def __init__(self, deck: Deck):
        self.deck = deck
        self.messages: list[str] = []
        self.ids: list[int] = []
        self.locations: list[str] = []

    def add(self, message: str, ids: list[int], where: list[tuple[int, int]]) -> None:
        locs = [self.deck.where(f, ln) for f, ln in where]
        self.messages.append(f"{', '.join(locs)}: {message}" if locs else message)
        self.ids.extend(ids)
        self.locations.extend(locs)

    def raise_if_any(self) -> None:
        if self.messages:
            shown = self.messages[:100]
            more = len(self.messages) - len(shown)
            text = f"{len(self.messages)} error(s) in model:\n  " + "\n  ".join(shown)
            if more:
                text += f"\n  ... and {more} more"
            raise ModelError(text, self.ids, self.locations)


def build_model(deck: Deck) -> Model:
    """Build the :class:`Model` of a deck.

    Raises
    ------
    ModelError
        Listing every missing or duplicate grid, coordinate system, element, property or
        material id, with the referring card's id and file:line.
    """
    p = _Problems(deck)
    grids = deck.table("GRID")
    g = grids.columns
    gid = g["id"]
    cp, cd, ps, seid = g["cp"].copy(), g["cd"].copy(), g["ps"].copy(), g["seid"].copy()
    gset = deck.table("GRDSET").columns
    if len(gset["cp"]):
        if len(gset["cp"]) > 1:
            t = deck.table("GRDSET")
            p.add("more than one GRDSET card", [], list(zip(t.file, t.line, strict=True)))
        for arr, name in ((cp, "cp"), (cd, "cd"), (ps, "ps"), (seid, "seid")):
            default = gset[name][0]
            if default != INT_BLANK:
                arr[arr == INT_BLANK] = default
    for arr in (cp, cd, ps, seid):
        arr[arr == INT_BLANK] = 0
    _duplicates(p, "GRID", gid, grids)
    check_values(deck, p.add)
    bad = np.nonzero(seid != 0)[0]
    for i in bad[:20]:
        p.add(
            f"GRID {gid[i]} has SEID {seid[i]}; expected 0 (superelements are not supported)",
            [int(gid[i])],
            [(grids.file[i], grids.line[i])],
        )

    spoint_ids = np.array(
        sorted({i for r in deck.records_of("SPOINT") for i in r.ids}), dtype=np.int64
    )
    clash = np.intersect1d(spoint_ids, gid)
    if len(clash):
        p.add(
            f"ids used by both GRID and SPOINT: {clash[:20].tolist()}; expected distinct ids",
            clash[:20].tolist(),
            [],
        )

    coords, xyz_grid = _resolve_coordinates(deck, p, gid, cp, g)
    p.raise_if_any()

    node_ids = np.concatenate([gid, spoint_ids])
    is_grid = np.concatenate([np.ones(len(gid), bool), np.zeros(len(spoint_ids), bool)])
    order = np.argsort(node_ids, kind="stable")
    node_ids, is_grid = node_ids[order], is_grid[order]
    zeros_s = np.zeros(len(spoint_ids), np.int64)
    xyz = np.concatenate([xyz_grid, np.zeros((len(spoint_ids), 3))])[order]
    cp_all = np.concatenate([cp, zeros_s])[order]
    cd_all = np.concatenate([cd, zeros_s])[order]
    ps_all = np.concatenate([ps, zeros_s])[order]

    frames = np.broadcast_to(np.eye(3), (len(node_ids), 3, 3)).copy()
    for c in np.unique(cd_all[is_grid]):
        sel = np.nonzero(is_grid & (cd_all == c))[0]
        if c not in coords:
            rows = np.nonzero(cd == c)[0][:20]
            # QRG GRID: CD >= -1; -1 makes a fluid grid point, which femcal does not model
            fluid = " (CD -1, a fluid grid point, is not supported by femcal)" if c == -1 else ""
            p.add(
                f"GRID CD {c} is not a defined coordinate system{fluid}",
                gid[rows].tolist(),
                [(grids.file[i], grids.line[i]) for i in rows[:5]],
            )
            continue
        frames[sel] = displacement_frames(coords[int(c)], xyz[sel])

    ndof_per = np.where(is_grid, 6, 1)
    dof_start = np.concatenate([[0], np.cumsum(ndof_per)[:-1]]).astype(np.int64)
    n_dof = int(ndof_per.sum())

    model_stub = Model(node_ids, is_grid, xyz, cp_all, cd_all, ps_all, frames, dof_start, n_dof,
                       coords, elements={}, properties={}, materials={},
                       files=list(deck.files))  # fmt: skip
    elements = _elements(deck, p, model_stub)
    properties = _properties(deck, p)
    materials = _materials(deck, p)
    _check_property_refs(deck, p, elements, properties)
    used = {int(x) for b in elements.values() if ELEMENT_PROPERTIES[b.type] for x in b.pids}
    _check_material_refs(deck, p, properties, materials, elements, used)
    check_solid_poisson(deck, p.add, used)
    _check_constraint_refs(deck, p, model_stub)
    p.raise_if_any()
    return dataclasses.replace(
        model_stub, elements=elements, properties=properties, materials=materials,
        params=params_of(deck), constraints=constraints_of(deck, model_stub),
        eigen=eigen_of(deck), unsupported=unsupported_of(deck), solution=deck.sol_text,
        solution_number=deck.sol,
    )  # fmt: skip


def load_model(path: str | os.PathLike[str]) -> Model:
    """Read a deck file (with its INCLUDEs) and build its model.

    Raises
    ------
    DeckError
        For text that is not a valid deck, naming file, line, card and field.
    ModelError
        For cards that do not make a consistent model.
    """
    return build_model(read_deck(path))


def _duplicates(
    p: _Problems,
    card: str,
    ids: np.ndarray,
    table: Table | None,
    where: list[tuple[int, int]] | None = None,
) -> None:
    if len(ids) < 2:
        return
    order = np.argsort(ids, kind="stable")
    s = ids[order]
    dup = np.nonzero(s[1:] == s[:-1])[0]
    for k in dup[:20]:
        i, j = order[k], order[k + 1]
        if table is not None:
            locs = [(table.file[i], table.line[i]), (table.file[j], table.line[j])]
        else:
            locs = [where[i], where[j]] if where else []
        p.add(f"{card} id {s[k]} defined twice; expected unique ids", [int(s[k])], locs)


def _resolve_coordinates(
    deck: Deck, p: _Problems, gid: np.ndarray, cp: np.ndarray, g: dict[str, np.ndarray]
) -> tuple[dict[int, CoordSystem], np.ndarray]:
    """Resolve all coordinate systems and grid positions (chained through CP and CORD1 grids)."""
    pending2: dict[int, tuple[str, int, np.ndarray, int, int]] = {}
    pending1: dict[int, tuple[str, tuple[int, int, int], int, int]] = {}
    seen: dict[int, tuple[int, int]] = {}
    for kind in "RCS":
        for card, store in ((f"CORD2{kind}", pending2), (f"CORD1{kind}", pending1)):
            t = deck.tables.get(card)
            if t is None:
                continue
            c = t.columns
            for i in range(len(t)):
                cid = int(c["cid"][i])
                loc = (int(t.file[i]), int(t.line[i]))
                if cid in seen or cid == 0:
                    p.add(
                        f"coordinate system {cid} defined twice (or redefines basic 0); "
                        "expected unique ids",
                        [cid],
                        [seen.get(cid, loc), loc],
                    )
                    continue
                seen[cid] = loc
                if card.startswith("CORD2"):
                    pts = np.array([[c[f"{a}{k}"][i] for k in "123"] for a in "abc"])
                    store[cid] = (kind, int(c["rid"][i]), pts, *loc)
                else:
                    store[cid] = (kind, (int(c["g1"][i]), int(c["g2"][i]), int(c["g3"][i])), *loc)
    coords: dict[int, CoordSystem] = {0: BASIC}
    xyz = np.full((len(gid), 3), np.nan)
    local = np.column_stack([g["x1"], g["x2"], g["x3"]]) if len(gid) else np.zeros((0, 3))
    done = np.zeros(len(gid), bool)
    grid_rows = IdIndex(gid)

    def place(cid: int, kind: str, origin: np.ndarray, axes: np.ndarray | None, loc) -> None:
        if axes is None:
            p.add(
                f"coordinate system {cid}: its three points do not define axes (A = B, or C "
                "on the A-B line)",
                [cid],
                [loc],
            )
            axes = np.eye(3)
        coords[cid] = CoordSystem(cid, kind, origin, axes)

    progress = True
    while progress:
        progress = False
        for cid in list(pending2):
            kind, rid, pts, f, ln = pending2[cid]
            if rid in coords:
                b = to_basic(coords[rid], pts)
                place(cid, kind, b[0], axes_from_points(b[0], b[1], b[2]), (f, ln))
                del pending2[cid]
                progress = True
        for cid in list(pending1):
            kind, gg, f, ln = pending1[cid]
            rows = [int(r) for r in grid_rows.rows(list(gg))]
            if any(r < 0 for r in rows):
                missing = [x for x, r in zip(gg, rows, strict=True) if r < 0]
                p.add(
                    f"CORD1{kind} {cid} refers to GRID {missing}, which do not exist",
                    missing,
                    [(f, ln)],
                )
                del pending1[cid]
                continue
            if all(done[r] for r in rows):
                a, b, c = (xyz[r] for r in rows)
                place(cid, kind, a, axes_from_points(a, b, c), (f, ln))
                del pending1[cid]
                progress = True
        todo = ~done
        if todo.any():
            for c in np.unique(cp[todo]):
                c = int(c)
                if c in coords:
                    sel = np.nonzero(todo & (cp == c))[0]
                    xyz[sel] = to_basic(coords[c], local[sel])
                    done[sel] = True
                    progress = True
    undefined = sorted(set(np.unique(cp[~done]).tolist()) - set(pending1) - set(pending2))
    grids = deck.table("GRID")
    for c in undefined:
        rows = np.nonzero((~done) & (cp == c))[0]
        p.add(
            f"GRID CP {c} is not a defined coordinate system",
            gid[rows[:20]].tolist(),
            [(grids.file[i], grids.line[i]) for i in rows[:5]],
        )
    stuck = {**{k: v[-2:] for k, v in pending2.items()}, **{k: v[-2:] for k, v in pending1.items()}}
    if stuck:
        p.add(
            f"coordinate systems {sorted(stuck)} cannot be resolved: they refer to each other "
            "(through RID or CORD1 grids) in a cycle, or to an undefined system",
            sorted(stuck),
            [tuple(v) for v in stuck.values()],
        )
    return coords, xyz


def _index_nodes(model: Model, ids: np.ndarray) -> np.ndarray:
    """Node indices for ids (INT_BLANK and 0 -> -2, unknown -> -1)."""
    out = model.node_index(np.where(ids == INT_BLANK, 0, ids))
    out[(ids == INT_BLANK) | (ids == 0)] = -2
    return out


def _elements(deck: Deck, p: _Problems, model: Model) -> dict[str, ElementBlock]:
    blocks: dict[str, ElementBlock] = {}
    all_ids, all_locs = [], []
    for etype, cols in ELEMENT_NODES.items():
        t = deck.tables.get(etype)
        if t is None or len(t) == 0:
            continue
        c = t.columns
        ids = c["eid"]
        raw = np.column_stack([c[n] for n in cols])
        nodes = _index_nodes(model, raw)
        opt = _OPTIONAL_FROM.get(etype, len(cols))
        required_missing = nodes[:, :opt] == -2
        unknown = nodes == -1
        for i in np.nonzero(unknown.any(axis=1) | required_missing.any(axis=1))[0][:50]:
            bad = raw[i][unknown[i]].tolist()
            msg = (
                f"{etype} {ids[i]} refers to GRID/SPOINT {bad}, which do not exist"
                if bad
                else f"{etype} {ids[i]} lacks a required node"
            )
            p.add(msg, [int(ids[i]), *bad], [(t.file[i], t.line[i])])
        nodes = np.where(nodes < 0, -1, nodes)
        if etype not in _SCALAR_COMPONENTS and etype not in _SCALAR_POINTS_ONLY:
            _repeated_nodes(p, etype, ids, raw, nodes, t)
        components = None
        if etype in _SCALAR_COMPONENTS:
            comps = np.column_stack([c[n] for n in _SCALAR_COMPONENTS[etype]])
            comps = np.where(comps == INT_BLANK, 0, comps)
            present = nodes >= 0
            grid = np.zeros_like(present)
            grid[present] = model.is_grid[nodes[present]]
            bad = present & ((grid & ((comps < 1) | (comps > 6))) | (~grid & (comps != 0)))
            for i in np.nonzero(bad.any(axis=1))[0][:20]:
                p.add(
                    f"{etype} {ids[i]}: component must be one digit 1-6 at a GRID and 0 or blank "
                    "at a SPOINT",
                    [int(ids[i])],
                    [(t.file[i], t.line[i])],
                )
            components = comps
        elif etype in _SCALAR_POINTS_ONLY:
            present = nodes >= 0
            grid = np.zeros_like(present)
            grid[present] = model.is_grid[nodes[present]]
            for i in np.nonzero(grid.any(axis=1))[0][:20]:
                p.add(
                    f"{etype} {ids[i]} connects a GRID; expected scalar points (SPOINT)",
                    [int(ids[i])],
                    [(t.file[i], t.line[i])],
                )
            components = np.zeros_like(nodes)
        if etype in ("CBAR", "CBEAM", "CBUSH"):
            g0 = c["g0"]
            has = (g0 != INT_BLANK) & (g0 != 0)
            if has.any():
                missing = has & (model.node_index(np.where(has, g0, 0)) < 0)
                for i in np.nonzero(missing)[0][:20]:
                    p.add(
                        f"{etype} {ids[i]} orientation node G0 {g0[i]} does not exist",
                        [int(ids[i]), int(g0[i])],
                        [(t.file[i], t.line[i])],
                    )
        pids = c["pid"] if "pid" in c else np.full(len(ids), -1, np.int64)
        if etype in ("CBAR", "CBEAM"):
            pids = _bar_pids(deck, etype, ids, pids)
            c = _bar_orientation_defaults(deck, etype, c)
        data = {k: v for k, v in c.items() if k not in cols and k not in ("eid", "pid")}
        blocks[etype] = ElementBlock(etype, ids, pids, nodes, components, data, t.file, t.line)
        all_ids.append(ids)
        all_locs.extend(zip(t.file.tolist(), t.line.tolist(), strict=True))
    if all_ids:
        _duplicates(p, "element", np.concatenate(all_ids), None, all_locs)
    # Rigid elements have an id space of their own (NASTRAN runs decks where an RBE2 and a
    # CQUAD4 share an id, e.g. refdecks/pyn_flutter_0012).
    rigid_ids, rigid_locs = [], []
    for name in ("RBE2", "RBE3"):
        rl = deck.records_of(name)
        rigid_ids.append(np.array([r.eid for r in rl], np.int64))
        rigid_locs.extend(zip(rl.file, rl.line, strict=True))
    t = deck.tables.get("RBAR")
    if t is not None:
        rigid_ids.append(t.columns["eid"])
        rigid_locs.extend(zip(t.file.tolist(), t.line.tolist(), strict=True))
    _duplicates(p, "rigid element", np.concatenate(rigid_ids), None, rigid_locs)
    return blocks


def _repeated_nodes(p: _Problems, etype: str, ids: np.ndarray, raw: np.ndarray,
                    nodes: np.ndarray, t) -> None:  # fmt: skip
    """An element that names one grid twice (a CQUAD4 G3 = G4, a CBAR GA = GB) has no shape:
    each is an error naming the element and the grid."""
    if nodes.shape[1] < 2:
        return
    s = np.sort(np.where(nodes >= 0, nodes, -1 - np.arange(nodes.shape[1])), axis=1)
    for i in np.nonzero((s[:, 1:] == s[:, :-1]).any(axis=1))[0][:20]:
        present = raw[i][nodes[i] >= 0]
        u, n = np.unique(present, return_counts=True)
        p.add(f"{etype} {ids[i]} names GRID {u[n > 1].tolist()} more than once; expected "
              "distinct grids", [int(ids[i]), *u[n > 1].tolist()],
              [(t.file[i], t.line[i])])  # fmt: skip


def _bar_pids(deck: Deck, etype: str, ids: np.ndarray, pids: np.ndarray) -> np.ndarray:
    """CBAR/CBEAM PID: as written, else the BAROR/BEAMOR PID, else the element id."""
    orient = deck.tables.get("BAROR" if etype == "CBAR" else "BEAMOR")
    default = INT_BLANK
    if orient is not None and len(orient):
        default = int(orient.columns["pid"][-1])
    out = np.where(pids == INT_BLANK, default, pids)
    return np.where(out == INT_BLANK, ids, out)


def _bar_orientation_defaults(
    deck: Deck, etype: str, c: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Blank orientation (X1-X3 and G0 all blank) and OFFT of CBAR/CBEAM from BAROR/BEAMOR."""
    orient = deck.tables.get("BAROR" if etype == "CBAR" else "BEAMOR")
    if orient is None or len(orient) == 0:
        return c
    o = {k: v[-1] for k, v in orient.columns.items()}
    c = dict(c)
    blank = np.isnan(c["x1"]) & np.isnan(c["x2"]) & np.isnan(c["x3"]) & (c["g0"] == INT_BLANK)
    if blank.any():
        for k in ("x1", "x2", "x3", "g0"):
            c[k] = np.where(blank, o[k], c[k])
    if o["offt"]:
        offt = c["offt"].copy()
        offt[offt == ""] = o["offt"]
        c["offt"] = offt
    return c


def _id_cards(
    deck: Deck, p: _Problems, cards: tuple[str, ...], id_col: str, what: str
) -> dict[str, object]:
    """Tables (dict of columns) or record lists of ``cards``, with ids unique across them."""
    out: dict[str, object] = {}
    ids, locs = [], []
    for name in cards:
        if name in deck.tables:
            t = deck.tables[name]
            out[name] = t.columns
            ids.append(t.columns[id_col])
            locs.extend(zip(t.file.tolist(), t.line.tolist(), strict=True))
        elif name in deck.records:
            rl = deck.records[name]
            out[name] = list(rl.items)
            ids.append(np.array([getattr(r, id_col) for r in rl], np.int64))
            locs.extend(zip(rl.file, rl.line, strict=True))
    if ids:
        _duplicates(p, what, np.concatenate(ids), None, locs)
    return out


def _properties(deck: Deck, p: _Problems) -> dict[str, object]:
    return _id_cards(deck, p, PROPERTY_CARDS, "pid", "property")


def _materials(deck: Deck, p: _Problems) -> dict[str, object]:
    mats = _id_cards(deck, p, MATERIAL_CARDS, "mid", "material")
    t = deck.tables.get("MAT1")
    if t is not None:
        c = t.columns
        both = np.isnan(c["e"]) & np.isnan(c["g"])
        for i in np.nonzero(both)[0][:20]:
            p.add(
                f"MAT1 {c['mid'][i]} has neither E nor G; expected at least one",
                [int(c["mid"][i])],
                [(t.file[i], t.line[i])],
            )
    return mats


def _ids_of(props: dict[str, object], name: str) -> np.ndarray:
    v = props.get(name)
    if v is None:
        return np.zeros(0, np.int64)
    if isinstance(v, dict):
        return v["pid"] if "pid" in v else v["mid"]
    return np.array([r.pid for r in v], np.int64)


def _check_property_refs(
    deck: Deck, p: _Problems, elements: dict[str, ElementBlock], props: dict[str, object]
) -> None:
    for etype, block in elements.items():
        allowed = ELEMENT_PROPERTIES[etype]
        if allowed is None:
            continue
        known = np.concatenate([_ids_of(props, n) for n in allowed])
        missing = ~np.isin(block.pids, known)
        for i in np.nonzero(missing)[0][:50]:
            p.add(
                f"{etype} {block.ids[i]} refers to property {block.pids[i]}, which is not "
                f"defined (expected a {' or '.join(allowed)} card)",
                [int(block.ids[i]), int(block.pids[i])],
                [(block.file[i], block.line[i])],
            )


def _check_material_refs(
    deck: Deck,
    p: _Problems,
    props: dict[str, object],
    mats: dict[str, object],
    elements: dict[str, ElementBlock],
    used: set[int],
) -> None:
    """Material references of the properties that elements use (NASTRAN ignores the rest)."""

    def known(allowed: tuple[str, ...]) -> set[int]:
        out: set[int] = set()
        for n in allowed:
            if n in mats:
                out.update(mats[n]["mid"].tolist())
        return out

    for name, (fields, allowed) in _PROPERTY_MATERIALS.items():
        if name not in props:
            continue
        t = deck.tables[name]
        ok = known(allowed)
        for f in fields:
            col = t.columns[f]
            for i in range(len(col)):
                mid = int(col[i])
                if int(t.columns["pid"][i]) not in used:
                    continue
                if mid in (INT_BLANK, -1) or (name == "PSHELL" and mid == 0) or mid in ok:
                    continue
                p.add(
                    f"{name} {t.columns['pid'][i]} field {f.upper()} refers to material {mid}, "
                    f"which is not defined (expected a {' or '.join(allowed)} card)",
                    [int(t.columns["pid"][i]), mid],
                    [(t.file[i], t.line[i])],
                )
    checks = (
        ("PCOMP", ("MAT1", "MAT2", "MAT8")),
        ("PCOMPG", ("MAT1", "MAT2", "MAT8")),
        ("PBARL", ("MAT1",)),
        ("PBEAML", ("MAT1",)),
        ("PBEAM", ("MAT1",)),
    )
    for name, allowed in checks:
        rl = deck.records_of(name)
        ok = known(allowed)
        for r, f, ln in zip(rl.items, rl.file, rl.line, strict=True):
            if r.pid not in used:
                continue
            mids = {ply.mid for ply in r.plies} if hasattr(r, "plies") else {r.mid}
            for mid in sorted(mids - ok):
                p.add(
                    f"{name} {r.pid} refers to material {mid}, which is not defined "
                    f"(expected a {' or '.join(allowed)} card)",
                    [r.pid, mid],
                    [(f, ln)],
                )
    if "CONROD" in elements:
        b = elements["CONROD"]
        ok = known(("MAT1",))
        for i in np.nonzero(~np.isin(b.data["mid"], list(ok)))[0][:20]:
            p.add(
                f"CONROD {b.ids[i]} refers to material {b.data['mid'][i]}, which is not "
                "defined (expected a MAT1 card)",
                [int(b.ids[i])],
                [(b.file[i], b.line[i])],
            )


def _check_constraint_refs(deck: Deck, p: _Problems, model: Model) -> None:
    """Every grid named by rigid elements, MPC, SPC, SUPORT and ASET cards must exist."""

    def check(card: str, ident: str, ids: list[int], loc: tuple[int, int]) -> None:
        ids = [i for i in ids if i not in (0, INT_BLANK)]
        if not ids:
            return
        bad = np.asarray(ids)[model.node_index(ids) < 0]
        if len(bad):
            p.add(
                f"{card} {ident} refers to GRID/SPOINT {sorted(set(bad.tolist()))[:20]}, "
                "which do not exist",
                bad[:20].tolist(),
                [loc],
            )

    for r, f, ln in _iter_records(deck, "RBE2"):
        check("RBE2", str(r.eid), [r.gn, *r.gm], (f, ln))
    for r, f, ln in _iter_records(deck, "RBE3"):
        ids = [r.refgrid, *[x for grp in r.groups for x in grp.grids], *[g for g, _ in r.um]]
        check("RBE3", str(r.eid), ids, (f, ln))
    for r, f, ln in _iter_records(deck, "MPC"):
        check("MPC", f"set {r.sid}", [t[0] for t in r.terms], (f, ln))
    for r, f, ln in _iter_records(deck, "SPC1"):
        check("SPC1", f"set {r.sid}", list(r.ids), (f, ln))
        # QRG SPC1: C of digits 1-6 for grid points; 0, 1 or blank only for scalar points
        if r.components == 0:
            rows = [model.node_index(list(r.ids)) if r.ids else np.zeros(0, np.int64)]
            for a, b in r.ranges:
                lo = int(np.searchsorted(model.node_ids, a))
                hi = int(np.searchsorted(model.node_ids, b, side="right"))
                rows.append(np.arange(lo, hi))
            at = np.concatenate(rows)
            at = at[at >= 0]
            grids = model.node_ids[at[model.is_grid[at]]].tolist()
            if grids:
                p.add(f"SPC1 set {r.sid} field C = 0 (or blank) at GRID {grids[:20]}: expected "
                      "component numbers 1-6 (0 or blank only at scalar points)", [r.sid],
                      [(f, ln)])  # fmt: skip
    for r, f, ln in _iter_records(deck, "ASET1"):
        check("ASET1", "", list(r.ids), (f, ln))
    t = deck.tables.get("SPC")
    if t is not None:  # QRG SPC: C of digits 1-6 for grid points; 0 or 1 for scalar points
        c = t.columns
        rows = model.node_index(c["g"])
        bad = (rows >= 0) & (c["c"] == 0)
        bad[bad] = model.is_grid[rows[bad]]
        for i in np.flatnonzero(bad)[:20]:
            p.add(f"SPC set {c['sid'][i]} field C = 0 at GRID {c['g'][i]}: expected component "
                  "numbers 1-6 (0 only at scalar points)", [int(c["sid"][i])],
                  [(t.file[i], t.line[i])])  # fmt: skip
    for card, cols in (
        ("RBAR", ("ga", "gb")),
        ("SPC", ("g",)),
        ("SUPORT", ("id",)),
        ("ASET", ("id",)),
    ):
        t = deck.tables.get(card)
        if t is None:
            continue
        c = t.columns
        for col in cols:
            ids = c[col]
            bad = np.nonzero(model.node_index(ids) < 0)[0]
            for i in bad[:20]:
                p.add(
                    f"{card} refers to GRID/SPOINT {ids[i]}, which does not exist",
                    [int(ids[i])],
                    [(t.file[i], t.line[i])],
                )


def _iter_records(deck: Deck, name: str):
    rl = deck.records_of(name)
    return zip(rl.items, rl.file, rl.line, strict=True)
