"""Model -> stiffness and mass matrices of the g-set (K_gg, M_gg).

One handler per element family (:mod:`~femcal.assembly.lines`, :mod:`~femcal.assembly.points`,
:mod:`~femcal.assembly.surfaces`, :mod:`~femcal.assembly.solids`) turns the model's element
blocks and their properties (:mod:`femcal.properties`) into the explicit inputs of the element
kernels (:mod:`femcal.elements`, which know no cards) and adds their matrices; one sparse
scatter per matrix (:mod:`~femcal.assembly.pattern`).

PARAMs honoured: COUPMASS (> 0: coupled mass where the element has one), WTMASS (scales the
whole mass matrix), K6ROT (shell drilling stiffness).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import ModelError
from ..model.model import ElementBlock, Model
from ..parallel import usable_cores
from . import lines, points, solids, surfaces
from .context import Context, name_positions
from .pattern import Assembler, Pattern


@dataclass(frozen=True)
class Matrices:
    """Assembled g-set matrices.

    Attributes
    ----------
    K, M : (n_dof, n_dof) CSR stiffness and mass in the nodes' displacement frames.
    element_mass : structural mass by element type (before WTMASS), for weight summaries.
    """

    K: sp.csr_matrix
    M: sp.csr_matrix
    element_mass: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Options:
    """Assembly options; None means "as the model's PARAMs say" (``Model.params``)."""

    coupled_mass: bool | None = None
    wtmass: float | None = None
    k6rot: float | None = None
    #: Threads computing element matrices (NumPy releases the GIL in its array work);
    #: None: the cores this process may use, at most 4. The sums are the same for any count.
    threads: int | None = None


def assemble(model: Model, options: Options | None = None) -> Matrices:
    """Stiffness and mass matrices of the whole model (g-set, before constraints).

    Raises
    ------
    ModelError
        For a model without nodes, or element or property data the kernels cannot use (zero
        length, a missing section type, ...), naming the element ids.
    """
    if model.n_nodes == 0:
        raise ModelError("the model has no grids or scalar points: nothing to assemble")
    coupled, wtmass, k6rot, threads = settings(model, options)
    ndof = np.where(model.is_grid, 6, 1)
    pairs = [element_pairs(b) for b in model.elements.values()]
    # the pattern's column indices are only needed at the end: built while the kernels run
    pattern = Pattern.build(model.dof_start, ndof, pairs, background=threads > 1)
    asm = Assembler(pattern, model.cd_frames, n_matrices=2)  # K and M
    masses = add_elements(Context(model, coupled, k6rot, threads), asm)
    M = _compact(asm.matrix(1))  # a lumped mass is (block) diagonal: keep only what it holds
    if wtmass != 1.0:
        M = M * wtmass
    return Matrices(asm.matrix(0), M, masses)


def settings(model: Model, options: Options | None) -> tuple[bool, float, float, int]:
    """(coupled mass, WTMASS, K6ROT, kernel threads) of ``options``, the model's PARAMs
    where they say None."""
    opt = options or Options()
    par = model.params
    coupled = opt.coupled_mass if opt.coupled_mass is not None else par.coupled_mass
    wtmass = opt.wtmass if opt.wtmass is not None else par.wtmass
    k6rot = opt.k6rot if opt.k6rot is not None else par.k6rot
    threads = opt.threads if opt.threads is not None else min(4, usable_cores())
    return coupled, wtmass, k6rot, max(1, threads)


def add_elements(ctx: Context, asm: Assembler) -> dict[str, float]:
    """Add the stiffness (matrix 0) and mass (matrix 1) of every element of ``ctx.model`` to
    ``asm``; returns the structural mass by element type (before WTMASS).

    Raises
    ------
    ModelError
        For an element type without a handler, or data its kernel cannot use.
    """
    masses: dict[str, float] = {}
    for etype, block in ctx.model.elements.items():
        handler = _HANDLERS.get(etype)
        if handler is None:
            raise ModelError(f"{etype} stiffness and mass are not implemented yet", block.ids[:20])
        try:
            masses[etype] = handler(ctx, block, asm)
        except ValueError as e:  # a kernel's complaint about elements at positions in the block
            raise ModelError(f"{etype}: {name_positions(str(e), block.ids)}",
                             block.ids[:20]) from None  # fmt: skip
    return masses


def _compact(A: sp.csr_matrix) -> sp.csr_matrix:
    """A copy of A without its stored zeros, built from the nonzeros only (A shares its
    index arrays with another matrix, so it is not compacted in place)."""
    keep = np.flatnonzero(A.data)  # far faster than a running count over every entry
    nonzeros_before = np.searchsorted(keep, A.indptr)  # per row boundary
    out = sp.csr_matrix(A.shape)
    out.data, out.indices = A.data[keep], A.indices[keep]
    out.indptr = nonzeros_before.astype(A.indptr.dtype)
    return out


def element_pairs(block: ElementBlock) -> np.ndarray:
    """(m, 2) the pairs of nodes each element of the block couples."""
    k = block.nodes.shape[1]
    if k == 1:
        return np.zeros((0, 2), np.int64)
    a, b = np.triu_indices(k, 1)
    return np.stack([block.nodes[:, a], block.nodes[:, b]], axis=-1).reshape(-1, 2)


_Handler = Callable[[Context, ElementBlock, Assembler], float]
_HANDLERS: dict[str, _Handler] = {
    "CROD": lines.rods,
    "CONROD": lines.rods,
    "CTUBE": lines.rods,
    "CBAR": lines.bars,
    "CBEAM": lines.beams,
    "CBUSH": lines.bushes,
    "CELAS1": points.scalars,
    "CELAS2": points.scalars,
    "CELAS3": points.scalars,
    "CELAS4": points.scalars,
    "CMASS1": points.scalars,
    "CMASS2": points.scalars,
    "CMASS3": points.scalars,
    "CMASS4": points.scalars,
    "CONM2": points.conm2,
    "CONM1": points.conm1,
    "CQUAD4": surfaces.shells,
    "CTRIA3": surfaces.shells,
    "CQUADR": surfaces.shells,
    "CTRIAR": surfaces.shells,
    "CQUAD8": surfaces.shells,
    "CTRIA6": surfaces.shells,
    "CSHEAR": surfaces.shear_panels,
    "CHEXA": solids.solids,
    "CPENTA": solids.solids,
    "CTETRA": solids.solids,
    "CPYRAM": solids.solids,
}
