"""Cards -> Model: node coordinates in the basic frame, DOF map, element blocks, tables."""

from .build import build_model
from .coords import CoordSystem
from .model import ElementBlock, Model

__all__ = ["CoordSystem", "ElementBlock", "Model", "build_model"]
