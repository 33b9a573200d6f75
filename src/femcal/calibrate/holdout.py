"""Validation on data the fit did not see: the calibration is repeated with part of the test
held out, and the held-out part is predicted by the model calibrated without it.

The folds (``holdout`` in the configuration):

* ``inputs``: each input's FRFs in turn (a hammer test with two impact points: two folds);
* ``sensors``: the sensor positions in ``holdout_folds`` groups of neighbours in the test's
  order, every direction of a position together;
* ``configurations``: each configuration in turn, when several are calibrated together;
* ``auto``: configurations when there are several, else inputs when every configuration
  has two or more, else sensors.

Each fold is calibrated as the whole test was, from what remains: the likelihood is
estimated again from the remaining residuals at the nominal model (under the same loss), the
parameters the remaining data cannot inform are held, and Levenberg-Marquardt minimises
misfit plus prior on the final surrogates (the full models at the calibrated point, corrected
to first order), from the nominal point and from the full calibration's (the lower minimum
wins). The held-out residuals are then evaluated on the full model at the fold's parameters
(their deviation under the same loss) and set against the nominal model's: a calibration
whose parameters stand for the test's noise or for something the model lacks predicts the
held-out data worse than the nominal values do.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from .cases import Case, residual_rows
from .config import HOLDOUT_KINDS
from .identifiability import identifiability
from .lm import levenberg_marquardt
from .parameters import Parameter
from .prior import Prior, likelihood_of
from .problem import Problem, Term
from .robust import huber_deviation


@dataclass(frozen=True)
class Fold:
    """One held-out part and its prediction.

    Attributes
    ----------
    name : what is held out (``hammer: input 839:+Y``).
    case : the configuration whose residuals are held out. rows : (n_residuals,) bool, which
        of its residuals (the metric's layout).
    p : (n_p,) the parameters calibrated without them. held : (n_p,) held at the nominal in
        that calibration.
    deviation_nominal, deviation_calibrated : the held-out residuals' deviation on the full
        model at the nominal point and at ``p``, under the search's loss (Huber's: the sum
        of squares within its threshold, growing linearly beyond).
    """

    name: str
    case: int
    rows: np.ndarray
    p: np.ndarray
    held: np.ndarray
    deviation_nominal: float
    deviation_calibrated: float

    @property
    def better(self) -> bool:
        """The calibration without the held-out data predicts them better than nominal."""
        return self.deviation_calibrated < self.deviation_nominal


@dataclass(frozen=True)
class HoldOut:
    """The hold-out validation: its kind (inputs, sensors or configurations) and folds."""

    kind: str
    folds: tuple[Fold, ...]

    @property
    def deviation_nominal(self) -> float:
        return float(sum(f.deviation_nominal for f in self.folds))

    @property
    def deviation_calibrated(self) -> float:
        return float(sum(f.deviation_calibrated for f in self.folds))

    @property
    def better(self) -> bool:
        """Over all folds, the held-out data are predicted better than by the nominal model."""
        return self.deviation_calibrated < self.deviation_nominal


def fold_plan(cases: Sequence[Case], kind: str, n_sensor_folds: int, metric: str
              ) -> tuple[str, list[tuple[str, int, np.ndarray]]]:  # fmt: skip
    """(the kind used, [(name, case, rows)]) for ``kind`` (see the module docstring).

    Raises
    ------
    ValueError
        For an unknown kind, ``inputs`` where a configuration has a single input,
        ``configurations`` with a single configuration, or fewer sensor positions than folds.
    """
    if kind not in HOLDOUT_KINDS:
        raise ValueError(f"holdout = {kind!r}: expected one of {', '.join(HOLDOUT_KINDS)}")
    if kind == "none":
        return kind, []
    if kind == "auto":
        kind = ("configurations" if len(cases) > 1 else
                "inputs" if all(len(c.inputs) > 1 for c in cases) else "sensors")  # fmt: skip
    several = len(cases) > 1
    plan = []
    if kind == "configurations":
        if not several:
            raise ValueError("holdout = \"configurations\" needs two configurations or more")
        for k, c in enumerate(cases):
            plan.append((f"configuration {c.name}", k, residual_rows(c, metric)))
        return kind, plan
    for k, c in enumerate(cases):
        at = f"{c.name}: " if several else ""
        if kind == "inputs":
            if len(c.inputs) < 2:
                raise ValueError(f"holdout = \"inputs\" needs two inputs or more; configuration "
                                 f"{c.name} has one ({c.inputs[0].label})")  # fmt: skip
            for i, ch in enumerate(c.inputs):
                own = c.setup.channel_names.get(ch.label)
                name = f"{own} ({ch.label})" if own else ch.label
                plan.append((f"{at}input {name}", k, residual_rows(c, metric, inputs=[i])))
            continue
        positions = list(dict.fromkeys(ch.grid if ch.grid is not None else ch.label
                                       for ch in c.outputs))  # fmt: skip
        if len(positions) < n_sensor_folds:
            raise ValueError(f"holdout_folds = {n_sensor_folds}: configuration {c.name} has "
                             f"only {len(positions)} sensor positions")  # fmt: skip
        for group in np.array_split(np.arange(len(positions)), n_sensor_folds):
            keys = {positions[g] for g in group}
            outs = [o for o, ch in enumerate(c.outputs)
                    if (ch.grid if ch.grid is not None else ch.label) in keys]  # fmt: skip
            first, last = (c.setup.channel_names.get(c.outputs[o].label, c.outputs[o].label)
                           for o in (outs[0], outs[-1]))  # fmt: skip
            plan.append((f"{at}sensors {first} to {last} ({len(keys)} positions)", k,
                         residual_rows(c, metric, outputs=outs)))  # fmt: skip
    return kind, plan


def validate(cases: Sequence[Case], terms: Sequence[Term], nominal_terms: Sequence[Term],
             params: Sequence[Parameter], p_final: np.ndarray, prior: Prior,
             plan: tuple[str, list[tuple[str, int, np.ndarray]]],
             *, noise_sigma: float | None, hold_ratio: float, identifiable_ratio: float,
             max_iter: int, full_residuals: Callable[[int, np.ndarray], np.ndarray],
             search: Callable[[Problem, list[np.ndarray], int], Sequence] | None = None,
             progress: Callable[[str], None] | None = None) -> HoldOut:  # fmt: skip
    """Run the folds of ``plan`` (see the module docstring).

    Parameters
    ----------
    terms : per configuration, the final surrogate's term (corrected at ``p_final``).
    nominal_terms : per configuration, the nominal surrogate's term (the full model at p = 0).
    params : the shared parameters (their bounds are the search's).
    full_residuals : (case, p) -> that configuration's residuals (unweighted, all rows) on
        the full model at the shared p.
    search : (problem, start points, fold number from 1) -> the Levenberg-Marquardt
        results (with ``p`` and ``cost``) from each start point in order, wherever they run
        and kept wherever the caller keeps them (:func:`femcal.calibrate.starts.run_starts`);
        default: one after another here.
    """
    say = progress or (lambda _m: None)
    kind, folds = plan
    zero = np.zeros(len(p_final))
    r0, t0, J0 = [], [], []
    for term in nominal_terms:  # the transformed residuals and Jacobian, as the search sees
        J, e = term.jacobian(zero)
        t, d = term.transformed(e)
        r0.append(e)
        t0.append(t)
        J0.append(d[:, None] * J)
    out = []
    for n, (name, k, rows) in enumerate(folds, start=1):
        say(f"hold-out {n}/{len(folds)}: calibrating without {name}")
        keep = [np.ones(len(r), bool) for r in r0]
        keep[k] = ~rows
        used = [j for j in range(len(cases)) if keep[j].any()]
        liks = {j: likelihood_of(t0[j][keep[j]], len(cases[j].freq), noise_sigma)
                for j in used}  # fmt: skip
        ref = liks[used[0]]
        factors = {j: ref.scale / liks[j].scale for j in used}
        Jn = np.zeros((0, len(p_final)))
        for j in used:
            block = np.zeros((int(keep[j].sum()), len(p_final)))
            block[:, cases[j].index] = factors[j] * J0[j][keep[j]]
            Jn = np.vstack([Jn, block])
        held = identifiability(Jn, params, prior, ref, hold_ratio, identifiable_ratio).held
        lo = np.where(held, 0.0, [q.p_lower for q in params])
        hi = np.where(held, 0.0, [q.p_upper for q in params])
        fold_terms = tuple(replace(terms[j], factor=factors[j],
                                   rows=None if keep[j].all() else keep[j]) for j in used)
        problem = Problem(fold_terms, lo, hi, max_iter, ref.weights(prior))
        points = [zero, np.clip(p_final, lo, hi)]
        results = (search(problem, points, n) if search is not None
                   else [levenberg_marquardt(problem.fun, p0, lo, hi, max_iter=max_iter)
                         for p0 in points])  # fmt: skip
        best = min(results, key=lambda res: res.cost)  # (the first of equal ones)
        c = nominal_terms[k].huber
        r_cal = full_residuals(k, best.p)[rows]
        fold = Fold(name, k, rows, best.p, held, huber_deviation(r0[k][rows], c),
                    huber_deviation(r_cal, c))  # fmt: skip
        say(f"hold-out {n}/{len(folds)}: {name} predicted with deviation "
            f"{fold.deviation_calibrated:.5g} calibrated without it, {fold.deviation_nominal:.5g} "
            "nominal")  # fmt: skip
        out.append(fold)
    return HoldOut(kind, tuple(out))
