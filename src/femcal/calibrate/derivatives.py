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
the surrogate reduces (:mod:`femcal.calibrate.reduction`). A group is assembled again and
again on one sparsity pattern (:class:`~femcal.assembly.repeated.RepeatedAssembly`), so the
fits are dense arithmetic on data vectors; a parameter that only scales the group's K or M
(a modulus with G derived from it, a density) is found so by its own check and needs no
grid of its own. Eigen-sensitivities built on these
matrices are in :mod:`femcal.calibrate.sensitivity`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from math import comb

import numpy as np
import scipy.sparse as sp

from ..assembly import Options
from ..assembly.repeated import RepeatedAssembly
from ..errors import FemcalError
from ..model.model import Model
from ..parallel import executor
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


def _max_abs(x: np.ndarray) -> float:
    return float(np.abs(x).max()) if x.size else 0.0


def _chebyshev_points(count: int, lo: float, hi: float) -> np.ndarray:
    """``count`` Chebyshev points of the first kind on ``[lo, hi]``, increasing."""
    x = np.cos((2.0 * np.arange(count) + 1.0) * np.pi / (2.0 * count))[::-1]
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * x


def _relative_misfit(fitted: tuple[np.ndarray, np.ndarray],
                     exact: tuple[np.ndarray, np.ndarray]) -> tuple[float, str]:  # fmt: skip
    """Largest relative misfit of the fitted (K, M) data against the ``exact`` ones, and
    which of stiffness and mass it is in."""
    worst, which = 0.0, "stiffness"
    for name, f, x in zip(("stiffness", "mass"), fitted, exact, strict=True):
        scale = _max_abs(x)
        if scale > 0:
            miss = _max_abs(f - x) / scale
            if miss > worst:
                worst, which = miss, name
    return worst, which


def _misfit(nodes: np.ndarray, series: list, at: float, exact) -> tuple[float, str]:
    """:func:`_relative_misfit` of the interpolant through ``series`` (pairs (K, M) of data
    vectors at ``nodes``) against ``exact`` (K, M) at ``at``."""
    w = _lagrange_value_weights(nodes, at)
    return _relative_misfit(_weighted(series, w), exact)


def _weighted(series: list, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sum w_j K_j`` and ``sum w_j M_j`` of the pairs (K, M) of data vectors."""
    K = sum(c * m[0] for c, m in zip(w, series, strict=True))
    M = sum(c * m[1] for c, m in zip(w, series, strict=True))
    return K, M


def _describe(par: Parameter, kinds) -> str:
    """The parameter as errors name it: name, card, id, field and its elements' types."""
    return (f"parameter {par.name} ({par.card} {par.id} {par.field}, elements "
            f"{', '.join(sorted(kinds))})")  # fmt: skip


@dataclass(frozen=True)
class Nodes:
    """Interpolation offsets found for one parameter moving alone (:func:`interpolation_nodes`).

    offsets : (n,) the offsets, 0 (the centre) not among them.
    series : per offset the assembled (K, M), as the evaluation gave them.
    raised : whether the field's own degree failed and Chebyshev points of a raised degree
        approximate a smooth non-polynomial dependence (else the polynomial is exact, and any
        n distinct offsets give it).
    """

    offsets: np.ndarray
    series: list
    raised: bool


def interpolation_nodes(assemble_at, degree: int, interval: tuple[float, float],
                        what: str, at_zero=None, first_try: int | None = None,
                        align=None, assemble_all=None) -> Nodes:  # fmt: skip
    """Offsets ``d`` and the matrices ``assemble_at(d)`` = (K, M) there, on which the
    interpolating polynomial reproduces the matrices (see the module docstring).

    ``degree`` is the field's own degree (equally spaced points on +-SPREAD, as many as it
    needs); if that fails, :data:`RAISED_DEGREES` on Chebyshev points over ``interval``
    (which holds +-SPREAD). ``what`` names the parameter(s) in the error. ``at_zero``: the
    matrices at ``d = 0`` if the caller has them (else assembled once here). The matrices
    are data vectors of one pattern (:class:`~femcal.assembly.repeated.RepeatedAssembly`),
    or what ``align`` turns into them. ``first_try``: a raised degree
    to try before all others (the one an alike group of elements needed); it is checked as
    any other, and the usual ladder follows if it fails. ``align``: turns a list of what
    ``assemble_at`` returned into pairs (K, M) of one shape (default: as they are).
    ``assemble_all``: ``assemble_at`` of a list of offsets at once (default: one by one).

    Raises
    ------
    DerivativeError
        If no degree up to the highest reproduces the matrices.
    """
    if at_zero is None:
        at_zero = assemble_at(0.0)
    lo, hi = min(interval[0], -SPREAD), max(interval[1], SPREAD)
    align = align or (lambda items: items)
    assemble_all = assemble_all or (lambda offsets: [assemble_at(d) for d in offsets])

    def misfit(nodes: np.ndarray, series: list, at: float, exact) -> tuple[float, str]:
        *series, exact = align([*series, exact])
        return _misfit(nodes, series, at, exact)

    def raised_fit(raised: int) -> tuple[Nodes, float]:
        nodes = _chebyshev_points(raised + 1, lo, hi)
        between = 0.5 * (nodes[-2] + nodes[-1])
        *series, at_between = assemble_all([*nodes, between])
        miss = max(misfit(nodes, series, 0.0, at_zero)[0],
                   misfit(nodes, series, between, at_between)[0])  # fmt: skip
        return Nodes(nodes, series, True), miss

    if first_try is not None and first_try > degree:
        found, miss = raised_fit(first_try)
        if miss <= DEGREE_CHECK:
            return found
    nodes = np.linspace(-SPREAD, SPREAD, degree + 1)
    series = assemble_all(list(nodes))
    miss, which = misfit(nodes, series, 0.0, at_zero)
    if miss <= DEGREE_CHECK:
        return Nodes(nodes, series, False)
    first = (miss, which)
    for raised in (d for d in RAISED_DEGREES if d > degree and d != first_try):
        found, miss = raised_fit(raised)
        if miss <= DEGREE_CHECK:
            return found
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
    repeated = RepeatedAssembly(sub, options, whole=model)
    P = current_value(model, par.card, par.id, par.field)
    degree = max(spec.k_degree, spec.m_degree)

    def assemble_at(d: float) -> tuple[np.ndarray, np.ndarray]:
        return repeated.data(with_values(sub, [par], [P * (1.0 + d)]))

    found = interpolation_nodes(assemble_at, degree, (-SPREAD, SPREAD), _describe(par, rows))
    w = _lagrange_derivative_weights(found.offsets) / P  # d/dP = (d/d delta) / P
    dK, dM = _weighted(found.series, w)
    shape = (model.n_dof, model.n_dof)
    return (repeated.matrix(dK) if spec.k_degree > 0 else sp.csr_matrix(shape),
            repeated.matrix(dM) if spec.m_degree > 0 else sp.csr_matrix(shape))  # fmt: skip


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

    Each group's elements are assembled alone (:class:`~femcal.assembly.repeated.
    RepeatedAssembly`: one pattern, the whole model's shell normals). First each parameter
    moves alone about the centre, and its interpolation offsets are found as in
    :func:`interpolation_nodes` (the field's degree, raised on Chebyshev points where the
    dependence is rational; a raised degree one group needed is tried first for the alike
    parameters of the next). A parameter that, moving alone, scales the group's K or M in
    proportion to its value (found so at one offset) takes no grid: its terms are the
    others' scaled. Then the
    group is assembled on the tensor grid of the other parameters' offsets, with the centre
    in place of one offset of every parameter whose polynomial is exact (the same
    polynomial, and the grid shares the assemblies of the parameters moving alone), and the
    whole polynomial is checked at a point off the grid in every parameter. With
    ``first_order`` only the linear terms are kept (the derivatives at the
    centre: FEMCali's first-order surrogate); with ``constant`` the constant term (the
    group's matrices at the centre) is kept too.

    Raises
    ------
    DerivativeError
        If a parameter's dependence is not reproduced (:func:`interpolation_nodes`), or the
        group's joint dependence is not the product of its parameters' polynomials.
    """
    center = np.asarray(center, float)
    out: list[GroupPolynomial] = []
    groups = element_groups(model, params)
    raised: dict[tuple, int | None] = {}  # the degrees alike groups needed (None: their own)
    for n, (idx, rows) in enumerate(groups.items(), start=1):
        fit = _GroupFit(model, rows, [params[i] for i in idx], center[list(idx)], options,
                        raised)  # fmt: skip
        exps, K, M = fit.coefficients()
        k_at, m_at = (fit.repeated.places(at) for at in fit.places)  # (shared by the terms)
        terms, Kc, Mc = [], [], []
        tol = 1e-11
        shape = (model.n_dof, model.n_dof)
        k_scale, m_scale = _max_abs(fit.at_centre[0]), _max_abs(fit.at_centre[1])
        for a, Ka, Ma in zip(exps, K, M, strict=True):
            if (sum(a) == 0 and not constant) or (first_order and sum(a) > 1):
                continue
            k_zero = _max_abs(Ka) <= tol * max(k_scale, 1e-300)
            m_zero = _max_abs(Ma) <= tol * max(m_scale, 1e-300)
            if k_zero and m_zero and sum(a) > 0:
                continue  # the field's degree bounds both; this term is rounding
            terms.append(a)
            Kc.append(sp.csr_matrix(shape) if k_zero else fit.repeated.matrix(Ka, k_at))
            Mc.append(sp.csr_matrix(shape) if m_zero else fit.repeated.matrix(Ma, m_at))
        out.append(GroupPolynomial(idx, np.array(terms, int).reshape(-1, len(idx)), Kc, Mc))
        if progress is not None:
            progress(n, len(groups), [params[i].name for i in idx])
    return out


#: Elements of each type a group's degree is first found on (:meth:`_GroupFit._probe`), for
#: groups of over four times as many.
_PROBE = 64

#: Columns of the coefficient data turned from assemblies into coefficients at a time.
_COLUMNS = 1 << 16


class _GroupFit:
    """One group's assemblies about the centre and the polynomial through them (see
    :func:`group_polynomials`); every assembly is made once, whoever asks for it.

    K and M are kept as their data on the places of the group's pattern that hold a value
    (:attr:`places`: about half of a shell's pattern is zero, most of a lumped mass's), which
    grow if an assembly puts a value elsewhere."""

    def __init__(self, model: Model, rows: dict, pars: list[Parameter], centre: np.ndarray,
                 options: Options | None, raised: dict[tuple, int | None]):  # fmt: skip
        """``raised``: per (card, field, element types) the raised degree a group needed,
        None for the field's own (tried first for an alike parameter; what this group needs
        is put there)."""
        self.raised = raised
        self._model, self._rows, self._options = model, rows, options
        self.sub = subset(model, rows)
        self.kinds = list(rows)
        self.pars = pars
        self.centre = centre
        self.repeated = RepeatedAssembly(self.sub, options, whole=model)
        #: K's and M's places in the pattern (sorted positions)
        self.places = [np.zeros(0, np.int64), np.zeros(0, np.int64)]
        # offsets -> K and M data and the places each is on
        self._made: dict[tuple[float, ...], tuple] = {}
        # per matrix: the present places and each pattern position's rank among them
        self._rank: list[tuple | None] = [None, None]
        self._centre = self._made[(0.0,) * len(pars)] = self._assemble((0.0,) * len(pars))

    @property
    def at_centre(self) -> tuple[np.ndarray, np.ndarray]:
        """The group's K data and M data (on the present :attr:`places`) at the centre."""
        return self._placed(self._centre)

    def _assemble(self, offsets: tuple[float, ...]) -> tuple:
        return self._place(self._data(offsets))

    def _assemble_all(self, keys: list[tuple[float, ...]]) -> list[tuple]:
        """:meth:`_assemble` of each of ``keys``: up to as many at once as the assembly has
        threads, each on one (the main thread's share of an assembly, its sections and
        scatter, is then not waited for), placed in order."""
        workers = min(self.repeated.threads, len(keys))
        if workers < 2:
            return [self._assemble(key) for key in keys]
        with executor("threads", workers, name="femcal-fit") as pool:
            made = list(pool.map(lambda key: self._data(key, threads=1), keys))
        return [self._place(data) for data in made]

    def _data(self, offsets: tuple[float, ...], threads: int | None = None
              ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """The group's K and M data (nnz,) at the offsets."""
        values = [p.value(c + d) for p, c, d in zip(self.pars, self.centre, offsets, strict=True)]
        return self.repeated.data(with_values(self.sub, self.pars, values), threads=threads)

    def _place(self, data: tuple[np.ndarray, np.ndarray]) -> tuple:
        """An assembly's data on :attr:`places` (grown if it has values elsewhere)."""
        out = []
        for which, X in enumerate(data):
            at = self.places[which]
            if np.count_nonzero(X) != np.count_nonzero(X[at]):  # values elsewhere too
                held = np.zeros(len(X), bool)
                held[at] = True
                held |= X != 0.0
                at = self.places[which] = np.flatnonzero(held)
            out.append([X[at], at])
        return tuple(out)

    def _placed(self, made: tuple) -> tuple[np.ndarray, np.ndarray]:
        """K and M data of an assembly on the present :attr:`places`: an older assembly's
        data, on fewer places, go where their places rank among the present ones (the rank
        of every place of the pattern is made once per growth of the places), and are kept
        so in ``made`` (whoever holds it)."""
        out = []
        for which, (pair, now) in enumerate(zip(made, self.places, strict=True)):
            X, at = pair
            if len(at) != len(now):
                ranked = self._rank[which]
                if ranked is None or ranked[0] is not now:
                    rank = np.zeros(int(now[-1]) + 1, np.int64)
                    rank[now] = np.arange(len(now))
                    ranked = self._rank[which] = (now, rank)
                grown = np.zeros(len(now))
                grown[ranked[1][at]] = X
                X = pair[0] = grown
                pair[1] = now
            out.append(X)
        return out[0], out[1]

    def _alone(self, k: int) -> Nodes:
        """Parameter k's interpolation offsets, the others at the centre."""
        par = self.pars[k]

        def key(d: float) -> tuple[float, ...]:
            return tuple(d if j == k else 0.0 for j in range(len(self.pars)))

        def assemble_at(d: float) -> tuple:
            return assemble_all([d])[0]

        def assemble_all(offsets: list[float]) -> list[tuple]:
            points = [key(d) for d in offsets]
            missing = list(dict.fromkeys(pt for pt in points if pt not in self._made))
            self._made.update(zip(missing, self._assemble_all(missing), strict=True))
            return [self._made[pt] for pt in points]

        interval = (par.p_lower - self.centre[k], par.p_upper - self.centre[k])
        degree = max(par.spec.k_degree, par.spec.m_degree)
        if (par.spec.k_degree, par.spec.m_degree) in ((1, 0), (0, 1)):
            scaling = Nodes(np.array([SPREAD]), assemble_all([SPREAD]), False)
            if self._scales(k, scaling):  # (checked at -SPREAD too, by the whole polynomial)
                return scaling
        alike = (par.card, par.field, tuple(sorted(self.kinds)))
        if alike not in self.raised and sum(map(len, self._rows.values())) > 4 * _PROBE:
            self._probe(k, alike)  # (once per alike kind: what it found, raised or not)
        found = interpolation_nodes(assemble_at, degree, interval, _describe(par, self.kinds),
                                    self._centre, self.raised.get(alike),
                                    lambda items: [self._placed(m) for m in items],
                                    assemble_all)  # fmt: skip
        if found.raised:
            self.raised[alike] = len(found.offsets) - 1
        return found

    def _probe(self, k: int, alike: tuple) -> None:
        """Find the degree parameter k needs on a sample of the group's elements (about
        :data:`_PROBE`, spread over each type's rows) and note it in :attr:`raised` (None:
        the field's own) for the whole group, and alike groups after it, to try first: the
        ladder of degrees then climbs on the sample, not on every element. The whole
        group's fit is checked as any."""
        sample = {t: r[:: max(1, -(-len(r) // _PROBE))] for t, r in self._rows.items()}
        probe = _GroupFit(self._model, sample, self.pars, self.centre, self._options, {})
        try:
            found = probe._alone(k)
        except DerivativeError:  # the whole group's fit says what fails
            return
        self.raised[alike] = len(found.offsets) - 1 if found.raised else None

    def _scales(self, k: int, found: Nodes) -> str | None:
        """Which of the group's matrices ("K" or "M") parameter k, moving alone, scales in
        proportion to its value while it leaves the other (a modulus with G derived from E,
        a density), or None: then ``X(d) = X(0) (1 + d / (1 + c))`` is the whole dependence
        on it."""
        spec = self.pars[k].spec
        if found.raised or (spec.k_degree, spec.m_degree) not in ((1, 0), (0, 1)):
            return None
        which = 0 if spec.k_degree else 1
        base = self.at_centre
        for d, made in zip(found.offsets, found.series, strict=True):
            series = self._placed(made)
            factor = 1.0 + d / (1.0 + self.centre[k])
            scaled = (base[0] * factor, base[1]) if which == 0 else (base[0], base[1] * factor)
            if _relative_misfit(series, scaled)[0] > DEGREE_CHECK:
                return None
        return "KM"[which]

    def coefficients(self) -> tuple[list[tuple[int, ...]], list, list]:
        """Exponent tuples and the K and M data (on :attr:`places`) of their coefficients,
        per term, or empty where it is zero."""
        n = len(self.pars)
        alone = [self._alone(k) for k in range(n)]
        scales = [self._scales(k, a) for k, a in enumerate(alone)]
        # grid offsets: an exact polynomial's with the centre for its first offset (which
        # stays off the grid, the check's coordinate); a raised one's as found (the check
        # between its first two); a scaling parameter's the centre only (the check on the
        # other side of the centre from the offset it was found to scale at)
        grid, off = [], []
        for a, scale in zip(alone, scales, strict=True):
            if scale is not None:
                grid.append(np.zeros(1))
                off.append(-float(a.offsets[0]))
            elif a.raised:
                grid.append(a.offsets)
                off.append(0.5 * float(a.offsets[0] + a.offsets[1]))
            else:
                grid.append(np.concatenate([[0.0], a.offsets[1:]]))
                off.append(float(a.offsets[0]))
        off = tuple(off)
        points = [tuple(float(x) for x in pt) for pt in itertools.product(*grid)]
        for key in [k for k in self._made if k not in set(points) | {off}]:
            del self._made[key]  # the alone fits' other tries
        inv = [np.linalg.inv(np.vander(x, increasing=True)) for x in grid]
        base = list(itertools.product(*[range(len(x)) for x in grid]))
        W = np.array([[np.prod([inv[k][a[k], g[k]] for k in range(n)]) for g in base]
                      for a in base])  # fmt: skip
        missing = [pt for pt in dict.fromkeys([off, *points]) if pt not in self._made]
        self._made.update(zip(missing, self._assemble_all(missing), strict=True))
        check = self._made.pop(off)
        # the coefficients, sum_g W[a, g] X(g): the grid's assemblies in rows (the alone
        # lines' moved there), turned into coefficients in place a block of columns at a time
        made = [self._made.pop(pt) for pt in points]
        CK = np.empty((len(base), len(self.places[0])))
        CM = np.empty((len(base), len(self.places[1])))
        for g in range(len(points)):
            CK[g], CM[g] = self._placed(made[g])
            made[g] = None
        for lo in range(0, CK.shape[1], _COLUMNS):
            CK[:, lo : lo + _COLUMNS] = W @ CK[:, lo : lo + _COLUMNS]
        CM = W @ CM
        exps, CK, CM = self._with_scales(base, CK, CM, scales)
        # the check, off the grid in every parameter
        powers = [np.prod([o ** e for o, e in zip(off, a, strict=True)]) for a in exps]
        exact = self._placed(check)
        miss = _relative_misfit((_sum_rows(powers, CK, exact[0]),
                                 _sum_rows(powers, CM, exact[1])), exact)  # fmt: skip
        if miss[0] > DEGREE_CHECK:
            names = ", ".join(p.name for p in self.pars)
            raise DerivativeError(
                f"parameters {names}: the {miss[1]} of their elements "
                f"({', '.join(self.kinds)}) is not reproduced by the polynomial of degrees "
                f"{[len(x) - 1 for x in grid]} in them (misfit {miss[0]:.1e}) although each "
                "parameter's alone is; their derivatives would not be exact.")  # fmt: skip
        self._made.clear()
        return exps, CK, CM

    def _with_scales(self, base: list[tuple[int, ...]], CK: np.ndarray, CM: np.ndarray,
                     scales: list[str | None]) -> tuple[list, list, list]:  # fmt: skip
        """The terms of the scaling parameters added to the others' (``base``, the scaling
        parameters' exponents 0): a term with exponent 1 in a set of them is the base term
        times ``1 / (1 + c)`` of each, in the matrix they scale (zero in the other)."""
        which = [k for k, s in enumerate(scales) if s is not None]
        if not which:
            return base, list(CK), list(CM)
        exps, rows = [], []
        for ones in itertools.product((0, 1), repeat=len(which)):
            k_factor = m_factor = 1.0
            for k, e in zip(which, ones, strict=True):
                if e:
                    f = 1.0 / (1.0 + self.centre[k])
                    k_factor *= f if scales[k] == "K" else 0.0
                    m_factor *= f if scales[k] == "M" else 0.0
            if k_factor == 0.0 and m_factor == 0.0:
                continue
            for i, a in enumerate(base):
                exps.append(tuple(e if k not in which else ones[which.index(k)]
                                  for k, e in enumerate(a)))  # fmt: skip
                rows.append((i, k_factor, m_factor))
        # (a factor 1 keeps the base term's row itself, a factor 0 an empty row)
        K = [CK[i] if kf == 1.0 else CK[i] * kf if kf else CK[i, :0] for i, kf, _ in rows]
        M = [CM[i] if mf == 1.0 else CM[i] * mf if mf else CM[i, :0] for i, _, mf in rows]
        return exps, K, M


def _sum_rows(weights: list[float], rows: list[np.ndarray], like: np.ndarray) -> np.ndarray:
    """``sum_i weights[i] rows[i]`` over the rows that are not empty (zero terms)."""
    out = np.zeros_like(like)
    for w, r in zip(weights, rows, strict=True):
        if r.size and w:
            out += w * r
    return out


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
    """dK/dp_j X and dM/dp_j X (n_g, m) at ``center`` from the group polynomials about 0
    (:func:`polynomial_derivative_rows` spread over every row)."""
    rows, dKX, dMX = polynomial_derivative_rows(polys, center, j, X)
    fullK, fullM = np.zeros(X.shape), np.zeros(X.shape)
    fullK[rows], fullM[rows] = dKX, dMX
    return fullK, fullM


def polynomial_derivative_rows(polys: list[GroupPolynomial], center: np.ndarray, j: int,
                               X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows (ascending) where dK/dp_j X or dM/dp_j X at ``center`` is not zero, and
    those rows of the two, (n_rows, m) each, from the group polynomials about 0; X (n_g, m)
    real.

    The terms' matrices are summed with their weights first (one pass over their entries
    each), then their stored rows (the parameter's elements' DOF) alone are multiplied: a
    group of high degree has many terms, and X many columns. Each row of a sparse product
    is its own sum, so these rows are those of the whole product, to the bit.
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
                dK.append((w, Kc))
            if Mc.nnz:
                dM.append((w, Mc))
    sums = [_weighted_sum(terms) if terms else None for terms in (dK, dM)]
    present = [A for A in sums if A is not None]
    stored = touched_rows(present) if present else np.zeros(0, np.int64)
    dKX, dMX = (A[stored] @ X if A is not None else np.zeros((len(stored), X.shape[1]))
                for A in sums)  # fmt: skip
    keep = np.any(dKX != 0, axis=1) | np.any(dMX != 0, axis=1)
    return stored[keep], dKX[keep], dMX[keep]


def touched_rows(mats: list[sp.csr_matrix]) -> np.ndarray:
    """Sorted indices of the rows with a stored entry in any of the CSR matrices (symmetric
    matrices: the same indices are their columns)."""
    hit = np.zeros(mats[0].shape[0], bool)
    for A in mats:
        hit[np.flatnonzero(np.diff(A.indptr))] = True
    return np.flatnonzero(hit)


def _weighted_sum(terms: list[tuple[float, sp.csr_matrix]]) -> sp.csr_matrix:
    """``sum w A`` over the (w, A) in order, as a sparse sum of the terms one after another
    would give it: the first run of terms on the same index arrays (a group's,
    :meth:`~femcal.assembly.repeated.RepeatedAssembly.matrix`) is summed on its data
    vectors (the same additions in the same order, without a sparse addition per term;
    explicit zeros it may keep add nothing to a product), every later term added to the sum
    as a sparse matrix."""
    w, A = terms[0]
    data = w * A.data
    k = 1
    while k < len(terms) and terms[k][1].indices is A.indices and terms[k][1].indptr is A.indptr:
        data = data + terms[k][0] * terms[k][1].data
        k += 1
    total = sp.csr_matrix((data, A.indices, A.indptr), shape=A.shape)
    for w, B in terms[k:]:
        total = total + w * B
    return total
