"""Block shift-invert Lanczos against a dense reference: repeated roots, massless DOF, the
ARPACK fallback."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse as sp

from femcal.errors import SolverError
from femcal.model import EigenRequest
from femcal.solve.eigen import solve_modes
from femcal.solve.factor import factorize
from femcal.solve.lanczos import LanczosNotConverged, block_lanczos


def twin_chains(n: int = 400) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Two identical fixed-free spring chains of n DOF side by side (every root twice), with
    uneven springs and masses and every 7th DOF massless (infinite roots)."""
    rng = np.random.default_rng(3)
    k = 1e4 * (1 + rng.random(n))
    main = k + np.append(k[1:], 0.0)
    K1 = sp.diags([main, -k[1:], -k[1:]], [0, 1, -1])
    m = 1 + rng.random(n)
    m[::7] = 0.0
    M1 = sp.diags(m)
    return sp.block_diag([K1, K1]).tocsr(), sp.block_diag([M1, M1]).tocsr()


def reference(K, M, k: int) -> np.ndarray:
    """The k lowest finite roots, from the dense M x = mu K x (mu = 1 / lambda)."""
    mu = sl.eigh(M.toarray(), K.toarray(), eigvals_only=True)
    return np.sort(1.0 / mu[mu > 1e-12 * mu.max()])[:k]


@pytest.mark.parametrize(("block", "tol", "residual"),
                         [(1, None, 1e-4), (3, None, 1e-4), (8, None, 1e-4), (8, 1e-10, 1e-6)])
def test_block_lanczos_finds_repeated_roots_and_skips_massless_dof(block, tol, residual):
    """Eigenvalues to rounding whatever the tolerance; the equation residual follows it (the
    default 1e-8 leaves 1.3e-5 of |K phi| here, 1e-10 less than 1e-6)."""
    K, M = twin_chains()
    sigma = -10.0
    solve, _ = factorize((K - sigma * M).tocsc())
    kw = {} if tol is None else {"tol": tol}
    lam, vec, solves = block_lanczos(solve, M, sigma, 24, block=block, **kw)
    ref = reference(K, M, 24)
    np.testing.assert_allclose(lam, ref, rtol=1e-9)
    assert np.allclose(ref[0::2], ref[1::2], rtol=1e-12)  # the roots do come in pairs
    np.testing.assert_allclose(vec.T @ (M @ vec), np.eye(24), atol=1e-9)
    res = K @ vec - (M @ vec) * lam
    assert np.abs(res).max() <= residual * np.abs(K @ vec).max()
    assert solves >= 2


def test_the_basis_products_run_in_the_callers_wide_context():
    """``wide`` wraps the products over the whole basis at every step (where the caller
    gives them more BLAS threads than the solves), and the roots are the same."""
    from contextlib import contextmanager

    K, M = twin_chains()
    sigma = -10.0
    solve, _ = factorize((K - sigma * M).tocsc())
    entered: list[int] = []

    @contextmanager
    def wide():
        entered.append(1)
        yield

    lam, _, solves = block_lanczos(solve, M, sigma, 24, block=8, wide=wide)
    plain = block_lanczos(solve, M, sigma, 24, block=8)
    assert len(entered) == solves - 1  # every step after the start block
    np.testing.assert_allclose(lam, plain[0], rtol=1e-12)
    np.testing.assert_allclose(lam, reference(K, M, 24), rtol=1e-9)


def test_solve_modes_block_and_arpack_agree():
    K, M = twin_chains()
    req = EigenRequest(nd=16)
    a = solve_modes(K, M, req, method="block")
    b = solve_modes(K, M, req, method="arpack")
    np.testing.assert_allclose(a.eigenvalues, b.eigenvalues, rtol=1e-10)
    np.testing.assert_allclose(a.generalized_mass, 1.0, rtol=1e-10)
    with pytest.raises(ValueError, match="method 'lanczos'"):
        solve_modes(K, M, req, method="lanczos")


def test_too_small_a_basis_says_so_and_solve_modes_falls_back_to_arpack(monkeypatch):
    K, M = twin_chains()
    solve, _ = factorize((K + 10.0 * M).tocsc())
    with pytest.raises(LanczosNotConverged, match=r"of 30 roots converged with a basis of"):
        block_lanczos(solve, M, -10.0, 30, block=4, max_dim=40)
    import femcal.solve.eigen as modal

    real = modal.block_lanczos
    monkeypatch.setattr(modal, "block_lanczos",
                        lambda *a, **kw: real(*a, **{**kw, "max_dim": 40}))  # fmt: skip
    lines: list[str] = []
    res = solve_modes(K, M, EigenRequest(nd=20), progress=lines.append)
    assert any("ARPACK instead" in line for line in lines)
    np.testing.assert_allclose(res.eigenvalues, reference(K, M, 20), rtol=1e-9)


def test_an_unknown_factorisation_backend_is_an_error():
    K, _ = twin_chains(20)
    with pytest.raises(ValueError, match="backend 'umfpack': expected 'auto'"):
        factorize(K.tocsc(), backend="umfpack")


def test_more_roots_continue_on_the_same_basis():
    """enough() False: k doubles and the iteration goes on (no restart): the roots are those
    of the dense reference, and it takes fewer solves than two runs from scratch."""
    K, M = twin_chains()
    sigma = -10.0
    solve, _ = factorize((K - sigma * M).tocsc())
    ref = reference(K, M, 60)
    asked: list[int] = []

    def enough(lam):
        asked.append(len(lam))
        return len(lam) >= 40

    lam, vec, solves = block_lanczos(solve, M, sigma, 12, block=4, enough=enough)
    assert asked[0] == 12 and asked[-1] >= 40 and len(asked) >= 3  # 12 -> 24 -> 48
    np.testing.assert_allclose(lam, ref[: len(lam)], rtol=1e-9)
    np.testing.assert_allclose(vec.T @ (M @ vec), np.eye(len(lam)), atol=1e-9)
    fresh = sum(block_lanczos(solve, M, sigma, k, block=4)[2] for k in (12, 24, 48))
    assert solves < fresh


def test_v2_request_is_answered_in_one_block_iteration():
    """Every root below V2 (more than the first guess of 22): the same roots as the dense
    solver, and the block iteration is not started again."""
    K, M = twin_chains()
    ref = reference(K, M, 200)
    f2 = np.sqrt(0.5 * (ref[69] + ref[70])) / (2 * np.pi)  # 70 roots below V2
    lines: list[str] = []
    res = solve_modes(K, M, EigenRequest(v2=f2, nd=None), progress=lines.append)
    np.testing.assert_allclose(res.eigenvalues, ref[:70], rtol=1e-9)
    assert sum("Lanczos: " in line and "roots of" in line for line in lines) == 1
    assert any("going on" in line for line in lines)
    # the factor and the iteration's end are said (the steps of a long solve)
    assert any(line.startswith("K - sigma M factored (") for line in lines)
    ended = [line for line in lines if re.match(r"Lanczos: \d+ roots converged in \d+ block", line)]
    assert len(ended) == 1 and int(ended[0].split()[1]) >= 70


def test_independent_parts_follow_the_values_and_leave_the_matrices_alone(monkeypatch):
    """Two chains side by side are two parts, also when an explicit zero joins them; a
    coupling mass joins them; K and M are not changed (the graph is built on copies)."""
    import femcal.solve.parts as parts_module
    from femcal.solve.parts import independent_parts

    monkeypatch.setattr(parts_module, "PART_MIN", 100)
    K, M = twin_chains(300)
    assert [len(p) for p in independent_parts(K, M)] == [300, 300]
    np.testing.assert_array_equal(independent_parts(K, M)[1], np.arange(300, 600))
    c = K.tocoo()  # the same with a stored zero between the chains
    joined = sp.csr_matrix((np.r_[c.data, 0.0, 0.0],
                            (np.r_[c.row, 0, 300], np.r_[c.col, 300, 0])), shape=K.shape)
    assert joined.nnz == K.nnz + 2
    before = (joined.data.copy(), joined.indices.copy(), joined.indptr.copy())
    assert len(independent_parts(joined, M)) == 2
    for a, b in zip(before, (joined.data, joined.indices, joined.indptr), strict=True):
        np.testing.assert_array_equal(a, b)
    Mc = M.tolil()
    Mc[299, 300] = Mc[300, 299] = 0.1  # a consistent mass across
    assert len(independent_parts(K, sp.csr_matrix(Mc))) == 1
    # a small set of DOF is gathered with the other small ones, not a part of its own
    small = sp.block_diag([K, sp.identity(50)]).tocsr()
    assert [len(p) for p in independent_parts(small, sp.block_diag([M, sp.identity(50)]))] \
        == [300, 300, 50]  # fmt: skip
    monkeypatch.setattr(parts_module, "PART_MIN", 400)
    assert len(independent_parts(K, M)) == 1  # parts below PART_MIN are not split


def test_independent_parts_join_sets_an_entry_joins_one_way_only(monkeypatch):
    """An entry stored on one side of the diagonal only (a pattern that is not symmetric)
    joins two sets as an entry on both sides does: the strong search's two sets become one
    part."""
    import femcal.solve.parts as parts_module
    from femcal.solve.parts import independent_parts

    monkeypatch.setattr(parts_module, "PART_MIN", 100)
    K, M = twin_chains(300)
    c = K.tocoo()
    for row, col in ((0, 300), (300, 0), (150, 450)):
        one_way = sp.csr_matrix((np.r_[c.data, 1e-30], (np.r_[c.row, row], np.r_[c.col, col])),
                                shape=K.shape)  # fmt: skip
        assert [len(p) for p in independent_parts(one_way, M)] == [600]


def test_independent_parts_are_ordered_by_their_lowest_dof_whatever_the_search_numbers(
        monkeypatch):  # fmt: skip
    """Parts of equal size come in the order of their lowest DOF (which part a forked worker
    takes depends on it), also when the graph search numbers its sets the other way."""
    import femcal.solve.parts as parts_module
    from femcal.solve.parts import independent_parts

    monkeypatch.setattr(parts_module, "PART_MIN", 100)
    K, M = twin_chains(300)
    found = independent_parts(K, M)
    real = parts_module.connected_components

    def reversed_labels(*args, **kwargs):
        count, label = real(*args, **kwargs)
        return count, count - 1 - label

    monkeypatch.setattr(parts_module, "connected_components", reversed_labels)
    again = independent_parts(K, M)
    assert [p[0] for p in again] == [0, 300]
    for a, b in zip(found, again, strict=True):
        np.testing.assert_array_equal(a, b)


def test_independent_parts_are_joined_where_k_and_m_cancel_and_by_duplicates(monkeypatch):
    """An entry where K_ij = -M_ij joins two sets (the patterns' union, not the values' sum,
    decides), and so do duplicated entries that cancel. A matrix with duplicates is split as
    its canonical form is: the graph searched is canonical (SciPy's strong search never
    ends on a duplicated entry)."""
    import femcal.solve.parts as parts_module
    from femcal.solve.parts import _coupling, independent_parts

    monkeypatch.setattr(parts_module, "PART_MIN", 100)
    K, M = twin_chains(300)
    K, Mc = K.tolil(), (4.0 * sp.identity(600)).tolil()
    K[0, 300] = K[300, 0] = -2.0
    Mc[0, 300] = Mc[300, 0] = 2.0
    assert [len(p) for p in independent_parts(K.tocsr(), Mc.tocsr())] == [600]
    # every entry stored twice, half each: the same parts as the matrix itself
    K, M = twin_chains(300)
    c = K.tocoo()

    def raw_csr(rows, cols, vals):  # duplicates kept (SciPy's COO conversion sums them)
        order = np.argsort(rows, kind="stable")
        indptr = np.r_[0, np.cumsum(np.bincount(rows, minlength=600))]
        return sp.csr_matrix((vals[order], cols[order], indptr), shape=(600, 600))

    twice = raw_csr(np.r_[c.row, c.row], np.r_[c.col, c.col], np.r_[c.data, c.data] / 2)
    assert not twice.has_canonical_format
    assert _coupling(twice).has_canonical_format
    assert [len(p) for p in independent_parts(twice, M)] == [300, 300]
    # a duplicate pair that cancels still couples (as it did)
    cancel = raw_csr(np.r_[c.row, 0, 0, 300, 300], np.r_[c.col, 300, 300, 0, 0],
                     np.r_[c.data, 1.0, -1.0, 1.0, -1.0])  # fmt: skip
    assert [len(p) for p in independent_parts(cancel, M)] == [600]


def one_process(monkeypatch) -> None:
    """Solve the parts in this process alone (no forked worker shares them)."""
    import femcal.solve.eigen as modal

    monkeypatch.setattr(modal, "_fork_factors", lambda backend: False)


def soft_and_stiff(n: int = 700) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """A chain of n DOF beside the same chain 1e4 times stiffer: the stiff one's lowest
    root lies above the soft one's 60 lowest."""
    K, M = twin_chains(n)
    stiff = sp.diags(np.r_[np.ones(n), np.full(n, 1e4)])
    return sp.csr_matrix(stiff @ K), M


@pytest.mark.parametrize("request_", [EigenRequest(nd=20), EigenRequest(nd=None, v2=None)])
def test_a_part_without_wanted_roots_is_not_iterated_on(monkeypatch, request_):
    """Solved part by part, the roots are the dense reference's; the stiff part's lowest
    root, checked, lies above what the request reaches, so only the soft part gets a basis.
    For a V2 request the bound is V2 from the start."""
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    one_process(monkeypatch)
    K, M = soft_and_stiff()
    ref = reference(K, M, 40)
    if request_.nd is None:  # every root below a V2 between the 30th and 31st
        request_ = EigenRequest(nd=None, v2=np.sqrt(0.5 * (ref[29] + ref[30])) / (2 * np.pi))
    lines: list[str] = []
    res = solve_modes(K, M, request_, progress=lines.append)
    want = 20 if request_.nd else 30
    np.testing.assert_allclose(res.eigenvalues, ref[:want], rtol=1e-9)
    assert any("2 independent parts (700, 700 DOF)" in line for line in lines)
    # each part's factor and check is said as it ends (the steps of a long solve)
    for k in (1, 2):
        assert any(line.startswith(f"part {k} of 2 (700 DOF): K - sigma M factored (")
                   for line in lines)  # fmt: skip
        assert any(line.startswith(f"part {k} of 2: its lowest root lies at ") for line in lines)
    assert sum("Lanczos: " in line and "roots of 700 DOF" in line for line in lines) == 1
    assert any("no root of it is wanted" in line for line in lines)
    assert np.all(res.vectors[700:] == 0.0)  # the soft chain's modes
    res_k = K @ res.vectors - (M @ res.vectors) * res.eigenvalues
    assert np.abs(res_k).max() <= 1e-4 * np.abs(K @ res.vectors).max()


def test_parts_with_the_same_roots_give_every_copy(monkeypatch):
    """Two identical chains, each a part: every root twice, as the dense reference has them,
    and the factor handed to the caller solves with the whole K - sigma M."""
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    K, M = twin_chains(700)
    kept: list = []
    res = solve_modes(K, M, EigenRequest(nd=16), on_factor=lambda s, sig: kept.append((s, sig)))
    ref = reference(K, M, 16)
    np.testing.assert_allclose(res.eigenvalues, ref, rtol=1e-9)
    assert np.allclose(ref[0::2], ref[1::2], rtol=1e-12)
    np.testing.assert_allclose(res.vectors.T @ (M @ res.vectors), np.eye(16), atol=1e-9)
    (solve, sigma), = kept
    b = np.random.default_rng(1).standard_normal((1400, 3))
    A = (K - sigma * M).tocsc()
    np.testing.assert_allclose(A @ solve(b), b, atol=1e-9 * np.abs(b).max())
    np.testing.assert_allclose(A @ solve(b[:, 0]), b[:, 0], atol=1e-9 * np.abs(b).max())


def test_a_part_whose_check_does_not_converge_is_solved(monkeypatch):
    """The check of a part's lowest root bounds nothing when it does not converge: the part
    is then solved as any, and the roots are the dense reference's."""
    import femcal.solve.eigen as modal
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    real = modal.block_lanczos

    def failing_check(solve, M, sigma, k, **kw):
        if k == 1:
            raise LanczosNotConverged("no convergence", 0)
        return real(solve, M, sigma, k, **kw)

    monkeypatch.setattr(modal, "block_lanczos", failing_check)
    one_process(monkeypatch)
    K, M = soft_and_stiff()
    lines: list[str] = []
    res = solve_modes(K, M, EigenRequest(nd=20), progress=lines.append)
    np.testing.assert_allclose(res.eigenvalues, reference(K, M, 20), rtol=1e-9)
    assert sum("Lanczos: " in line and "roots of 700 DOF" in line for line in lines) == 2


def same_modes(a, b, M) -> None:
    """The same roots and mass-normalised modes, to rounding (the same code in two
    processes: no check of the bits a factorisation decides)."""
    np.testing.assert_allclose(a.eigenvalues, b.eigenvalues, rtol=1e-10)
    np.testing.assert_allclose(np.abs(np.diag(a.vectors.T @ (M @ b.vectors))), 1.0, atol=1e-8)


def _shared_and_alone(monkeypatch, K, M, request, **kw) -> tuple:
    """(lines, result) of the parts shared with a forked worker, then the result in one
    process."""
    import femcal.solve.eigen as modal

    monkeypatch.setattr(modal, "_fork_factors", lambda backend: True)
    lines: list[str] = []
    shared = solve_modes(K, M, request, progress=lines.append, **kw)
    one_process(monkeypatch)
    alone = solve_modes(K, M, request, **kw)
    return lines, shared, alone


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
@pytest.mark.parametrize("worker_holds", ["soft", "stiff"])
def test_parts_shared_with_a_forked_worker_give_one_processs_roots(monkeypatch, worker_holds):
    """The parts factored and checked in two processes at once: whether the worker holds the
    part whose roots are wanted (its roots come back) or the one ranked out (it is stopped),
    the roots and vectors are one process's, and the dense reference's."""
    import femcal.solve.eigen as modal
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    soft_here = worker_holds == "stiff"
    monkeypatch.setattr(modal, "_shares", lambda parts: ([0], [1]) if soft_here else ([1], [0]))
    K, M = soft_and_stiff()
    lines, shared, alone = _shared_and_alone(monkeypatch, K, M, EigenRequest(nd=20))
    assert any("2 independent parts (700, 700 DOF): shared with a forked process" in line
               for line in lines)  # fmt: skip
    assert any("(cholmod, in the forked process)" in line or
               "(superlu, in the forked process)" in line for line in lines)  # fmt: skip
    assert any(line.startswith("part 2 of 2 (700 DOF) has its lowest root at")
               and "no root of it is wanted" in line for line in lines)  # fmt: skip
    same_modes(shared, alone, M)
    np.testing.assert_allclose(shared.eigenvalues, reference(K, M, 20), rtol=1e-9)
    assert np.all(shared.vectors[700:] == 0.0)  # the soft chain's modes


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
@pytest.mark.parametrize("method", ["block", "arpack"])
def test_the_workers_lone_part_is_bounded_by_its_own_iteration(monkeypatch, method):
    """A worker with one part runs no separate check of it: its block Lanczos bounds the
    lowest root on the way, said as the check would say it (ARPACK, which gives no bound
    before its end, keeps the check); the ranking and the roots are one process's."""
    import femcal.solve.eigen as modal
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    monkeypatch.setattr(modal, "_shares", lambda parts: ([1], [0]))  # the soft chain there
    here = os.getpid()
    real = modal._lowest_root

    def checked_here_only(*args):
        if os.getpid() != here and method == "block":
            raise RuntimeError("the worker checked its lone part")
        return real(*args)

    monkeypatch.setattr(modal, "_lowest_root", checked_here_only)
    K, M = soft_and_stiff()
    lines, shared, alone = _shared_and_alone(monkeypatch, K, M, EigenRequest(nd=20),
                                             method=method)  # fmt: skip
    bound = [line for line in lines if line.startswith("part 1 of 2: its lowest root lies at")]
    assert len(bound) == 1
    assert float(bound[0].split(" at ")[1].split()[0]) <= shared.frequencies_hz[0]
    assert any(line.startswith("part 2 of 2 (700 DOF) has its lowest root at")
               and "no root of it is wanted" in line for line in lines)  # fmt: skip
    same_modes(shared, alone, M)
    np.testing.assert_allclose(shared.eigenvalues, reference(K, M, 20), rtol=1e-9)


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
def test_a_lone_part_that_fails_before_its_bound_is_still_ranked_out(monkeypatch):
    """The worker's lone part fails in its iteration before a bound (here: too little memory
    for its basis): the check bounds it instead, this process ranks it out (its roots lie
    above those wanted) and never sees the failure, as when the check ran first."""
    import femcal.solve.eigen as modal
    import femcal.solve.parts as parts_module
    from femcal.errors import ResourceError

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    monkeypatch.setattr(modal, "_shares", lambda parts: ([0], [1]))  # the stiff chain there
    here = os.getpid()
    real = modal.check_memory

    def no_memory_there(*args, **kwargs):
        if os.getpid() != here:
            raise ResourceError("no memory in the worker")
        return real(*args, **kwargs)

    monkeypatch.setattr(modal, "check_memory", no_memory_there)
    K, M = soft_and_stiff()
    lines, shared, alone = _shared_and_alone(monkeypatch, K, M, EigenRequest(nd=20))
    assert any(line.startswith("part 2 of 2: its lowest root lies at") for line in lines)
    assert any(line.startswith("part 2 of 2 (700 DOF) has its lowest root at")
               and "no root of it is wanted" in line for line in lines)  # fmt: skip
    same_modes(shared, alone, M)


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
def test_equal_roots_of_two_parts_come_in_the_parts_order_on_either_path(monkeypatch):
    """Two identical parts have equal roots: their vectors come in the parts' order whether
    a forked worker found half of them or not (their bounds, from a check here and from the
    worker's Lanczos there, differ in their last digits)."""
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    K, M = twin_chains(700)
    _, shared, alone = _shared_and_alone(monkeypatch, K, M, EigenRequest(nd=16))
    np.testing.assert_allclose(shared.eigenvalues, alone.eigenvalues, rtol=1e-10)
    for modes in (shared, alone):
        first = (modes.vectors[:700] != 0).any(axis=0)
        np.testing.assert_array_equal(first, np.arange(16) % 2 == 0)  # part 1's, then 2's
    np.testing.assert_allclose(np.abs(np.diag(shared.vectors.T @ (M @ alone.vectors))), 1.0,
                               atol=1e-8)  # fmt: skip


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
def test_parts_both_wanted_and_shared_give_every_root(monkeypatch):
    """Two chains whose roots interleave, each a part and each iterated on (one here, one in
    the worker, at the same time): every root of both, as one process and the dense
    reference have them."""
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    K, M = twin_chains(700)
    K = sp.csr_matrix(sp.diags(np.r_[np.ones(700), np.full(700, 1.3)]) @ K)
    lines, shared, alone = _shared_and_alone(monkeypatch, K, M, EigenRequest(nd=24))
    assert sum(line.startswith("Lanczos: ") and "roots converged" in line
               for line in lines) == 2  # fmt: skip
    same_modes(shared, alone, M)
    np.testing.assert_allclose(shared.eigenvalues, reference(K, M, 24), rtol=1e-9)
    assert (shared.vectors[:700] != 0).any(axis=0).sum() > 0
    assert (shared.vectors[700:] != 0).any(axis=0).sum() > 0
    np.testing.assert_allclose(shared.vectors.T @ (M @ shared.vectors), np.eye(24), atol=1e-9)


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
@pytest.mark.parametrize("bad_part", [0, 1])
def test_a_part_that_cannot_be_factored_is_named_wherever_it_is_factored(monkeypatch,
                                                                       bad_part):  # fmt: skip
    """The solver's error for a part whose K - sigma M cannot be factored comes out the
    same whether this process or the forked worker factors it (the worker's error is
    raised here, and the worker ended)."""
    import femcal.solve.eigen as modal
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    monkeypatch.setattr(modal, "_fork_factors", lambda backend: True)
    K, M = twin_chains(700)
    scale = np.ones(1400)
    scale[700 * bad_part: 700 * (bad_part + 1)] = 2.0  # marks the part that fails
    K = sp.csr_matrix(sp.diags(scale) @ K)
    real = modal._shifted_factor

    def failing(Kp, Mp, sigma, factoring):
        if Kp[0, 0] == K[700 * bad_part, 700 * bad_part]:
            raise SolverError(f"K - sigma M is singular (part of {Kp.shape[0]} DOF, pid "
                              f"{os.getpid()})")  # fmt: skip
        return real(Kp, Mp, sigma, factoring)

    monkeypatch.setattr(modal, "_shifted_factor", failing)
    with pytest.raises(SolverError, match=r"K - sigma M is singular \(part of 700 DOF, pid"
                       ) as caught:  # fmt: skip
        solve_modes(K, M, EigenRequest(nd=10))
    in_worker = f"pid {os.getpid()})" not in str(caught.value)
    assert in_worker == (bad_part == 1)  # the worker holds the second part


def chains(scales: list[float], n: int = 700) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Spring chains of n DOF side by side, the k-th stiffened by scales[k]."""
    K1, M1 = twin_chains(n)
    K1, M1 = K1[:n, :n], M1[:n, :n]
    K = sp.block_diag([s * K1 for s in scales]).tocsr()
    return K, sp.block_diag([M1] * len(scales)).tocsr()


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
@pytest.mark.parametrize("request_", [EigenRequest(nd=24), EigenRequest(nd=None, v2=None)])
def test_several_parts_on_each_side_give_one_processs_roots(monkeypatch, request_):
    """Four parts, two here and two in the worker (the worker iterates on both of its own),
    one of them ranked out; for an ND and a V2 request the roots are one process's and the
    dense reference's."""
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    K, M = chains([1.0, 1.3, 1e4, 2.0])
    ref = reference(K, M, 60)
    if request_.nd is None:  # every root below a V2 between the 30th and 31st
        request_ = EigenRequest(nd=None, v2=np.sqrt(0.5 * (ref[29] + ref[30])) / (2 * np.pi))
    lines, shared, alone = _shared_and_alone(monkeypatch, K, M, request_)
    assert any("4 independent parts" in line and "shared with a forked process" in line
               for line in lines)  # fmt: skip
    assert any(line.startswith("part 3 of 4 (700 DOF) has its lowest root")
               for line in lines)  # fmt: skip
    same_modes(shared, alone, M)
    want = 24 if request_.nd else 30
    np.testing.assert_allclose(shared.eigenvalues, ref[:want], rtol=1e-9)
    assert np.all(shared.vectors[1400:2100] == 0.0)  # none of the stiff chain's


@pytest.mark.skipif(os.name != "posix", reason="the worker is forked")
def test_a_failed_fork_solves_every_part_here(monkeypatch):
    import femcal.solve.eigen as modal
    import femcal.solve.parts as parts_module

    monkeypatch.setattr(parts_module, "PART_MIN", 500)
    monkeypatch.setattr(modal, "_fork_factors", lambda backend: True)

    def no_fork(*args, **kw):
        raise OSError(12, "Cannot allocate memory")

    monkeypatch.setattr(modal, "ForkedPeer", no_fork)
    K, M = soft_and_stiff()
    lines: list[str] = []
    res = solve_modes(K, M, EigenRequest(nd=20), progress=lines.append)
    assert any("2 independent parts (700, 700 DOF): solved one by one" in line
               for line in lines)  # fmt: skip
    np.testing.assert_allclose(res.eigenvalues, reference(K, M, 20), rtol=1e-9)
