"""The full model's exact FRF Jacobian at a surrogate's centre (femcal.calibrate.gradient)
against central differences of the full model, and the first-order correction."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.calibrate import gradient
from femcal.calibrate.gradient import first_order_correction
from femcal.calibrate.metric import jacobian, log_frequencies, residuals
from femcal.calibrate.problem import Problem
from femcal.calibrate.reduction import build_surrogate
from femcal.parallel.executors import beside
from femcal.testdata.data import Channel

from .calib_decks import write_plate

OUTS = [Channel.parse(s) for s in ("28:+Z", "25:+Z", "14:+Y", "21:3", "7:+X")]
INS = [Channel.parse(s) for s in ("28:+Z", "11:+Y")]


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    return write_plate(tmp_path_factory.mktemp("grad"))


# with the residual flexibility's static block, and with every mode in the FRFs: in the slow
# tier (the fast tier checks the residual surrogate's Jacobian at its centre in
# test_calibrate_surrogate)
@pytest.mark.parametrize("residual, frf_modes", [
    (False, 5), pytest.param(True, 6, marks=pytest.mark.slow),
    pytest.param(False, None, marks=pytest.mark.slow)])
def test_exact_centre_jacobian_equals_central_differences_of_the_full_model(setup, residual,
                                                                          frf_modes):
    """The full model (the surrogate at its own centre) differenced at +-h in every
    parameter: the exact Jacobian matches to the differences' accuracy (their truncation,
    about 1e-7 of the derivative at h = 1e-5, measured: 1e-5 at h = 1e-4, as h squared; their
    round-off, about 1e-16 / h of the FRF, far below); the surrogate's own
    Jacobian (eigenvector derivatives truncated to its basis) is further off. Also with all
    the basis's modes in the FRFs (the series for the top modes stops at its cap)."""
    model, params = setup
    n = len(params)
    c = np.linspace(0.05, -0.05, n)
    f = log_frequencies(10.0, 250.0, 0.02, 2.0)
    kw = dict(n_modes=20, zeta=0.02, residual=residual, frf_modes=frf_modes)

    def full(p):
        sur, _ = build_surrogate(model, params, p, OUTS, INS, **kw)
        return sur.frf(p, f)

    sur, _ = build_surrogate(model, params, c, OUTS, INS, exact_gradient=True, **kw)
    H, dH = sur.exact.frf_and_jacobian(f, 0.02, "accelerance")
    H_s, dH_s = sur.frf_and_jacobian(c, f)
    np.testing.assert_allclose(H, H_s, rtol=1e-9, atol=1e-11 * np.abs(H).max())
    assert (sur.exact.R is not None) == residual
    if frf_modes is not None:
        assert sur.exact.tail == 0.0 and 1 <= sur.exact.terms <= 12
    h = 1e-5
    err_exact, err_sur = [], []
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        fd = (full(c + e) - full(c - e)) / (2 * h)
        scale = np.abs(fd).max()
        err_exact.append(np.abs(dH[i] - fd).max() / scale)
        err_sur.append(np.abs(dH_s[i] - fd).max() / scale)
    # with all 20 modes in the FRFs the top modes' series is capped (12 terms): close, not
    # exact (measured 2.6e-5; the plate's QUAD4 residual bending flexibility makes its
    # spectrum above the band dense, modes 16-19 within 3 %)
    bound = 2e-6 if frf_modes is not None else 5e-5
    if frf_modes is None:
        assert sur.exact.tail == np.inf
    assert max(err_exact) < bound, (params[int(np.argmax(err_exact))].name, max(err_exact))
    if not residual:  # (with the residual's static block the plate's basis is nearly exact)
        assert max(err_sur) > 5 * max(err_exact)


def test_exact_derivatives_with_half_the_sensors_beside_are_one_process_s(setup,
                                                                          monkeypatch):
    """The series of half the sensors in a forked process beside (two cores) gives every
    sensor's derivatives in its place, as one process does, but for the last bits that the
    solves' block widths decide. (The test plate's series is below the size that splits:
    the size is lowered here.)"""
    model, params = setup
    c = np.linspace(0.05, -0.05, len(params))
    kw = dict(n_modes=20, zeta=0.02, frf_modes=5, exact_gradient=True)
    one, _ = build_surrogate(model, params, c, OUTS, INS, **kw)
    calls = []
    monkeypatch.setattr(gradient, "SPLIT_WORK", 0)
    monkeypatch.setattr(gradient, "beside", lambda *a, **k: calls.append(1) or beside(*a, **k))
    two, _ = build_surrogate(model, params, c, OUTS, INS, beside_ok=True, **kw)
    assert calls == [1]
    for name in ("dlam", "d_S", "d_P"):
        a, b = getattr(one.exact, name), getattr(two.exact, name)
        assert a.shape == b.shape and np.abs(a).max() > 0, name
        assert np.abs(a - b).max() <= 1e-10 * np.abs(a).max(), name


def test_first_order_correction_gives_the_full_jacobian_at_the_centre(setup):
    model, params = setup
    n = len(params)
    c = np.linspace(-0.04, 0.04, n)
    f = log_frequencies(10.0, 250.0, 0.02, 2.0)
    sur, _ = build_surrogate(model, params, c, OUTS, INS, n_modes=20, zeta=0.02,
                             frf_modes=8, exact_gradient=True)  # fmt: skip
    H_test = sur.frf(np.zeros(n), f)  # some other point's FRFs
    E = first_order_correction(sur, sur.exact, f, H_test, "complex-log")
    H, dH = sur.exact.frf_and_jacobian(f, 0.02, "accelerance")
    J_full = jacobian(H, dH, "complex-log", H_test)
    lo, hi = -0.3 * np.ones(n), 0.3 * np.ones(n)
    prob = Problem.single(sur, f, H_test, "complex-log", lo, hi, 10, None, E)
    r, jac = prob.fun(c)
    np.testing.assert_allclose(r, residuals(H, H_test, "complex-log"), atol=1e-12)
    np.testing.assert_allclose(jac(), J_full, rtol=1e-10, atol=1e-12 * np.abs(J_full).max())
    p = c + 0.01
    plain = Problem.single(sur, f, H_test, "complex-log", lo, hi, 10)
    np.testing.assert_allclose(prob.fun(p)[0], plain.fun(p)[0] + E @ (p - c), atol=1e-12)
