"""The reduced surrogate: FRFs against the full model, exactness for parameters the matrices
depend on linearly, the analytic Jacobian of the log-FRF metric against finite differences."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from femcal.assembly import assemble
from femcal.calibrate.metric import jacobian, jacobian_of_parts, log_frequencies, residuals
from femcal.calibrate.parameters import with_values
from femcal.calibrate.reduction import build_surrogate
from femcal.model import EigenRequest
from femcal.response.frf import channel_matrix, modal_frf
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel

from .calib_decks import write_plate

OUTS = [Channel.parse(s) for s in ("28:+Z", "25:+Z", "14:+Y", "21:3", "7:+X")]
INS = [Channel.parse(s) for s in ("28:+Z", "11:+Y")]


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    return write_plate(tmp_path_factory.mktemp("sur"))


def full_frf(model, params, p, f, zeta, n_modes):
    m = with_values(model, params, [q.value(x) for q, x in zip(params, p, strict=True)])
    modes, _ = solve_normal_modes(m, request=EigenRequest(nd=n_modes))
    C = channel_matrix(m, OUTS)
    B = channel_matrix(m, INS).T
    return modal_frf(modes.shapes, modes.radians, C, B, f, zeta, "accelerance"), modes


def test_surrogate_at_its_centre_is_the_full_model(setup):
    model, params = setup
    p = np.linspace(-0.1, 0.1, len(params))
    sur, modes = build_surrogate(model, params, p, OUTS, INS, n_modes=40, zeta=0.02)
    f = np.linspace(5, 300, 80)
    H_full, _ = full_frf(model, params, p, f, 0.02, 40)
    np.testing.assert_allclose(sur.frf(p, f), H_full, rtol=1e-8, atol=1e-10 * np.abs(H_full).max())
    np.testing.assert_allclose(sur.frequencies_hz(p), modes.frequencies_hz, rtol=1e-9)


def _ritz(model, params, p, Phi):
    m = with_values(model, params, [q.value(x) for q, x in zip(params, p, strict=True)])
    mats = assemble(m)
    return sla.eigh(Phi.T @ mats.K @ Phi, Phi.T @ mats.M @ Phi, eigvals_only=True)


def test_exact_surrogate_is_the_ritz_model_anywhere(setup):
    model, params = setup
    center = np.linspace(0.05, -0.05, len(params))
    sur, modes0 = build_surrogate(model, params, center, OUTS, INS, n_modes=40,
                                  zeta=0.02)  # fmt: skip
    rng = np.random.default_rng(7)
    for _ in range(3):  # every parameter at once, thickness and products of E, A, T included
        p = rng.uniform(-0.2, 0.2, len(params))
        np.testing.assert_allclose(sur.modes(p)[0], _ritz(model, params, p, modes0.shapes),
                                   rtol=1e-9)  # fmt: skip


def test_first_order_surrogate_is_exact_for_one_linear_parameter(setup):
    model, params = setup
    sur, modes0 = build_surrogate(model, params, np.zeros(len(params)), OUTS, INS,
                                  n_modes=40, zeta=0.02, order="first-order")  # fmt: skip
    # K and M are linear in each of these and no two of them multiply each other (E and A of
    # one rod would: its stiffness is E A / L), so FEMCali's first-order K~(p) is exact
    for group in (["E_steel"], ["A_bar", "I1_bar", "k_bush", "k_spring", "m_tip"]):
        p = np.array([0.15 if q.name in group else 0.0 for q in params])
        np.testing.assert_allclose(sur.modes(p)[0], _ritz(model, params, p, modes0.shapes),
                                   rtol=1e-9)  # fmt: skip
    # the thickness enters bending cubically: first order is not exact there
    p = np.array([0.15 if q.name == "t" else 0.0 for q in params])
    err = np.abs(sur.modes(p)[0] / _ritz(model, params, p, modes0.shapes) - 1).max()
    assert 1e-4 < err < 0.1


@pytest.mark.parametrize("metric", ["log-magnitude", "complex-log"])
def test_metric_jacobian_equals_central_differences(setup, metric):
    model, params = setup
    sur, _ = build_surrogate(model, params, np.zeros(len(params)), OUTS, INS,
                             n_modes=30, zeta=0.02)  # fmt: skip
    f = log_frequencies(10.0, 250.0, 0.02, 2.0)
    rng = np.random.default_rng(4)
    p = rng.uniform(-0.15, 0.15, len(params))
    H_test = sur.frf(np.zeros(len(params)), f) * (1 + 0.05 * rng.normal(size=(5, 2, len(f))))
    H, dH = sur.frf_and_jacobian(p, f)
    J = jacobian(H, dH, metric, H_test)
    H_parts, sel, X = sur.frf_and_jacobian_parts(p, f)  # the search's own path, real parts
    assert np.array_equal(H_parts, H) and np.array_equal(sel, np.arange(len(params)))
    J_parts = jacobian_of_parts(H, X, metric, H_test)
    h = 1e-4  # fourth-order differences: truncation ~h^4, rounding ~1e-16 / h
    for i in range(len(params)):
        e = np.zeros(len(params))
        e[i] = h

        def eps(k, e=e):
            return residuals(sur.frf(p + k * e, f), H_test, metric)

        fd = (8 * (eps(1) - eps(-1)) - (eps(2) - eps(-2))) / (12 * h)  # fourth order
        scale = np.abs(fd).max()
        assert np.abs(J[:, i] - fd).max() < 1e-6 * scale, params[i].name
        assert np.abs(J_parts[:, i] - fd).max() < 1e-6 * scale, params[i].name
    # some columns alone, written into a wider Jacobian at their places (the search's held
    # parameters: zero columns), are those columns
    which = np.arange(len(params)) % 2 == 0
    _, sel, X_some = sur.frf_and_jacobian_parts(p, f, which)
    wide = jacobian_of_parts(H, X_some, metric, H_test, out=np.zeros((len(J), len(params))),
                             columns=sel)  # fmt: skip
    scale = np.abs(J_parts).max()
    assert np.abs(wide[:, which] - J_parts[:, which]).max() <= 1e-13 * scale
    assert not wide[:, ~which].any()


@pytest.mark.parametrize("metric", ["log-magnitude", "complex-log"])
def test_metric_jacobian_of_many_outputs_is_the_complex_quotient(metric):
    """The Jacobian is formed a few outputs at a time: with 40 outputs of 300 frequencies
    that is several blocks and a short last one, each in its place, whole or at given
    columns."""
    rng = np.random.default_rng(12)
    n_p, n_o, n_i, n_f = 5, 40, 3, 300

    def cplx(*shape):
        return rng.normal(size=shape) + 1j * rng.normal(size=shape)

    H, H_test, dH = cplx(n_o, n_i, n_f), cplx(n_o, n_i, n_f), cplx(n_p, n_o, n_i, n_f)
    X = np.concatenate([dH.real, dH.imag], axis=-1)
    q = (dH / H).reshape(n_p, -1).T / np.log(10.0)
    want = q.real
    if metric == "complex-log":
        half = np.cos(np.angle(H / H_test) / 2.0).ravel()
        want = np.vstack([q.real, half[:, None] * q.imag])
    J = jacobian_of_parts(H, X, metric, H_test)
    assert J.shape == want.shape
    assert np.abs(J - want).max() <= 1e-12 * np.abs(want).max()
    cols = np.array([0, 3, 4, 6, 7])  # into a wider Jacobian, at these columns
    wide = jacobian_of_parts(H, X, metric, H_test, out=np.zeros((len(want), 9)), columns=cols)
    assert np.array_equal(wide[:, cols], J)
    assert not np.delete(wide, cols, axis=1).any()


def test_log_frequencies_have_n_samples_per_half_power_bandwidth():
    f = log_frequencies(10.0, 100.0, 0.01, 3.0)
    assert f[0] == 10.0 and f[-1] == pytest.approx(100.0)
    assert np.allclose(f[1:] / f[:-1], f[1] / f[0])
    assert f[1] / f[0] == pytest.approx(1 + 2 * 0.01 / 3, rel=2e-3)
    with pytest.raises(ValueError, match="expected 0 < f_lo < f_hi"):
        log_frequencies(0.0, 10.0, 0.01)


def test_enriched_basis_makes_the_jacobian_at_the_centre_that_of_the_full_model(setup):
    """Static eigenvector-derivative vectors in the basis: the surrogate is still the full
    model at its centre (its n_modes lowest modes make the FRFs), and its Jacobian there is
    closer to central differences of the full model than the modes-only surrogate's, whose
    eigenvector derivatives are truncated to the basis."""
    model, params = setup
    n = len(params)
    c = np.linspace(0.05, -0.05, n)
    f = log_frequencies(10.0, 250.0, 0.02, 2.0)
    h = 1e-5
    J_full = np.array([(full_frf(model, params, c + h * e, f, 0.02, 20)[0]
                        - full_frf(model, params, c - h * e, f, 0.02, 20)[0]) / (2 * h)
                       for e in np.eye(n)])  # fmt: skip
    H_full, modes = full_frf(model, params, c, f, 0.02, 20)
    worst = {}
    for enrich in (None, 250.0):
        sur, _ = build_surrogate(model, params, c, OUTS, INS, n_modes=20, zeta=0.02,
                                 enrich_hz=enrich)  # fmt: skip
        H, dH = sur.frf_and_jacobian(c, f)
        np.testing.assert_allclose(H, H_full, rtol=1e-6, atol=1e-8 * np.abs(H_full).max())
        np.testing.assert_allclose(sur.frequencies_hz(c)[:20], modes.frequencies_hz, rtol=1e-9)
        worst[enrich] = max(np.abs(dH[i] - J_full[i]).max() / np.abs(J_full[i]).max()
                            for i in range(n))  # fmt: skip
        if enrich:
            assert sur.K0.shape[0] > 20  # the basis did grow
    assert worst[250.0] < 0.5 * worst[None]  # measured 0.45 (2.7e-4 against 6.0e-4)


def test_derivative_vectors_lumped_mass_shortcut_and_reused_factor_change_nothing(setup,
                                                                                 monkeypatch):
    """With a diagonal (lumped) M the derivative vectors' M-products run over the rows with
    mass only, and the eigen solution's factor of K - sigma M may serve their solves: the
    vectors span the same space as the general path's with their own factorisation."""
    from femcal.calibrate import reduction as sur_mod
    from femcal.calibrate.derivatives import group_polynomials
    from femcal.solve.factor import factorize

    model, params = setup
    c = np.linspace(0.05, -0.05, len(params))
    m = with_values(model, params, [q.value(x) for q, x in zip(params, c, strict=True)])
    mats = assemble(m)
    assert sur_mod._mass_root(mats.M) is not None  # the plate's mass is lumped
    modes, red = solve_normal_modes(m, matrices=mats, request=EigenRequest(nd=20))
    polys = group_polynomials(model, params, np.zeros(len(params)), constant=True)
    args = (polys, c, mats.K, mats.M, red, modes.shapes, modes.eigenvalues, 12, 30)
    Ka, Ma = red.reduce(mats.K), red.reduce(mats.M)
    solve, _ = factorize((Ka - sur_mod.STATIC_SHIFT * Ma).tocsc())
    Q_lumped = sur_mod.derivative_vectors(*args, solve=solve)
    monkeypatch.setattr(sur_mod, "_mass_root", lambda M: None)
    Q_general = sur_mod.derivative_vectors(*args)
    assert Q_lumped.shape == Q_general.shape and Q_lumped.shape[1] > 10
    cosines = np.linalg.svd(Q_lumped.T @ (mats.M @ Q_general), compute_uv=False)
    np.testing.assert_allclose(cosines, 1.0, atol=1e-8)
    # M-orthonormal and M-orthogonal to the modes
    np.testing.assert_allclose(Q_lumped.T @ (mats.M @ Q_lumped), np.eye(Q_lumped.shape[1]),
                               atol=1e-10)  # fmt: skip
    assert np.abs(modes.shapes.T @ (mats.M @ Q_lumped)).max() < 1e-10


def test_gram_and_mass_root():
    from femcal.calibrate.reduction import _gram, _mass_root

    rng = np.random.default_rng(3)
    Y = rng.standard_normal((50, 7))
    np.testing.assert_allclose(_gram(Y), Y.T @ Y, rtol=1e-13, atol=1e-12)
    import scipy.sparse as sp

    d = np.array([2.0, 0.0, 3.0, 0.5])
    R = _mass_root(sp.diags(d))
    np.testing.assert_allclose((R.T @ R).toarray(), np.diag(d))
    assert R.shape == (3, 4)
    assert _mass_root(sp.csr_matrix(np.array([[1.0, 0.1], [0.1, 1.0]]))) is None


def test_surrogate_soft_modes_are_accurate_beside_stiff_directions():
    """An enriched basis holds directions far stiffer than its modes. The small eigenproblem
    is solved inverted so that the soft modes keep their relative accuracy: their eigenvalues'
    finite differences over a tiny step match the exact derivative psi^T dK psi (a direct
    solver's error, eps times the stiffest eigenvalue, would swamp the step)."""
    from femcal.calibrate.surrogate import Surrogate

    rng = np.random.default_rng(11)
    lam = np.array([57.0, 64.0, 8.7e3, 1.2e4, 3.0e6, 1e9, 5e10, 1e11])
    r = len(lam)
    C = np.eye(r) + 0.05 * rng.standard_normal((r, r))
    C = 0.5 * (C + C.T)
    K0 = np.sqrt(lam)[:, None] * C * np.sqrt(lam)[None, :]  # graded coupling
    dK = np.sqrt(lam)[:, None] * (0.01 * rng.standard_normal((r, r))) * np.sqrt(lam)[None, :]
    dK = 0.5 * (dK + dK.T)
    sur = Surrogate(np.zeros(1), K0, np.eye(r), np.ones((1, 1), int), dK[None], np.zeros((1, r, r)),
                    np.ones((1, r)), np.ones((1, r)), 0.01, "accelerance", np.zeros(r))  # fmt: skip
    h = 1e-7
    lam_p, lam_m = sur.modes(np.array([h]))[0], sur.modes(np.array([-h]))[0]
    lam0, psi = sur.modes(np.zeros(1))
    exact = np.einsum("ij,ik,kj->j", psi, dK, psi)
    fd = (lam_p - lam_m) / (2 * h)
    np.testing.assert_allclose(fd[:4], exact[:4], rtol=1e-4)
    # M~-normalised and ascending
    np.testing.assert_allclose(psi.T @ psi, np.eye(r), atol=1e-8)
    assert np.all(np.diff(lam0) > 0)


def test_residual_flexibility_surrogate_is_the_full_model_at_its_centre_with_its_jacobian(setup):
    """residual=True: the FRFs add the residual flexibility of the modes beyond n_modes. At
    the centre the surrogate is the full model's modal sum plus femcal.response.frf's residual
    flexibility; its Jacobian matches central differences of the full model (the static
    responses in the basis hold nearly massless directions with eigenvalues ~1e17: a repeated
    -pair threshold relative to those dropped the coupling of the two lowest modes)."""
    from femcal.response.frf import residual_flexibility

    model, params = setup

    def full(p, f):
        m = with_values(model, params, [q.value(x) for q, x in zip(params, p, strict=True)])
        modes, red = solve_normal_modes(m, request=EigenRequest(nd=20))
        C, B = channel_matrix(m, OUTS), channel_matrix(m, INS).T
        R = residual_flexibility(red.reduce(assemble(m).K), red.T, C, B, modes.shapes,
                                 modes.radians)  # fmt: skip
        return modal_frf(modes.shapes, modes.radians, C, B, f, 0.02, "accelerance", residual=R)

    c = np.linspace(0.05, -0.05, len(params))
    f = log_frequencies(10.0, 250.0, 0.02, 2.0)
    sur, _ = build_surrogate(model, params, c, OUTS, INS, n_modes=20, zeta=0.02,
                             residual=True)  # fmt: skip
    H_full = full(c, f)
    H, dH = sur.frf_and_jacobian(c, f)
    np.testing.assert_allclose(H, H_full, rtol=1e-8, atol=1e-9 * np.abs(H_full).max())
    np.testing.assert_allclose(sur.frf(c, f), H, rtol=1e-12, atol=1e-14 * np.abs(H).max())
    without = full_frf(model, params, c, f, 0.02, 20)[0]
    assert (np.abs(without - H_full) / np.abs(H_full)).max() > 0.05  # it does matter
    h = 1e-5
    for i in range(len(params)):
        e = np.zeros(len(params))
        e[i] = h
        fd = (full(c + e, f) - full(c - e, f)) / (2 * h)
        # the surrogate's own Jacobian: its eigenvector derivatives are truncated to the
        # basis (measured up to 1.2e-4, I1_bar; the differences' own error is 2e-8)
        assert np.abs(dH[i] - fd).max() < 3e-4 * np.abs(fd).max(), params[i].name


def test_jacobian_of_some_parameters_is_theirs_and_zero_elsewhere(setup):
    """frf_and_jacobian with ``which``: the chosen parameters' derivatives as without it,
    the others zero (the search skips the parameters its bounds hold)."""
    model, params = setup
    sur, _ = build_surrogate(model, params, np.zeros(len(params)), OUTS, INS,
                             n_modes=30, zeta=0.02)  # fmt: skip
    f = np.linspace(10.0, 250.0, 40)
    p = np.linspace(-0.1, 0.1, len(params))
    which = np.arange(len(params)) % 3 != 1
    H, dH = sur.frf_and_jacobian(p, f)
    H_w, dH_w = sur.frf_and_jacobian(p, f, which)
    assert np.array_equal(H, H_w)
    # (to rounding: all parameters' derivatives come from one product, whose shape BLAS
    # may split otherwise for fewer of them)
    np.testing.assert_allclose(dH_w[which], dH[which], rtol=0, atol=1e-13 * np.abs(dH).max())
    assert not dH_w[~which].any() and np.abs(dH[~which]).max() > 0


def test_problem_jacobian_is_its_terms_stacked_with_the_prior_rows(setup):
    """Problem.fun's Jacobian, made in one array with the prior's rows after the data's, is
    the terms' own Jacobians weighed (Huber, factor), placed at their parameters' columns
    and stacked: one term on every parameter, another on some of them in another order with
    some residuals left out (a hold-out fold), a third on every parameter with some left
    out, and a parameter held by its bounds."""
    from femcal.calibrate.problem import Problem, Term

    model, params = setup
    n = len(params)
    sur, _ = build_surrogate(model, params, np.zeros(n), OUTS, INS, n_modes=20, zeta=0.02)
    f = log_frequencies(10.0, 250.0, 0.02, 2.0)
    rng = np.random.default_rng(3)
    H_test = sur.frf(np.zeros(n), f) * (1 + 0.1 * rng.normal(size=(len(OUTS), len(INS), len(f))))
    index = np.array([n - 1, 0, 2])[: min(3, n)]
    sub, _ = build_surrogate(model, [params[i] for i in index], np.zeros(len(index)), OUTS,
                             INS, n_modes=20, zeta=0.02)  # fmt: skip
    H_sub = sub.frf(np.zeros(len(index)), f) * (1 + 0.1 * rng.normal(size=H_test.shape))
    rows = rng.random(2 * H_sub.size) < 0.7
    rows_all = rng.random(H_test.size) < 0.5
    terms = (Term(sur, f, H_test, "complex-log", np.arange(n), factor=0.7, huber=0.05),
             Term(sub, f, H_sub, "complex-log", index, factor=1.3, rows=rows),
             Term(sur, f, H_test, "log-magnitude", np.arange(n), rows=rows_all))
    lower, upper = -0.2 * np.ones(n), 0.2 * np.ones(n)
    lower[1] = upper[1] = 0.0  # held by its bounds: no column computed
    weights = np.linspace(1.0, 2.0, n)
    problem = Problem(terms, lower, upper, 10, weights)
    p = rng.uniform(-0.1, 0.1, n)
    p[1] = 0.0
    J = problem.fun(p)[1]()
    which = lower < upper
    blocks = []
    for t in terms:
        Jt, e = t.jacobian(p, which)
        _, dt = t.transformed(e)
        placed = np.zeros((len(e), n))
        placed[:, t.index] = t.factor * (dt[:, None] * Jt)
        blocks.append(placed)
    want = np.vstack([*blocks, np.diag(weights)])
    n_rows = terms[0].n_residuals + int(rows.sum()) + int(rows_all.sum())
    assert J.shape == want.shape == (n_rows + n, n)
    assert np.abs(J - want).max() <= 1e-14 * np.abs(want).max()
    assert not J[: -n, 1].any()  # the held parameter's column


def test_surrogate_keeps_the_modes_of_its_last_point_only(setup):
    """The modes at the last point are kept, read-only, and are those of a fresh solution;
    another point solves anew; a copy made by replace() or by pickling keeps none."""
    import dataclasses
    import pickle

    model, params = setup
    n = len(params)
    sur, _ = build_surrogate(model, params, np.zeros(n), OUTS, INS, n_modes=20, zeta=0.02)
    p, q = np.full(n, 0.05), np.full(n, -0.05)
    lam, psi = sur.modes(p)
    assert not lam.flags.writeable and not psi.flags.writeable
    assert sur.modes(p)[0] is lam
    fresh = sur._solve_modes(q)
    lam_q = sur.modes(q)[0]
    assert lam_q is not lam and np.array_equal(lam_q, fresh[0])
    assert np.array_equal(sur.modes(p)[0], lam)
    for copy in (dataclasses.replace(sur), pickle.loads(pickle.dumps(sur))):
        assert "_modes_at" not in copy.__dict__
        assert np.array_equal(copy.modes(p)[0], lam)
