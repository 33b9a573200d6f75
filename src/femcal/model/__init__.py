"""The Model: coordinates, DOF map, element blocks, property and material tables, constraints,
PARAMs and eigenvalue requests as frozen data.

This package holds the data and nothing that reads a deck, so the layers below it (properties,
elements, assembly, solve, response) import it without the deck layer. A model comes from a
deck with :func:`femcal.model.build.build_model` (or :func:`femcal.load_model` for a file),
or from code with :class:`femcal.model.builder.ModelBuilder`.
"""

from .analysis import EigenRequest, EigenSetup, Params
from .constraints import (
    Constraints,
    Interpolation,
    LinearEquation,
    RigidBar,
    RigidLink,
    WeightedNodes,
)
from .coords import CoordSystem
from .model import ElementBlock, Model

__all__ = [
    "Constraints",
    "CoordSystem",
    "EigenRequest",
    "EigenSetup",
    "ElementBlock",
    "Interpolation",
    "LinearEquation",
    "Model",
    "Params",
    "RigidBar",
    "RigidLink",
    "WeightedNodes",
]
