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

    def jacobian(self, p: np.ndarray, which: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """(J (n_residuals, n_p_c), eps) at the shared p (unweighted; ``rows`` only), the
        correction included (at the centre of a corrected term: the full model's); with
        ``which`` (shared, bool) only those parameters' columns are computed (the others:
        the correction's alone)."""
        q = np.asarray(p, float)[self.index]
        mine = None if which is None else np.asarray(which)[self.index]
        H, sel, X = self.surrogate.frf_and_jacobian_parts(q, self.freq, mine)
        r = residuals(H, self.H_test, self.metric)
        if len(sel) == len(q):
            J = jacobian_of_parts(H, X, self.metric, self.H_test)
        else:  # (the other columns are zero)
            J = jacobian_of_parts(H, X, self.metric, self.H_test,
                                  out=np.zeros((len(r), len(q))), columns=sel)  # fmt: skip
        if self.correction is not None:
            J += self.correction  # (J is this call's own array)
            r = r + self.correction @ (q - self.surrogate.p_center)
        return (J, r) if self.rows is None else (J[self.rows], r[self.rows])

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

    def data_jacobian(self, p: np.ndarray, which: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """(J (n_residuals, n_p), r (n_residuals,)) of the data part at p: every term's
        transformed residuals and their Jacobian, weighed by its factor, the corrections
        included; with ``which`` (n_p,) bool only those columns (:meth:`Term.jacobian`)."""
        Js, rs = [], []
        n_p = len(self.lower)
        for t in self.terms:
            Jt, et = t.jacobian(p, which)
            rt, dt = t.transformed(et)
            if t.huber is not None:  # (least squares: dt = 1)
                Jt = dt[:, None] * Jt
            if t.factor != 1.0:
                Jt = t.factor * Jt
            if len(t.index) == n_p and (t.index == np.arange(n_p)).all():
                Js.append(Jt)
            else:
                J = np.zeros((len(rt), n_p))
                J[:, t.index] = Jt
                Js.append(J)
            rs.append(t.factor * rt)
        return (Js[0] if len(Js) == 1 else np.vstack(Js)), np.concatenate(rs)

    def fun(self, p: np.ndarray):
        """Residuals and a callable for their Jacobian (computed for accepted points only)."""
        r = self._data_residuals(p)
        w = self.weights

        def jac() -> np.ndarray:  # (a parameter held by its bounds needs no column)
            J = self.data_jacobian(p, self.lower < self.upper)[0]
            return J if w is None else np.vstack([J, np.diag(w)])

        return (r if w is None else np.concatenate([r, w * p])), jac

    def cost(self, p: np.ndarray) -> float:
        """|r|^2 / 2 at p, the prior included."""
        r = self.fun(p)[0]
        return 0.5 * float(r @ r)

    def deviation(self, p: np.ndarray) -> float:
        """The data part alone, unweighted and untransformed: the sum of every term's
        eps^T eps."""
        return float(sum(float(r @ r) for r in (t.residuals(p) for t in self.terms)))
