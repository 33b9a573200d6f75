"""The reference study's calibration, end to end (FEMCali's method, Abrahamsson and Kammer):

1. the test side is the measured FRFs, an identified model of them
   (:func:`femcal.identify.identify`), or both; channels the identification calls suspect
   are left out;
2. damping equalisation: every test pole gets the damping zeta0 (the median identified
   damping by default) with its damped frequency kept, and every FE mode gets modal damping
   zeta0, so mass and stiffness parameters are calibrated without pairing modes;
3. frequencies at equal logarithmic steps, a few per half-power bandwidth 2 zeta0 w;
4. the FE model is reduced on its modes at the current point (with static
   eigenvector-derivative vectors of the modes up to ``enrich_hz``, and with ``residual``
   the static responses to the inputs for the residual flexibility), with the exact
   polynomial dependence of K and M on the parameters (or FEMCali's first-order form): built
   by :mod:`femcal.calibrate.reduction`, evaluated by :mod:`femcal.calibrate.surrogate`; with
   ``exact_gradient`` its residuals get the first-order correction that gives them the full
   model's Jacobian at the centre (:mod:`femcal.calibrate.gradient`);
5. Levenberg-Marquardt within the bounds on the log-FRF deviation, from Latin hypercube
   starts (the nominal among them) in parallel processes; the best minimum wins;
6. trust-region cycles: the surrogate is rebuilt at the candidate, where it is the full
   model; the step is kept if the full model's cost fell, and LM runs again within the trust
   radius, until the parameters the CRLB calls informed move less than ``settle`` (or the
   radius falls below it, or ``max_cycles`` is reached); when a kept step lowers the full
   model's cost by less than ``restart_fall``, or the cycles settle, the multi-start search
   runs again over the whole box on the current surrogate (at most ``restarts`` times), and
   its best start is the next candidate (the full model decides again): a local minimum the
   cycles have reached is left when a search on the newer surrogate finds a lower one;
7. the calibrated model is solved in full; frequencies, MAC and the deviation before and
   after and the Cramér-Rao bounds at the solution make the typed
   :class:`~femcal.calibrate.result.CalibrationResult`.

The starts and cycles are kept in a state folder as they finish, so a stopped run resumes
(:mod:`femcal.calibrate.starts`); files of the edge (report, calibrated deck, pictures) are
written by :mod:`femcal.jobs.calibration`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..atomic import write_atomic
from ..correlate import mac, pair_modes, pseudo_orthogonality, serep_mass
from ..identify import IdentifiedModel, equalize_damping
from ..model.model import Model
from ..response.frf import channel_matrix
from ..testdata.data import FRFData
from .config import Config
from .derivatives import group_polynomials
from .gradient import first_order_correction
from .identifiability import identifiability, identifiability_summary
from .lm import latin_hypercube
from .metric import deviation, log_frequencies, residuals
from .parameters import Parameter
from .prior import likelihood_of, posterior, prior_of
from .reduction import build_surrogate
from .result import (
    BandBounds,
    CalibrationResult,
    Cycle,
    ModePairing,
    ParameterResult,
    StartResult,
)
from .starts import Problem, run_starts

#: The surrogate's construction version: part of the resume fingerprint, so that starts
#: finished by a version that built the surrogate (or its elements) differently are run
#: again rather than mixed with new ones. Raise it with every such change.
SURROGATE_VERSION = 7


#: Config fields that do not change a start's result (file names, the report-only truth, the
#: number of worker processes, pictures, the raw text).
_NOT_IN_FINGERPRINT = ("path", "deck", "parameters", "test_frf", "test_model", "test_truth",
                       "workers", "pictures", "raw")  # fmt: skip


def _digest(value: object) -> str:
    """A short hash of arrays, dataclasses, mappings, sequences and plain values, by content."""
    h = hashlib.sha256()

    def feed(v: object) -> None:
        if isinstance(v, np.ndarray):
            h.update(f"a{v.dtype.str}{v.shape}".encode())
            h.update(repr(v.tolist()).encode() if v.dtype == object
                     else np.ascontiguousarray(v).tobytes())
        elif dataclasses.is_dataclass(v) and not isinstance(v, type):
            h.update(type(v).__name__.encode())
            for f in dataclasses.fields(v):
                feed(f.name)
                feed(getattr(v, f.name))
        elif isinstance(v, dict):
            h.update(b"d")
            for k in sorted(v, key=repr):
                feed(k)
                feed(v[k])
        elif isinstance(v, list | tuple):
            h.update(f"l{len(v)}".encode())
            for x in v:
                feed(x)
        else:
            h.update(repr(v).encode())

    feed(value)
    return h.hexdigest()[:16]


def fingerprint(model: Model, params: Sequence[Parameter], cfg: Config, n_starts: int,
                freq: np.ndarray, H_test: np.ndarray) -> str:  # fmt: skip
    """What decides a calibration's starts, hashed: the surrogate's version, the number of
    starts, the settings (not file names or worker counts), the parameters, the model's
    arrays and tables (not where they were read from) and the test FRFs compared."""
    settings = {k: v for k, v in vars(cfg).items() if k not in _NOT_IN_FINGERPRINT}
    physics = replace(model, files=[], elements={t: replace(b, file=b.file[:0], line=b.line[:0])
                                                 for t, b in model.elements.items()})  # fmt: skip
    return _digest((SURROGATE_VERSION, n_starts, settings, list(params), physics, freq, H_test))


def _test_frfs(data: FRFData | None, ident: IdentifiedModel | None, keep: np.ndarray,
               zeta0: float, freq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(frequencies, H_X (n_out, n_in, n_f)): the damping-equalised identified model at
    ``freq``, or, without an identified model, the measured FRFs at the measured frequencies
    nearest to ``freq`` (no interpolation: it would bend the resonance peaks)."""
    if ident is not None:
        return freq, equalize_damping(ident, zeta0).frf(freq).H[keep]
    f = data.frequency_hz
    if freq[0] < f[0] * (1 - 1e-9) or freq[-1] > f[-1] * (1 + 1e-9):
        raise ValueError(f"the calibration band {freq[0]:g}-{freq[-1]:g} Hz lies outside the "
                         f"test data ({f[0]:g}-{f[-1]:g} Hz)")  # fmt: skip
    pos = np.clip(np.searchsorted(f, freq), 1, len(f) - 1)
    idx = np.unique(np.where(freq - f[pos - 1] <= f[pos] - freq, pos - 1, pos))
    return f[idx], data.H[keep][:, :, idx]


def calibrate(model: Model, params: Sequence[Parameter], cfg: Config, *,
              data: FRFData | None = None, identified: IdentifiedModel | None = None,
              truth: np.ndarray | None = None, state: str | Path | None = None,
              fresh: bool = False, workers: int | None = None,
              starts: int | None = None,
              progress: Callable[[str], None] | None = None) -> CalibrationResult:  # fmt: skip
    """Calibrate ``params`` of ``model`` against the test (see the module docstring).

    Parameters
    ----------
    cfg : the calibration's settings (its ``[calibration]`` section; the file names are not
        read here).
    data, identified : the measured FRFs and/or an identified model of them (at least one;
        with an identified model its poles, shapes and suspect channels are used).
    truth : (n_p,) a synthetic test's known values P, for the report's errors only.
    state : folder for the finished starts and cycles (``starts/`` in a job's output). Each
        start is kept with a fingerprint of everything that decides it (the model's arrays and
        tables, the parameters, the settings, the test FRFs compared, the surrogate's version),
        and a run resumes from the starts whose fingerprint is its own. None: nothing kept.
    fresh : ignore finished starts in ``state``. workers, starts : override the
        configuration's.

    Raises
    ------
    ValueError
        For test data in other units than ``cfg.model_units``, a band without test modes or
        data, test FRFs that are zero in the band.
    """
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    params = list(params)
    if data is None and identified is None:
        raise ValueError("calibrate needs the test FRFs or an identified test model")
    for what, test in (("test FRFs", data), ("identified test model", identified)):
        if test is not None and cfg.model_units and test.units and test.units != cfg.model_units:
            raise ValueError(f"the {what} are in {test.units}, the FE model in "
                             f"{cfg.model_units}: convert them first "
                             "(femcal.testdata.convert_units)")  # fmt: skip
    n_workers = workers or cfg.workers
    n_starts = starts or cfg.starts
    lo = np.array([p.p_lower for p in params])
    hi = np.array([p.p_upper for p in params])
    ident = identified
    source = ident if ident is not None else data
    keep = np.ones(len(source.outputs), bool)
    if ident is not None and cfg.exclude_suspect_channels and ident.suspect.any():
        keep = ~ident.suspect
        say("suspect channels left out: "
            + ", ".join(ident.outputs[i].label for i in np.flatnonzero(ident.suspect)))
    outputs = tuple(c for c, k in zip(source.outputs, keep, strict=True) if k)
    excluded = tuple(c for c, k in zip(source.outputs, keep, strict=True) if not k)
    inputs = tuple(source.inputs)
    quantity = source.quantity
    band = cfg.band
    if ident is not None:
        sel = (ident.frequency_hz >= band[0]) & (ident.frequency_hz <= band[1])
        if not sel.any():
            raise ValueError(f"no identified test mode lies in the calibration band "
                             f"{band[0]:g}-{band[1]:g} Hz")  # fmt: skip
        test_hz, test_shapes = ident.frequency_hz[sel], ident.shapes[keep][:, sel]
        zeta0 = cfg.zeta0 or float(np.median(ident.damping_ratio[sel]))
    else:
        test_hz, test_shapes = np.zeros(0), np.zeros((len(outputs), 0))
        zeta0 = float(cfg.zeta0)
    freq = log_frequencies(band[0], band[1], zeta0, cfg.samples_per_bandwidth)
    freq, H_test = _test_frfs(data, ident, keep, zeta0, freq)
    if (np.abs(H_test) == 0).any():
        raise ValueError("the test FRFs are zero somewhere in the band: the log metric needs "
                         "nonzero values")  # fmt: skip
    say(f"metric: {cfg.metric} over {band[0]:g}-{band[1]:g} Hz, {len(freq)} frequencies "
        f"({cfg.samples_per_bandwidth:g} per half-power bandwidth at zeta0 = {zeta0:.4f}), "
        f"{len(outputs)} outputs x {len(inputs)} inputs")  # fmt: skip
    fp = fingerprint(model, params, cfg, n_starts, freq, H_test)
    state_dir = Path(state) if state is not None else None
    rng = np.random.default_rng(cfg.seed)
    prior = prior_of(params, cfg.bounds_sigma)
    weights: list[np.ndarray] = []  # the prior's rows, set from the nominal model's residual

    say(f"the exact dependence of K and M on the {len(params)} parameters, element group by "
        "element group")
    polys = group_polynomials(model, params, np.zeros(len(params)), constant=True)

    frf_modes: list[int] = []  # the FRFs' mode count, fixed at the nominal model

    def surrogate_at(p: np.ndarray):
        say(f"surrogate at p = [{', '.join(f'{x:+.4f}' for x in p)}]")
        sur, modes = build_surrogate(
            model, params, p, outputs, inputs, n_modes=cfg.reduction_modes, zeta=zeta0,
            quantity=quantity, order=cfg.surrogate, polynomials=polys,
            enrich_hz=cfg.enrich_hz or None, n_enrich=cfg.enrich_vectors,
            residual=cfg.residual, frf_modes=frf_modes[0] if frf_modes else None,
            frf_hz=cfg.modal_hz if not frf_modes and cfg.modal_hz else None,
            exact_gradient=cfg.exact_gradient, progress=say)  # fmt: skip
        if not frf_modes:
            frf_modes.append(sur.n_frf)
            if cfg.modal_hz:
                top = float(sur.basis_hz[-1])
                which = (f"the {sur.n_frf} modes up to {cfg.modal_hz:g} Hz"
                         if cfg.modal_hz < top else
                         f"all {sur.n_frf} reduction modes (up to {top:.1f} Hz: modal_hz = "
                         f"{cfg.modal_hz:g} lies above them)")  # fmt: skip
                say(f"the FRFs sum {which} at the nominal" + (
                    ", the others as residual flexibility" if cfg.residual else ""))
        return sur, modes

    def problem_on(sur, lower: np.ndarray, upper: np.ndarray) -> Problem:
        corr = (first_order_correction(sur, sur.exact, freq, H_test, cfg.metric)
                if sur.exact is not None else None)  # fmt: skip
        return Problem(sur, freq, H_test, cfg.metric, lower, upper, cfg.max_iterations,
                       weights[0] if weights else None, corr)  # fmt: skip

    def starts_in(name: str, problem: Problem, pts: list[np.ndarray],
                  center: np.ndarray) -> list[StartResult]:  # fmt: skip
        folder = state_dir / name if state_dir is not None else None
        if fresh and folder is not None and folder.is_dir():
            for f in folder.glob("start_*.json"):
                f.unlink()
        return run_starts(problem, pts, workers=n_workers, folder=folder,
                          fingerprint=fp + f"-{name}-" + ",".join(f"{x:.12g}" for x in center),
                          progress=say)  # fmt: skip

    cycles: list[Cycle] = []

    def save_cycles() -> None:
        if state_dir is None:
            return
        text = json.dumps([_cycle_state(c) for c in cycles], indent=1)
        write_atomic(state_dir / "cycles.json", lambda tmp: Path(tmp).write_text(text))

    # cycle 1: the multi-start search over the whole box on the nominal surrogate
    say("cycle 1: Levenberg-Marquardt from every start on the nominal model's surrogate")
    center = np.zeros(len(params))
    sur, modes_c = surrogate_at(center)
    modes0, sur0 = modes_c, sur
    # before the search: what the test can inform, with the nominal model's residual
    J0, r0 = problem_on(sur, lo, hi).data_jacobian(center)
    likelihood = likelihood_of(r0, len(freq), cfg.noise_sigma)
    before = identifiability(J0, params, prior, likelihood, cfg.hold_ratio,
                             cfg.identifiable_ratio)  # fmt: skip
    held = before.held
    say(identifiability_summary(before, params, likelihood))
    lo, hi = np.where(held, 0.0, lo), np.where(held, 0.0, hi)  # held at the nominal
    weights.append(likelihood.weights(prior))
    starts0 = [np.zeros(len(params))]
    if n_starts > 1:
        starts0 += list(latin_hypercube(n_starts - 1, lo, hi, rng))
    problem = problem_on(sur, lo, hi)
    cost_c = problem.cost(center)
    results = starts_in("cycle1", problem, starts0, center)
    best = min(results, key=lambda r: r.cost)
    cand, pred = best.p, best.cost
    cycles.append(Cycle(1, center, cand, best.deviation, best.start + 1, tuple(results),
                        exact_deviation_at_center=problem.deviation(center),
                        moved=float(np.abs(cand).max())))  # fmt: skip
    save_cycles()
    say(f"cycle 1: best start {best.start + 1}, deviation {best.deviation:.5g} (surrogate)")
    # cycles 2...: trust region; the surrogate rebuilt at the candidate is the full model
    # there, which decides whether the step is kept
    radius = max(float(np.abs(cand - center).max()), cfg.settle)
    settled = False
    restarts_left = cfg.restarts if n_starts > 1 else 0
    searched = False  # the candidate came from a multi-start search over the whole box
    for c in range(2, cfg.max_cycles + 1):
        sur_new, modes_new = surrogate_at(cand)
        prob_new = problem_on(sur_new, lo, hi)
        cost_new = prob_new.cost(cand)
        predicted = cost_c - pred
        rho = (cost_c - cost_new) / predicted if predicted > 0 else 0.0
        accepted = cost_new < cost_c
        step = np.abs(cand - center)
        step_radius, from_search = radius, searched
        exact_at_candidate = prob_new.deviation(cand)
        candidate = cand
        stalled, fall = False, 0.0
        if accepted:
            post_c = posterior(prob_new.data_jacobian(cand)[0], prior, likelihood, ~held)
            informed = ~held & (post_c.ratio < cfg.identifiable_ratio)
            moved = float(step[informed].max() if informed.any() else step.max())
            fall = (cost_c - cost_new) / cost_c
            center, sur, modes_c, cost_c, problem = cand, sur_new, modes_new, cost_new, prob_new
            radius = min(2 * radius, 1.0) if rho > 0.75 else (radius / 2 if rho < 0.25 else radius)
            say(f"cycle {c}: step kept (full-model cost {cost_new:.5g}, {100 * fall:.3g} % "
                f"lower, ratio to the predicted fall {rho:.2f}); the informed parameters "
                f"moved {moved:.2e}")  # fmt: skip
            settled = moved < cfg.settle
            stalled = fall < cfg.restart_fall
        else:
            if not searched:  # a quarter of the rejected step (of the radius, if it filled it)
                radius = min(radius, float(step.max())) / 4.0
            moved = 0.0  # (a far search candidate says nothing about the local radius)
            say(f"cycle {c}: {'the search candidate' if searched else 'step'} rejected "
                f"(full-model cost {cost_new:.5g} against {cost_c:.5g}); trust radius "
                f"{radius:.3g}")  # fmt: skip
            settled = radius < cfg.settle
        last = c == cfg.max_cycles
        local: StartResult | None = None
        found: list[StartResult] = []
        search_best: float | None = None
        if not settled and not last:  # the trust-region step from the centre
            box = replace(problem, lower=np.maximum(lo, center - radius),
                          upper=np.minimum(hi, center + radius))  # fmt: skip
            local = starts_in(f"cycle{c}", box, [center], center)[0]
        res, searched = local, False
        if (settled or stalled) and restarts_left > 0 and not last:
            restarts_left -= 1
            why = "settled" if settled else f"the cost fell by only {100 * fall:.3g} %"
            say(f"cycle {c}: {why}: the multi-start search runs again from {n_starts} new "
                f"starts on this surrogate ({restarts_left} more allowed)")  # fmt: skip
            found = starts_in(f"cycle{c}_search", problem,
                              list(latin_hypercube(n_starts, lo, hi, rng)), center)  # fmt: skip
            best = min(found, key=lambda r: r.cost)
            ref = ((local.cost, local.deviation, local.p) if local
                   else (cost_c, problem.deviation(center), center))  # fmt: skip
            search_best = best.deviation
            # another minimum: lower by restart_fall and elsewhere (not the same one again)
            if (best.cost < (1 - cfg.restart_fall) * ref[0]
                    and np.abs(best.p - ref[2]).max() > cfg.settle):
                res, searched, settled = best, True, False
                say(f"cycle {c}: search start {best.start + 1} reaches a lower minimum "
                    f"(deviation {best.deviation:.5g} on the surrogate against "
                    f"{ref[1]:.5g}): it is the next candidate")  # fmt: skip
            else:
                say(f"cycle {c}: the search found no lower minimum elsewhere (its best: "
                    f"deviation {best.deviation:.5g} on the surrogate, at most "
                    f"{np.abs(best.p - ref[2]).max():.2g} from here in p; "
                    f"here {ref[1]:.5g})")  # fmt: skip
        common = dict(candidate=candidate, exact_deviation_at_candidate=exact_at_candidate,
                      rho=rho, accepted=accepted, radius=step_radius, from_search=from_search,
                      moved_informed=moved, searched=bool(found),
                      search_best_deviation=search_best)  # fmt: skip
        if res is None:  # settled, or the last cycle
            cycles.append(Cycle(c, center, center, problem.deviation(center), 1, **common))
            save_cycles()
            break
        cand, pred = res.p, res.cost
        cycles.append(Cycle(c, center, cand, res.deviation, res.start + 1,
                            tuple(([local] if local else []) + found), **common))  # fmt: skip
        save_cycles()
    p_final = center
    values = np.array([par.value(p) for par, p in zip(params, p_final, strict=True)])
    # the full model at the solution is the last surrogate's centre
    modes_after = modes_c
    Cg = channel_matrix(model, outputs)
    # the full model's FRFs: each surrogate at its centre (the modal sum over the reduction
    # modes, with the residual flexibility if asked)
    H_before = sur0.frf(np.zeros(len(params)), freq)
    H_after = sur.frf(p_final, freq)
    dev_before = deviation(residuals(H_before, H_test, cfg.metric))
    dev_after = deviation(residuals(H_after, H_test, cfg.metric))
    J = problem.data_jacobian(p_final)[0]
    post = posterior(J, prior, likelihood, ~held)
    band_bounds = []
    n_pairs = len(outputs) * len(inputs)
    for b in cfg.crlb_bands:
        rows_f = (freq >= b[0]) & (freq <= b[1])
        rows = np.tile(rows_f, n_pairs * (2 if cfg.metric == "complex-log" else 1))
        band_bounds.append(BandBounds(tuple(b), posterior(J[rows], prior, likelihood,
                                                          ~held).std))  # fmt: skip
    fe_before = np.asarray(Cg @ modes0.shapes)
    fe_after = np.asarray(Cg @ modes_after.shapes)
    mac_b = mac(test_shapes, fe_before)
    mac_a = mac(test_shapes, fe_after)
    pairings = _pairings(test_hz, test_shapes, fe_before, fe_after, modes0, modes_after, band,
                         len(outputs))  # fmt: skip
    parameters = []
    for i, par in enumerate(params):
        std = float(post.std[i])
        extra = {}
        if truth is not None:  # a synthetic test: the error against the known value
            p_true = truth[i] / par.nominal - 1.0
            extra = dict(true=float(truth[i]), true_p=float(p_true),
                         error_pct=float(100 * (values[i] / truth[i] - 1.0)),
                         error_over_std=float(abs(p_final[i] - p_true) / std)
                         if std > 0 else None)  # fmt: skip
        crlb_p = float(post.crlb[i])
        parameters.append(ParameterResult(
            par, float(values[i]), float(p_final[i]), held=bool(held[i]),
            prior_std_p=float(prior.std[i]), posterior_std_p=std,
            posterior_std=std * abs(par.nominal), ratio=float(post.ratio[i]), crlb_p=crlb_p,
            crlb=crlb_p * abs(par.nominal),
            identifiable=bool(~held[i] & (post.ratio[i] < cfg.identifiable_ratio)),
            at_bound=bool(not held[i] and (np.isclose(p_final[i], par.p_lower, atol=1e-9)
                                           or np.isclose(p_final[i], par.p_upper, atol=1e-9))),
            reason=before.reasons[i], **extra))  # fmt: skip
    result = CalibrationResult(
        config=cfg, model=model, data=data, identified=ident, parameters=tuple(parameters),
        p_final=p_final, zeta0=zeta0, freq=freq, outputs=outputs, inputs=inputs,
        excluded=excluded, H_test=H_test, H_before=H_before, H_after=H_after,
        deviation_before=dev_before, deviation_after=dev_after, cycles=tuple(cycles),
        settled=settled, frf_modes=frf_modes[0], prior=prior, likelihood=likelihood,
        identifiability=before, posterior=post, band_bounds=tuple(band_bounds),
        test_hz=test_hz, test_shapes=test_shapes, modes_before=modes0, modes_after=modes_after,
        mac_before=mac_b, mac_after=mac_a, modes=pairings, seconds=time.perf_counter() - t0)
    say(f"deviation {dev_before:.5g} -> {dev_after:.5g}")
    return result


def _pairings(test_hz: np.ndarray, test_shapes: np.ndarray, fe_before: np.ndarray,
              fe_after: np.ndarray, modes0, modes_after, band: tuple[float, float],
              n_outputs: int) -> tuple[ModePairing, ...]:  # fmt: skip
    """Each test mode with the FE modes paired with it before and after calibration, and the
    pseudo-orthogonality after it: mass reduced to the sensors by SEREP on the FE modes up to
    1.5 times the band's top (at most one less than the sensors)."""
    pairs_b = {pp.test: pp for pp in pair_modes(test_shapes, test_hz, fe_before,
                                                modes0.frequencies_hz)}  # fmt: skip
    pairs_a = {pp.test: pp for pp in pair_modes(test_shapes, test_hz, fe_after,
                                                modes_after.frequencies_hz)}  # fmt: skip
    f_after = modes_after.frequencies_hz
    serep = list(np.flatnonzero(f_after <= 1.5 * band[1])[: max(n_outputs - 1, 1)])
    poc = (pseudo_orthogonality(test_shapes, fe_after[:, serep], serep_mass(fe_after[:, serep]))
           if len(test_hz) else np.zeros((0, len(serep))))  # fmt: skip
    out = []
    for k, f in enumerate(test_hz):
        b, a = pairs_b.get(k), pairs_a.get(k)
        out.append(ModePairing(
            k + 1, float(f),
            b.fe + 1 if b else None, float(modes0.frequencies_hz[b.fe]) if b else None,
            b.mac if b else None, b.frequency_difference if b else None,
            a.fe + 1 if a else None, float(f_after[a.fe]) if a else None,
            a.mac if a else None, a.frequency_difference if a else None,
            float(abs(poc[k, serep.index(a.fe)])) if a and a.fe in serep else None))  # fmt: skip
    return tuple(out)


def _cycle_state(c: Cycle) -> dict:
    """A cycle as the state folder keeps it (its starts in full)."""
    out = {k: v for k, v in vars(c).items() if k != "starts"}
    out = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in out.items()}
    return {**out, "starts": [s.to_dict() for s in c.starts]}
