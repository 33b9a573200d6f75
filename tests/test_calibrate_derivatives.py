"""Calibration parameters and their exact derivatives: dK/dp, dM/dp and eigen-sensitivities
against central finite differences of full assemblies and eigen solutions."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from femcal.assembly import assemble
from femcal.assembly.constraints import build_reduction
from femcal.calibrate.derivatives import (
    DerivativeError,
    parameter_matrices,
)
from femcal.calibrate.parameters import (
    current_value,
    read_parameters,
    with_values,
)
from femcal.calibrate.sensitivity import eigenvalue_sensitivities, eigenvector_sensitivity
from femcal.deck import read_deck
from femcal.io.calibration import write_calibrated_deck
from femcal.model.build import build_model

from .calib_decks import PARAMS_TOML, plate_deck, write_plate


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    d = tmp_path_factory.mktemp("plate")
    model, params = write_plate(d)
    return d / "plate.bdf", model, params


def _rel(A, B) -> float:
    A, B = sp.csr_matrix(A), sp.csr_matrix(B)
    scale = np.abs(B.data).max()
    diff = A - B
    return float(np.abs(diff.data).max() / scale) if diff.nnz else 0.0


def test_parameters_read_their_nominal_from_the_deck(plate):
    _, model, params = plate
    got = {p.name: (p.nominal, p.lower, p.upper) for p in params}
    assert got["t"] == pytest.approx((5.0, 4.0, 6.0))
    assert got["k_bush"] == pytest.approx((60.0, 30.0, 90.0))
    assert got["m_tip"] == pytest.approx((0.002, 0.001, 0.003))
    assert params[0].p_lower == pytest.approx(-0.2) and params[0].p_upper == pytest.approx(0.2)
    changed = with_values(model, params, [p.nominal * 1.1 for p in params])
    for p in params:
        assert current_value(changed, p.card, p.id, p.field) == pytest.approx(1.1 * p.nominal)
        assert current_value(model, p.card, p.id, p.field) == pytest.approx(p.nominal)


@pytest.mark.parametrize("name", ["t", "E_steel", "rho_steel", "A_bar", "I1_bar", "A_rod",
                                  "k_bush", "k_spring", "m_tip"])  # fmt: skip
def test_dk_and_dm_equal_central_differences(plate, name):
    _, model, params = plate
    par = next(p for p in params if p.name == name)
    dK, dM = parameter_matrices(model, par)
    h = 1e-4 * par.nominal
    plus = assemble(with_values(model, [par], [par.nominal + h]))
    minus = assemble(with_values(model, [par], [par.nominal - h]))
    fd_K = (plus.K - minus.K) / (2 * h)
    fd_M = (plus.M - minus.M) / (2 * h)
    if par.spec.k_degree:
        assert _rel(dK, fd_K) < 1e-6
    else:
        assert dK.nnz == 0 and abs(fd_K).max() == 0
    if par.spec.m_degree:
        assert _rel(dM, fd_M) < 1e-6
    else:
        assert dM.nnz == 0 and abs(fd_M).max() == 0


def _modes(model, red=None):
    mats = assemble(model)
    red = red or build_reduction(model)
    K, M = red.reduce(mats.K).toarray(), red.reduce(mats.M).toarray()
    mu, v = sla.eigh(M, K)  # M is singular (massless rotations): 1 / lambda, K-normalised
    keep = np.argsort(mu)[::-1][:12]
    lam, phi = 1.0 / mu[keep], v[:, keep] / np.sqrt(mu[keep])  # mass-normalised
    return mats, red, lam, phi


@pytest.mark.parametrize("name", ["t", "E_steel", "rho_steel", "A_bar", "k_bush", "m_tip"])
def test_eigen_sensitivities_equal_central_differences(plate, name):
    _, model, params = plate
    par = next(p for p in params if p.name == name)
    mats, red, lam, phi = _modes(model)
    dK, dM = parameter_matrices(model, par)
    dKa, dMa = red.reduce(dK), red.reduce(dM)
    n = 5
    dlam = eigenvalue_sensitivities(phi[:, :n], lam[:n], dKa, dMa)
    h = 1e-4 * par.nominal
    # fourth-order central differences: (8 (f(h) - f(-h)) - (f(2h) - f(-2h))) / 12 h
    runs = {s: _modes(with_values(model, [par], [par.nominal + s * h]), red)[2:]
            for s in (-2, -1, 1, 2)}  # fmt: skip

    def fd(get):
        return (8 * (get(1) - get(-1)) - (get(2) - get(-2))) / (12 * h)

    fd_lam = fd(lambda s: runs[s][0][:n])
    np.testing.assert_allclose(dlam, fd_lam, rtol=1e-6, atol=1e-6 * np.abs(fd_lam).max())
    Ka, Ma = red.reduce(mats.K), red.reduce(mats.M)
    for k in range(n):
        dphi = eigenvector_sensitivity(Ka, Ma, phi[:, k], lam[k], dKa, dMa)
        fdv = fd(lambda s, k=k: np.sign(runs[s][1][:, k] @ phi[:, k]) * runs[s][1][:, k])
        assert np.abs(dphi - fdv).max() < 1e-6 * np.abs(fdv).max(), k


def _shear_flexible_bar(tmp_path):
    """The plate deck with the bar given shear flexibility (PBAR K1 = K2 = 0.8): its
    stiffness is then rational in the area, not linear."""
    text = plate_deck().replace("PBAR,2,2,120.,900.,1600.,2000.",
                                "PBAR,2,2,120.,900.,1600.,2000.\n,,,,,,,,\n,.8,.8")  # fmt: skip
    (tmp_path / "d.bdf").write_text(text)
    (tmp_path / "p.toml").write_text(PARAMS_TOML)
    model = build_model(read_deck(tmp_path / "d.bdf"))
    params = read_parameters(tmp_path / "p.toml", model)
    return model, next(p for p in params if p.name == "A_bar")


def test_a_smooth_nonpolynomial_dependence_gets_a_raised_degree(tmp_path):
    model, par = _shear_flexible_bar(tmp_path)
    dK, dM = parameter_matrices(model, par)
    h = 1e-4 * par.nominal
    plus = assemble(with_values(model, [par], [par.nominal + h]))
    minus = assemble(with_values(model, [par], [par.nominal - h]))
    assert _rel(dK, (plus.K - minus.K) / (2 * h)) < 1e-6
    assert _rel(dM, (plus.M - minus.M) / (2 * h)) < 1e-6


def test_a_dependence_no_raised_degree_reproduces_is_refused(tmp_path, monkeypatch):
    import femcal.calibrate.derivatives as derivatives

    monkeypatch.setattr(derivatives, "RAISED_DEGREES", (2,))
    model, par = _shear_flexible_bar(tmp_path)
    with pytest.raises(DerivativeError, match=r"A_bar \(PBAR 2 A, elements CBAR\).*not a "
                       r"polynomial of degree 1 in it.*nor reproduced to 1e-09 by one of "
                       r"degree 2"):  # fmt: skip
        parameter_matrices(model, par)


def test_bad_parameter_files_are_named(plate, tmp_path):
    _, model, _ = plate
    bad = [('card = "PSHELL"\nid = 1\nfield = "T"\nnominal = 6.0\nlower = 4.0\nupper = 7.0',
            "nominal 6.0 but the deck has 5.0"),
           ('card = "PSHELL"\nid = 1\nfield = "MID1"\nlower = 4.0\nupper = 7.0',
            "PSHELL MID1 is not a parameter field"),
           ('card = "PSHELL"\nid = 77\nfield = "T"\nlower = 4.0\nupper = 7.0',
            "PSHELL 77 is not in the deck"),
           ('card = "PSHELL"\nid = 1\nfield = "T"\nlower = 5.5\nupper = 7.0',
            "must hold the nominal"),
           ('card = "PSHELL"\nid = 1\nfield = "T"', "give bounds"),
           ('card = "PSHELL"\nid = 1\nfield = "T"\nlower = 4.0\nupper = 7.0\nconfidence = -0.1',
            "confidence = -0.1: expected the standard deviation as a fraction")]  # fmt: skip
    for body, message in bad:
        (tmp_path / "p.toml").write_text(f'[[parameter]]\nname = "x"\n{body}\n')
        with pytest.raises(ValueError, match=message):
            read_parameters(tmp_path / "p.toml", model)


def test_calibrated_deck_carries_the_new_values(plate, tmp_path):
    deck_path, _, params = plate
    values = [p.nominal * (1.0 + 0.01 * (k + 1)) for k, p in enumerate(params)]
    files = write_calibrated_deck(deck_path, params, values, tmp_path / "cal.bdf")
    assert files == [tmp_path / "cal.bdf", tmp_path / "cal.changes.bdf"]
    back = build_model(read_deck(files[0]))
    for p, v in zip(params, values, strict=True):  # the digits of an 8-character free field
        assert current_value(back, p.card, p.id, p.field) == pytest.approx(v, rel=5e-5)


@pytest.mark.parametrize("shear_modulus", ["", "81000."])
def test_group_polynomials_reproduce_the_groups_matrices(tmp_path, shear_modulus):
    """Each group's polynomial (its constant term included) equals the group's matrices
    assembled alone at points of the parameter box, for every kind of parameter: the
    plate's thickness (rational: a raised degree), E (which scales the plate's K when G is
    derived from it; with G given it does not, and the tensor grid takes it) and density,
    the bar's, rod's, bush's, spring's and mass's."""
    from femcal.calibrate.derivatives import element_groups, group_polynomials
    from femcal.calibrate.parameters import subset

    deck = plate_deck().replace("MAT1,1,210000.,,", f"MAT1,1,210000.,{shear_modulus},")
    (tmp_path / "d.bdf").write_text(deck)
    (tmp_path / "p.toml").write_text(PARAMS_TOML)
    model = build_model(read_deck(tmp_path / "d.bdf"))
    params = read_parameters(tmp_path / "p.toml", model)
    polys = group_polynomials(model, params, np.zeros(len(params)), constant=True)
    groups = element_groups(model, params)
    assert [g.params for g in polys] == list(groups)
    plate = next(g for g in polys if "CQUAD4" in groups[g.params])
    assert plate.exponents[:, 0].max() >= 5  # the thickness's degree was raised
    rng = np.random.default_rng(4)
    for g in polys:
        sub = subset(model, groups[g.params])
        pars = [params[i] for i in g.params]
        for _ in range(3):
            d = rng.uniform([p.p_lower for p in pars], [p.p_upper for p in pars])
            exact = assemble(with_values(sub, pars, [p.value(x) for p, x in zip(pars, d,
                                                                               strict=True)]))
            weights = [float(np.prod(d ** a)) for a in g.exponents]
            K = sum(w * X for w, X in zip(weights, g.K, strict=True))
            M = sum(w * X for w, X in zip(weights, g.M, strict=True))
            assert _rel(K, exact.K) < 1e-8, [p.name for p in pars]
            if exact.M.nnz:
                assert _rel(M, exact.M) < 1e-8, [p.name for p in pars]


def test_a_groups_degree_is_found_on_a_sample_first(tmp_path, monkeypatch):
    """A large group's raised degree is found on a sample of its elements: the whole group is
    then assembled only at that degree's points, and its polynomial is the same as when the
    ladder of degrees climbs on every element."""
    import femcal.calibrate.derivatives as derivatives
    from femcal.assembly.repeated import RepeatedAssembly

    (tmp_path / "d.bdf").write_text(plate_deck())
    (tmp_path / "p.toml").write_text(PARAMS_TOML)
    model = build_model(read_deck(tmp_path / "d.bdf"))
    params = read_parameters(tmp_path / "p.toml", model)
    n_quads = len(model.elements["CQUAD4"].ids)
    sizes: list[tuple] = []  # (element types, elements) of each assembly
    data = RepeatedAssembly.data

    def counted(self, part, **kw):
        sizes.append((tuple(part.elements), sum(len(b.ids) for b in part.elements.values())))
        return data(self, part, **kw)

    monkeypatch.setattr(RepeatedAssembly, "data", counted)
    runs = {}
    for probe in (n_quads, 2):  # no probe (the group is not 4 times larger), then a sample
        monkeypatch.setattr(derivatives, "_PROBE", probe)
        sizes.clear()
        polys = derivatives.group_polynomials(model, params, np.zeros(len(params)),
                                              constant=True)  # fmt: skip
        plate = next(g for g in polys if g.exponents[:, 0].max() >= 5)
        whole = sizes.count((("CQUAD4",), n_quads))
        runs[probe] = (plate, whole, sum(t == ("CQUAD4",) and k < n_quads for t, k in sizes))
    (alone, whole_alone, _), (probed, whole_probed, sample) = runs[n_quads], runs[2]
    assert sample > 0 and whole_probed < whole_alone
    np.testing.assert_array_equal(probed.exponents, alone.exponents)
    for a, b in zip(probed.K + probed.M, alone.K + alone.M, strict=True):
        # the same assemblies at the same points; the fits' products may be split otherwise
        assert _rel(a, b) < 1e-13 if b.nnz else a.nnz == 0


def test_a_polynomials_derivative_sums_its_terms_as_a_sparse_sum_does():
    """dK/dp_j X from the group polynomials sums a group's terms on their data (they share
    their index arrays) and adds the other groups' as sparse matrices: the same matrix as
    the sparse sum of every weighted term, in the same order; its rows version gives the
    rows the parameter touches and their values."""
    from femcal.calibrate.derivatives import (
        GroupPolynomial,
        polynomial_derivative,
        polynomial_derivative_rows,
        shift_weight,
    )

    rng = np.random.default_rng(5)
    n = 40

    def terms(count: int, density: float) -> list[sp.csr_matrix]:
        shared = sp.random(n, n, density=density, format="lil", random_state=rng)
        shared[n - 8 :, :] = shared[:, n - 8 :] = 0  # DOF the elements do not touch
        shared[n - 9, : n - 8] = 1.0  # a row the pattern stores ...
        shared = sp.csr_matrix(shared)
        stored_zeros = np.arange(shared.indptr[n - 9], shared.indptr[n - 8])
        out = []
        for _ in range(count):  # one pattern, other values (a group's terms)
            data = rng.standard_normal(shared.nnz)
            data[stored_zeros] = 0.0  # ... as zeros in every term
            A = sp.csr_matrix((data, shared.indices, shared.indptr), shape=(n, n))
            A.indices, A.indptr = shared.indices, shared.indptr  # shared, as a group's are
            out.append(A)
        return out

    exps_a = np.array([[0, 0], [1, 0], [2, 0], [3, 1], [1, 1]])
    exps_b = np.array([[0], [1], [2]])
    polys = [GroupPolynomial((0, 1), exps_a, terms(5, 0.2), terms(5, 0.1)),
             GroupPolynomial((0,), exps_b, terms(3, 0.3), [sp.csr_matrix((n, n))] * 3)]
    center = np.array([0.13, -0.07])
    X = rng.standard_normal((n, 3))
    for j in (0, 1):
        dK = dM = 0.0
        for g in polys:
            if j in g.params:
                unit = np.zeros(len(g.params), int)
                unit[g.params.index(j)] = 1
                c = center[list(g.params)]
                for a, Kc, Mc in zip(g.exponents, g.K, g.M, strict=True):
                    w = shift_weight(a, unit, c)
                    dK = dK + w * Kc
                    dM = dM + w * Mc
        dKX, dMX = polynomial_derivative(polys, center, j, X)
        for got, want in ((dKX, dK @ X), (dMX, dM @ X)):
            assert np.abs(got - want).max() <= 1e-14 * np.abs(want).max()
        # the rows the parameter touches alone: those where either product is not zero
        # (not the stored row of zeros, nor the rows no element has)
        rows, dKr, dMr = polynomial_derivative_rows(polys, center, j, X)
        touched = np.flatnonzero(np.any(dK @ X != 0, axis=1) | np.any(dM @ X != 0, axis=1))
        assert np.array_equal(rows, touched) and n - 9 not in rows and len(rows) == n - 9
        for got, want in ((dKr, dK @ X), (dMr, dM @ X)):
            assert np.abs(got - want[rows]).max() <= 1e-14 * np.abs(want).max()


def test_assemblies_side_by_side_give_the_same_polynomials(tmp_path):
    """A group's assemblies run side by side (one kernel thread each), placed in order: the
    polynomials are bitwise those of one assembly at a time."""
    import femcal.calibrate.derivatives as derivatives
    from femcal.assembly import Options

    (tmp_path / "d.bdf").write_text(plate_deck(12, 6))
    (tmp_path / "p.toml").write_text(PARAMS_TOML)
    model = build_model(read_deck(tmp_path / "d.bdf"))
    params = read_parameters(tmp_path / "p.toml", model)
    polys = {}
    for threads in (1, 2):
        polys[threads] = derivatives.group_polynomials(
            model, params, np.zeros(len(params)), options=Options(threads=threads),
            constant=True)  # fmt: skip
    for a, b in zip(polys[1], polys[2], strict=True):
        assert a.params == b.params
        np.testing.assert_array_equal(a.exponents, b.exponents)
        for X, Y in zip(a.K + a.M, b.K + b.M, strict=True):
            assert (X != Y).nnz == 0


@pytest.mark.parametrize("mid3", ["1", ""])
def test_alike_groups_are_probed_once(tmp_path, monkeypatch, mid3):
    """What a sample found for a parameter, a raised degree (a thickness with transverse
    shear: rational) or the field's own (shear-rigid: cubic), holds for the alike parameters
    of later groups: they are not probed again. Parameters that scale K or M (E, RHO) are
    found so without a sample."""
    import re

    import femcal.calibrate.derivatives as derivatives

    # two plates' halves with their own thickness each, one material
    deck = re.sub(r"CQUAD4,(\d*[02468]),1,", r"CQUAD4,\1,6,", plate_deck(8, 4))
    deck = deck.replace("PSHELL,1,1,5.,1,,1",
                        f"PSHELL,1,1,5.,1,,{mid3}\nPSHELL,6,1,5.,1,,{mid3}")  # fmt: skip
    (tmp_path / "d.bdf").write_text(deck)
    (tmp_path / "p.toml").write_text(PARAMS_TOML + '''
[[parameter]]
name = "t2"
card = "PSHELL"
id = 6
field = "T"
lower_rel = -0.2
upper_rel = 0.2
''')  # fmt: skip
    model = build_model(read_deck(tmp_path / "d.bdf"))
    params = read_parameters(tmp_path / "p.toml", model)
    probed: list[str] = []
    probe = derivatives._GroupFit._probe

    def counted(self, k, alike):
        probed.append(self.pars[k].name)
        return probe(self, k, alike)

    monkeypatch.setattr(derivatives, "_PROBE", 2)
    monkeypatch.setattr(derivatives._GroupFit, "_probe", counted)
    polys = derivatives.group_polynomials(model, params, np.zeros(len(params)), constant=True)
    assert probed == ["t"]  # the first plate's thickness only
    names = [p.name for p in params]
    degree = max(g.exponents[:, list(g.params).index(names.index("t2"))].max()
                 for g in polys if names.index("t2") in g.params)  # fmt: skip
    assert (degree > 3) == bool(mid3)  # raised with transverse shear, cubic without
