"""Normal modes of a model, as NASTRAN's SOL 103 computes them: matrices, constraints,
AUTOSPC, the eigensolution and the shapes on the g-set."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..assembly import Matrices, Options, assemble
from ..assembly.constraints import Reduction, autospc, build_reduction
from ..errors import FemcalWarning, ModelError
from ..model.analysis import EigenRequest
from ..model.element_types import SOLIDS
from ..model.model import Model
from .eigen import EigenResult, check_finite, solve_modes

#: The SOL numbers of a normal modes solution (SOL 3 is its rigid-format number); None for a
#: bulk-data file or a model built in code.
MODES_SOLUTIONS = (103, 3, None)


@dataclass(frozen=True)
class Modes:
    """Normal modes on the g-set.

    Attributes
    ----------
    eigenvalues : (k,) rad^2/s^2; frequencies_hz, radians : (k,).
    generalized_mass, generalized_stiffness : (k,).
    shapes : (n_g, k) mode shapes in the nodes' displacement frames.
    node_ids, dof_start, is_grid : the g-set layout (see :class:`~femcal.model.Model`).
    autospc : (m, 2) (node id, component) fixed by AUTOSPC or as empty DOF.
    n_a : size of the solved set; backend : eigensolver backend.
    """

    eigenvalues: np.ndarray
    generalized_mass: np.ndarray
    generalized_stiffness: np.ndarray
    shapes: np.ndarray
    node_ids: np.ndarray
    dof_start: np.ndarray
    is_grid: np.ndarray
    autospc: np.ndarray
    n_a: int
    backend: str

    @property
    def radians(self) -> np.ndarray:
        return np.sign(self.eigenvalues) * np.sqrt(np.abs(self.eigenvalues))

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.radians / (2.0 * np.pi)

    def grid_displacements(self, mode: int) -> np.ndarray:
        """(n_grids, 6) displacement of each GRID in mode ``mode`` (0-based), CD frames."""
        starts = self.dof_start[self.is_grid]
        return self.shapes[starts[:, None] + np.arange(6), mode]


def fill_ordering(model: Model) -> str:
    """The fill-reducing ordering of the model's factors (:data:`femcal.solve.factor.
    ORDERINGS`): AMD where the model has no solid elements, CHOLMOD's own choice otherwise.

    A mesh of surfaces, lines and points makes a two-dimensional graph: nested dissection
    (METIS) saves little of AMD's fill there, but CHOLMOD tries it after AMD when the fill
    is large and keeps it whatever its own time, which is then most of a large factor's.
    On a solid AMD's fill is several times METIS's, so CHOLMOD chooses there. (The
    measurements are in benchmarks/RESULTS.md.)
    """
    return "default" if any(t in model.elements for t in SOLIDS) else "amd"


def solve_normal_modes(
    model: Model,
    *,
    matrices: Matrices | None = None,
    request: EigenRequest | None = None,
    progress: Callable[[str], None] | None = None,
    on_factor: Callable | None = None,
) -> tuple[Modes, Reduction]:
    """Normal modes of a model, as NASTRAN SOL 103 computes them.

    ``request`` (default: the model's, as its case control METHOD selects) says which roots;
    the model's AUTOSPC setting is honoured, and DOF with neither stiffness nor mass are
    always removed. Returns the modes and the constraint reduction used. ``on_factor``
    receives the factor of the a-set's K - sigma M (see
    :func:`femcal.solve.eigen.solve_modes`).

    Raises
    ------
    ModelError
        For a model with features that change the answer and that femcal does not model
        (``Model.unsupported``), inconsistent constraints, or no eigenvalue request.
    SolverError
        For a mechanism, or an iteration that does not converge.
    """
    problem = a_set_problem(model, matrices=matrices, request=request, progress=progress)
    res: EigenResult = solve_modes(problem.K, problem.M, problem.request, progress=progress,
                                   on_factor=on_factor, ordering=fill_ordering(model))  # fmt: skip
    return g_set_modes(model, problem.reduction, res), problem.reduction


@dataclass(frozen=True)
class ASetProblem:
    """The eigenproblem SOL 103 solves: K_aa phi = lambda M_aa phi on the a-set.

    Attributes
    ----------
    K, M : (n_a, n_a) CSR, the constrained (reduced) stiffness and mass.
    reduction : u_g = T u_a, AUTOSPC applied.
    request : which roots (the model's METHOD, or the caller's request).
    """

    K: sp.csr_matrix
    M: sp.csr_matrix
    reduction: Reduction
    request: EigenRequest


def a_set_problem(
    model: Model,
    *,
    matrices: Matrices | None = None,
    request: EigenRequest | None = None,
    progress: Callable[[str], None] | None = None,
) -> ASetProblem:
    """The a-set eigenproblem of a model, as :func:`solve_normal_modes` solves it: the model
    checked, K and M assembled (unless given), constraints and AUTOSPC applied. Every
    eigensolver backend starts from here, so that all of them solve the same problem.

    Raises
    ------
    ModelError
        As :func:`solve_normal_modes`.
    """
    say = progress or (lambda s: None)
    if model.solution_number not in MODES_SOLUTIONS:
        warnings.warn(FemcalWarning(
            f"the deck asks for SOL {model.solution}, which femcal does not run: it is solved "
            "as SOL 103 (normal modes)"), stacklevel=3)  # fmt: skip
    if model.unsupported:
        raise ModelError("the deck uses features that change the SOL 103 answer and are not "
                         f"supported: {'; '.join(model.unsupported)} (femcal solves the full "
                         "model)")  # fmt: skip
    req = request or model.eigen.request()
    mats = matrices or assemble(model, Options())
    check_finite(mats.K, mats.M)
    say(f"assembled K and M: {model.n_dof} DOF, {mats.K.nnz} nonzeros in K")
    red = build_reduction(model)
    K_aa, M_aa = red.reduce(mats.K), red.reduce(mats.M)
    red = autospc(model, red, K_aa, M_aa, enabled=model.params.autospc)
    if len(red.autospc):
        K_aa, M_aa = red.reduce(mats.K), red.reduce(mats.M)
    say(f"a-set {len(red.a_dofs)} DOF; solving for modes")
    return ASetProblem(K_aa, M_aa, red, req)


def g_set_modes(model: Model, red: Reduction, res: EigenResult) -> Modes:
    """:class:`Modes` on the g-set from an a-set eigensolution (any backend's)."""
    shapes = red.expand(res.vectors)
    node, comp = model.dof_owner(red.autospc)
    return Modes(
        res.eigenvalues, res.generalized_mass, res.generalized_stiffness, np.asarray(shapes),
        model.node_ids, model.dof_start, model.is_grid,
        np.column_stack([model.node_ids[node], comp]), len(red.a_dofs), res.backend,
    )  # fmt: skip
