"""Real eigenvalue analysis (SOL 103): K phi = lambda M phi on the a-set.

Shift-invert Lanczos on a factor of K - sigma M for large problems (block Lanczos,
:mod:`femcal.solve.lanczos`, by default; ARPACK's eigsh with our own OPinv on request or when
the block iteration does not converge), a dense solution for small ones. EIGRL semantics: all
roots in [V1, V2] (Hz), at most ND of them.

The shift is negative, so that free-free models give their rigid-body modes, and follows the
problem's scale (:func:`default_shift`): a model in any consistent unit system, or with a
modulus of 1e-12, gives the same modes relative to its own scale. Too small a shift against
K's scale leaves K - sigma M as singular as K for free-free models and drops stiff modes as
"infinite"; too large a one crowds the lowest roots together in the shift-inverted spectrum.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import ThreadpoolController

from ..assembly.constraints import select_symmetric
from ..errors import FemcalWarning, SolverError
from ..model.analysis import EigenRequest
from ..parallel.executors import ForkedPeer, may_fork_beside, openmp_forks_safely
from ..resources import check_memory
from .factor import HAVE_CHOLMOD, NotPositiveDefinite, factorize
from .lanczos import LanczosNotConverged, block_lanczos
from .parts import independent_parts

#: Below this a-set size the dense solver is used.
DENSE_LIMIT = 600
#: |sigma| of the default negative shift, sigma = -(2 pi DEFAULT_SHIFT_HZ)^2, kept within
#: SHIFT_RANGE of the problem's scale (see :func:`default_shift`).
DEFAULT_SHIFT_HZ = 1.0
#: |sigma| / scale bounds, scale the median K_ii / M_ii. The lower bound keeps the shift-
#: inverted spectrum resolvable in double precision (the stiffest modes' 1 / (lam - sigma)
#: stay 1e-10 of the largest, above the dense solver's cut for massless directions, 1e-12);
#: the upper one keeps it below the lowest modes of slender and thin structures, whose
#: lowest eigenvalues are 1e-7 to 1e-10 of the scale (the reference decks and the truck
#: frame lie in this window, so their shift is the 1 Hz one).
SHIFT_RANGE = (1e-10, 1e-6)
#: Above this share of the DOF wanted as roots, a model up to DENSE_ALL_LIMIT DOF is solved
#: dense: a Lanczos basis of nearly every vector costs more than the dense solution.
DENSE_SHARE, DENSE_ALL_LIMIT = 0.5, 8000
#: The lower bound of an independent part's lowest root (:func:`_lowest_root`): the block's
#: columns and the relative residual of theta the bound allows for. A few steps of a small
#: block decide whether a part holds any root wanted.
CHECK_BLOCK, CHECK_TOL = 4, 1e-4


@dataclass(frozen=True)
class EigenResult:
    """Eigenpairs on the a-set, ascending.

    Attributes
    ----------
    eigenvalues : (k,) lambda = omega^2 (rad^2/s^2).
    vectors : (n_a, k) mode shapes, normalised as requested.
    generalized_mass, generalized_stiffness : (k,) phi^T M phi and phi^T K phi.
    backend : factorisation used ("cholmod", "superlu", "dense").
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    generalized_mass: np.ndarray
    generalized_stiffness: np.ndarray
    backend: str

    @property
    def radians(self) -> np.ndarray:
        return np.sqrt(np.abs(self.eigenvalues)) * np.sign(self.eigenvalues)

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.radians / (2.0 * np.pi)


def _to_lambda(f_hz: float) -> float:
    return (2.0 * np.pi * f_hz) ** 2


def _bound_lambda(f_hz: float) -> float:
    """The eigenvalue bound of a V1 or V2, with its sign: QRG EIGRL remark 5, a negative V1
    (or V2) bounds the negative roots (the sign would be lost in the square)."""
    return float(np.sign(f_hz)) * _to_lambda(f_hz)


def check_finite(K: sp.spmatrix, M: sp.spmatrix) -> None:
    """Raise :class:`SolverError` when K or M holds an infinite or NaN entry: values of the
    deck each within range whose products overflow (a modulus near 1e308 times a thickness)."""
    for name, A in (("K", K), ("M", M)):
        if not np.isfinite(A.data if sp.issparse(A) else A).all():
            raise SolverError(f"{name} holds entries beyond double precision: a value of the "
                              "deck (a modulus, thickness, area or mass near 1e300?) or their "
                              "product overflows")  # fmt: skip


def problem_scale(K: sp.spmatrix, M: sp.spmatrix) -> float:
    """The eigenproblem's scale (rad^2/s^2): the median of K_ii / M_ii over the DOF with both
    positive, else the ratio of the traces. Scaling K or M (another unit system) scales it as
    it scales every eigenvalue."""
    k, m = np.asarray(K.diagonal()), np.asarray(M.diagonal())
    both = (k > 0) & (m > 0)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        if both.any():
            return float(np.median(k[both] / m[both]))
        km, mm = float(np.abs(k).sum()), float(np.abs(m).sum())
        return km / mm if km > 0 and mm > 0 else 1.0


def default_shift(K: sp.spmatrix, M: sp.spmatrix) -> float:
    """The negative shift: -(2 pi DEFAULT_SHIFT_HZ)^2 kept within SHIFT_RANGE times the
    problem's scale (:func:`problem_scale`)."""
    scale = problem_scale(K, M)
    lo, hi = SHIFT_RANGE
    return -float(np.clip(_to_lambda(DEFAULT_SHIFT_HZ), lo * scale, hi * scale))


def solve_modes(
    K: sp.spmatrix,
    M: sp.spmatrix,
    request: EigenRequest,
    *,
    shift_hz: float | None = None,
    backend: str = "auto",
    method: str = "block",
    progress: Callable[[str], None] | None = None,
    on_factor: Callable[[Callable[[np.ndarray], np.ndarray], float], None] | None = None,
    ordering: str = "default",
) -> EigenResult:
    """Lowest eigenpairs of K phi = lambda M phi satisfying the request.

    Parameters
    ----------
    K, M : (n, n) symmetric; K positive semi-definite, M positive semi-definite (massless DOF
        give infinite eigenvalues, which are never returned).
    shift_hz : |sigma| of the negative shift, sigma = -(2 pi shift_hz)^2; None: scaled to
        the problem (:func:`default_shift`).
    backend : factorisation for the sparse path ("auto", "cholmod", "superlu").
    method : the sparse path's Lanczos: "block" (:mod:`femcal.solve.lanczos`, one solve per
        block of 8 vectors; ARPACK if it does not converge) or "arpack" (scipy's eigsh with
        our OPinv, one solve per vector).
    progress : called with short status lines during long solves.
    on_factor : called as ``on_factor(solve, sigma)`` with the sparse path's factor of
        K - sigma M (``solve(b)`` for b (n,) or (n, k)), for callers that solve with the
        same matrix afterwards (not called on the dense path).
    ordering : the factor's fill-reducing ordering (:data:`femcal.solve.factor.ORDERINGS`).

    An ND above the number of DOF is capped at it, with a :class:`FemcalWarning`.

    Raises
    ------
    SolverError
        When the model has no mass, when K - sigma M cannot be factorised (a mechanism: a
        DOF with neither stiffness nor mass that no constraint removes), or the iteration
        does not converge (the converged pairs are in ``partial``).
    ResourceError
        When the roots asked for would not fit in memory.
    """
    n = K.shape[0]
    request, sigma, lam_lo, lam_hi = shift_and_range(K, M, request, shift_hz=shift_hz)
    if method not in ("block", "arpack"):
        raise ValueError(f"method {method!r}: expected 'block' or 'arpack'")
    many = request.nd is not None and request.nd >= DENSE_SHARE * n and n <= DENSE_ALL_LIMIT
    if n <= DENSE_LIMIT or many:
        check_memory(8.0 * n * n * 6, f"the dense eigensolution of {n} DOF")
        lam, vec, name = _dense(K, M, sigma)
    else:
        lam, vec, name = _lanczos(K, M, sigma, request, lam_lo, lam_hi, (backend, ordering),
                                  progress, on_factor, method)  # fmt: skip
    keep = (lam >= lam_lo) & (lam <= lam_hi)
    lam, vec = lam[keep], vec[:, keep]  # (a copy, laid out as the products below expect)
    if request.nd is not None:
        lam, vec = lam[: request.nd], vec[:, : request.nd]
    gm = np.einsum("ik,ik->k", vec, M @ vec)
    # (the vectors are this function's own copy: scaled in place, one array fewer of n x k)
    if request.norm.upper() == "MAX":
        big = vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])]
        vec /= big
    else:
        vec /= np.sqrt(np.where(gm > 0, gm, 1.0))
    gm = np.einsum("ik,ik->k", vec, M @ vec)
    gk = np.einsum("ik,ik->k", vec, K @ vec)
    if name != "dense":
        # the vectors' Rayleigh quotients, not the Lanczos Ritz values: these carry the
        # rounding of every solve with the factor of K - sigma M (on a 1 M DOF plate the
        # lowest is 1.7e-7 from the 80-bit quotient of its vector), the quotients only the
        # vectors' error squared and the rounding of two products
        lam = gk / gm
        order = np.argsort(lam, kind="stable")
        lam, vec, gm, gk = lam[order], vec[:, order], gm[order], gk[order]
    return EigenResult(lam, vec, gm, gk, name)


def shift_and_range(
    K: sp.spmatrix, M: sp.spmatrix, request: EigenRequest, *, shift_hz: float | None = None
) -> tuple[EigenRequest, float, float, float]:
    """What every eigensolver backend checks and derives before solving: ``(request, sigma,
    lam_lo, lam_hi)``, the request with ND capped at the DOF (with a :class:`FemcalWarning`),
    the negative shift (:func:`default_shift`, or -(2 pi shift_hz)^2) and the eigenvalue
    range of [V1, V2] (Hz), widened by 1e-9 so that a root on a bound is kept.

    Raises
    ------
    SolverError
        For no free DOF, no mass, entries or a shift beyond double precision, or a request
        with neither ND nor V2.
    """
    n = K.shape[0]
    if n == 0:
        raise SolverError("the model has no free DOF after constraints")
    check_finite(K, M)
    if not np.any(M.diagonal() != 0):
        raise SolverError("the model has no mass on its free DOF, so it has no normal modes: "
                          "expected a density (MAT1 RHO ...), a non-structural mass or mass "
                          "elements (CONM2, CMASS)")  # fmt: skip
    if request.nd is not None and request.nd > n:
        warnings.warn(FemcalWarning(f"ND = {request.nd} roots asked for, the model has {n} "
                                    f"free DOF: {n} roots at most"), stacklevel=3)  # fmt: skip
        request = replace(request, nd=n)
    # below the spectrum; V1 filters the roots afterwards
    sigma = default_shift(K, M) if shift_hz is None else -_to_lambda(shift_hz)
    if not np.isfinite(sigma):
        raise SolverError(f"the stiffness-to-mass ratios K_ii / M_ii (median "
                          f"{problem_scale(K, M):g}) are beyond double precision: expected "
                          "densities and masses in the deck's units")  # fmt: skip
    # widened by 1e-9 of their size: a root on a bound is kept
    lam_lo = -np.inf if request.v1 is None else _bound_lambda(request.v1)
    lam_lo -= 1e-9 * abs(lam_lo)
    lam_hi = np.inf if request.v2 is None else _bound_lambda(request.v2)
    lam_hi += 1e-9 * abs(lam_hi)
    if request.nd is None and request.v2 is None:
        raise SolverError("EIGRL needs ND or V2 (how many roots, or up to which frequency)")
    return request, sigma, lam_lo, lam_hi


def _arpack(K, M, sigma, solve, k):
    """k roots nearest above sigma by ARPACK's one-vector shift-invert Lanczos."""
    n = K.shape[0]
    op = spla.LinearOperator((n, n), matvec=solve, dtype=float)
    # a fixed start vector: the same matrices give the same modes, to the last digit, every run
    v0 = np.random.default_rng(20191).standard_normal(n)
    try:
        return spla.eigsh(K, k=k, M=M, sigma=sigma, OPinv=op, which="LM", mode="normal",
                          tol=1e-10, v0=v0)  # fmt: skip
    except spla.ArpackNoConvergence as e:
        raise SolverError(
            f"Lanczos did not converge for {k} roots ({len(e.eigenvalues)} converged)",
            partial=(e.eigenvalues, e.eigenvectors),
        ) from None
    except spla.ArpackError as e:
        raise SolverError(f"Lanczos (ARPACK) failed for {k} roots of {n} DOF: {e}") from None


def _shifted_factor(K, M, sigma, factoring):
    """The factor of K - sigma M; ``factoring``: (backend, ordering) as :func:`factorize`
    takes them."""
    A = (K - sigma * M).tocsc()
    try:
        return factorize(A, backend=factoring[0], ordering=factoring[1])
    except NotPositiveDefinite as e:
        raise SolverError(
            "K - sigma M is singular or not positive definite: the model has a mechanism "
            f"(DOF with neither stiffness nor mass, or negative stiffness) [{e}]"
        ) from None


def _dense(K, M, sigma):
    Kd = K.toarray() if sp.issparse(K) else np.asarray(K)
    Md = M.toarray() if sp.issparse(M) else np.asarray(M)
    A = Kd - sigma * Md
    try:
        L = np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        raise SolverError(
            "K - sigma M is not positive definite: the model has a mechanism (DOF with neither "
            "stiffness nor mass) or negative stiffness"
        ) from None
    Li = sl.solve_triangular(L, np.eye(len(A)), lower=True)
    C = Li @ Md @ Li.T
    mu, y = np.linalg.eigh((C + C.T) / 2)
    tol = 1e-12 * max(mu.max(), 1e-300)
    finite = mu > tol
    mu, y = mu[finite][::-1], y[:, finite][:, ::-1]
    lam = sigma + 1.0 / mu
    vec = sl.solve_triangular(L.T, y, lower=False)
    return lam, vec, "dense"


def _lanczos(K, M, sigma, request, lam_lo, lam_hi, factoring, progress, on_factor=None,
             method="block"):  # fmt: skip
    parts = independent_parts(K, M)
    if len(parts) > 1:
        return _in_parts(K, M, parts, sigma, request, lam_lo, lam_hi, factoring, progress,
                         on_factor, method)  # fmt: skip
    solve, name = _shifted_factor(K, M, sigma, factoring)
    if progress:
        progress(f"K - sigma M factored ({name}, {K.shape[0]} DOF)")
    if on_factor is not None:
        on_factor(solve, sigma)
    lam, vec = _iterate(K, M, sigma, solve, name, request, lam_lo, lam_hi, progress, method)
    return lam, vec, name


def _in_parts(K, M, parts, sigma, request, lam_lo, lam_hi, factoring, progress, on_factor,
              method):  # fmt: skip
    """The roots of a problem that splits into independent parts (:mod:`femcal.solve.parts`),
    part by part. Each part is factored at sigma and its lowest root bounded from below
    (:func:`_lowest_root`); the parts are solved from the lowest up. Once the roots found
    answer the request up to a root lambda_cut (the ND-th, or V2), a part whose lowest root
    lies above lambda_cut has no root wanted and is not iterated on: a flat shell's membrane,
    whose roots lie far above its bending's, then costs a few steps instead of a basis.

    Where a worker forked beside this process may factorise (:func:`_fork_factors`; not when
    ``on_factor`` wants every part's factor here), the parts are shared out between the two
    (:func:`_shares`). Each process factors and checks its own parts at the same time; the
    worker then iterates on its parts at once (:func:`_parts_worker`), before the ranking
    is known (a lone part of the worker's is not checked apart: its Lanczos bounds its lowest
    root on the way, :func:`_lone_part`), while this process waits for the worker's bounds,
    ranks every part and iterates on its own parts only as the ranking wants them (iterating
    ahead here would compete with the worker for the cores and the memory, for roots the
    ranking may drop).
    Roots the ranking does not want are dropped, and the worker is stopped once none of its
    parts is wanted. A part's roots depend neither on the other parts nor on which process
    found them, so the result is the same either way. Where the fork fails, every part is
    solved here."""
    say = progress or (lambda _s: None)
    n = K.shape[0]
    total = len(parts)
    here, there = (_shares(parts) if on_factor is None and _fork_factors(factoring[0])
                   else (list(range(total)), []))  # fmt: skip
    peer = None
    if there:
        try:
            peer = ForkedPeer(_parts_worker, K, M, parts, there, sigma, request, lam_lo,
                              lam_hi, factoring, method)  # fmt: skip
        except OSError:  # the fork failed (a limit on processes or memory): all here
            here, there = list(range(total)), []
    say(f"{total} independent parts ({', '.join(str(len(p)) for p in parts)} DOF): " + (
        "solved one by one" if not there else
        "shared with a forked process"))  # fmt: skip
    with peer if peer is not None else contextlib.nullcontext():
        held: dict[int, tuple] = {}
        name = ""
        for k in here:
            Kp, Mp, solve, name = _factored(K, M, parts[k], sigma, factoring)
            say(f"part {k + 1} of {total} ({len(parts[k])} DOF): K - sigma M factored ({name})")
            held[k] = (Kp, Mp, solve)
        if on_factor is not None:
            on_factor(_block_solve(n, [(parts[k], held[k][2]) for k in here]), sigma)
        ranked = [r for k in here
                  if (r := _checked(k, total, parts[k], *held[k], sigma, say)) is not None]
        ranked.sort(key=lambda r: (r[0], r[1]))
        worker = _WorkerParts(peer, say) if peer is not None else None
        if worker is not None:
            ranked += [(lowest, k, None) for lowest, k in worker.lowest()]
            ranked.sort(key=lambda r: (r[0], r[1]))
        found: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # part -> (roots, vectors on it)
        for lowest, k, dense in ranked:
            idx = parts[k]
            cut = _cutoff(np.concatenate([np.zeros(0), *(r[0] for r in found.values())]),
                          request, lam_lo, lam_hi)  # fmt: skip
            if cut is not None and lowest > cut:
                say(f"part {k + 1} of {total} ({len(idx)} DOF) " + (
                    f"has its lowest root at {_hz(lowest):.6g} Hz or above, beyond the "
                    f"{_hz(cut):.6g} Hz the request reaches" if np.isfinite(lowest) else
                    "has no root of finite frequency") + ": no root of it is wanted")  # fmt: skip
                held.pop(k, None)
                if worker is not None:  # (the parts after this one lie higher still)
                    worker.stop()
                    worker = None
                continue
            if k in there:
                lam, vec = worker.roots(k)
            elif dense is not None:
                lam, vec = dense
            else:
                Kp, Mp, solve = held.pop(k)
                lam, vec = _iterate(Kp, Mp, sigma, solve, name, request, lam_lo, lam_hi,
                                    progress, method)  # fmt: skip
            found[k] = (lam, vec)
        if worker is not None:
            worker.stop()
    # the parts in their own order (equal roots of two parts in the same order whichever
    # process found them, whatever their bounds), each part's vectors written once, on its
    # rows, into its roots' places in the ascending order
    ks = sorted(found)
    lam = np.concatenate([np.zeros(0), *(found[k][0] for k in ks)])
    order = np.argsort(lam, kind="stable")
    place = np.empty(len(lam), dtype=np.int64)
    place[order] = np.arange(len(lam))
    vec = np.zeros((n, len(lam)))
    start = 0
    for k in ks:
        part_vec = found[k][1]
        cols = place[start : start + part_vec.shape[1]]
        vec[parts[k][:, None], cols[None, :]] = part_vec
        start += part_vec.shape[1]
    return lam[order], vec, name


class _WorkerParts:
    """This process's view of :func:`_parts_worker`: its parts' lower bounds, then their
    roots as they come (kept until asked for), its progress lines said on the way."""

    def __init__(self, peer: ForkedPeer, say: Callable[[str], None]) -> None:
        self.peer, self.say = peer, say
        self.bounds: list[tuple[float, int]] | None = None
        self.found: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def _take(self, message: tuple) -> None:
        if message[0] == "say":
            self.say(message[1])
        elif message[0] == "lowest":
            self.bounds = message[1]
        elif message[0] == "roots":
            self.found[message[1]] = message[2:]
        else:  # pragma: no cover - a bug
            raise RuntimeError(f"the forked parts' worker sent {message[0]!r}")

    def lowest(self) -> list[tuple[float, int]]:
        """(lower bound of the lowest root, part) of each of the worker's parts with mass."""
        while self.bounds is None:
            self._take(self.peer.receive())
        return self.bounds

    def roots(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Part k's (roots, vectors on its DOF), waiting for them."""
        while k not in self.found:
            self._take(self.peer.receive())
        return self.found.pop(k)

    def stop(self) -> None:
        """End the worker, whatever it is doing: nothing more is wanted of it."""
        self.peer.stop()


def _fork_factors(backend: str) -> bool:
    """Whether a worker forked beside this process can help and may factorise: SciPy's
    SuperLU always may, CHOLMOD where the OpenMP runtime allows it
    (:func:`femcal.parallel.executors.openmp_forks_safely`)."""
    return may_fork_beside() and (backend == "superlu" or not HAVE_CHOLMOD
                                  or openmp_forks_safely())  # fmt: skip


def _shares(parts: list[np.ndarray]) -> tuple[list[int], list[int]]:
    """The parts (largest first) shared out between this process and a forked one: each in
    turn to the one with fewer DOF so far, this one first on a tie."""
    here: list[int] = []
    there: list[int] = []
    load = [0, 0]
    for k, idx in enumerate(parts):
        side = 0 if load[0] <= load[1] else 1
        (here, there)[side].append(k)
        load[side] += len(idx)
    return here, there


def _factored(K, M, idx, sigma, factoring) -> tuple:
    """A part's (K_p, M_p, solve, backend name): its rows and columns, and the factor of
    K_p - sigma M_p."""
    Kp, Mp = select_symmetric(K, idx), select_symmetric(M, idx)
    solve, name = _shifted_factor(Kp, Mp, sigma, factoring)
    return Kp, Mp, solve, name


def _checked(k, total, idx, Kp, Mp, solve, sigma, say) -> tuple | None:
    """Part k's place in the ranking: (a lower bound of its lowest root, k, its roots and
    vectors when a part this small is solved dense, else None); None for a part without
    mass (every root of it is infinite)."""
    if not Mp.count_nonzero():
        return None
    if len(idx) <= DENSE_LIMIT:
        dense = _dense(Kp, Mp, sigma)[:2]
        return (dense[0][0] if len(dense[0]) else np.inf), k, dense
    lowest = _lowest_root(solve, Mp, sigma)
    say(f"part {k + 1} of {total}: " + (
        "no root of finite frequency" if not np.isfinite(lowest) else
        "the check bounds nothing, so the part is solved" if lowest <= sigma else
        f"its lowest root lies at {_hz(lowest):.6g} Hz or above"))  # fmt: skip
    return lowest, k, None


def _parts_worker(outbox, K, M, parts, mine, sigma, request, lam_lo, lam_hi, factoring,
                  method) -> None:  # fmt: skip
    """The forked worker's side of :func:`_in_parts`: factor and check the parts ``mine``
    (one part: see :func:`_lone_part`), send ``("lowest", [(bound, k), ...])``, then iterate
    on them from the lowest up, as :func:`_in_parts` would with these parts alone, sending
    ``("roots", k, lam, vectors on the part's DOF)`` for each. A part these parts' own
    roots rank out is ranked out by all the parts' roots too (the cut only falls as roots
    are added). Progress lines go out as ``("say", line)``. It runs with the caller's BLAS
    threads, so that a part's roots are those the caller would find."""
    total = len(parts)

    def say(line: str) -> None:
        outbox.send(("say", line))

    held: dict[int, tuple] = {}
    name = ""
    for k in mine:
        Kp, Mp, solve, name = _factored(K, M, parts[k], sigma, factoring)
        say(f"part {k + 1} of {total} ({len(parts[k])} DOF): K - sigma M factored ({name}, "
            "in the forked process)")  # fmt: skip
        held[k] = (Kp, Mp, solve)
    lone = mine[0] if len(mine) == 1 and method == "block" else None
    if lone is not None and len(parts[lone]) > DENSE_LIMIT and held[lone][1].count_nonzero():
        _lone_part(outbox, say, lone, total, *held[lone], name, sigma, request, lam_lo,
                   lam_hi, method)  # fmt: skip
        return
    ranked = sorted((r for k in mine
                     if (r := _checked(k, total, parts[k], *held[k], sigma, say)) is not None),
                    key=lambda r: (r[0], r[1]))  # fmt: skip
    outbox.send(("lowest", [(lowest, k) for lowest, k, _ in ranked]))
    found: list[np.ndarray] = []
    for lowest, k, dense in ranked:
        cut = _cutoff(np.concatenate([np.zeros(0), *found]), request, lam_lo, lam_hi)
        if cut is not None and lowest > cut:
            break
        Kp, Mp, solve = held.pop(k)
        lam, vec = dense if dense is not None else _iterate(
            Kp, Mp, sigma, solve, name, request, lam_lo, lam_hi, say, method)  # fmt: skip
        found.append(lam)
        outbox.send(("roots", k, lam, vec))


def _lone_part(outbox, say, k, total, Kp, Mp, solve, name, sigma, request, lam_lo, lam_hi,
               method) -> None:  # fmt: skip
    """The forked worker's one part: iterated at once (block Lanczos), its lowest root's
    bound sent as the Lanczos finds it (its first steps are the check's: :func:`_lowest_root`
    would only repeat them), then its roots. ``say`` sends a progress line."""
    sent = False

    def bounded(lowest: float) -> None:
        nonlocal sent
        say(f"part {k + 1} of {total}: its lowest root lies at {_hz(lowest):.6g} Hz or above")
        outbox.send(("lowest", [(lowest, k)]))
        sent = True

    try:
        lam, vec = _iterate(Kp, Mp, sigma, solve, name, request, lam_lo, lam_hi, say, method,
                            on_lowest=bounded)  # fmt: skip
    except Exception:
        # failed before its bound: the check bounds the part instead, so that this process
        # can rank it out (and never see the failure) as it would have
        if not sent:
            with contextlib.suppress(Exception):
                bounded(_lowest_root(solve, Mp, sigma))
        raise
    if not sent:  # (the iteration ended first, or ARPACK found the roots)
        if len(lam):
            bounded(_bound(lam[0], sigma))
        else:
            outbox.send(("lowest", [(np.inf, k)]))
    outbox.send(("roots", k, lam, vec))


def _hz(lam: float) -> float:
    return float(np.sqrt(max(lam, 0.0)) / (2.0 * np.pi))


def _cutoff(lam: np.ndarray, request: EigenRequest, lam_lo: float, lam_hi: float
            ) -> float | None:  # fmt: skip
    """The highest root the request can still want, given the roots found so far: the ND-th
    in range once ND are found, else V2's; None when nothing bounds it yet."""
    in_range = np.sort(lam[(lam >= lam_lo) & (lam <= lam_hi)])
    if request.nd is not None and len(in_range) >= request.nd:
        return float(in_range[request.nd - 1])
    return float(lam_hi) if np.isfinite(lam_hi) else None


def _lowest_root(solve: Callable, M: sp.spmatrix, sigma: float) -> float:
    """A lower bound of a part's lowest root. The block Lanczos (:data:`CHECK_BLOCK`
    vectors) runs until its largest theta = 1 / (lambda - sigma) has a residual below
    :data:`CHECK_TOL` theta; the eigenvalue it approximates then lies within that of it, so
    that root is at least sigma + (lambda - sigma) / (1 + CHECK_TOL). It is the lowest as
    any Lanczos root is: the random start block has a component along every mode. A check
    that does not converge bounds nothing: the shift itself is returned (the part is
    solved)."""
    try:
        with ThreadpoolController().limit(limits=1, user_api="blas"):
            lam = block_lanczos(solve, M, sigma, 1, block=CHECK_BLOCK, tol=CHECK_TOL)[0]
    except LanczosNotConverged:
        return float(sigma)
    if not len(lam):
        return np.inf
    return _bound(lam[0], sigma)


def _bound(lam: float, sigma: float) -> float:
    """The lower bound of a root that a Ritz value lam within :data:`CHECK_TOL` (relative,
    in theta = 1 / (lambda - sigma)) of it gives."""
    return float(sigma + (lam - sigma) / (1.0 + CHECK_TOL))


def _block_solve(n: int, parts: list[tuple[np.ndarray, Callable]]) -> Callable:
    """x = (K - sigma M)^-1 b for b (n,) or (n, k) from the parts' own factors."""

    def solve(b: np.ndarray) -> np.ndarray:
        b = np.asarray(b)
        x = np.empty(b.shape)
        for idx, part in parts:
            x[idx] = part(b[idx])
        return x

    return solve


def _iterate(K, M, sigma, solve, name, request, lam_lo, lam_hi, progress, method,
             on_lowest: Callable[[float], None] | None = None):  # fmt: skip
    """The Lanczos iteration on a factor of K - sigma M: (lam ascending, vectors).
    ``on_lowest`` is told a lower bound of the lowest root (as :func:`_lowest_root`'s) once
    the block Lanczos has one, if it does before its end."""
    n = K.shape[0]
    want = request.nd if request.nd is not None else 20
    k = min(max(want + 2, 12), n - 2)
    blas = ThreadpoolController()
    threads = max((c.num_threads for c in blas.select(user_api="blas").lib_controllers),
                  default=1)  # fmt: skip

    def wide() -> object:
        return blas.limit(limits=threads, user_api="blas")

    lam = vec = None
    solves = 0

    def told(lam_low: float) -> None:
        nonlocal on_lowest
        if on_lowest is not None:
            on_lowest(_bound(lam_low, sigma))
            on_lowest = None

    def answered(lam: np.ndarray) -> bool:
        """Whether the roots found (ascending) answer the request: the ND lowest roots in
        range are all there, or every root below V2 is."""
        in_range = (lam >= lam_lo) & (lam <= lam_hi)
        if request.nd is not None and in_range.sum() >= request.nd:
            return True
        return bool(np.isfinite(lam_hi) and len(lam) and lam[-1] > lam_hi)

    def enough(lam: np.ndarray) -> bool:
        if answered(lam):
            return True
        if progress:
            n_in = int(((lam >= lam_lo) & (lam <= lam_hi)).sum())
            progress(f"Lanczos: {n_in} roots in range so far, going on")
        return False

    while True:
        # the basis: the block iteration keeps about twice the roots in vectors of n
        check_memory(8.0 * n * (2 * k + 16) * 2, f"{k} roots of {n} DOF")
        if progress:
            progress(f"Lanczos: {k} roots of {n} DOF ({name}, {method})")
        # One BLAS thread per pool during the iteration: the Lanczos' and CHOLMOD's OpenBLAS
        # pools otherwise compete for the cores and slow every solve down. Only the
        # reorthogonalisation's products over the whole basis, between two solves, take the
        # pools' threads: they read the whole basis, at every step.
        finished = False
        with blas.limit(limits=1, user_api="blas"):
            if method == "block":
                try:
                    # more roots wanted on the same basis, not from scratch: it returns
                    # when enough() says so or when every root of the problem is found
                    lowest = None if on_lowest is None else (CHECK_TOL, told)
                    lam, vec, solves = block_lanczos(solve, M, sigma, k, enough=enough,
                                                     wide=wide, lowest=lowest)  # fmt: skip
                    finished = True
                except LanczosNotConverged as e:
                    if progress:
                        progress(f"{e}: ARPACK instead")
                    lam, vec = _arpack(K, M, sigma, solve, k)
            else:
                lam, vec = _arpack(K, M, sigma, solve, k)
        order = np.argsort(lam)
        lam, vec = lam[order], vec[:, order]
        if finished or answered(lam) or k >= n - 2:
            if progress:
                progress(f"Lanczos: {len(lam)} roots converged" + (
                    f" in {solves} block solves" if finished else " (ARPACK)"))  # fmt: skip
            return lam, vec
        k = min(2 * k, n - 2)
