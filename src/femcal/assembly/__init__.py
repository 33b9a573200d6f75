"""Model -> K and M: the sparsity pattern and scatter (:mod:`~femcal.assembly.pattern`), one
handler per element family that turns element blocks and their properties into kernel inputs
(:mod:`~femcal.assembly.matrices`), the constraint transform and reduction to the independent
set (:mod:`~femcal.assembly.constraints`), and the grid point weight
(:mod:`~femcal.assembly.weight`)."""

from .constraints import Reduction, autospc, build_reduction
from .matrices import Matrices, Options, assemble

__all__ = ["Matrices", "Options", "Reduction", "assemble", "autospc", "build_reduction"]
