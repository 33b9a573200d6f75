"""Model-form augmentation: the missing element the model-form search names, added to the
model as a calibration parameter, so that the data say whether the model is better with it.

A calibrated model whose misfit stays well above the test's noise lacks something the
structure has (:mod:`femcal.calibrate.modelform`), and its parameters are biased by standing
for it: they carry over to another configuration worse than they should (a mass missing
from the hammer frame made the calibrated values predict the rig frame worse than the
nominal ones, benchmarks/RESULTS.md). The search names the single spring to ground or point
mass that removes most of the remaining misfit; :func:`choose` picks it when the warning
fired and it removes at least ``augment_fall`` of the deviation, and :func:`added_element`
turns it into a NASTRAN element (a CONM2, or a CELAS1 to ground with its PELAS) on free ids
and a parameter on its size (bounds a tenth to ten times the size the search found, so the
calibration, not the search, decides it; the cards' text is
:func:`femcal.io.calibration.element_cards`). The calibration is then run again with it
(:mod:`femcal.jobs.calibration`), and the two are set side by side on data neither fit saw
(:func:`verdict`): an element that only fits the noise does not predict held-out data
better (without held-out data the verdict is left open). This is the step Friswell and
Mottershead describe after error localisation (Finite Element Model Updating in Structural
Dynamics, ch. 8): the localised candidate becomes an updating parameter.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..model.model import Model
from .modelform import Candidate
from .parameters import Parameter

#: The added element's parameter spans this factor either side of the size the search found.
SPAN = 10.0


@dataclass(frozen=True)
class AddedElement:
    """A missing element added to a configuration's deck as a calibration parameter.

    Attributes
    ----------
    configuration : the configuration whose model lacked it (its name).
    candidate : what the model-form search found (place, component, size, the fraction of
        the deviation it removes).
    parameter : the calibration parameter on its size (CONM2 M or PELAS K), nominal the
        search's size, bounds a tenth to ten times it.
    element_id : the new element's id; property_id : its PELAS's (None for a mass).
    """

    configuration: str
    candidate: Candidate
    parameter: Parameter
    element_id: int
    property_id: int | None = None

    def describe(self) -> str:
        """``CONM2 9001 on GRID 7129 (a point mass, 0.00555 as the search sized it)``."""
        c = self.candidate
        what = (f"CONM2 {self.element_id} on GRID {c.grid} (a point mass"
                if c.kind == "point mass" else
                f"CELAS1 {self.element_id} with PELAS {self.property_id} on GRID {c.grid}, "
                f"component {c.component} (a spring to ground")  # fmt: skip
        return f"{what}, {c.value:.3g} as the search sized it)"


def choose(candidates: Iterable[tuple[str, Candidate, bool]], least_fall: float
           ) -> tuple[str, Candidate] | None:  # fmt: skip
    """The element to add: of each configuration's best candidate (name, candidate, whether
    its model-form warning fired), the one that removes the largest fraction of its
    configuration's deviation, if its warning fired and that fraction is at least
    ``least_fall`` (> 0); None otherwise."""
    if least_fall <= 0:
        return None
    best: tuple[str, Candidate] | None = None
    for name, c, warned in candidates:
        if warned and c.fall >= least_fall and (best is None or c.fall > best[1].fall):
            best = (name, c)
    return best


def _free_id(used: Iterable[int]) -> int:
    """One more than the largest id in ``used`` (1 if none), within NASTRAN's 8 digits."""
    top = max((int(i) for i in used), default=0)
    if top + 1 > 99_999_999:
        raise ValueError("no free id below 100000000 for the added element")
    return top + 1


def element_ids(model: Model) -> list[int]:
    """Every element id of the model, rigid elements among them (NASTRAN gives them one
    numbering)."""
    ids = [int(i) for b in model.elements.values() for i in b.ids]
    c = model.constraints
    ids += [r.id for r in (*c.rigid_links, *c.rigid_bars, *c.interpolations)]
    return ids


def property_ids(model: Model) -> list[int]:
    """Every property id of the model (tables and records)."""
    out: list[int] = []
    for table in model.properties.values():
        if isinstance(table, dict):
            out += [int(i) for i in np.asarray(table.get("pid", []))]
        else:
            out += [int(r.pid) for r in table]
    return out


def added_element(model: Model, configuration: str, candidate: Candidate,
                  taken: Iterable[str] = (), *, other_element_ids: Iterable[int] = (),
                  other_property_ids: Iterable[int] = ()) -> AddedElement:  # fmt: skip
    """The element and the parameter that add ``candidate`` to ``model`` (see the module
    docstring), of the candidate's size (round it first to what its field holds): new ids
    one above the largest of the model's and of ``other_element_ids`` /
    ``other_property_ids`` (the deck's cards the model does not hold: dampers, plot
    elements); the parameter named
    ``added_mass_<grid>`` or ``added_spring_<grid>_<component>`` (with a number after it if
    that is in ``taken``).

    Raises
    ------
    ValueError
        For a candidate of no positive size, or when no id below 100000000 is free.
    """
    c = candidate
    if not (np.isfinite(c.value) and c.value > 0):
        raise ValueError(f"the model-form candidate {c.describe()} has no positive size")
    eid = _free_id([*element_ids(model), *other_element_ids])
    value = float(c.value)
    names = set(taken)
    if c.kind == "point mass":
        base, card, field, pid = f"added_mass_{c.grid}", "CONM2", "M", None
        ident = eid
        what = f"a point mass on GRID {c.grid} that the model-form search named"
    else:
        pid = _free_id([*property_ids(model), *other_property_ids])
        base, card, field = f"added_spring_{c.grid}_{c.component}", "PELAS", "K"
        ident = pid
        what = (f"a spring to ground on GRID {c.grid}, component {c.component}, that the "
                "model-form search named")  # fmt: skip
    name, n = base, 1
    while name in names:
        n += 1
        name = f"{base}_{n}"
    par = Parameter(name, card, ident, field, value, value / SPAN, value * SPAN, what)
    return AddedElement(configuration, c, par, eid, pid)


def verdict(heldout_first: float | None, heldout_added: float | None
            ) -> tuple[bool | None, str]:  # fmt: skip
    """Whether the data prefer the calibration with the added element, and why, on held-out
    data (both calibrations validated): the added parameter always lowers the fitted
    deviation, and the element was chosen because it lowers it, so only data the fits did
    not see can say it stands for something real. None when there are none to judge by."""
    if heldout_first is None or heldout_added is None:
        return None, ("not judged: no held-out data (holdout = \"none\"), and a fit with one "
                      "more parameter is always closer")  # fmt: skip
    return heldout_added < heldout_first, (f"held-out deviation {heldout_added:.5g} with it "
                                           f"against {heldout_first:.5g} without")  # fmt: skip
