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
    # ... or relative ones: lower_rel = -0.2, upper_rel = 0.2  (fractions of P0); each
    # side once, either way; 0 < lower < upper, the nominal (positive) between them
    confidence = 0.05           # optional: the engineer's standard deviation of the value,
                                #  as a fraction of the nominal (the prior's; default: the
                                #  bounds read as bounds_sigma standard deviations)

Each field also states how the element matrices depend on it (polynomial degree of K and M
in the value), which :mod:`femcal.calibrate.derivatives` uses for exact derivatives.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..model.element_types import ELEMENT_PROPERTIES
from ..model.model import ElementBlock, Model
from .config import ConfigError, unknown_key_message


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


#: The keys of a ``[[parameter]]`` table (the file's only top-level key is ``parameter``).
PARAMETER_KEYS = ("name", "description", "card", "id", "field", "nominal", "lower", "upper",
                  "lower_rel", "upper_rel", "confidence")


#: TOML integers have no bound; femcal's fit in 64 bits.
INT_LIMIT = 2**63


def _value(item: dict, key: str, kind, where: str):
    """item[key] as a finite int or float; ConfigError naming the parameter and key otherwise
    (a string or boolean is not a number, a float not an id)."""
    value = item[key]
    what = "a whole number" if kind is int else "a number"
    in_range = isinstance(value, int | float) and (
        abs(value) < INT_LIMIT if isinstance(value, int) else math.isfinite(value))
    if (isinstance(value, bool) or not in_range
            or (kind is int and isinstance(value, float))):  # fmt: skip
        raise ConfigError(f"{where}: {key} = {value!r}: expected {what}")
    return kind(value)


def _read_toml(path: Path) -> dict:
    """A TOML file's tables; ConfigError naming the file if it is not UTF-8 TOML."""
    text = path.read_bytes()
    try:
        return tomllib.loads(text.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not a text file in UTF-8 (byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML ({e})") from None


def _tables(doc: dict, path: Path) -> list[dict]:
    """The file's ``[[parameter]]`` tables; ConfigError for anything else in the file."""
    for key in doc:
        if key != "parameter":
            raise ConfigError(f"{path}: the top level: {unknown_key_message(key, ('parameter',))}")
    items = doc.get("parameter")
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{path}: no [[parameter]] tables")
    for n, item in enumerate(items, start=1):
        if not isinstance(item, dict):
            raise ConfigError(f"{path}: parameter #{n} = {item!r}: expected a [[parameter]] "
                              "table")  # fmt: skip
    return items


def _bound(item: dict, side: str, nominal: float, where: str) -> tuple[float, str]:
    """One side's bound (``side`` is ``lower`` or ``upper``) as a value of P, from the
    absolute key or the relative one (a fraction of the nominal), and how the file gave it
    (``lower = 6.4``, ``lower_rel = -0.2``, for messages)."""
    rel = f"{side}_rel"
    if side in item and rel in item:
        raise ConfigError(f"{where}: both {side} and {rel} are given; give one ({side} the "
                          f"value, {rel} a fraction of the nominal)")  # fmt: skip
    if side in item:
        v = _value(item, side, float, where)
        return v, f"{side} = {v!r}"
    if rel in item:
        r = _value(item, rel, float, where)
        value = nominal * (1.0 + r)
        if not np.isfinite(value):
            raise ConfigError(f"{where}: {rel} = {r!r}: expected a fraction of the nominal "
                              f"({nominal!r}) that keeps the bound finite")  # fmt: skip
        return value, f"{rel} = {r!r} ({value!r})"
    raise ConfigError(f"{where}: missing {side} (or {rel}): give bounds as lower and upper "
                      "(values) or lower_rel and upper_rel (fractions of the nominal), either "
                      "way for each side")  # fmt: skip


def read_parameters(path: str | os.PathLike[str], model: Model) -> list[Parameter]:
    """Parameters of a TOML file (see the module docstring), nominal values from the model.

    Each bound is given once, as a value (``lower``, ``upper``) or as a fraction of the
    nominal (``lower_rel``, ``upper_rel``); the two sides may be given either way. The
    nominal must be positive and lie within the bounds, and the bounds must keep the value
    positive, with ``lower < upper`` strictly: bounds given the wrong way round are an
    error, not swapped, and equal bounds (nothing to calibrate) are an error too: to keep a
    value, leave the parameter out.

    Raises
    ------
    ConfigError
        Naming the file and the parameter: not TOML, an unknown or missing key, a value of
        the wrong kind, an unknown card/field, a card not in the model, a nominal that
        differs from the model's, a bound given both ways, bounds inverted, equal, not
        positive or not holding the nominal, a repeated name or field.
    """
    path = Path(path)
    items = _tables(_read_toml(path), path)
    out: list[Parameter] = []
    seen: dict[str, str] = {}
    for n, item in enumerate(items, start=1):
        name = item.get("name")
        where = f"{path}: parameter {name if isinstance(name, str) and name else f'#{n}'}"
        for key in item:
            if key not in PARAMETER_KEYS:
                raise ConfigError(f"{where}: {unknown_key_message(key, PARAMETER_KEYS)}")
        missing = [k for k in ("name", "card", "id", "field") if k not in item]
        if missing:
            raise ConfigError(f"{where}: missing {', '.join(missing)}")
        for key in ("name", "card", "field", "description"):
            if key in item and (not isinstance(item[key], str)
                                or (key != "description" and not item[key].strip())):
                raise ConfigError(f"{where}: {key} = {item[key]!r}: expected a "
                                  f"{'string' if key == 'description' else 'name'}")
        card, field = item["card"].strip().upper(), item["field"].strip().upper()
        if (card, field) not in FIELDS:
            known = ", ".join(f"{c} {f}" for c, f in FIELDS)
            raise ConfigError(f"{where}: {card} {field} is not a parameter field femcal "
                              f"calibrates ({known})")  # fmt: skip
        ident = _value(item, "id", int, where)
        try:
            nominal = current_value(model, card, ident, field)
        except ValueError as e:
            raise ConfigError(f"{where}: {e}") from None
        if not np.isfinite(nominal) or nominal <= 0:
            raise ConfigError(f"{where}: {card} {ident} {field} is {nominal} in the deck; a "
                              "parameter needs a positive nominal value (P = P0 (1 + p))")
        if "nominal" in item and not np.isclose(_value(item, "nominal", float, where), nominal,
                                                rtol=1e-9, atol=0.0):  # fmt: skip
            raise ConfigError(f"{where}: nominal {item['nominal']!r} but the deck has "
                              f"{nominal!r}")  # fmt: skip
        lo, lo_text = _bound(item, "lower", nominal, where)
        hi, hi_text = _bound(item, "upper", nominal, where)
        if lo > hi:
            raise ConfigError(f"{where}: {lo_text} is above {hi_text}: expected lower < upper "
                              "(bounds are not swapped for you)")  # fmt: skip
        if lo == hi:
            raise ConfigError(f"{where}: {lo_text} equals {hi_text}: nothing to calibrate; "
                              "widen the bounds, or leave the parameter out to keep the "
                              "deck's value")  # fmt: skip
        if not lo > 0:
            raise ConfigError(f"{where}: {lo_text}: expected a positive lower bound (the "
                              f"value {field} must stay positive)")  # fmt: skip
        if not lo <= nominal <= hi:
            raise ConfigError(f"{where}: bounds [{lo!r}, {hi!r}] must hold the nominal "
                              f"{nominal!r} (the deck's {card} {ident} {field})")
        confidence = None
        if "confidence" in item:
            confidence = _value(item, "confidence", float, where)
            if not 0 < confidence < 10:
                raise ConfigError(f"{where}: confidence = {confidence}: expected the standard "
                                  "deviation as a fraction of the nominal, e.g. 0.05")
        key = f"{card} {ident} {field}"
        if name in seen:
            raise ConfigError(f"{where}: the name is used twice")
        if key in seen.values():
            raise ConfigError(f"{where}: {key} is already a parameter")
        seen[name] = key
        out.append(Parameter(name, card, ident, field, nominal, lo, hi,
                             item.get("description", ""), confidence))  # fmt: skip
    return out


def read_truth(path: str | os.PathLike[str], params: list[Parameter]) -> np.ndarray:
    """The known values of a synthetic test's parameters (femcal's hidden-truth TOML, e.g.
    models/truck_frame/hammer_test.truth.toml): ``[[parameter]]`` tables with ``name`` and
    ``true`` (the field's value); ``card``, ``id`` and ``field``, where given, must be the
    parameter's. Returns the true values (n_p,) in the parameters' order.

    Raises
    ------
    ConfigError
        Naming the file and parameter: not TOML, a parameter missing, a ``true`` that is not
        a number, a card/id/field that is not the parameter's.
    """
    path = Path(path)
    doc = _read_toml(path)
    tables = doc.get("parameter", [])
    if not isinstance(tables, list):
        raise ConfigError(f"{path}: parameter = {tables!r}: expected [[parameter]] tables")
    items = {str(t.get("name")): t for t in tables if isinstance(t, dict)}
    out = np.empty(len(params))
    for i, par in enumerate(params):
        where = f"{path}: parameter {par.name}"
        if par.name not in items:
            raise ConfigError(f"{where}: not in the file (it needs a [[parameter]] with "
                              "name and true for every calibrated parameter)")  # fmt: skip
        item = items[par.name]
        for key, mine in (("card", par.card), ("id", par.id), ("field", par.field)):
            if key in item and str(item[key]).upper() != str(mine).upper():
                raise ConfigError(f"{where}: {key} = {item[key]!r}, but the parameter's is "
                                  f"{mine!r}")  # fmt: skip
        if "true" not in item:
            raise ConfigError(f"{where}: missing true (the parameter's true value)")
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
