"""What the test can inform, decided before the search from the nominal model.

With the metric's exact Jacobian at the nominal point, the prior and the likelihood
(:mod:`femcal.calibrate.prior`), each parameter's posterior standard deviation is set against
its prior's. A parameter whose ratio stays at ``hold_ratio`` or above (0.99 by default: the
test narrows its prior by less than 1 %) is held at its nominal value: the test cannot inform
it, and left free it would only move to absorb what the model lacks. One whose ratio falls
below ``identifiable_ratio`` (0.5) is identifiable: the test determines it better than the
engineer did. The rest are calibrated and weakly informed; the prior keeps them near their
nominal values unless the test asks otherwise. Brun's collinearity index of the identifiable
set, and the pairs whose posterior correlation is strong, say which parameters the test
informs only in combination.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .parameters import Parameter
from .prior import Likelihood, Posterior, Prior, collinearity_index, posterior

#: A posterior correlation at least this strong marks a pair the test informs together.
STRONG_CORRELATION = 0.9


@dataclass(frozen=True)
class Identifiability:
    """The analysis before the search.

    Attributes
    ----------
    posterior : at the nominal point, every parameter free.
    held : (n_p,) held at the nominal value (not calibrated).
    identifiable : (n_p,) calibrated and determined by the test.
    collinearity : Brun's index of the identifiable set's sensitivities.
    pairs : (i, j, correlation) of calibrated parameters whose posterior correlation is
        strong: the test informs their combination more than each.
    reasons : per parameter, why it is held, identifiable or weakly informed.
    """

    posterior: Posterior
    held: np.ndarray
    identifiable: np.ndarray
    collinearity: float
    pairs: tuple[tuple[int, int, float], ...]
    reasons: tuple[str, ...]


def identifiability(J: np.ndarray, params: Sequence[Parameter], prior: Prior,
                    likelihood: Likelihood, hold_ratio: float,
                    identifiable_ratio: float) -> Identifiability:  # fmt: skip
    """The analysis (see the module docstring) from the metric's Jacobian J (m, n_p) at the
    nominal point."""
    post = posterior(J, prior, likelihood)
    held = post.ratio >= hold_ratio
    ident = ~held & (post.ratio < identifiable_ratio)
    calibrated = np.flatnonzero(~held)
    pairs = tuple(
        (int(i), int(j), float(post.correlation[i, j]))
        for a, i in enumerate(calibrated) for j in calibrated[a + 1:]
        if abs(post.correlation[i, j]) >= STRONG_CORRELATION)  # fmt: skip
    reasons = []
    for k in range(len(params)):
        narrowed = f"at the nominal model the test narrows its prior to {100 * post.ratio[k]:.0f} %"
        if held[k]:
            reasons.append(f"held at the nominal: {narrowed} (at least {100 * hold_ratio:g} % "
                           "stays: the test cannot inform it)")  # fmt: skip
        elif ident[k]:
            reasons.append(f"identifiable: {narrowed}")
        else:
            reasons.append(f"calibrated, weakly informed: {narrowed}; the prior keeps it near "
                           "its nominal value unless the test asks otherwise")  # fmt: skip
        partners = [(i if j == k else j, c) for i, j, c in pairs if k in (i, j)]
        if partners:
            reasons[-1] += "; informed together with " + ", ".join(
                f"{params[o].name} (correlation {c:+.2f})" for o, c in partners)
    return Identifiability(post, held, ident, collinearity_index(J, ident), pairs,
                           tuple(reasons))  # fmt: skip


def identifiability_summary(result: Identifiability, params: Sequence[Parameter],
                            likelihoods: Sequence[Likelihood],
                            names: Sequence[str] = ()) -> str:  # fmt: skip
    """One line: what is held, what is identifiable, and how each configuration's residuals
    were counted (``names`` label them where there are several)."""
    pnames = [p.name for p in params]
    ident = [pnames[i] for i in np.flatnonzero(result.identifiable)]
    held = int(result.held.sum())
    counts = []
    for k, lk in enumerate(likelihoods):
        label = f"{names[k]}: " if len(likelihoods) > 1 and k < len(names) else ""
        counts.append(label + (
            f"{lk.m} residuals counted as {lk.n_eff:.0f} independent observations (sigma "
            f"{lk.sigma:.3g} from the nominal model's residual)" if lk.estimated else
            f"{lk.m} independent residuals of sigma {lk.sigma:.3g}"))  # fmt: skip
    return (f"identifiability at the nominal model: {len(pnames) - held} of {len(pnames)} "
            f"parameters calibrated, {held} held at their nominal values (the test cannot "
            f"inform them); identifiable: {', '.join(ident) or 'none'}; {'; '.join(counts)}")
