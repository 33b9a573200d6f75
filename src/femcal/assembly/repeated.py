"""The same elements assembled again and again with other property and material values.

Derivatives and polynomial fits (:mod:`femcal.calibrate.derivatives`) assemble one group of
elements at many parameter values. Their connectivity does not change, so the sparsity
pattern (over the nodes the elements touch only), the CSR positions of the element blocks,
the shells' grid normals and what the quadrilaterals' kernels take from their shape alone
(within :data:`KEEP_BYTES`) are made once here, and every assembly is a pair of data
vectors (K and M) on that one pattern: combining assemblies is arithmetic on dense vectors,
not a sparse sum.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import ModelError
from ..model.model import Model
from .context import Context, shell_grid_normals
from .matrices import Options, add_elements, element_pairs, settings
from .pattern import Assembler, Pattern

#: Memory the kernels may keep between assemblies (what depends on the elements' shape
#: alone, :class:`femcal.elements.shell.QuadGeometry`); beyond it they recompute it.
KEEP_BYTES = 512 << 20
#: What a quadrilateral keeps: in-plane rows (4 x 4 x 16), out-of-plane rows (4 x 5 x 12),
#: int(N_a N_b), int(N_a), det J, area and area covariance.
QUAD_KEPT_BYTES = 8 * (4 * 4 * 16 + 4 * 5 * 12 + 16 + 4 + 4 + 1 + 4)


class RepeatedAssembly:
    """K and M of a fixed set of elements as data vectors on one pattern.

    Parameters
    ----------
    part : the elements (a model, often a part of a larger one with all its nodes).
    options : assembly options (the model's PARAMs where None).
    whole : the model ``part`` was taken from: its shells' grid normals tie the part's
        shells' drilling rotations, so that the part's matrices are its share of the whole
        model's. None: ``part`` is the whole model.
    """

    def __init__(self, part: Model, options: Options | None = None, *,
                 whole: Model | None = None):  # fmt: skip
        if part.n_nodes == 0:
            raise ModelError("the model has no grids or scalar points: nothing to assemble")
        self.coupled, self.wtmass, self.k6rot, self.threads = settings(part, options)
        self.normals = shell_grid_normals(whole if whole is not None else part)
        nodes = [b.nodes[b.nodes >= 0] for b in part.elements.values()]
        touched = np.unique(np.concatenate(nodes)) if nodes else np.zeros(0, np.int64)
        ndof = np.where(part.is_grid, 6, 1)
        pairs = [element_pairs(b) for b in part.elements.values()]
        self.pattern = Pattern.build(part.dof_start, ndof, pairs, diagonal=touched)
        self._positions: dict = {}
        # the quadrilaterals' shape-only kernel data, kept while they fit KEEP_BYTES
        quads = sum(len(b.ids) for t, b in part.elements.items() if t in ("CQUAD4", "CQUADR"))
        self._kept: dict | None = {} if quads * QUAD_KEPT_BYTES <= KEEP_BYTES else None

    @property
    def nnz(self) -> int:
        """Length of the data vectors."""
        return self.pattern.nnz

    def data(self, model: Model, *, threads: int | None = None
             ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """K and M data (nnz,) of ``model``: the elements given at construction (the same
        blocks, in the same order) with other property or material values. ``threads``: the
        kernels' worker threads (default: the options'; the sums are the same for any).
        Assemblies of one instance may run in several threads at once.

        Raises
        ------
        ModelError
            As :func:`femcal.assembly.assemble` does.
        """
        asm = Assembler(self.pattern, model.cd_frames, n_matrices=2, positions=self._positions)
        add_elements(Context(model, self.coupled, self.k6rot, threads or self.threads,
                             self.normals, self._kept), asm)  # fmt: skip
        M = asm.data(1)
        if self.wtmass != 1.0:
            M *= self.wtmass
        return asm.data(0), M

    def places(self, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """CSR column indices and row pointers of the pattern's places ``at`` (sorted
        positions) alone, for :meth:`matrix`."""
        p = self.pattern
        return p.indices[at], np.searchsorted(at, p.indptr).astype(p.indptr.dtype)

    def matrix(self, data: np.ndarray,
               places: tuple[np.ndarray, np.ndarray] | None = None) -> sp.csr_matrix:  # fmt: skip
        """The g-set CSR matrix of a data vector, sharing its index arrays with others:
        the pattern's, or with ``places`` (from :meth:`places`) the data are those places'
        only. Its structure must not be changed in place."""
        p = self.pattern
        out = sp.csr_matrix((p.n_dof, p.n_dof))
        indices, indptr = (p.indices, p.indptr) if places is None else places
        out.data, out.indices, out.indptr = np.asarray(data, float), indices, indptr
        return out
