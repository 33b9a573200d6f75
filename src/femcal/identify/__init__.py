"""System identification from measured FRFs in any layout: mode indicator functions and the
band's partition, the pLSCF ("PolyMAX") and frequency-domain subspace estimators,
stabilisation diagrams and the automatic choice of poles, fixed-pole least squares (LSFD)
with residual poles, mode and fit quality, and damping equalisation (see
:mod:`femcal.identify.workflow`)."""

from .layout import Layout
from .lsq import FixedPoleModel, fit_fixed_poles
from .stabilization import Criteria, Stabilization, stable_columns
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
    "Criteria",
    "FixedPoleModel",
    "IdentifiedModel",
    "Layout",
    "Part",
    "Settings",
    "Stabilization",
    "equalize_damping",
    "fit_fixed_poles",
    "frequency_response",
    "identify",
    "model_of_order",
    "stable_columns",
    "subspace_basis",
]
