"""Block shift-invert Lanczos against a dense reference: repeated roots, massless DOF, the
ARPACK fallback."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse as sp

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
