"""Files at the edge: atomic writes, result files of a solution, identified models and
calibration reports."""

import importlib

#: Public name -> the module that defines it, imported when first used (so that importing
#: one writer does not load the others).
_EXPORTS = {
    # mode shapes, grids and trace lines as a universal file (UFF 15, 82, 55)
    "Grids": "uff_shapes", "TraceLines": "uff_shapes", "ModeShapes": "uff_shapes",
    "model_grids": "uff_shapes", "fe_shapes": "uff_shapes", "identified_shapes": "uff_shapes",
    "mesh_edges": "uff_shapes", "sensor_wireframe": "uff_shapes",
    "write_uff_shapes": "uff_shapes", "read_uff_shapes": "uff_shapes",
    # eigenvalues and eigenvectors as a NASTRAN punch file
    "write_punch": "punch", "read_punch": "punch", "PunchModes": "punch",
}  # fmt: skip

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> object:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'femcal.io' has no attribute {name!r}")
    return getattr(importlib.import_module(f"femcal.io.{module}"), name)
