"""Building the surrogate (:class:`~femcal.calibrate.surrogate.Surrogate`): the full model's
modes at the centre, the basis enriched with static eigenvector-derivative vectors or the
static responses to the inputs, and each element group's polynomial terms reduced on that
basis and re-expanded about the centre."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..assembly import Options, assemble
from ..model import EigenRequest
from ..model.model import Model
from ..response.frf import channel_matrix
from ..response.modal import QUANTITIES
from ..solve.factor import NotPositiveDefinite, factorize
from ..solve.normal_modes import solve_normal_modes
from .derivatives import (
    GroupPolynomial,
    group_polynomials,
    polynomial_derivative,
    shift_weight,
    touched_rows,
)
from .gradient import centre_derivatives
from .parameters import Parameter, with_values
from .surrogate import ORDERS, STATIC_SHIFT, Surrogate

#: Derivative vectors whose own eigenvalue is above this times the basis's largest are
#: dropped (frequencies 100 times the basis's top).
STIFF_CUTOFF = 1e4


def _reexpand(polys: list[GroupPolynomial], Phi: np.ndarray, center: np.ndarray, n_p: int, *,
              first_order: bool) -> tuple[list, list, list]:  # fmt: skip
    """Reduce each group's terms about p = 0 on the basis and re-expand them about the
    centre: ``C'_b = sum_{a >= b} C_a prod_i binom(a_i, b_i) c_i^(a_i - b_i)``; returns
    exponents (n_p,), reduced K and M of the non-constant terms (first order only if asked)."""
    exps, Kt, Mt = [], [], []
    for g in polys:
        idx = list(g.params)
        # a group's matrices touch only its elements' DOF: reduce on those rows of Phi
        rows = touched_rows(g.K + g.M)
        P = np.ascontiguousarray(Phi[rows])

        def on_basis(A, rows=rows, P=P) -> np.ndarray:
            return P.T @ (A[rows][:, rows] @ P) if A.nnz else np.zeros((P.shape[1],) * 2)

        Ks, Ms = _reduced_all(g.K, on_basis), _reduced_all(g.M, on_basis)
        red = {tuple(a): (Kr, Mr) for a, Kr, Mr in zip(g.exponents, Ks, Ms, strict=True)}
        c = center[idx]
        for b in red:
            if sum(b) == 0 or (first_order and sum(b) > 1):
                continue
            Kb = np.zeros_like(red[b][0])
            Mb = np.zeros_like(red[b][1])
            for a, (Ka, Ma) in red.items():
                w = shift_weight(a, b, c)
                if w:
                    Kb += w * Ka
                    Mb += w * Ma
            e = np.zeros(n_p, int)
            e[idx] = b
            exps.append(e)
            Kt.append(Kb)
            Mt.append(Mb)
    return exps, Kt, Mt


def _reduced_all(mats: list, on_basis: Callable) -> list[np.ndarray]:
    """``on_basis`` of each matrix, a matrix that is a multiple of an earlier one (a term of a
    parameter that scales the group: the same index arrays, proportional data) reduced as
    that multiple of the earlier one's reduction."""
    out: list[np.ndarray] = []
    done: list[tuple[object, np.ndarray, np.ndarray]] = []  # (matrix, probe places, reduced)
    for A in mats:
        reduced = None
        for B, probe, RB in done:
            factor = _proportion(A, B, probe)
            if factor is not None:
                reduced = factor * RB
                break
        if reduced is None:
            reduced = on_basis(A)
            if A.nnz:
                n = len(A.data)
                done.append((A, np.array([np.argmax(np.abs(A.data)), n // 3, n // 2]), reduced))
        out.append(reduced)
    return out


def _proportion(A, B, probe: np.ndarray) -> float | None:
    """f with A = f B to rounding, if A and B share their index arrays (else None): the
    ratio at a few places first, then every entry."""
    if A.nnz != B.nnz or A.indices is not B.indices or A.indptr is not B.indptr:
        return None
    factor = A.data[probe[0]] / B.data[probe[0]]
    scale = float(np.abs(A.data[probe[0]]))
    if np.abs(A.data[probe] - factor * B.data[probe]).max() > 1e-14 * scale:
        return None
    if np.abs(A.data - factor * B.data).max() > 1e-14 * scale:
        return None
    return float(factor)


def _mass_root(M) -> sp.csr_matrix | None:
    """R (n_m, n) with R^T R = M when M is diagonal (lumped mass): the n_m rows with mass,
    scaled by the root of their mass. None when M has off-diagonal terms."""
    M = sp.csr_matrix(M)
    d = M.diagonal()
    if (d < 0).any() or M.count_nonzero() != np.count_nonzero(d):
        return None
    rows = np.flatnonzero(d)
    return sp.csr_matrix((np.sqrt(d[rows]), (np.arange(len(rows)), rows)),
                         shape=(len(rows), M.shape[0]))  # fmt: skip


def _gram(Y: np.ndarray) -> np.ndarray:
    """Y^T Y (k, k) of Y (n, k) by a symmetric rank-k update (half a general product)."""
    upper = sla.blas.dsyrk(1.0, np.asfortranarray(Y.T) if not Y.T.flags.f_contiguous else Y.T)
    return np.triu(upper) + np.triu(upper, 1).T


def _m_compress(X: np.ndarray, M, Phi: np.ndarray, n_keep: int) -> np.ndarray:
    """The at most ``n_keep`` strongest directions of X (n_g, k), unit-normalised, after
    making it M-orthogonal to the M-orthonormal basis Phi (n_g, r): (n_g, q) M-orthonormal
    columns, M-orthogonal to Phi. Directions below 1e-10 of the strongest are dropped. X is
    overwritten when M is not diagonal.
    """
    # X' = X - Phi C, M-orthogonal to the basis (two passes: the static vectors lie mostly in
    # the basis, so one pass leaves rounding behind), and the Gram matrix X'^T M X'
    R = _mass_root(M)
    if R is not None:  # lumped mass: the M-products run over the rows with mass only
        Y, P = R @ X, R @ Phi
        C = np.zeros((Phi.shape[1], X.shape[1]))
        for _ in range(2):
            D = P.T @ Y
            Y -= P @ D
            C += D
        del P
        norms = np.sqrt(np.einsum("nk,nk->k", Y, Y))
        G = _gram(Y)
        del Y
    else:
        C = None
        for _ in range(2):
            X -= Phi @ (Phi.T @ (M @ X))
        MX = M @ X
        norms = np.sqrt(np.maximum(np.einsum("nk,nk->k", X, MX), 0.0))
        G = X.T @ MX
        del MX
    # the strongest directions of the unit-normalised set
    big = norms > 1e-12 * max(float(norms.max()), 1e-300)
    G = G[np.ix_(big, big)] / np.outer(norms[big], norms[big])
    w, V = np.linalg.eigh(0.5 * (G + G.T))
    order = np.argsort(w)[::-1]
    w, V = w[order], V[:, order]
    keep = w > 1e-10 * w[0]
    keep[n_keep:] = False
    W = V[:, keep] / np.sqrt(w[keep]) / norms[big][:, None]
    Q = X[:, big] @ W
    if C is not None:
        Q -= Phi @ (C[:, big] @ W)
    Q -= Phi @ (Phi.T @ (M @ Q))
    return Q


def derivative_vectors(polys: list[GroupPolynomial], center: np.ndarray, K: object,
                       M: object, red: object, Phi: np.ndarray, lam_basis: np.ndarray,
                       m: int, n_keep: int, depth: int = 2,
                       solve: Callable | None = None) -> np.ndarray:  # fmt: skip
    """Static eigenvector-derivative vectors to enrich a modal basis.

    The part of a mode's derivative dphi_i/dp_j outside the basis Phi is, up to terms in
    lam_i / lam_k of the modes k not in the basis, ``(K - s M)^-1 (dK_j - lam_i dM_j) phi_i``
    (s a small negative shift); ``depth`` terms of the series
    ``(K - lam M)^-1 = K^-1 + lam K^-1 M K^-1 + ...`` are taken. These vectors for the first
    m modes and every parameter, M-orthogonalised against Phi (n_g, r) and compressed to
    the ``n_keep`` strongest directions of the unit-normalised set, make the Rayleigh-Ritz
    surrogate's eigenvector derivatives (and so its FRF Jacobian) right at the centre, where
    the modes alone truncate them.

    Parameters
    ----------
    K, M : g-set matrices at the centre (sparse). red : the constraint reduction
        (:class:`femcal.assembly.constraints.Reduction`): the solves are on its a-set.
    Phi : (n_g, r) M-orthonormal basis at the centre whose first len(lam_basis) columns are
        the modes, lam_basis their eigenvalues; the first m modes get derivative vectors.
    solve : a factor of the a-set's K - STATIC_SHIFT M if one is at hand (the eigen
        solution's, :func:`femcal.solve.eigen.solve_modes` ``on_factor``); factored here if not.

    Returns
    -------
    (n_g, q) M-orthonormal vectors, M-orthogonal to Phi, q <= n_keep.
    """
    lam = lam_basis[:m]
    Ka, Ma = red.reduce(K), red.reduce(M)
    if solve is None:
        solve, _ = factorize((Ka - STATIC_SHIFT * Ma).tocsc())
    Tt = red.T.T.tocsr()
    cols = []
    for j in range(center.size):
        dKX, dMX = polynomial_derivative(polys, center, j, Phi[:, :m])
        F = Tt @ (dKX - dMX * lam[None, :])
        if not np.any(F):
            continue
        Y = solve(F)
        cols.append(red.T @ Y)
        for _ in range(1, depth):  # (K - lam M)^-1 = K^-1 + lam K^-1 M K^-1 + ...
            Y = solve(Ma @ Y)
            cols.append(red.T @ Y)
    if not cols:
        return np.zeros((Phi.shape[0], 0))
    X = np.hstack(cols)
    del cols
    Q = _m_compress(X, M, Phi, n_keep)
    # the vectors' own modes (K- and M-orthogonal); those far above the basis (stiff
    # directions: axial bars, springs, drilling) are dropped: they add ~lam_i / theta to the
    # derivatives and would spoil the small eigenproblem's accuracy (its error is ~eps times
    # its largest eigenvalue)
    theta, U = sla.eigh(Q.T @ (K @ Q), Q.T @ (M @ Q))
    keep = theta <= STIFF_CUTOFF * float(np.max(np.abs(lam_basis)))
    return Q @ U[:, keep]


def stiffness_solve(K: object, red: object) -> Callable[[np.ndarray], np.ndarray]:
    """A factor of the a-set's K (unshifted) for static solves.

    Raises
    ------
    ValueError
        When K is singular (a free model has no static flexibility).
    """
    try:
        solve, _ = factorize(red.reduce(K).tocsc())
    except NotPositiveDefinite:
        raise ValueError("the residual flexibility needs a restrained model (K is singular: "
                         "free-free, or a mechanism)") from None  # fmt: skip
    return solve


def static_vectors(polys: list[GroupPolynomial], center: np.ndarray, solve: Callable,
                   red: object, Bg: object) -> np.ndarray:  # fmt: skip
    """The static responses to the inputs, X = K^-1 B_g^T (n_g, n_in), and their parameter
    derivatives ``-K^-1 dK/dp_j X`` for every parameter: (n_g, n_in (1 + n_p)) at most.
    ``solve`` is the a-set's K^-1 (:func:`stiffness_solve`)."""
    Tt = red.T.T.tocsr()
    B = np.asarray(sp.csr_matrix(Bg).T.todense())  # (n_g, n_in)
    X = red.T @ solve(Tt @ B)
    cols = [X]
    for j in range(center.size):
        dKX, _ = polynomial_derivative(polys, center, j, X)
        if np.any(dKX):
            cols.append(red.T @ solve(Tt @ dKX))
    return np.hstack(cols)


def build_surrogate(model: Model, params: list[Parameter], p_center: np.ndarray,
                    outputs: Sequence, inputs: Sequence, *, n_modes: int = 100,
                    zeta: float = 0.01, quantity: str = "accelerance", order: str = "exact",
                    polynomials: list | None = None, options: Options | None = None,
                    enrich_hz: float | None = None, n_enrich: int | None = None,
                    residual: bool = False, frf_modes: int | None = None,
                    frf_hz: float | None = None, exact_gradient: bool = False,
                    centre_only: bool = False, beside_ok: bool = False,
                    progress: Callable[[str], None] | None = None,
                    ) -> tuple[Surrogate, object]:  # fmt: skip
    """Reduce the (nominal) model at ``p_center`` on its first ``n_modes`` modes there.

    Parameters
    ----------
    outputs, inputs : channels (``femcal.testdata.data.Channel``) of the test data.
    order : ``exact`` (every polynomial term) or ``first-order`` (FEMCali's).
    polynomials : the model's group polynomials about p = 0 with their constant terms
        (:func:`femcal.calibrate.derivatives.group_polynomials` with ``constant=True``);
        computed here if not given. They do not depend on the centre, so a run computes
        them once and reduces them on each new basis.
    enrich_hz : with it, the basis gets static eigenvector-derivative vectors of the modes
        up to this frequency (:func:`derivative_vectors`), at most ``n_enrich`` of them
        (default ``n_modes``); the FRFs still sum the ``n_modes`` lowest modes. This makes
        the Jacobian right at the centre (the modes alone truncate the eigenvector
        derivatives), which the trust-region cycles near the solution need.
    residual : the FRFs get the residual flexibility of the modes beyond the ``frf_modes``
        lowest (as :func:`femcal.response.frf.residual_flexibility`), the basis the static responses
        to the inputs and their parameter derivatives (:func:`static_vectors`). Needs a
        restrained model.
    frf_modes : the FRFs sum this many lowest modes (default ``n_modes``); with
        ``residual`` the others enter as residual flexibility. Or ``frf_hz``: the modes up
        to this frequency at the centre (at least one).
    exact_gradient : also compute the full model's exact FRF derivatives at the centre
        (:func:`femcal.calibrate.gradient.centre_derivatives`), kept as ``Surrogate.exact``.
    centre_only : the surrogate is wanted at its centre only (the full model's FRFs there):
        its basis is the same, but the polynomial terms are not reduced on it, so that it
        does not depend on the parameters (its FRFs at the centre are the same numbers).
    beside_ok : the exact derivatives may use a forked process beside this one
        (:func:`femcal.calibrate.gradient.centre_derivatives`).

    Returns
    -------
    The surrogate and the full model's modes at the centre
    (:class:`femcal.solve.normal_modes.Modes`).
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}")
    if order not in ORDERS:
        raise ValueError(f"order must be one of {', '.join(ORDERS)}, not {order!r}")
    say = progress or (lambda _m: None)
    values = [par.value(p) for par, p in zip(params, p_center, strict=True)]
    model_c = with_values(model, params, values)
    mats = assemble(model_c, options)
    factor: dict = {}

    def keep_factor(solve: Callable, sigma: float) -> None:
        if abs(sigma - STATIC_SHIFT) <= 1e-12 * abs(STATIC_SHIFT):
            factor["solve"] = solve

    modes, red = solve_normal_modes(model_c, matrices=mats, request=EigenRequest(nd=n_modes),
                              on_factor=keep_factor if enrich_hz is not None or exact_gradient
                              else None)  # fmt: skip
    Phi = modes.shapes  # (n_g, r), mass-normalised
    n_frf = Phi.shape[1]
    if frf_hz is not None:
        if frf_modes is not None:
            raise ValueError("give frf_modes or frf_hz, not both")
        frf_modes = max(int(np.searchsorted(modes.frequencies_hz, frf_hz, side="right")), 1)
    if frf_modes is not None:
        if not 1 <= frf_modes <= n_frf:
            raise ValueError(f"frf_modes = {frf_modes}: expected 1 to the {n_frf} modes solved")
        n_frf = int(frf_modes)
    say(f"surrogate: {Phi.shape[1]} modes up to {modes.frequencies_hz[-1]:.1f} Hz; the "
        f"{order} dependence of K and M on {len(params)} parameters")
    if polynomials is None:
        polynomials = group_polynomials(model, params, np.zeros(len(params)), options=options,
                                        constant=True)  # fmt: skip
    Cg = channel_matrix(model, outputs)
    Bg = channel_matrix(model, inputs)
    n_basis_modes = Phi.shape[1]
    if enrich_hz is not None:
        m = int(np.searchsorted(modes.frequencies_hz, enrich_hz, side="right"))
        if m:
            extra = derivative_vectors(polynomials, np.asarray(p_center, float), mats.K,
                                       mats.M, red, Phi, modes.eigenvalues[:n_basis_modes], m,
                                       n_enrich or n_modes,
                                       solve=factor.get("solve"))  # fmt: skip
            Phi = np.hstack([Phi, extra])
            say(f"surrogate basis enriched: {extra.shape[1]} static eigenvector-derivative "
                f"vectors of the {m} modes up to {enrich_hz:g} Hz (the stiffer ones dropped)")
    static_solve = None
    if residual:
        if (modes.eigenvalues <= 0).any():
            raise ValueError("the residual flexibility needs a restrained model: a basis mode "
                             "is a rigid-body mode")  # fmt: skip
        static_solve = stiffness_solve(mats.K, red)
        X = static_vectors(polynomials, np.asarray(p_center, float), static_solve, red, Bg)
        block = _m_compress(X, mats.M, Phi, n_keep=X.shape[1])
        Phi = np.hstack([Phi, block])
        say(f"surrogate basis: {block.shape[1]} static responses to the inputs and their "
            "parameter derivatives (residual flexibility)")
    exps, Kt, Mt = ([], [], []) if centre_only else _reexpand(
        polynomials, Phi, np.asarray(p_center, float), len(params),
        first_order=order == "first-order")  # fmt: skip
    r = Phi.shape[1]
    K0 = Phi.T @ (mats.K @ Phi)
    M0 = Phi.T @ (mats.M @ Phi)
    sur = Surrogate(np.asarray(p_center, float), 0.5 * (K0 + K0.T), 0.5 * (M0 + M0.T),
                    np.array(exps, int).reshape(-1, len(params)),
                    np.array(Kt).reshape(-1, r, r), np.array(Mt).reshape(-1, r, r),
                    np.asarray(Cg @ Phi), np.asarray(Bg @ Phi), float(zeta), quantity,
                    modes.frequencies_hz.copy(), n_frf, residual)  # fmt: skip
    if exact_gradient:
        exact = centre_derivatives(polynomials, np.asarray(p_center, float), mats.M, red,
                                   modes.shapes, modes.eigenvalues, Cg, Bg, n_frf,
                                   shifted_solve=factor.get("solve"), static_solve=static_solve,
                                   residual=residual, K=mats.K,
                                   beside_ok=beside_ok)  # fmt: skip
        sur = replace(sur, exact=exact)
        say(f"the full model's exact FRF derivatives at the centre ({exact.terms} series terms "
            "for the modes above the basis" + (")" if exact.tail == 0.0 else
            f"; exact for the FRF modes up to {exact.exact_to_hz:.0f} Hz, approximate for the "
            f"few above, near the basis's top ({modes.frequencies_hz[-1]:.0f} Hz): of little "
            "weight in a band far below them; modal_hz = "
            f"{np.floor(exact.exact_to_hz):.0f} in [calibration] makes every one exact)"))
    return sur, modes
