"""Exact parameter derivatives of K and M, and their polynomial dependence on the parameters.

dK/dP and dM/dP come from the element kernels themselves. Every parameter field states the
polynomial degree d of the element matrices in its value
(:data:`femcal.calibrate.parameters.FIELDS`: thickness enters membrane and mass linearly and
bending cubically; K is linear in E, A, I, J, spring rates; M linear in RHO, A, T,
concentrated masses). The elements that depend on the parameter are assembled alone at d + 1
values around P; the matrices are then exactly the polynomial through them, whose derivative
at P is a fixed combination of the d + 1 matrices (Lagrange weights). No step size is
involved: the result is exact up to rounding. The degree is checked every time at one more
point (the interpolating polynomial must reproduce the matrices at P itself).

Some dependences are smooth but not polynomial: the CQUAD4's and CTRIA3's transverse shear
with residual bending flexibility, ``(1/(k G t) + var/D(t))^-1``, is rational in the thickness,
and so is a bar's stiffness with shear flexibility in its area. When the field's degree
does not reproduce the matrices, the degree is raised (:data:`RAISED_DEGREES`) with
Chebyshev points over the interval the value will move in, until the interpolant
reproduces them to :data:`DEGREE_CHECK` at the centre and between the two outermost points;
the derivative is then the interpolant's, accurate to about that level (the tests compare
it with finite differences). Beyond the highest degree the parameter is refused with a
clear error instead of giving a wrong derivative.

The same fits, on a tensor grid of offsets per group of elements that shares its parameters,
give K and M as polynomials in several parameters at once (:func:`group_polynomials`), which
the surrogate reduces (:mod:`femcal.calibrate.reduction`). Eigen-sensitivities built on these
matrices are in :mod:`femcal.calibrate.sensitivity`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from math import comb

import numpy as np
import scipy.sparse as sp

from ..assembly import Options, assemble
from ..errors import FemcalError
from ..model.model import Model
from .parameters import Parameter, affected_elements, current_value, subset, with_values

#: Relative half-width of the interpolation points around P.
SPREAD = 0.3
#: Largest relative misfit at P accepted as "the dependence is that polynomial".
DEGREE_CHECK = 1e-9
#: Degrees tried, in turn, when the field's own degree does not reproduce the matrices
#: (a smooth non-polynomial dependence); an even number of Chebyshev points each.
RAISED_DEGREES = (7, 11, 15)


class DerivativeError(FemcalError):
    """A parameter's derivative cannot be formed exactly (names parameter and cause)."""


def _lagrange_derivative_weights(nodes: np.ndarray, at: float = 0.0) -> np.ndarray:
    """Weights w (n,) with f'(at) = sum w_j f(nodes_j) for every polynomial of degree
    n - 1."""
    n = len(nodes)
    w = np.zeros(n)
    for j in range(n):
        others = np.delete(nodes, j)
        denom = np.prod(nodes[j] - others)
        # derivative of prod_{k != j} (x - x_k) at x = at
        s = 0.0
        for m in range(n - 1):
            s += np.prod(np.delete(at - others, m))
        w[j] = s / denom
    return w


def _lagrange_value_weights(nodes: np.ndarray, at: float = 0.0) -> np.ndarray:
    """Weights with f(at) = sum w_j f(nodes_j) for polynomials of degree n - 1."""
    n = len(nodes)
    w = np.zeros(n)
    for j in range(n):
        others = np.delete(nodes, j)
        w[j] = np.prod(at - others) / np.prod(nodes[j] - others)
    return w


def _combine(mats: list[sp.csr_matrix], w: np.ndarray) -> sp.csr_matrix:
    out = mats[0] * w[0]
    for A, c in zip(mats[1:], w[1:], strict=True):
        out = out + A * c
    return sp.csr_matrix(out)


def _max_abs(A: sp.spmatrix) -> float:
    A = sp.csr_matrix(A)
    return float(np.abs(A.data).max()) if A.nnz else 0.0


def _chebyshev_points(count: int, lo: float, hi: float) -> np.ndarray:
    """``count`` Chebyshev points of the first kind on ``[lo, hi]``, increasing."""
    x = np.cos((2.0 * np.arange(count) + 1.0) * np.pi / (2.0 * count))[::-1]
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * x


def _relative_misfit(Ks: list, Ms: list, w: np.ndarray, exact) -> tuple[float, str]:
    """Largest relative misfit of ``sum w_j Ks[j]`` and ``sum w_j Ms[j]`` against ``exact``
    (K, M), and which of stiffness and mass it is in."""
    worst, which = 0.0, "stiffness"
    for name, series, X in (("stiffness", Ks, exact[0]), ("mass", Ms, exact[1])):
        scale = _max_abs(X)
        if scale > 0:
            miss = _max_abs(_combine(series, w) - X) / scale
            if miss > worst:
                worst, which = miss, name
    return worst, which


def _misfit(nodes: np.ndarray, series: list, at: float, exact) -> tuple[float, str]:
    """:func:`_relative_misfit` of the interpolant through ``series`` (pairs (K, M) at
    ``nodes``) against ``exact`` (K, M) at ``at``."""
    w = _lagrange_value_weights(nodes, at)
    return _relative_misfit([m[0] for m in series], [m[1] for m in series], w, exact)


def _describe(par: Parameter, kinds) -> str:
    """The parameter as errors name it: name, card, id, field and its elements' types."""
    return (f"parameter {par.name} ({par.card} {par.id} {par.field}, elements "
            f"{', '.join(sorted(kinds))})")  # fmt: skip


def interpolation_nodes(assemble_at, degree: int, interval: tuple[float, float],
                        what: str, at_zero=None) -> tuple[np.ndarray, list]:  # fmt: skip
    """Offsets ``d`` and the matrices ``assemble_at(d)`` = (K, M) there, on which the
    interpolating polynomial reproduces the matrices (see the module docstring).

    ``degree`` is the field's own degree (equally spaced points on +-SPREAD, as many as it
    needs); if that fails, :data:`RAISED_DEGREES` on Chebyshev points over ``interval``
    (which holds +-SPREAD). ``what`` names the parameter(s) in the error. ``at_zero``: the
    matrices at ``d = 0`` if the caller has them (else assembled once here).

    Raises
    ------
    DerivativeError
        If no degree up to the highest reproduces the matrices.
    """
    if at_zero is None:
        at_zero = assemble_at(0.0)
    nodes = np.linspace(-SPREAD, SPREAD, degree + 1)
    series = [assemble_at(d) for d in nodes]
    miss, which = _misfit(nodes, series, 0.0, at_zero)
    if miss <= DEGREE_CHECK:
        return nodes, series
    first = (miss, which)
    lo, hi = min(interval[0], -SPREAD), max(interval[1], SPREAD)
    for raised in (d for d in RAISED_DEGREES if d > degree):
        nodes = _chebyshev_points(raised + 1, lo, hi)
        series = [assemble_at(d) for d in nodes]
        between = 0.5 * (nodes[-2] + nodes[-1])
        miss = max(_misfit(nodes, series, 0.0, at_zero)[0],
                   _misfit(nodes, series, between, assemble_at(between))[0])  # fmt: skip
        if miss <= DEGREE_CHECK:
            return nodes, series
    raise DerivativeError(
        f"{what}: the {first[1]} of its elements is not a polynomial of degree {degree} in "
        f"it (misfit {first[0]:.1e}), nor reproduced to {DEGREE_CHECK:.0e} by one of degree "
        f"{RAISED_DEGREES[-1]} (misfit {miss:.1e}); its derivative would not be exact.")


def parameter_matrices(model: Model, par: Parameter, *, options: Options | None = None
                       ) -> tuple[sp.csr_matrix, sp.csr_matrix]:  # fmt: skip
    """dK/dP and dM/dP (g-set CSR, per unit of P) at the model's current value of P.

    Raises
    ------
    DerivativeError
        If no element depends on the parameter, or the matrices are not the polynomial of
        the field's degree in it.
    """
    spec = par.spec
    rows = affected_elements(model, par)
    if not rows:
        raise DerivativeError(f"parameter {par.name} ({par.card} {par.id} {par.field}): no "
                              "element depends on it")  # fmt: skip
    sub = subset(model, rows)
    P = current_value(model, par.card, par.id, par.field)
    degree = max(spec.k_degree, spec.m_degree)

    def assemble_at(d: float) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        mats = assemble(with_values(sub, [par], [P * (1.0 + d)]), options)
        return mats.K, mats.M

    nodes, series = interpolation_nodes(assemble_at, degree, (-SPREAD, SPREAD),
                                        _describe(par, rows))  # fmt: skip
    w = _lagrange_derivative_weights(nodes) / P  # d/dP = (d/d delta) / P
    shape = series[0][0].shape
    dK = _combine([m[0] for m in series], w) if spec.k_degree > 0 else sp.csr_matrix(shape)
    dM = _combine([m[1] for m in series], w) if spec.m_degree > 0 else sp.csr_matrix(shape)
    return dK, dM


def derivative_matrices(model: Model, params: list[Parameter], *,
                        options: Options | None = None, scaled: bool = True,
                        progress=None) -> list[tuple[sp.csr_matrix, sp.csr_matrix]]:  # fmt: skip
    """(dK, dM) of every parameter at the model's current values; with ``scaled`` per unit
    of the scaled parameter p (``dX/dp = P0 dX/dP``), else per unit of P."""
    out = []
    for k, par in enumerate(params):
        dK, dM = parameter_matrices(model, par, options=options)
        if scaled:
            dK, dM = dK * par.nominal, dM * par.nominal
        out.append((dK, dM))
        if progress is not None:
            progress(k + 1, len(params), par)
    return out


@dataclass(frozen=True)
class GroupPolynomial:
    """K and M of one group of elements as a polynomial in the scaled offsets
    ``d_i = p_i - p_c,i`` of the parameters they depend on: exact, or to 1e-9 where a
    dependence is rational and the degree was raised (:func:`interpolation_nodes`).

    params : indices (into the parameter list) of the group's parameters.
    exponents : (n_terms, len(params)) exponent of each d_i in each term (the constant term
        only if asked for).
    K, M : per term, the g-set coefficient matrix (CSR).
    """

    params: tuple[int, ...]
    exponents: np.ndarray
    K: list[sp.csr_matrix]
    M: list[sp.csr_matrix]


def element_groups(model: Model, params: list[Parameter]) -> dict[tuple[int, ...], dict]:
    """Elements grouped by the set of parameters their matrices depend on:
    (parameter indices) -> {element type: rows}."""
    marks: dict[str, list[set[int]]] = {t: [set() for _ in range(len(b))]
                                        for t, b in model.elements.items()}  # fmt: skip
    for i, par in enumerate(params):
        rows = affected_elements(model, par)
        if not rows:
            raise DerivativeError(f"parameter {par.name} ({par.card} {par.id} {par.field}): "
                                  "no element depends on it")  # fmt: skip
        for etype, r in rows.items():
            for k in r:
                marks[etype][k].add(i)
    groups: dict[tuple[int, ...], dict] = {}
    for etype, sets in marks.items():
        for k, st in enumerate(sets):
            if st:
                groups.setdefault(tuple(sorted(st)), {}).setdefault(etype, []).append(k)
    return {g: {t: np.array(r) for t, r in d.items()} for g, d in groups.items()}


def group_polynomials(model: Model, params: list[Parameter], center: np.ndarray, *,
                      options: Options | None = None, first_order: bool = False,
                      constant: bool = False, progress=None) -> list[GroupPolynomial]:  # fmt: skip
    """The exact polynomial dependence of K and M on the parameters, group by group, about
    the scaled point ``center`` (the model given is the nominal one).

    Each group's elements are assembled alone on a tensor grid of (degree + 1) offsets per
    parameter; the polynomial through those values is the matrices' dependence exactly
    (checked at the centre, as in :func:`parameter_matrices`). If that check fails, each
    parameter's degree is found alone (raised on Chebyshev points where its dependence is
    rational, :func:`interpolation_nodes`) and the grid is built again. With ``first_order``
    only the linear terms are kept (the derivatives at the centre: FEMCali's first-order
    surrogate); with ``constant`` the constant term (the group's matrices at the centre) is
    kept too.
    """
    center = np.asarray(center, float)
    out: list[GroupPolynomial] = []
    groups = element_groups(model, params)
    for n, (idx, rows) in enumerate(groups.items(), start=1):
        sub = subset(model, rows)
        pars = [params[i] for i in idx]
        at_values = [par.value(center[i]) for i, par in zip(idx, pars, strict=True)]
        at_c = assemble(with_values(sub, pars, at_values), options)
        degrees = [max(p.spec.k_degree, p.spec.m_degree) for p in pars]
        nodes = [np.linspace(-SPREAD, SPREAD, d + 1) for d in degrees]
        Ks, Ms, coef_w = _tensor_fit(sub, idx, pars, center, nodes, options)
        miss = _constant_misfit(Ks, Ms, coef_w, at_c)
        if miss[0] > DEGREE_CHECK:  # a dependence that is not the fields' polynomial
            nodes = [_alone_nodes(sub, pars, k, idx[k], at_values, at_c, center, degrees[k],
                                  options) for k in range(len(idx))]  # fmt: skip
            Ks, Ms, coef_w = _tensor_fit(sub, idx, pars, center, nodes, options)
            miss = _constant_misfit(Ks, Ms, coef_w, at_c)
        if miss[0] > DEGREE_CHECK:
            names = ", ".join(p.name for p in pars)
            raise DerivativeError(
                f"parameters {names}: the {miss[1]} of their elements ({', '.join(rows)}) is "
                f"not reproduced by the polynomial of degrees {[len(x) - 1 for x in nodes]} in "
                f"them (misfit {miss[0]:.1e}) although each parameter's alone is; their "
                "derivatives would not be exact.")  # fmt: skip
        grid = list(Ks)  # the exponent tuples are the grid's indices
        zero = tuple(0 for _ in idx)
        terms, Kc, Mc = [], [], []
        for a in grid:
            if (a == zero and not constant) or (first_order and sum(a) > 1):
                continue
            w = np.array([coef_w[a][g] for g in grid])
            K = _combine([Ks[g] for g in grid], w)
            M = _combine([Ms[g] for g in grid], w)
            tol = 1e-11
            k_zero = _max_abs(K) <= tol * max(_max_abs(at_c.K), 1e-300)
            m_zero = _max_abs(M) <= tol * max(_max_abs(at_c.M), 1e-300)
            if k_zero and m_zero and a != zero:
                continue  # the field's degree bounds both; this term is rounding
            terms.append(a)
            Kc.append(sp.csr_matrix(K.shape) if k_zero else K)
            Mc.append(sp.csr_matrix(M.shape) if m_zero else M)
        out.append(GroupPolynomial(idx, np.array(terms, int).reshape(-1, len(idx)), Kc, Mc))
        if progress is not None:
            progress(n, len(groups), [p.name for p in pars])
    return out


def _alone_nodes(sub: Model, pars: list[Parameter], k: int, i: int, at_values: list[float],
                 at_c, center: np.ndarray, degree: int, options: Options | None
                 ) -> np.ndarray:  # fmt: skip
    """Interpolation offsets for parameter ``pars[k]`` (index i) moving alone about the
    centre, the others held at ``at_values`` (``at_c``: the group's matrices there; see
    :func:`interpolation_nodes`)."""
    par = pars[k]

    def assemble_at(d: float) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        vals = list(at_values)
        vals[k] = par.value(center[i] + d)
        mats = assemble(with_values(sub, pars, vals), options)
        return mats.K, mats.M

    interval = (par.p_lower - center[i], par.p_upper - center[i])
    return interpolation_nodes(assemble_at, degree, interval, _describe(par, sub.elements),
                               (at_c.K, at_c.M))[0]  # fmt: skip


def _tensor_fit(sub: Model, idx: tuple[int, ...], pars: list[Parameter], center: np.ndarray,
                nodes: list[np.ndarray], options: Options | None
                ) -> tuple[dict, dict, dict]:  # fmt: skip
    """The group's K and M on the tensor grid of ``nodes`` (offsets per parameter about
    ``center``), and the weights giving each monomial coefficient from them: ``Ks[g]``,
    ``Ms[g]`` per grid index g, ``coef_w[a][g]`` per exponent tuple a."""
    grid = list(itertools.product(*[range(len(x)) for x in nodes]))
    Ks, Ms = {}, {}
    for g in grid:
        vals = [par.value(center[i] + nodes[k][g[k]]) for k, (i, par)
                in enumerate(zip(idx, pars, strict=True))]  # fmt: skip
        mats = assemble(with_values(sub, pars, vals), options)
        Ks[g], Ms[g] = mats.K, mats.M
    # coefficients: apply the inverse Vandermonde matrix along every parameter
    inv = [np.linalg.inv(np.vander(x, increasing=True)) for x in nodes]
    coef_w = {a: {g: float(np.prod([inv[k][a[k], g[k]] for k in range(len(idx))]))
                  for g in grid} for a in grid}  # fmt: skip
    return Ks, Ms, coef_w


def _constant_misfit(Ks: dict, Ms: dict, coef_w: dict, at_c) -> tuple[float, str]:
    """Relative misfit of the fitted constant term against the matrices at the centre, and
    in which of stiffness and mass it is largest."""
    grid = list(Ks)
    zero = tuple(0 for _ in grid[0])
    w = np.array([coef_w[zero][g] for g in grid])
    return _relative_misfit([Ks[g] for g in grid], [Ms[g] for g in grid], w, (at_c.K, at_c.M))


def shift_weight(a, b, c) -> float:
    """Weight of the term ``prod d_i^a_i`` (about p = 0) in the term ``prod (d_i - c_i)^b_i``
    about c: ``prod_i binom(a_i, b_i) c_i^(a_i - b_i)`` (0 unless a >= b). With b a unit
    vector it is the monomial's derivative at c."""
    if any(ai < bi for ai, bi in zip(a, b, strict=True)):
        return 0.0
    return float(np.prod([comb(int(ai), int(bi)) * ci ** (ai - bi)
                          for ai, bi, ci in zip(a, b, c, strict=True)]))  # fmt: skip


def polynomial_derivative(polys: list[GroupPolynomial], center: np.ndarray, j: int,
                           X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """dK/dp_j X and dM/dp_j X (n_g, m) at ``center`` from the group polynomials about 0.

    The terms' matrices are summed with their weights first (one pass over their entries
    each), then multiplied once: a group of high degree has many terms, and X many columns.
    """
    dK, dM = [], []
    for g in polys:
        if j not in g.params:
            continue
        idx = list(g.params)
        unit = np.zeros(len(idx), int)
        unit[idx.index(j)] = 1
        c = center[idx]
        for a, Kc, Mc in zip(g.exponents, g.K, g.M, strict=True):
            w = shift_weight(a, unit, c)
            if w == 0.0:
                continue
            if Kc.nnz:
                dK.append(w * Kc)
            if Mc.nnz:
                dM.append(w * Mc)
    dKX = sum(dK[1:], dK[0]) @ X if dK else np.zeros(X.shape)
    dMX = sum(dM[1:], dM[0]) @ X if dM else np.zeros(X.shape)
    return dKX, dMX
