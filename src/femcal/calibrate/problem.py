"""What the search minimises: each configuration's log-FRF metric on its surrogate (a
:class:`Term`), under Huber's loss (:mod:`femcal.calibrate.robust`) and weighed against the
others, plus the prior's rows (:class:`Problem`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .metric import jacobian_of_parts, residuals
from .robust import huber_transform
from .surrogate import Surrogate


@dataclass(frozen=True)
class Term:
    """One configuration's part of the metric: its surrogate's FRFs against its test's at
    ``freq`` (n_f,). ``index`` (n_p_c,) places the surrogate's parameters in the shared
    vector; ``factor`` weighs its residuals against the other terms' (the likelihood's
    reference scale over its own); ``correction`` (n_residuals, n_p_c), if given, is added
    to the residuals as ``correction (p - p_c)`` about the surrogate's centre p_c (the
    first-order correction of :mod:`femcal.calibrate.gradient`); ``rows`` (n_residuals,)
    bool, if given, keeps only those residuals (a hold-out fold's training part); ``huber``,
    if given, is the threshold of Huber's loss on the residuals (None: least squares)."""

    surrogate: Surrogate
    freq: np.ndarray
    H_test: np.ndarray
    metric: str
    index: np.ndarray
    factor: float = 1.0
    correction: np.ndarray | None = None
    rows: np.ndarray | None = None
    huber: float | None = None

    def residuals(self, p: np.ndarray) -> np.ndarray:
        """eps at the shared p (unweighted; ``rows`` only)."""
        q = np.asarray(p, float)[self.index]
        r = residuals(self.surrogate.frf(q, self.freq), self.H_test, self.metric)
        if self.correction is not None:
            r = r + self.correction @ (q - self.surrogate.p_center)
        return r if self.rows is None else r[self.rows]

    @property
    def n_residuals(self) -> int:
        """How many residuals the term gives (``rows`` only)."""
        n = self.H_test.size * (2 if self.metric == "complex-log" else 1)
        return n if self.rows is None else int(np.count_nonzero(self.rows))

    def jacobian(self, p: np.ndarray, which: np.ndarray | None = None, *,
                 out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """(J (n_residuals, n_p_c), eps) at the shared p (unweighted; ``rows`` only), the
        correction included (at the centre of a corrected term: the full model's); with
        ``which`` (shared, bool) only those parameters' columns are computed (the others:
        the correction's alone). J is written into ``out`` (n_residuals, n_p_c), a zero
        array, if given, and is otherwise a new array."""
        q = np.asarray(p, float)[self.index]
        mine = None if which is None else np.asarray(which)[self.index]
        H, sel, X = self.surrogate.frf_and_jacobian_parts(q, self.freq, mine)
        r = residuals(H, self.H_test, self.metric)
        into = out if self.rows is None else None
        if len(sel) == len(q):
            J = jacobian_of_parts(H, X, self.metric, self.H_test, out=into)
        else:  # (the other columns are zero)
            J = jacobian_of_parts(H, X, self.metric, self.H_test, columns=sel,
                                  out=np.zeros((len(r), len(q))) if into is None else into)
        if self.correction is not None:
            J += self.correction  # (J is this call's own array, or out)
            r = r + self.correction @ (q - self.surrogate.p_center)
        if self.rows is None:
            return J, r
        J, r = J[self.rows], r[self.rows]
        if out is not None:
            out[:] = J
            J = out
        return J, r

    def transformed(self, eps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(t, dt/de) of residuals under the term's loss (t = eps under least squares)."""
        if self.huber is None:
            return eps, np.ones_like(eps)
        return huber_transform(eps, self.huber)


@dataclass(frozen=True)
class Problem:
    """What every start minimises: the terms' weighted, transformed residuals (every
    configuration's metric under its loss) within the bounds, plus ``(weights p)^2`` (the
    prior's rows; None for none)."""

    terms: tuple[Term, ...]
    lower: np.ndarray
    upper: np.ndarray
    max_iter: int
    weights: np.ndarray | None = None

    @classmethod
    def single(cls, surrogate: Surrogate, freq: np.ndarray, H_test: np.ndarray, metric: str,
               lower: np.ndarray, upper: np.ndarray, max_iter: int,
               weights: np.ndarray | None = None,
               correction: np.ndarray | None = None) -> Problem:  # fmt: skip
        """One configuration whose surrogate's parameters are all of them."""
        term = Term(surrogate, freq, H_test, metric, np.arange(len(lower)),
                    correction=correction)  # fmt: skip
        return cls((term,), np.asarray(lower, float), np.asarray(upper, float), max_iter,
                   weights)  # fmt: skip

    def _data_residuals(self, p: np.ndarray) -> np.ndarray:
        return np.concatenate([t.factor * t.transformed(t.residuals(p))[0] for t in self.terms])

    def data_jacobian(self, p: np.ndarray, which: np.ndarray | None = None, *,
                      extra_rows: int = 0) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """(J (n_residuals + extra_rows, n_p), r (n_residuals,)) of the data part at p: every
        term's transformed residuals and their Jacobian, weighed by its factor, the
        corrections included, and ``extra_rows`` rows of zeros after them (room for the
        prior's rows); with ``which`` (n_p,) bool only those columns (:meth:`Term.jacobian`)."""
        n_p = len(self.lower)
        sizes = [t.n_residuals for t in self.terms]
        J = np.zeros((sum(sizes) + extra_rows, n_p))
        rs = []
        at = 0
        for t, size in zip(self.terms, sizes, strict=True):
            block = J[at : at + size]
            whole = len(t.index) == n_p and bool((t.index == np.arange(n_p)).all())
            Jt, et = t.jacobian(p, which, out=block if whole else None)
            rt, dt = t.transformed(et)
            # (in place: Jt is the term's own array or its block of J)
            if t.huber is not None:  # (least squares: dt = 1)
                Jt *= dt[:, None]
            if t.factor != 1.0:
                Jt *= t.factor
            if not whole:
                block[:, t.index] = Jt
            rs.append(t.factor * rt)
            at += size
        return J, np.concatenate(rs)

    def fun(self, p: np.ndarray):
        """Residuals and a callable for their Jacobian (computed for accepted points only)."""
        r = self._data_residuals(p)
        w = self.weights

        def jac() -> np.ndarray:  # (a parameter held by its bounds needs no column)
            if w is None:
                return self.data_jacobian(p, self.lower < self.upper)[0]
            J = self.data_jacobian(p, self.lower < self.upper, extra_rows=len(w))[0]
            J[-len(w) :] = np.diag(w)
            return J

        return (r if w is None else np.concatenate([r, w * p])), jac

    def cost(self, p: np.ndarray) -> float:
        """|r|^2 / 2 at p, the prior included."""
        r = self.fun(p)[0]
        return 0.5 * float(r @ r)

    def deviation(self, p: np.ndarray) -> float:
        """The data part alone, unweighted and untransformed: the sum of every term's
        eps^T eps."""
        return float(sum(float(r @ r) for r in (t.residuals(p) for t in self.terms)))
