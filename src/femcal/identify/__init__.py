"""System identification from measured FRFs: frequency-domain subspace identification,
fixed-pole least squares, residual poles, band merging, stabilisation diagrams and damping
equalisation (see :mod:`femcal.identify.workflow` for the study's workflow)."""

from .lsq import FixedPoleModel, fit_fixed_poles
from .stabilization import Stabilization, mac, stabilization
from .subspace import model_of_order, subspace_basis
from .workflow import (
    IdentifiedModel,
    Part,
    Settings,
    equalize_damping,
    frequency_response,
    identify,
)

__all__ = [
    "FixedPoleModel",
    "IdentifiedModel",
    "Part",
    "Settings",
    "Stabilization",
    "equalize_damping",
    "fit_fixed_poles",
    "frequency_response",
    "identify",
    "mac",
    "model_of_order",
    "stabilization",
    "subspace_basis",
]
