"""The reference study's calibration, end to end (FEMCali's method, Abrahamsson and Kammer),
made Bayesian so that its parameters carry over to configurations it did not see:

1. one or more configurations of the structure, each a model and a test, their parameters
   shared by name; each test is the measured FRFs, an identified model of them
   (:func:`femcal.identify.identify`), or both; channels the identification calls suspect
   are left out (:mod:`femcal.calibrate.cases`);
2. damping equalisation: every test pole gets the damping zeta0 (the median identified
   damping by default) with its damped frequency kept, and every FE mode gets modal damping
   zeta0, so mass and stiffness parameters are calibrated without pairing modes;
3. frequencies at equal logarithmic steps, a few per half-power bandwidth 2 zeta0 w;
4. each FE model is reduced on its modes at the current point (with static
   eigenvector-derivative vectors of the modes up to ``enrich_hz``, and with ``residual``
   the static responses to the inputs for the residual flexibility), with the exact
   polynomial dependence of K and M on the parameters (or FEMCali's first-order form): built
   by :mod:`femcal.calibrate.reduction`, evaluated by :mod:`femcal.calibrate.surrogate`; with
   ``exact_gradient`` its residuals get the first-order correction that gives them the full
   model's Jacobian at the centre (:mod:`femcal.calibrate.gradient`);
5. before the search, at the nominal point: the bounds (or each parameter's confidence)
   make a Gaussian prior, each test's residual sets its likelihood, and the parameters the
   tests cannot inform are held at their nominal values (:mod:`femcal.calibrate.prior`,
   :mod:`femcal.calibrate.identifiability`);
6. Levenberg-Marquardt within the bounds on the log-FRF deviation plus the prior's term
   (the posterior's maximum), from Latin hypercube starts (the nominal among them) in
   parallel processes; the best minimum wins;
7. trust-region cycles: the surrogates are rebuilt at the candidate, where they are the full
   models; the step is kept if the full models' cost fell, and LM runs again within the
   trust radius, until the identifiable parameters move less than ``settle`` (or the radius
   falls below it, or ``max_cycles`` is reached: the last cycle only checks the candidate
   before it, so the result is always a point the full models have judged, and
   ``max_cycles = 1`` runs as 2, one search and its check); when a kept step lowers the
   cost by less than ``restart_fall``, or the cycles settle, the multi-start search runs
   again over the whole box on the current surrogates (at most ``restarts`` times), and its
   best start is the next candidate (the full models decide again): a local minimum the
   cycles have reached is left when a search on the newer surrogates finds a lower one;
8. the calibrated models are solved in full; frequencies, MAC, the deviation before and
   after and the posterior at the solution, with each configuration's model-form
   diagnostics (:mod:`femcal.calibrate.modelform`) and the validation on held-out data
   (:mod:`femcal.calibrate.holdout`), make the typed
   :class:`~femcal.calibrate.result.CalibrationResult`.

The starts and cycles are kept in a state folder as they finish (each file written whole or
not at all), so a stopped run resumes (:mod:`femcal.calibrate.starts`) from the starts whose
fingerprint is its own: the models, the settings, the tests and the content of every file
read, INCLUDEs too (:func:`fingerprint`); files of the edge (report, calibrated decks,
pictures) are written by :mod:`femcal.jobs.calibration`.
"""

from __future__ import annotations

import contextlib
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
from ..identify import IdentifiedModel
from ..model.model import Model
from ..parallel.cluster import Engine, Session, result_of
from ..parallel.executors import beside
from ..parallel.progress import Detail
from ..response.frf import channel_matrix
from ..testdata.data import FRFData
from .cases import Case, TestSetup, prepare_case, residual_rows
from .channels import suspect_channels
from .config import SETTINGS, Config, ConfigError, check_config
from .gradient import first_order_correction
from .holdout import fold_plan, validate
from .identifiability import identifiability, identifiability_summary
from .lm import latin_hypercube
from .metric import deviation, residuals
from .modelform import ModelForm, diagnose, measured_scatter
from .parameters import Parameter, share_parameters
from .prior import Likelihood, likelihood_of, posterior, prior_of
from .problem import Problem, Term
from .reduction import build_surrogate
from .result import (
    BandBounds,
    CalibrationResult,
    CaseResult,
    Cycle,
    ModePairing,
    ParameterResult,
    StartResult,
)
from .robust import robust_scale
from .starts import run_starts
from .surrogate import Surrogate

#: The surrogate's construction version: part of the resume fingerprint, so that starts
#: finished by a version that built the surrogate (or its elements) differently are run
#: again rather than mixed with new ones. Raise it with every such change.
SURROGATE_VERSION = 10


def _starts_task(name: str) -> str:
    """The console's name for a run of starts: ``cycle1`` -> ``cycle 1: starts``,
    ``cycle3_search`` -> ``cycle 3: search starts``, ``cycle2`` (the one local start) ->
    ``cycle 2: step``."""
    cycle, _, kind = name.removeprefix("cycle").partition("_")
    what = "search starts" if kind == "search" else ("starts" if cycle == "1" else "step")
    return f"cycle {cycle}: {what}"


#: Config fields that do not change a start's result (where the files are, whose content
#: enters through the models, the test FRFs and the files' own digests; the number of worker
#: processes, pictures, the raw text; whether a model-form element is added afterwards, which
#: is another run). The configurations' settings enter on their own.
_NOT_IN_FINGERPRINT = ("path", "configurations", "workers", "engine", "scheduler", "pictures",
                       "raw", "augment_fall")


def file_digest(path: str | Path) -> str:
    """A hash of a file's bytes (not of its name); ``"missing"`` for a file that cannot be
    read, so that a run that finds it again differs from one that did not."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return "missing"
    return h.hexdigest()


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


def fingerprint(parts: Sequence[tuple[Model, Sequence[Parameter], np.ndarray, np.ndarray, float]],
                cfg: Config, n_starts: int, *, channels: Sequence[object] = (),
                sources: Sequence[str | Path] = (), derivatives_beside: bool = False
                ) -> str:  # fmt: skip
    """What decides a calibration's starts, hashed: the surrogate's version, the number of
    starts, the settings (not file names or worker counts; each configuration's band,
    damping, identification and units) and, per configuration, its model's arrays and tables
    (not where they were read from), its parameters, the test FRFs compared at their
    frequencies and the equalised damping: ``parts`` holds (model, params, freq, H_test,
    zeta0) per configuration; ``channels`` what else of the test decides them (the channels
    compared, the FRFs' quantity). Besides, the content (not the name) of every file the
    models were read from, a deck's INCLUDEs among them (:attr:`Model.files`), and of the
    files in ``sources`` (a configuration's parameter, test, sensor and input files): a
    change to any of them starts afresh, even one that leaves the arrays alone. And whether
    the exact derivatives' series may run in two processes (``derivatives_beside``, more
    than one local worker), which decides their last bits."""
    settings = {k: v for k, v in vars(cfg).items() if k not in _NOT_IN_FINGERPRINT}
    settings["configurations"] = [(c.band, c.zeta0, c.identify, c.model_units)
                                  for c in cfg.configurations]  # fmt: skip
    physics = []
    files = []
    for model, params, freq, H_test, zeta0 in parts:
        bare = replace(model, files=[], elements={t: replace(b, file=b.file[:0], line=b.line[:0])
                                                  for t, b in model.elements.items()})  # fmt: skip
        physics.append((bare, list(params), freq, H_test, float(zeta0)))
        files += [file_digest(f) for f in model.files]
    files += [file_digest(f) for f in sources]
    return _digest((SURROGATE_VERSION, n_starts, settings, physics, list(channels), files,
                    bool(derivatives_beside)))


def calibrate(model: Model, params: Sequence[Parameter], cfg: Config, *,
              data: FRFData | None = None, identified: IdentifiedModel | None = None,
              truth: np.ndarray | None = None, state: str | Path | None = None,
              fresh: bool = False, workers: int | None = None,
              starts: int | None = None, engine: Engine | None = None,
              progress: Callable[[str], None] | None = None) -> CalibrationResult:  # fmt: skip
    """Calibrate ``params`` of ``model`` against one test: :func:`calibrate_setups` with the
    first configuration of ``cfg`` (its name, band and zeta0; its files are not read here,
    but their content enters the resume fingerprint).
    ``data``, ``identified``: the measured FRFs and/or an identified model of them."""
    check_config(cfg)
    conf = cfg.configurations[0]
    setup = TestSetup(conf.name, model, tuple(params), conf.band, data, identified, conf.zeta0,
                      conf.model_units)
    return calibrate_setups([setup], cfg, truth=truth, state=state,
                            fresh=fresh, workers=workers, starts=starts, engine=engine,
                            progress=progress, sources=conf.sources)  # fmt: skip


def check_overrides(workers: int | None, starts: int | None) -> None:
    """ConfigError for a ``workers`` or ``starts`` override (None: none) out of its
    setting's range."""
    for what, n in (("workers", workers), ("starts", starts)):
        if n is not None and (isinstance(n, bool) or not isinstance(n, int)
                              or not SETTINGS[what].accepts(n)):
            raise ConfigError(f"{what} = {n!r}: expected {SETTINGS[what].expected}")


def calibrate_setups(setups: Sequence[TestSetup], cfg: Config, *,
                     truth: np.ndarray | None = None, state: str | Path | None = None,
                     fresh: bool = False, workers: int | None = None,
                     starts: int | None = None, engine: Engine | None = None,
                     session: Session | None = None,
                     progress: Callable[[str], None] | None = None,
                     sources: Sequence[str | Path] = ()) -> CalibrationResult:  # fmt: skip
    """Calibrate the parameters of one or more configurations, shared by name, against their
    tests (see the module docstring).

    Parameters
    ----------
    setups : per configuration its model, parameters, band and test
        (:class:`~femcal.calibrate.cases.TestSetup`).
    cfg : the calibration's settings (its ``[calibration]`` section; the files of its
        configurations are not read here).
    truth : (n_p,) a synthetic test's known values P of the shared parameters, for the
        report's errors only (NaN: not known, e.g. an added element's).
    state : folder for the finished starts and cycles (``starts/`` in a job's output). Each
        start is kept with a fingerprint of everything that decides it (the models' arrays and
        tables, the parameters, the settings, the test FRFs and channels compared, the
        surrogate's version, the content of the files the models were read from and of
        ``sources``), and a run resumes from the starts whose fingerprint is its own. None:
        nothing kept.
    fresh : ignore finished starts in ``state``. workers, starts : override the
        configuration's (at least 1).
    engine : where the starts (and the surrogates of several configurations) run; default
        the configuration's ``engine``, ``scheduler`` and ``workers``
        (:class:`~femcal.parallel.cluster.Engine`). The starts give the same numbers on
        every engine; surrogates built on a Dask worker (one BLAS thread) differ from those
        built here in the last digits, and so do exact derivatives made in one process
        (one worker, or Dask) from those made in two (more local workers; the resume
        fingerprint tells them apart).
    session : an engine already open (a job's, :class:`~femcal.parallel.cluster.Session`):
        used, and left open, in place of ``engine``.
    sources : the other files the run was read from (parameter, test, sensor and input
        files): their content enters the fingerprint.

    Raises
    ------
    ConfigError
        For settings out of range (:func:`~femcal.calibrate.config.check_config`).
    ValueError
        For no configuration, shared parameters that disagree, test data in other units,
        a band without test modes or data, test FRFs that are zero in the band.
    """
    if not setups:
        raise ValueError("calibrate needs at least one configuration")
    check_config(cfg)
    check_overrides(workers, starts)
    if session is not None:
        return _calibrate_setups(setups, cfg, truth=truth, state=state, fresh=fresh,
                                 starts=starts, session=session, progress=progress,
                                 sources=sources)  # fmt: skip
    engine = engine or Engine(cfg.engine, workers or cfg.workers, cfg.scheduler)
    if engine.kind == "dask" and progress is not None:
        progress(f"the starts run on {engine.describe()}")
    with engine.session() as held:
        return _calibrate_setups(setups, cfg, truth=truth, state=state, fresh=fresh,
                                 starts=starts, session=held, progress=progress,
                                 sources=sources)  # fmt: skip


def _calibrate_setups(setups: Sequence[TestSetup], cfg: Config, *, truth: np.ndarray | None,
                      state: str | Path | None, fresh: bool, starts: int | None,
                      session: Session, progress: Callable[[str], None] | None,
                      sources: Sequence[str | Path]) -> CalibrationResult:  # fmt: skip
    """:func:`calibrate_setups` with its settings checked, on an open engine ``session``."""
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    params, indices = share_parameters([s.params for s in setups], [s.name for s in setups])
    n_p = len(params)
    cases = [prepare_case(s, idx, cfg, say) for s, idx in zip(setups, indices, strict=True)]
    plan = fold_plan(cases, cfg.holdout, cfg.holdout_folds, cfg.metric)  # bad settings fail now
    n_starts = starts or cfg.starts
    lo = np.array([p.p_lower for p in params])
    hi = np.array([p.p_upper for p in params])
    # more than one local worker: a surrogate built here may use a forked process beside
    two_here = session.engine.kind == "local" and session.engine.workers > 1
    fp = fingerprint([(c.model, c.params, c.freq, c.H_test, c.zeta0) for c in cases], cfg,
                     n_starts, channels=[(c.outputs, c.inputs, c.quantity) for c in cases],
                     sources=sources, derivatives_beside=two_here)  # fmt: skip
    state_dir = Path(state) if state is not None else None
    rng = np.random.default_rng(cfg.seed)
    prior = prior_of(params, cfg.bounds_sigma)
    weighing: dict[str, object] = {}  # the prior's rows and the terms' factors, set below

    frf_modes: dict[int, int] = {}  # per configuration the FRFs' mode count, fixed at the nominal

    def build_arguments(k: int, p: np.ndarray) -> tuple[tuple, dict]:
        """:func:`build_surrogate`'s arguments for configuration k at p (no progress)."""
        case = cases[k]
        q = p[case.index]
        say(Detail(f"{case.name}: surrogate at p = [{', '.join(f'{x:+.4f}' for x in q)}]"))
        return (case.model, list(case.params), q, case.outputs, case.inputs), dict(
            n_modes=cfg.reduction_modes, zeta=case.zeta0, quantity=case.quantity,
            order=cfg.surrogate, polynomials=case.polynomials,
            enrich_hz=cfg.enrich_hz or None, n_enrich=cfg.enrich_vectors,
            residual=cfg.residual, frf_modes=frf_modes.get(k),
            frf_hz=cfg.modal_hz if k not in frf_modes and cfg.modal_hz else None,
            exact_gradient=cfg.exact_gradient)  # fmt: skip

    def surrogate_at(k: int, p: np.ndarray,
                     built: tuple[Surrogate, object] | None = None
                     ) -> tuple[Surrogate, object]:  # fmt: skip
        """Configuration k's surrogate at p: ``built`` elsewhere, or built here."""
        case = cases[k]
        if built is None:
            args, kwargs = build_arguments(k, p)
            built = build_surrogate(*args, **kwargs, progress=say, beside_ok=two_here)
        sur, modes = built
        if k not in frf_modes:
            frf_modes[k] = sur.n_frf
            if cfg.modal_hz:
                top = float(sur.basis_hz[-1])
                which = (f"the {sur.n_frf} modes up to {cfg.modal_hz:g} Hz"
                         if cfg.modal_hz < top else
                         f"all {sur.n_frf} reduction modes (up to {top:.1f} Hz: modal_hz = "
                         f"{cfg.modal_hz:g} lies above them)")  # fmt: skip
                say(f"{case.name}: the FRFs sum {which} at the nominal" + (
                    ", the others as residual flexibility" if cfg.residual else ""))
        return sur, modes

    def surrogates_at(p: np.ndarray) -> tuple[list[Surrogate], list]:
        """Every configuration's surrogate at p: built at once on a Dask cluster when
        there are several (each model sent there once), one after another here otherwise
        (each build is parallel inside)."""
        if len(cases) > 1 and session.engine.kind == "dask":
            pool = session.pool()
            jobs = []
            for k in range(len(cases)):
                (model, *rest), kwargs = build_arguments(k, p)
                jobs.append(pool.submit(_build_surrogate, session.share_once(model),
                                        *rest, kwargs))  # fmt: skip
            say(f"surrogates of {len(cases)} configurations building on "
                f"{session.engine.describe()}")  # fmt: skip
            built = [surrogate_at(k, p, result_of(job, f"the surrogate of configuration "
                                                       f"{cases[k].name}"))
                     for k, job in enumerate(jobs)]  # fmt: skip
        else:
            built = [surrogate_at(k, p) for k in range(len(cases))]
        return [b[0] for b in built], [b[1] for b in built]

    corrections: dict[int, tuple[Surrogate, np.ndarray | None]] = {}

    def correction_of(sur: Surrogate, case: Case) -> np.ndarray | None:
        """The surrogate's first-order correction, computed once per surrogate (the last
        few surrogates' are kept)."""
        if id(sur) not in corrections:
            while len(corrections) >= 2 * len(cases):
                del corrections[next(iter(corrections))]
            corrections[id(sur)] = (sur, first_order_correction(
                sur, sur.exact, case.freq, case.H_test, cfg.metric)
                if sur.exact is not None else None)  # fmt: skip
        return corrections[id(sur)][1]

    def terms_on(surs: Sequence[Surrogate]) -> tuple[Term, ...]:
        factors = weighing.get("factors", [1.0] * len(cases))
        thresholds = weighing.get("huber", [None] * len(cases))
        return tuple(
            Term(sur, c.freq, c.H_test, cfg.metric, c.index, float(f), correction_of(sur, c),
                 huber=h)
            for c, sur, f, h in zip(cases, surs, factors, thresholds, strict=True))  # fmt: skip

    def problem_on(surs: Sequence[Surrogate], lower: np.ndarray, upper: np.ndarray) -> Problem:
        return Problem(terms_on(surs), lower, upper, cfg.max_iterations,
                       weighing.get("weights"))  # fmt: skip

    def starts_in(name: str, problem: Problem, pts: list[np.ndarray], center: np.ndarray,
                  task: str | None = None) -> list[StartResult]:  # fmt: skip
        """The starts ``pts`` on ``problem``, kept in the state folder ``name`` (resumed
        there), their fingerprint the run's and ``center``'s."""
        folder = state_dir / name if state_dir is not None else None
        if fresh and folder is not None and folder.is_dir():
            for f in folder.glob("start_*.json"):
                f.unlink()
        return run_starts(problem, pts, session=session, folder=folder,
                          fingerprint=fp + f"-{name}-" + ",".join(f"{x:.12g}" for x in center),
                          progress=say, task=task or _starts_task(name))  # fmt: skip

    cycles: list[Cycle] = []

    def save_cycles() -> None:
        if state_dir is None:
            return
        text = json.dumps([_cycle_state(c) for c in cycles], indent=1)
        write_atomic(state_dir / "cycles.json", lambda tmp: Path(tmp).write_text(text))

    # cycle 1: the multi-start search over the whole box on the nominal surrogates
    say("cycle 1: Levenberg-Marquardt from every start on the nominal model's surrogate")
    center = np.zeros(n_p)
    surs, modes_c = surrogates_at(center)
    surs0, modes0 = surs, modes_c
    # before the search: what the tests can inform, with the nominal models' residuals; each
    # configuration's residuals are weighed by its own likelihood, the first's as reference
    r0s = [t.residuals(center) for t in terms_on(surs)]  # the full models at the nominal
    if cfg.loss == "huber":  # its threshold from each test's noise or robust spread
        weighing["huber"] = [cfg.huber_c * (cfg.noise_sigma or robust_scale(r)) for r in r0s]
    terms0 = terms_on(surs)
    likelihoods = [likelihood_of(t.transformed(r)[0], len(c.freq), cfg.noise_sigma)
                   for t, r, c in zip(terms0, r0s, cases, strict=True)]  # fmt: skip
    reference = likelihoods[0]
    weighing["factors"] = [reference.scale / lk.scale for lk in likelihoods]
    J0 = problem_on(surs, lo, hi).data_jacobian(center)[0]
    before = identifiability(J0, params, prior, reference, cfg.hold_ratio,
                             cfg.identifiable_ratio)  # fmt: skip
    held = before.held
    say(identifiability_summary(before, params, likelihoods, [c.name for c in cases]))
    lo, hi = np.where(held, 0.0, lo), np.where(held, 0.0, hi)  # held at the nominal
    weighing["weights"] = reference.weights(prior)
    starts0 = [np.zeros(n_p)]
    if n_starts > 1:
        starts0 += list(latin_hypercube(n_starts - 1, lo, hi, rng))
    problem = problem_on(surs, lo, hi)
    cost_c = problem.cost(center)
    results = starts_in("cycle1", problem, starts0, center)
    best = min(results, key=lambda r: r.cost)
    cand, pred = best.p, best.cost
    cycles.append(Cycle(1, center, cand, best.deviation, best.start + 1, tuple(results),
                        exact_deviation_at_center=problem.deviation(center),
                        moved=float(np.abs(cand).max())))  # fmt: skip
    save_cycles()
    say(f"cycle 1: best start {best.start + 1}, deviation {best.deviation:.5g} (surrogate)")
    # cycles 2...: trust region; the surrogates rebuilt at the candidate are the full models
    # there, which decide whether the step is kept. The last cycle only decides, so that the
    # result is always a point the full models have checked: max_cycles = 1 runs the one
    # search of cycle 1 and a cycle 2 that checks its candidate, as max_cycles = 2 does
    n_cycles = max(cfg.max_cycles, 2)
    if cfg.max_cycles < 2:
        say("max_cycles = 1: cycle 2 only checks cycle 1's candidate on the full model")
    radius = max(float(np.abs(cand - center).max()), cfg.settle)
    settled = False
    restarts_left = cfg.restarts if n_starts > 1 else 0
    searched = False  # the candidate came from a multi-start search over the whole box
    for c in range(2, n_cycles + 1):
        surs_new, modes_new = surrogates_at(cand)
        prob_new = problem_on(surs_new, lo, hi)
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
            post_c = posterior(prob_new.data_jacobian(cand)[0], prior, reference, ~held)
            informed = ~held & (post_c.ratio < cfg.identifiable_ratio)
            moved = float(step[informed].max() if informed.any() else step.max())
            fall = (cost_c - cost_new) / cost_c
            center, surs, modes_c, cost_c, problem = cand, surs_new, modes_new, cost_new, prob_new
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
        last = c == n_cycles
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
    J = problem.data_jacobian(p_final)[0]
    post = posterior(J, prior, reference, ~held)
    band_bounds = []
    for b in cfg.crlb_bands:
        rows = np.concatenate([residual_rows(c, cfg.metric, band=b) for c in cases])
        band_bounds.append(BandBounds(tuple(b), posterior(J[rows], prior, reference,
                                                          ~held).std))  # fmt: skip
    at_bound = {params[i].name for i in range(n_p) if not held[i] and (
        np.isclose(p_final[i], params[i].p_lower, atol=1e-9)
        or np.isclose(p_final[i], params[i].p_upper, atol=1e-9))}  # fmt: skip
    parameters = []
    for i, par in enumerate(params):
        std = float(post.std[i])
        extra = {}
        if truth is not None and np.isfinite(truth[i]):  # a synthetic test's known value
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
            at_bound=par.name in at_bound, reason=before.reasons[i], **extra))  # fmt: skip

    def full_residuals(k: int, p: np.ndarray) -> np.ndarray:
        """Configuration k's residuals on its full model at the shared p."""
        case = cases[k]
        q = p[case.index]
        sur, _ = build_surrogate(
            case.model, list(case.params), q, case.outputs, case.inputs,
            n_modes=cfg.reduction_modes, zeta=case.zeta0, quantity=case.quantity,
            order=cfg.surrogate, polynomials=case.polynomials, residual=cfg.residual,
            frf_modes=frf_modes[k], exact_gradient=False, centre_only=True)  # fmt: skip
        return residuals(sur.frf(q, case.freq), case.H_test, cfg.metric)

    bound_names = [[q.name for q in case.params if q.name in at_bound] for case in cases]
    form_inputs = [(case, surs[k], modes_c[k], p_final, cfg.metric, r0s[k], bound_names[k],
                    cfg.noise_sigma) for k, case in enumerate(cases)]  # fmt: skip
    # the model-form diagnostics (NumPy on what is at hand) run in a forked process of their
    # own while the hold-out folds (which factorise) run here, when there are cores for both
    aside = bool(plan[1]) and two_here
    with (beside(_model_forms, form_inputs) if aside
          else contextlib.nullcontext()) as call:
        holdout = (validate(cases, problem.terms, terms0, params, p_final, prior, plan,
                            noise_sigma=cfg.noise_sigma, hold_ratio=cfg.hold_ratio,
                            identifiable_ratio=cfg.identifiable_ratio,
                            max_iter=cfg.max_iterations, full_residuals=full_residuals,
                            search=lambda prob, pts, n: starts_in(
                                f"holdout{n}", prob, pts, p_final,
                                task=f"hold-out {n}/{len(plan[1])}: starts"),
                            progress=say)
                   if plan[1] else None)  # fmt: skip
        forms = (result_of(call.future, "the model-form diagnostics") if aside
                 else _model_forms(form_inputs))  # fmt: skip
    case_results = tuple(
        _case_result(case, surs0[k], surs[k], modes0[k], modes_c[k], p_final, frf_modes[k],
                     likelihoods[k], cfg.metric, r0s[k], forms[k])
        for k, case in enumerate(cases))  # fmt: skip

    result = CalibrationResult(
        config=cfg, parameters=tuple(parameters), p_final=p_final, cases=case_results,
        cycles=tuple(cycles), settled=settled, prior=prior, identifiability=before,
        posterior=post, band_bounds=tuple(band_bounds), seconds=time.perf_counter() - t0,
        holdout=holdout)
    say(f"deviation {result.deviation_before:.5g} -> {result.deviation_after:.5g}")
    return result


def _build_surrogate(model: Model, params: list[Parameter], q: np.ndarray,
                     outputs: Sequence, inputs: Sequence, kwargs: dict) -> tuple:
    """:func:`build_surrogate` as a task for a worker (positional arguments only)."""
    return build_surrogate(model, params, q, outputs, inputs, **kwargs)


def _model_form(case: Case, sur: Surrogate, modes_after, p_final: np.ndarray, metric: str,
                eps_before: np.ndarray, at_bound: list[str],
                noise_sigma: float | None) -> ModelForm:  # fmt: skip
    """One configuration's model-form diagnostics (:func:`~femcal.calibrate.modelform.
    diagnose`) at the calibrated point against the given noise level (else the measured
    FRFs' scatter about the identified model)."""
    noise = noise_sigma or measured_scatter(case.setup.data, case.setup.identified,
                                            case.outputs, case.setup.band, metric)
    H_after = sur.frf(p_final[case.index], case.freq)
    eps_after = residuals(H_after, case.H_test, metric)
    return diagnose(case.model, modes_after, case.outputs, case.inputs, case.freq,
                    case.zeta0, case.setup.band, case.test_hz, eps_before, eps_after, H_after,
                    case.H_test, metric, noise, at_bound, case.setup.channel_names)  # fmt: skip


def _model_forms(inputs: list[tuple]) -> list[ModelForm]:
    """:func:`_model_form` of every configuration's inputs (a task for a worker)."""
    return [_model_form(*args) for args in inputs]


def _case_result(case: Case, sur0: Surrogate, sur: Surrogate, modes0, modes_after,
                 p_final: np.ndarray, frf_modes: int, likelihood: Likelihood, metric: str,
                 eps_before: np.ndarray, form: ModelForm) -> CaseResult:  # fmt: skip
    """One configuration's outcome: the full model's FRFs (each surrogate at its centre: the
    modal sum over the reduction modes, with the residual flexibility if asked), deviations,
    MAC and mode pairings before and after, and its model-form diagnostics ``form``
    (:func:`_model_form`)."""
    n_p_c = len(case.params)
    H_before = sur0.frf(np.zeros(n_p_c), case.freq)
    H_after = sur.frf(p_final[case.index], case.freq)
    eps_after = residuals(H_after, case.H_test, metric)
    Cg = channel_matrix(case.model, case.outputs)
    fe_before = np.asarray(Cg @ modes0.shapes)
    fe_after = np.asarray(Cg @ modes_after.shapes)
    return CaseResult(
        name=case.name, model=case.model, data=case.setup.data,
        identified=case.setup.identified, index=case.index, band=case.setup.band,
        zeta0=case.zeta0, freq=case.freq, outputs=case.outputs, inputs=case.inputs,
        excluded=case.excluded, H_test=case.H_test, H_before=H_before, H_after=H_after,
        deviation_before=deviation(residuals(H_before, case.H_test, metric)),
        deviation_after=deviation(eps_after),
        frf_modes=frf_modes, likelihood=likelihood, test_hz=case.test_hz,
        test_shapes=case.test_shapes, modes_before=modes0, modes_after=modes_after,
        mac_before=mac(case.test_shapes, fe_before), mac_after=mac(case.test_shapes, fe_after),
        modes=_pairings(case.test_hz, case.test_shapes, fe_before, fe_after, modes0,
                        modes_after, case.setup.band, len(case.outputs)),
        model_form=form, channel_names=dict(case.setup.channel_names),
        suspects=suspect_channels(case.outputs, case.inputs, case.freq, case.H_test, H_after,
                                  H_before=H_before, phase=metric == "complex-log",
                                  model=case.model, modes=modes_after, zeta=case.zeta0,
                                  quantity=case.quantity,
                                  names=dict(case.setup.channel_names)))  # fmt: skip


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
