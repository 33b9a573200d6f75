"""Calibration parameters: which card field each one is, its nominal value (the model's), its
bounds, and the model with new values (the calibrated deck is written by
:func:`femcal.io.calibration.write_calibrated_deck`).

A parameter P is scaled as in the reference study: ``P = P0 (1 + p)``, so p = 0 is the
nominal model and the bounds become ``p_lo = lower / P0 - 1``, ``p_hi = upper / P0 - 1``.

The parameter file is TOML with one ``[[parameter]]`` table per parameter::

    [[parameter]]
    name = "p1"                 # unique
    description = "side rail thickness (mm)"   # optional
    card = "PSHELL"             # see FIELDS
    id = 1                      # the card's id (PID, MID, or element id for CONM2)
    field = "T"
    nominal = 8.0               # optional; if given it must equal the model's value
    lower = 6.4                 # absolute bounds ...
    upper = 9.6
    # ... or relative ones: lower_rel = -0.2, upper_rel = 0.2  (fractions of P0)
    confidence = 0.05           # optional: the engineer's standard deviation of the value,
                                #  as a fraction of the nominal (the prior's; default: the
                                #  bounds read as bounds_sigma standard deviations)

Each field also states how the element matrices depend on it (polynomial degree of K and M
in the value), which :mod:`femcal.calibrate.derivatives` uses for exact derivatives.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..model.element_types import ELEMENT_PROPERTIES
from ..model.model import ElementBlock, Model


@dataclass(frozen=True)
class FieldSpec:
    """Where a parameter field lives and how K and M depend on it.

    kind : ``property`` / ``material`` (a table column of ``Model.properties`` /
    ``Model.materials``), ``record`` (a field of a list card's records, index for tuples),
    or ``element`` (a column of an element block's data, the id being the element id).
    k_degree, m_degree : polynomial degree of the element stiffness and mass in the value
    (0: independent of it); where a dependence is rational (the CQUAD4's and CTRIA3's
    transverse shear in T), :mod:`femcal.calibrate.derivatives` raises the degree it fits.
    """

    card: str
    field: str
    kind: str
    column: str
    index: int | None
    k_degree: int
    m_degree: int
    meaning: str


def _spec(card, field, kind, column, k, m, meaning, index=None) -> FieldSpec:
    return FieldSpec(card, field, kind, column, index, k, m, meaning)


#: The parameter fields femcal calibrates.
FIELDS: dict[tuple[str, str], FieldSpec] = {
    (s.card, s.field): s
    for s in [
        _spec("PSHELL", "T", "property", "t", 3, 1,
              "membrane and mass linear, bending cubic in T; the CQUAD4 (with MID3) and "
              "CTRIA3 transverse shear is rational in T (residual bending flexibility)"),
        _spec("MAT1", "E", "material", "e", 1, 0, "stiffness linear in E (G derived from E)"),
        _spec("MAT1", "RHO", "material", "rho", 0, 1, "mass linear in RHO"),
        _spec("PBAR", "A", "property", "a", 1, 1, "axial stiffness and mass linear in A"),
        _spec("PBAR", "I1", "property", "i1", 1, 0, "bending stiffness linear in I1"),
        _spec("PBAR", "I2", "property", "i2", 1, 0, "bending stiffness linear in I2"),
        _spec("PBAR", "J", "property", "j", 1, 0, "torsion stiffness linear in J"),
        _spec("PROD", "A", "property", "a", 1, 1, "axial stiffness and mass linear in A"),
        _spec("PROD", "J", "property", "j", 1, 0, "torsion stiffness linear in J"),
        _spec("PELAS", "K", "property", "k", 1, 0, "spring stiffness"),
        *[_spec("PBUSH", f"K{i + 1}", "record", "k", 1, 0, f"bush stiffness K{i + 1}", i)
          for i in range(6)],
        _spec("CONM2", "M", "element", "m", 0, 1, "concentrated mass"),
    ]
}  # fmt: skip

#: Element types that reference each property card.
PROPERTY_ELEMENTS = {
    card: tuple(e for e, props in ELEMENT_PROPERTIES.items() if props and card in props)
    for card in {c for props in ELEMENT_PROPERTIES.values() if props for c in props}
}

#: Material fields of property tables (column names) and of property records (attributes).
_MATERIAL_COLUMNS = ("mid", "mid1", "mid2", "mid3", "mid4")


@dataclass(frozen=True)
class Parameter:
    """One calibration parameter: ``P = nominal (1 + p)`` with ``p`` in ``[p_lower,
    p_upper]``; ``lower`` and ``upper`` are the absolute bounds of P; ``confidence`` the
    standard deviation of p the engineer gives it (None: the bounds set it)."""

    name: str
    card: str
    id: int
    field: str
    nominal: float
    lower: float
    upper: float
    description: str = ""
    confidence: float | None = None

    @property
    def spec(self) -> FieldSpec:
        return FIELDS[(self.card, self.field)]

    @property
    def p_lower(self) -> float:
        return self.lower / self.nominal - 1.0

    @property
    def p_upper(self) -> float:
        return self.upper / self.nominal - 1.0

    def value(self, p: float) -> float:
        """P for the scaled parameter p."""
        return self.nominal * (1.0 + p)


def _locate(model: Model, spec: FieldSpec, ident: int, where: str):
    """(container, row) of the parameter's value; ValueError naming what is missing."""
    if spec.kind in ("property", "material"):
        tables = model.properties if spec.kind == "property" else model.materials
        table = tables.get(spec.card)
        key = "mid" if spec.kind == "material" else "pid"
        if not isinstance(table, dict):
            raise ValueError(f"{where}: the deck has no {spec.card} card")
        rows = np.flatnonzero(table[key] == ident)
        if len(rows) != 1:
            raise ValueError(f"{where}: {spec.card} {ident} is not in the deck")
        return table, int(rows[0])
    if spec.kind == "record":
        recs = model.properties.get(spec.card)
        if not isinstance(recs, list):
            raise ValueError(f"{where}: the deck has no {spec.card} card")
        rows = [i for i, r in enumerate(recs) if r.pid == ident]
        if len(rows) != 1:
            raise ValueError(f"{where}: {spec.card} {ident} is not in the deck")
        return recs, rows[0]
    block = model.elements.get(spec.card)
    if block is None:
        raise ValueError(f"{where}: the deck has no {spec.card} element")
    rows = np.flatnonzero(block.ids == ident)
    if len(rows) != 1:
        raise ValueError(f"{where}: {spec.card} {ident} is not in the deck")
    return block, int(rows[0])


def current_value(model: Model, card: str, ident: int, field: str) -> float:
    """The model's value of a parameter field."""
    spec = FIELDS[(card, field)]
    where = f"{card} {ident} {field}"
    box, row = _locate(model, spec, ident, where)
    if spec.kind == "record":
        return float(getattr(box[row], spec.column)[spec.index])
    if spec.kind == "element":
        return float(box.data[spec.column][row])
    return float(box[spec.column][row])


def _value(item: dict, key: str, kind, where: str):
    """item[key] as int or float; ValueError naming the parameter and key otherwise."""
    try:
        if kind is int and isinstance(item[key], float):
            raise ValueError
        return kind(item[key])
    except (TypeError, ValueError):
        what = "a whole number" if kind is int else "a number"
        raise ValueError(f"{where}: {key} = {item[key]!r}: expected {what}") from None


def read_parameters(path: str | os.PathLike[str], model: Model) -> list[Parameter]:
    """Parameters of a TOML file (see the module docstring), nominal values from the model.

    Raises
    ------
    ValueError
        Naming the file and the parameter: a missing key, an unknown card/field, a card not
        in the model, a nominal that differs from the model's, bounds that do not hold the
        nominal, a repeated name or field.
    """
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML ({e})") from None
    items = doc.get("parameter")
    if not isinstance(items, list) or not items:
        raise ValueError(f"{path}: no [[parameter]] tables")
    out: list[Parameter] = []
    seen: dict[str, str] = {}
    for n, item in enumerate(items, start=1):
        name = str(item.get("name", f"#{n}"))
        where = f"{path}: parameter {name}"
        missing = [k for k in ("name", "card", "id", "field") if k not in item]
        if missing:
            raise ValueError(f"{where}: missing {', '.join(missing)}")
        card, field = str(item["card"]).upper(), str(item["field"]).upper()
        if (card, field) not in FIELDS:
            known = ", ".join(f"{c} {f}" for c, f in FIELDS)
            raise ValueError(f"{where}: {card} {field} is not a parameter field femcal "
                             f"calibrates ({known})")  # fmt: skip
        ident = _value(item, "id", int, where)
        try:
            nominal = current_value(model, card, ident, field)
        except ValueError as e:
            raise ValueError(f"{where}: {e}") from None
        if not np.isfinite(nominal) or nominal == 0:
            raise ValueError(f"{where}: {card} {ident} {field} is {nominal} in the deck; a "
                             "parameter needs a nonzero nominal value")  # fmt: skip
        if "nominal" in item and not np.isclose(_value(item, "nominal", float, where), nominal,
                                                rtol=1e-9):  # fmt: skip
            raise ValueError(f"{where}: nominal {item['nominal']} but the deck has {nominal}")
        if "lower" in item and "upper" in item:
            lo, hi = _value(item, "lower", float, where), _value(item, "upper", float, where)
        elif "lower_rel" in item and "upper_rel" in item:
            lo = nominal * (1.0 + _value(item, "lower_rel", float, where))
            hi = nominal * (1.0 + _value(item, "upper_rel", float, where))
        else:
            raise ValueError(f"{where}: give bounds as lower and upper (absolute) or lower_rel "
                             "and upper_rel (fractions of the nominal)")  # fmt: skip
        lo, hi = min(lo, hi), max(lo, hi)
        if not lo <= nominal <= hi or lo == hi:
            raise ValueError(f"{where}: bounds [{lo}, {hi}] must hold the nominal {nominal}")
        confidence = None
        if "confidence" in item:
            confidence = _value(item, "confidence", float, where)
            if not 0 < confidence < 10:
                raise ValueError(f"{where}: confidence = {confidence}: expected the standard "
                                 "deviation as a fraction of the nominal, e.g. 0.05")  # fmt: skip
        key = f"{card} {ident} {field}"
        if name in seen:
            raise ValueError(f"{where}: the name is used twice")
        if key in seen.values():
            raise ValueError(f"{where}: {key} is already a parameter")
        seen[name] = key
        out.append(Parameter(name, card, ident, field, nominal, lo, hi,
                             str(item.get("description", "")), confidence))  # fmt: skip
    return out


def read_truth(path: str | os.PathLike[str], params: list[Parameter]) -> np.ndarray:
    """The known values of a synthetic test's parameters (femcal's hidden-truth TOML, e.g.
    models/truck_frame/hammer_test.truth.toml): ``[[parameter]]`` tables with ``name`` and
    ``true`` (the field's value); ``card``, ``id`` and ``field``, where given, must be the
    parameter's. Returns the true values (n_p,) in the parameters' order.

    Raises
    ------
    ValueError
        Naming the file and parameter: not TOML, a parameter missing, a ``true`` that is not
        a number, a card/id/field that is not the parameter's.
    """
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML ({e})") from None
    items = {str(t.get("name")): t for t in doc.get("parameter", []) if isinstance(t, dict)}
    out = np.empty(len(params))
    for i, par in enumerate(params):
        where = f"{path}: parameter {par.name}"
        if par.name not in items:
            raise ValueError(f"{where}: not in the file (it needs a [[parameter]] with "
                             "name and true for every calibrated parameter)")  # fmt: skip
        item = items[par.name]
        for key, mine in (("card", par.card), ("id", par.id), ("field", par.field)):
            if key in item and str(item[key]).upper() != str(mine).upper():
                raise ValueError(f"{where}: {key} = {item[key]!r}, but the parameter's is "
                                 f"{mine!r}")  # fmt: skip
        if "true" not in item:
            raise ValueError(f"{where}: missing true (the parameter's true value)")
        out[i] = _value(item, "true", float, where)
    return out


def share_parameters(lists: Sequence[Sequence[Parameter]], sources: Sequence[str]
                     ) -> tuple[list[Parameter], list[np.ndarray]]:  # fmt: skip
    """The parameters of several configurations as one set, shared by name: the union in
    order of first appearance, and for each configuration the positions (n_p_c,) of its
    parameters in it. A parameter named in several configurations is one parameter: its
    scaled change p is the same in all of them, so its nominal value, bounds and confidence
    must agree (its card and id may differ from deck to deck).

    Raises
    ------
    ValueError
        Naming the parameter and both sources where a shared parameter's nominal value,
        bounds or confidence differ.
    """
    shared: list[Parameter] = []
    first: dict[str, tuple[int, str]] = {}
    index = []
    for params, source in zip(lists, sources, strict=True):
        pos = []
        for par in params:
            if par.name not in first:
                first[par.name] = (len(shared), source)
                shared.append(par)
            k, where = first[par.name]
            known = shared[k]
            for what in ("nominal", "lower", "upper", "confidence"):
                a, b = getattr(known, what), getattr(par, what)
                if (a is None) != (b is None) or (a is not None and not np.isclose(
                        a, b, rtol=1e-9, atol=0.0)):
                    raise ValueError(f"parameter {par.name}: {what} {a} in {where} but {b} in "
                                     f"{source}; a parameter shared by name needs one "
                                     f"{what}")  # fmt: skip
            pos.append(k)
        index.append(np.array(pos, dtype=int))
    return shared, index


def with_values(model: Model, params: list[Parameter], values: np.ndarray) -> Model:
    """A copy of the model with the parameters set to ``values`` (P, not p); the original
    model is not changed (the tables that change are copied)."""
    props = dict(model.properties)
    mats = dict(model.materials)
    elements = dict(model.elements)
    for par, v in zip(params, np.asarray(values, float), strict=True):
        spec = par.spec
        _, row = _locate(model, spec, par.id, par.name)
        if spec.kind in ("property", "material"):
            group = props if spec.kind == "property" else mats
            table = dict(group[spec.card])
            col = np.array(table[spec.column], copy=True)
            col[row] = v
            table[spec.column] = col
            group[spec.card] = table
        elif spec.kind == "record":
            recs = list(props[spec.card])
            old = recs[row]
            vals = list(getattr(old, spec.column))
            vals[spec.index] = v
            recs[row] = replace(old, **{spec.column: tuple(vals)})
            props[spec.card] = recs
        else:
            block = elements[spec.card]
            data = dict(block.data)
            col = np.array(data[spec.column], copy=True)
            col[row] = v
            data[spec.column] = col
            elements[spec.card] = replace(block, data=data)
        model = replace(model, properties=props, materials=mats, elements=elements)
    return model


def affected_elements(model: Model, par: Parameter) -> dict[str, np.ndarray]:
    """Element type -> row indices (into its block) of the elements whose matrices depend
    on the parameter."""
    spec = par.spec
    out: dict[str, np.ndarray] = {}
    if spec.kind == "element":
        block = model.elements[spec.card]
        out[spec.card] = np.flatnonzero(block.ids == par.id)
        return out
    if spec.kind in ("property", "record"):
        pids = {par.id}
        types = PROPERTY_ELEMENTS[spec.card]
    else:  # a material: every property that refers to it, and CONROD elements
        pids = set()
        for table in model.properties.values():
            if isinstance(table, dict):
                for c in _MATERIAL_COLUMNS:
                    if c in table:
                        pids |= {int(x) for x in table["pid"][table[c] == par.id]}
            else:
                for r in table:
                    mids = [getattr(r, "mid", None)]
                    mids += [ply.mid for ply in getattr(r, "plies", ())]
                    if par.id in mids:
                        pids.add(int(r.pid))
        types = tuple(model.elements)
        if "CONROD" in model.elements:
            block = model.elements["CONROD"]
            rows = np.flatnonzero(block.data["mid"] == par.id)
            if len(rows):
                out["CONROD"] = rows
    for etype in types:
        block = model.elements.get(etype)
        if block is None or etype == "CONROD":
            continue
        rows = np.flatnonzero(np.isin(block.pids, list(pids)))
        if len(rows):
            out[etype] = rows
    return out


def subset(model: Model, rows: dict[str, np.ndarray]) -> Model:
    """The model with only the given elements (type -> rows); nodes and DOF unchanged."""
    blocks = {}
    for etype, r in rows.items():
        b = model.elements[etype]
        blocks[etype] = ElementBlock(
            b.type, b.ids[r], b.pids[r], b.nodes[r],
            None if b.components is None else b.components[r],
            {k: v[r] for k, v in b.data.items()}, b.file[r], b.line[r],
        )  # fmt: skip
    return replace(model, elements=blocks)
