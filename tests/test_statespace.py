"""State-space models from modes: the same FRFs as the modal sum; poles, series, parallel."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.response.frf import modal_frf, point_matrix
from femcal.response.statespace import (
    StateSpace,
    frequency_response,
    from_modes,
    modal_form,
    modal_to_poles,
    parallel,
    poles_to_modal,
    series,
)

from .conftest import solve_cantilever


@pytest.fixture(scope="module")
def cantilever():
    model, _, modes, _ = solve_cantilever(coupled_mass=True, n_modes=6)
    C = point_matrix(model, [(11, 2), (7, 2), (9, 6)])
    return modes, C


@pytest.mark.parametrize(
    ("output", "quantity"),
    [("displacement", "receptance"), ("velocity", "mobility"), ("acceleration", "accelerance")],
)
def test_state_space_frf_equals_the_modal_frf(cantilever, output, quantity):
    modes, C = cantilever
    zeta = np.linspace(0.005, 0.03, len(modes.radians))
    f = np.concatenate([np.linspace(1.0, 900.0, 31), modes.frequencies_hz])
    ss = from_modes(modes.shapes, modes.radians, zeta, C, C.T, output)
    assert ss.n_states == 2 * len(modes.radians)
    H = frequency_response(ss, f)
    ref = modal_frf(modes.shapes, modes.radians, C, C.T, f, zeta, quantity)
    assert np.allclose(H, ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
    # the diagonal (complex) modal form is the same system
    assert np.allclose(frequency_response(modal_form(ss), f), H, rtol=1e-8,
                       atol=1e-12 * np.abs(H).max())  # fmt: skip


def test_poles_give_the_modes_frequencies_and_damping(cantilever):
    modes, C = cantilever
    zeta = np.linspace(0.01, 0.05, len(modes.radians))
    ss = from_modes(modes.shapes, modes.radians, zeta, C, C.T)
    p = ss.poles()
    p = p[p.imag > 0]
    f, z = poles_to_modal(p)
    order = np.argsort(f)
    assert np.allclose(f[order], modes.frequencies_hz, rtol=1e-10)
    assert np.allclose(z[order], zeta, rtol=1e-8)
    back = modal_to_poles(f[order], z[order])
    assert np.allclose(back, p[order], rtol=1e-10)


def _random_system(rng, n, n_in, n_out):
    A = rng.normal(size=(n, n)) - 3.0 * np.eye(n)  # stable enough
    return StateSpace(A, rng.normal(size=(n, n_in)), rng.normal(size=(n_out, n)),
                      rng.normal(size=(n_out, n_in)))  # fmt: skip


def test_series_and_parallel_multiply_and_add_responses():
    rng = np.random.default_rng(5)
    a = _random_system(rng, 4, 2, 3)
    b = _random_system(rng, 3, 3, 2)
    c = _random_system(rng, 5, 2, 3)
    f = np.linspace(0.01, 2.0, 9)
    Ha, Hb, Hc = (frequency_response(s, f) for s in (a, b, c))
    Hs = frequency_response(series(a, b), f)
    assert np.allclose(Hs, np.einsum("ojf,jif->oif", Hb, Ha))
    assert np.allclose(frequency_response(parallel(a, c), f), Ha + Hc)
    with pytest.raises(ValueError, match="inputs"):
        series(a, c)
    with pytest.raises(ValueError, match="inconsistent shapes"):
        StateSpace(np.eye(2), np.ones((3, 1)), np.ones((1, 2)), np.zeros((1, 1)))
