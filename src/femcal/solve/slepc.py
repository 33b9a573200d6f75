"""Normal modes with SLEPc under MPI: an optional eigensolver backend for the largest models.

``mpirun -n N femcal solve --backend slepc DECK`` (or :func:`solve_normal_modes_slepc` in a
program started by ``mpirun``) solves the same a-set eigenproblem as the default path
(:func:`femcal.solve.normal_modes.a_set_problem`: assembly, constraints, AUTOSPC; the shift,
the ND cap and the [V1, V2] range of :func:`femcal.solve.eigen.shift_and_range`) with SLEPc's
Krylov-Schur in shift-and-invert mode, K - sigma M factorised by MUMPS (parallel sparse
Cholesky, LDL^T) spread over the ranks. petsc4py and slepc4py are imported only when this
backend is used, so femcal installs and imports without them; without them the backend says
how to get them (``make setup-slepc``).

Method
------
* The eigenproblem: K phi = lambda M phi as a generalized Hermitian problem (GHEP, so the
  Krylov basis is M-orthogonal). M may be singular (massless rotations of lumped shells):
  those directions have infinite roots, never returned. The iteration starts from a vector
  in the range of the operator, so the Ritz vectors have no components along them without
  SLEPc's purification (one more solve per vector); only after a breakdown (a small model
  whose finite roots are all found) are the roots found again with purification on.
* The spectral transformation: shift-and-invert at the default solver's negative shift sigma
  (below the spectrum, so free-free models give their rigid-body modes), roots wanted nearest
  to it; each operator application is one MUMPS solve with the factor of K - sigma M.
* The factor: MUMPS Cholesky (symmetric LDL^T, which PETSc uses for Cholesky on AIJ
  matrices); its inertia is checked so that a K - sigma M that is not positive definite (a
  mechanism, negative stiffness) is an error as it is for the default solver, not a silently
  different answer (this needs MUMPS' null-pivot detection, ICNTL(24) = 1, and under MPI
  the root front on one process, ICNTL(13) = 1).
* The request: ND roots (plus two, as the default solver's Lanczos asks), or, for an EIGRL
  with V2 and no ND, 20 roots and then twice as many, on the same factor, until the largest
  root found lies above V2; then the roots are filtered by [V1, V2] and cut to ND as the
  default solver does. Spectrum slicing (``EPSSetInterval``) was not chosen: it needs the
  inertia at many shifts (one factorisation each), where the roots of a modal request lie in
  one cluster just above sigma.
* The tolerance: 1e-10 on the relative residual of the shift-inverted problem, which makes
  the vectors accurate to about that. The eigenvalues returned are the vectors' Rayleigh
  quotients phi^T K phi / phi^T M phi (computed on the distributed matrices), whose error is
  of the order of the residual's square plus the rounding of the two products: SLEPc's own
  values sigma + 1 / theta carry the rounding of every MUMPS solve, which grows with the
  factor's size and conditioning (Debian's MUMPS orders with PORD, having no METIS, so its
  factor of a 200 x 200 plate holds 58 M entries where CHOLMOD's holds 34 M): on the 100 x
  100 clamped plate they are 2e-8 from the exact lowest root, the Rayleigh quotient 1.5e-10.
* The results: the eigenvalues are known on every rank; the generalized masses and
  stiffnesses are computed on the distributed matrices; the eigenvectors are gathered to
  rank 0, normalised as the request says (MASS or MAX) and expanded to the g-set, so rank 0
  returns the same :class:`~femcal.solve.normal_modes.Modes` as the default path (backend
  ``"slepc"``); the other ranks return None.

What is distributed and what is not
-----------------------------------
Distributed: the matrices (each rank owns one contiguous block of rows of the PETSc MPIAIJ
K and M, preallocated exactly from its CSR row lengths), the factorisation and the solves
(MUMPS), the Krylov basis (each rank holds its rows of every vector) and the products with
K and M. Not distributed: the model, the element matrices and the constraint reduction.
Every rank reads the deck and assembles the whole K_aa and M_aa, as the default path does,
keeps its block of rows and frees the rest before the factorisation (the memory peak of the
solution), so the assembly costs every rank as much time and transient memory as one
process of the default solver. Distributing the assembly would take: the assembler
(:func:`femcal.assembly.assemble`) running the element handlers over one share of each
element block, its sparsity pattern built from those elements only, with the shells' grid
normals still computed from the whole model (the CQUAD4 and CTRIA3 drilling terms use them);
the reduction T^T K_r T of each rank's partial sum K_r (it is linear, so the partial sums add
up to K_aa), added into the PETSc matrices with ADD_VALUES; and AUTOSPC and the shift's
diagonal ratios computed from the distributed rows, with the rows split at grid boundaries
so that each grid's 3 x 3 blocks lie on one rank.

Threads: MUMPS' dense kernels run on OpenBLAS, and the assembly on threads; each rank uses
the cores it is bound to, or, unbound, the machine's cores divided by the ranks (at least
one), so that 2 ranks on 2 cores do not run 4 threads.
Further PETSc, SLEPc and MUMPS options can be given in the environment variable
``PETSC_OPTIONS``: ``-eps_view``, ``-log_view``, and MUMPS' with SLEPc's prefix for the
factor, ``-st_mat_mumps_icntl_14 100`` (more workspace). Debian's MUMPS has neither METIS
nor (PT-)SCOTCH, so it orders with PORD and analyses on one rank.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..assembly import Matrices, Options, assemble
from ..assembly.constraints import Reduction
from ..errors import FemcalError, SolverError
from ..model.analysis import EigenRequest
from ..model.model import Model
from ..parallel import usable_cores
from ..resources import check_memory
from .eigen import EigenResult, shift_and_range
from .normal_modes import Modes, a_set_problem, g_set_modes

#: Relative residual tolerance of the Krylov-Schur iteration (shift-inverted problem).
TOLERANCE = 1e-10
#: Restarts of the Krylov-Schur iteration before it is said not to converge.
MAX_RESTARTS = 1000
#: Roots asked for when the request has no ND (then doubled until one lies above V2), and the
#: fewest roots asked for, as the default solver's Lanczos.
ROOTS_WITHOUT_ND, FEWEST_ROOTS = 20, 12
#: A root whose shift-inverted value 1 / (lambda - sigma) is below this fraction of the
#: largest one is a massless direction's (infinite) root, as the default dense solver cuts.
INFINITE_ROOT = 1e-12
#: How to install the backend, for the error raised when petsc4py or slepc4py is missing.
INSTALL_HINT = (
    "run `make setup-slepc` (as root on Debian: it installs python3-petsc4py, "
    "python3-slepc4py and Open MPI with apt-get and makes .venv-slepc/), then "
    "`mpirun -n N .venv-slepc/bin/femcal solve --backend slepc DECK`"
)


class BackendUnavailable(FemcalError):
    """An optional eigensolver backend whose libraries are not installed in this Python."""


def petsc_modules() -> tuple[Any, Any]:
    """``(PETSc, SLEPc)``, petsc4py and slepc4py initialised on first use.

    PETSc is initialised without the program's arguments (femcal's own options are not
    PETSc's); options for it come from the ``PETSC_OPTIONS`` environment variable.

    Raises
    ------
    BackendUnavailable
        When petsc4py or slepc4py cannot be imported, saying how to install them.
    """
    try:
        import petsc4py
        import slepc4py
    except ImportError as e:
        raise BackendUnavailable(
            f"the SLEPc backend needs petsc4py and slepc4py, which this Python "
            f"({sys.executable}) does not have ({e}): {INSTALL_HINT}"
        ) from None
    if "petsc4py.PETSc" not in sys.modules:
        petsc4py.init([])
    if "slepc4py.SLEPc" not in sys.modules:
        slepc4py.init([])
    from petsc4py import PETSc
    from slepc4py import SLEPc

    return PETSc, SLEPc


def mpi_rank_and_size() -> tuple[int, int]:
    """This process's rank and the number of ranks in PETSc's world communicator (``(0, 1)``
    when the program was not started by ``mpirun``)."""
    PETSc, _ = petsc_modules()
    comm = PETSc.COMM_WORLD
    return comm.getRank(), comm.getSize()


def _cores_per_rank(size: int) -> int:
    """Threads for this rank's assembly and BLAS: the cores it is bound to (mpirun's
    ``--bind-to core``), or, unbound, the machine's cores shared among the ranks."""
    usable = usable_cores()
    if usable < (os.cpu_count() or usable):
        return usable
    return max(1, usable // size)


def row_block(n: int, rank: int, size: int) -> tuple[int, int]:
    """The rows [start, stop) rank ``rank`` of ``size`` owns of n: n // size each, one more
    for the first n % size ranks (PETSc's own split, PetscSplitOwnership)."""
    base, extra = divmod(n, size)
    start = rank * base + min(rank, extra)
    return start, start + base + (1 if rank < extra else 0)


def solve_normal_modes_slepc(
    model: Model,
    *,
    matrices: Matrices | None = None,
    request: EigenRequest | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[Modes, Reduction] | None:
    """Normal modes of a model (SOL 103) with SLEPc, on every rank of ``mpirun`` at once.

    Every rank must call it with the same model and request (it is collective over PETSc's
    world communicator). ``matrices``: the g-set K and M if already assembled (every rank's
    own copy); otherwise each rank assembles them, with its share of the cores, and frees
    them once its block of rows is taken. ``progress`` is called on rank 0 only.

    Returns
    -------
    On rank 0, ``(modes, reduction)`` as :func:`~femcal.solve.normal_modes.solve_normal_modes`
    returns them (``modes.backend == "slepc"``); on the other ranks None.

    Raises
    ------
    BackendUnavailable
        Without petsc4py and slepc4py.
    ModelError
        As the default path, for a model femcal cannot solve.
    SolverError
        For a mechanism (K - sigma M not positive definite), a failed factorisation, or an
        iteration that does not converge (the converged eigenvalues in ``partial``).
    """
    PETSc, SLEPc = petsc_modules()
    from threadpoolctl import threadpool_limits

    comm = PETSc.COMM_WORLD
    rank, size = comm.getRank(), comm.getSize()
    say = progress if (progress is not None and rank == 0) else (lambda s: None)
    cores = _cores_per_rank(size)
    if matrices is None:
        matrices = assemble(model, Options(threads=cores))
    problem = a_set_problem(model, matrices=matrices, request=request, progress=say)
    del matrices  # the caller's copy, if any, stays; ours goes
    red, K_aa, M_aa = problem.reduction, problem.K, problem.M
    req, sigma, lam_lo, lam_hi = shift_and_range(K_aa, M_aa, problem.request)
    del problem
    n = K_aa.shape[0]
    r0, r1 = row_block(n, rank, size)
    K = _mpiaij(PETSc, comm, K_aa[r0:r1], n)
    M = _mpiaij(PETSc, comm, M_aa[r0:r1], n)
    del K_aa, M_aa
    say(f"SLEPc: {n} DOF over {size} rank(s), Krylov-Schur, shift-invert at sigma = "
        f"{sigma:.6g}, MUMPS Cholesky")  # fmt: skip
    try:
        with threadpool_limits(limits=cores, user_api="blas"):
            lam, vec, gm, gk = _solve(PETSc, SLEPc, K, M, sigma, req, lam_lo, lam_hi, say)
    finally:
        K.destroy()
        M.destroy()
    if rank != 0:
        return None
    if req.norm.upper() == "MAX":
        big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
        scale = 1.0 / big
    else:
        scale = 1.0 / np.sqrt(np.where(gm > 0, gm, 1.0))
    vec *= scale
    gm, gk = gm * scale**2, gk * scale**2
    res = EigenResult(lam, vec, gm, gk, "slepc")
    return g_set_modes(model, red, res), red


def _mpiaij(PETSc: Any, comm: Any, rows: sp.csr_matrix, n: int) -> Any:
    """A PETSc MPIAIJ matrix (n, n) of which this rank owns ``rows`` (its block of CSR rows,
    global column numbers): preallocated exactly from the row lengths and filled in one call
    (MatMPIAIJSetPreallocationCSR), marked symmetric."""
    rows = sp.csr_matrix(rows)
    rows.sort_indices()
    m = rows.shape[0]
    itype = PETSc.IntType
    csr = (rows.indptr.astype(itype), rows.indices.astype(itype),
           rows.data.astype(PETSc.ScalarType))  # fmt: skip
    A = PETSc.Mat().createAIJ(size=((m, n), (m, n)), csr=csr, comm=comm)
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    A.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
    return A


def _configure(PETSc: Any, SLEPc: Any, K: Any, M: Any, sigma: float) -> Any:
    """The EPS: GHEP, Krylov-Schur, shift-and-invert at sigma, MUMPS Cholesky with inertia."""
    comm = K.getComm()
    eps = SLEPc.EPS().create(comm)
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setTarget(sigma)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(TOLERANCE, MAX_RESTARTS)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.setShift(sigma)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.CHOLESKY)
    pc.setFactorSolverType("mumps")
    # MUMPS reads its options with the factor's prefix (SLEPc's "st_") when it factorises
    opts, prefix = PETSc.Options(), pc.getOptionsPrefix() or ""
    opts.setValue(f"{prefix}mat_mumps_icntl_24", 1)  # null pivots detected: for the inertia
    if comm.getSize() > 1:
        opts.setValue(f"{prefix}mat_mumps_icntl_13", 1)  # root front on one rank: inertia
    eps.setFromOptions()  # PETSC_OPTIONS may refine any of this
    return eps


def _start_vector(eps: Any, K: Any) -> Any:
    """The iteration's start vector: OP r = (K - sigma M)^-1 M r for a fixed random r (the
    same for any number of ranks), so that every Krylov vector, and every Ritz vector made
    of them, lies in the range of OP and has no components along massless directions (it
    needs no purification, one more solve per eigenvector, the same way the default solver's
    Lanczos starts)."""
    n = K.getSize()[0]
    r0, r1 = K.getOwnershipRange()
    r, start = K.createVecs()
    r.setArray(np.random.default_rng(20191).standard_normal(n)[r0:r1])
    eps.getST().apply(r, start)
    r.destroy()
    return start


def _factor(PETSc: Any, eps: Any) -> None:
    """Factorise K - sigma M (EPS set-up) and check that it is positive definite."""
    try:
        eps.setUp()
    except PETSc.Error as e:
        raise SolverError(f"MUMPS could not factorise K - sigma M (PETSc error {e.ierr}): "
                          "the model has a mechanism, or MUMPS ran out of its workspace "
                          "(PETSC_OPTIONS='-st_mat_mumps_icntl_14 100' gives it more)") from None
    factor = eps.getST().getKSP().getPC().getFactorMatrix()
    negative, zero, _ = factor.getInertia()
    if negative or zero:
        raise SolverError(
            "K - sigma M is singular or not positive definite: the model has a mechanism "
            f"(DOF with neither stiffness nor mass, or negative stiffness) [MUMPS: {negative} "
            f"negative and {zero} zero pivots]"
        )


def _solve(
    PETSc: Any,
    SLEPc: Any,
    K: Any,
    M: Any,
    sigma: float,
    request: EigenRequest,
    lam_lo: float,
    lam_hi: float,
    say: Callable[[str], None],
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    """The roots the request asks for: ``(lam, vec, gm, gk)``, ascending; vec (n, k) is
    gathered to rank 0 (None on the other ranks), gm and gk = phi^T M phi, phi^T K phi of
    the unnormalised vectors (every rank)."""
    n = K.getSize()[0]
    eps = _configure(PETSc, SLEPc, K, M, sigma)
    start = None
    try:
        _factor(PETSc, eps)
        start = _start_vector(eps, K)
        want = request.nd if request.nd is not None else ROOTS_WITHOUT_ND
        k = min(max(want + 2, FEWEST_ROOTS), n)
        eps.setPurify(False)  # the start vector is in the range of OP already
        while True:
            eps.setDimensions(nev=k)
            eps.setInitialSpace([start])
            say(f"Krylov-Schur: {k} roots of {n} DOF")
            try:
                eps.solve()
            except PETSc.Error as e:
                raise SolverError(f"SLEPc failed for {k} roots of {n} DOF (PETSc error "
                                  f"{e.ierr})") from None  # fmt: skip
            found = eps.getConverged()
            lam = np.array([eps.getEigenvalue(i).real for i in range(found)])
            # fewer roots than asked for: after a breakdown, the Krylov space holds every
            # finite root there is (the others are massless directions'); else a failure
            exhausted = found < k and eps.getConvergedReason() == _BREAKDOWN(SLEPc)
            if found < k and not exhausted:
                its = eps.getIterationNumber()
                raise SolverError(f"Krylov-Schur did not converge for {k} roots of {n} DOF "
                                  f"({found} converged in {its} restarts)",
                                  partial=np.sort(lam))  # fmt: skip
            if exhausted and not eps.getPurify():
                # after a breakdown SLEPc went on from random vectors, outside the range of
                # OP: the same roots again, with their vectors purified (small models only)
                eps.setPurify(True)
                continue
            order = _finite_ascending(lam, sigma)
            if _answered(lam[order], request, lam_lo, lam_hi) or exhausted or k >= n:
                break
            say(f"Krylov-Schur: {int(((lam >= lam_lo) & (lam <= lam_hi)).sum())} roots in "
                "range so far, going on")  # fmt: skip
            k = min(2 * k, n)
        lam = lam[order]
        keep = (lam >= lam_lo) & (lam <= lam_hi)
        take = order[keep]
        if request.nd is not None:
            take = take[: request.nd]
        vec, gm, gk = _vectors(PETSc, eps, K, M, take)
        # the Rayleigh quotients of the converged vectors (see the module's docstring)
        lam = np.where(gm > 0, gk / np.where(gm > 0, gm, 1.0), lam[keep][: len(take)])
        up = np.argsort(lam, kind="stable")  # close roots may swap places as quotients
        if vec is not None:
            vec = vec[:, up]
        return lam[up], vec, gm[up], gk[up]
    finally:
        eps.destroy()
        if start is not None:
            start.destroy()


def _BREAKDOWN(SLEPc: Any) -> int:  # noqa: N802 - a constant of the module loaded late
    """SLEPc's reason for an iteration that ended because its Krylov space is invariant."""
    return int(SLEPc.EPS.ConvergedReason.DIVERGED_BREAKDOWN)


def _finite_ascending(lam: np.ndarray, sigma: float) -> np.ndarray:
    """Indices of the finite roots, ascending: those whose shift-inverted value 1 / (lam -
    sigma) is above INFINITE_ROOT of the largest (the rest are massless directions)."""
    if not len(lam):
        return np.zeros(0, np.int64)
    with np.errstate(divide="ignore"):
        mu = 1.0 / (lam - sigma)
    finite = np.flatnonzero(mu > INFINITE_ROOT * max(mu.max(), 1e-300))
    return finite[np.argsort(lam[finite], kind="stable")]


def _answered(lam: np.ndarray, request: EigenRequest, lam_lo: float, lam_hi: float) -> bool:
    """Whether the roots found (ascending) answer the request, as the default solver decides:
    ND roots in range, or a root above V2."""
    in_range = (lam >= lam_lo) & (lam <= lam_hi)
    if request.nd is not None and in_range.sum() >= request.nd:
        return True
    return bool(np.isfinite(lam_hi) and len(lam) and lam[-1] > lam_hi)


def _vectors(
    PETSc: Any, eps: Any, K: Any, M: Any, take: np.ndarray
) -> tuple[np.ndarray | None, np.ndarray, np.ndarray]:
    """The eigenvectors ``take`` gathered to rank 0 as (n, k) (None elsewhere), and their
    phi^T M phi and phi^T K phi computed on the distributed matrices (every rank)."""
    n = K.getSize()[0]
    rank = K.getComm().getRank()
    x, y = K.createVecs()
    scatter, whole = PETSc.Scatter.toZero(x)
    # every rank checks what rank 0 will hold, so that all of them stop together
    check_memory(8.0 * n * len(take) * 3, f"{len(take)} mode shapes of {n} DOF")
    vec = np.empty((n, len(take))) if rank == 0 else None
    gm, gk = np.empty(len(take)), np.empty(len(take))
    try:
        for j, i in enumerate(take):
            eps.getEigenvector(int(i), x)
            M.mult(x, y)
            gm[j] = x.dot(y)
            K.mult(x, y)
            gk[j] = x.dot(y)
            scatter.scatter(x, whole, PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)
            if vec is not None:
                vec[:, j] = whole.getArray(readonly=True)
    finally:
        for obj in (scatter, whole, x, y):
            obj.destroy()
    return vec, gm, gk
