"""femcal: finite-element normal modes and FRF-based model calibration for structural
dynamics, from NASTRAN decks or models built in code.

The public surface, imported when first used (``import femcal`` loads nothing heavy)::

    model = femcal.load_model("frame.bdf")           # read a deck and build its model
    modes, _ = femcal.solve_normal_modes(model)       # SOL 103 normal modes
    C = femcal.channel_matrix(model, channels)        # sensors on the model
    H = femcal.modal_frf(modes.shapes, modes.radians, C, B, f, 0.02, "accelerance")
    data = femcal.read_frf("test.uff")                # measured FRFs (npz, csv, uff, mat)
    ident = femcal.identify_model(data, (10.0, 120.0))  # pLSCF, parts from the CMIF
    femcal.mac(test_shapes, fe_shapes)                # correlation
    result = femcal.calibrate_model(model, params, cfg, data=data, identified=ident)

Each name's own docstring says more; the packages (``femcal.deck``, ``femcal.model``,
``femcal.assembly``, ``femcal.solve``, ``femcal.response``, ``femcal.testdata``,
``femcal.identify``, ``femcal.correlate``, ``femcal.calibrate``, ``femcal.io``,
``femcal.viz``, ``femcal.jobs``) hold the rest.
"""

from __future__ import annotations

import importlib

__version__ = "0.2.0"

#: Public name -> the module that defines it.
_API = {
    # read a deck, build a model
    "read_deck": "femcal.deck",
    "write_deck": "femcal.deck",
    "load_model": "femcal.model.build",
    "build_model": "femcal.model.build",
    "ModelBuilder": "femcal.model.builder",
    "Model": "femcal.model",
    "EigenRequest": "femcal.model",
    # matrices and modes
    "assemble": "femcal.assembly",
    "solve_normal_modes": "femcal.solve.normal_modes",
    "Modes": "femcal.solve.normal_modes",
    # responses
    "channel_matrix": "femcal.response.frf",
    "point_matrix": "femcal.response.frf",
    "modal_frf": "femcal.response.frf",
    "Rayleigh": "femcal.response.frf",
    # test data
    "Channel": "femcal.testdata",
    "FRFData": "femcal.testdata",
    "read_frf": "femcal.testdata",
    "write_frf": "femcal.testdata",
    # identification and correlation
    "identify_model": "femcal.identify:identify",
    "IdentifiedModel": "femcal.identify",
    "mac": "femcal.correlate",
    "pair_modes": "femcal.correlate",
    # calibration
    "read_parameters": "femcal.calibrate.parameters",
    "read_config": "femcal.calibrate.config",
    "calibrate_model": "femcal.calibrate.workflow:calibrate",
    "CalibrationResult": "femcal.calibrate.result",
    "run_calibration": "femcal.jobs.calibration:run",
    # errors
    "FemcalError": "femcal.errors",
    "DeckError": "femcal.errors",
    "ModelError": "femcal.errors",
    "SolverError": "femcal.errors",
}

#: The packages, imported on first use as attributes too (``femcal.identify.stabilization``).
_PACKAGES = ("assembly", "calibrate", "cli", "correlate", "deck", "elements", "errors",
             "examples", "identify", "io", "jobs", "markers", "model", "parallel", "properties",
             "response", "solve", "testdata", "viz")  # fmt: skip

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> object:
    if name in _PACKAGES:
        return importlib.import_module(f"femcal.{name}")
    target = _API.get(name)
    if target is None:
        raise AttributeError(f"module 'femcal' has no attribute {name!r}")
    module, _, attr = target.partition(":")
    value = getattr(importlib.import_module(module), attr or name)
    globals()[name] = value  # looked up once
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
