"""A calibration from its configuration file (:mod:`femcal.calibrate.config`), files in and
files out.

Reads each configuration's deck, parameters and test (FRFs, identified first if the
configuration asks, or an identified model), runs
:func:`femcal.calibrate.workflow.calibrate_setups` with its state in ``out/starts`` (a
stopped run resumes), and writes ``out/report.json``, each configuration's calibrated deck
(the engineer's deck with the calibrated fields changed, its changed INCLUDE files and its
changed cards alone: :func:`femcal.io.calibration.write_calibrated_deck`) and, when
identified here, ``out/identify/`` (``out/identify/<name>/`` with several
configurations: model.npz, identify.json, identification.html, the identification's page with
its verdict). When the model-form warning fires and the element the search names removes
at least ``augment_fall`` of the deviation, the element is added to its configuration's deck
as a parameter and the calibration runs again into ``out/augmented/`` (the deck with the
element, ``starts/``, the calibrated decks, report.json; :mod:`femcal.calibrate.augment`),
and the first report says what the data prefer. The pictures and ``report.html`` are
:func:`femcal.io.calibration.write_report`'s.
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..calibrate.augment import added_element, choose, verdict
from ..calibrate.cases import TestSetup
from ..calibrate.config import Config, Configuration
from ..calibrate.modelform import Candidate
from ..calibrate.parameters import (
    Parameter,
    current_value,
    read_parameters,
    read_truth,
    share_parameters,
)
from ..calibrate.result import Augmentation, CalibrationResult
from ..calibrate.workflow import calibrate_setups, check_overrides
from ..deck import read_deck
from ..errors import FemcalError, message
from ..identify import IdentifiedModel, Settings, identify
from ..io.calibration import (
    AUGMENTED_FOLDER,
    calibrated_deck_name,
    element_cards,
    field_value,
    unread_card_ids,
    write_augmented_deck,
    write_calibrated_deck,
    write_report_json,
)
from ..io.html import file_facts, provenance
from ..io.identified import read_model, write_model, write_summary
from ..io.identify_page import write_identification_page
from ..model.build import load_model
from ..model.model import Model
from ..parallel.cluster import Engine, Session
from ..testdata.data import FRFData, convert_units
from ..testdata.formats import read_frf
from ..testdata.points import channel_names


def load_test(conf: Configuration, out: Path, say: Callable[[str], None],
              pool: Executor | None = None
              ) -> tuple[FRFData | None, IdentifiedModel | None]:  # fmt: skip
    """The measured FRFs (in the model's units) and the identified model of one
    configuration: identified here (written to ``out``; its parts on ``pool`` when given)
    or read from its file.

    Raises
    ------
    ValueError
        For units that do not convert, or an identified model in other units than the
        model's.
    """
    data = read_frf(conf.test_frf) if conf.test_frf is not None else None
    if data is not None and conf.model_units and data.units and data.units != conf.model_units:
        data = convert_units(data, conf.model_units)
        say(f"{conf.name}: test FRFs converted to {conf.model_units}")
    ident = None
    if conf.identify is not None:
        s = conf.identify
        say(f"{conf.name}: identifying the test FRFs over {s.band[0]:g}-{s.band[1]:g} Hz")
        ident = identify(data, s.band, splits=s.splits, orders=s.orders,
                         settings=Settings(gamma=s.gamma, beta=s.beta, max_order=s.max_order,
                                           method=s.method),
                         progress=say, pool=pool)  # fmt: skip
        write_model(out / "model.npz", ident)
        write_summary(out / "identify.json", ident)
        write_identification_page(out / "identification.html", ident, [],
                                  provenance([file_facts("FRFs", conf.test_frf)]),
                                  source=str(conf.test_frf))  # fmt: skip
    elif conf.test_model is not None:
        ident = read_model(conf.test_model)
        say(f"{conf.name}: identified test model read from {conf.test_model}")
        if conf.model_units and ident.units and ident.units != conf.model_units:
            raise ValueError(f"{conf.test_model}: the identified model is in {ident.units}, the "
                             f"FE model in {conf.model_units}")  # fmt: skip
    return data, ident


def _truth(cfg: Config, per_config: list[list], shared: list) -> np.ndarray | None:
    """A synthetic test's known values of the shared parameters, from the configurations'
    truth files (None unless every shared parameter's is known)."""
    known: dict[str, float] = {}
    for conf, params in zip(cfg.configurations, per_config, strict=True):
        if conf.test_truth is not None:
            known.update(zip((p.name for p in params), read_truth(conf.test_truth, params),
                             strict=True))  # fmt: skip
    if not known or any(p.name not in known for p in shared):
        return None
    return np.array([known[p.name] for p in shared])


@dataclass(frozen=True)
class Inputs:
    """What a calibration reads before its tests: per configuration its model and
    parameters, the parameters shared by name, and a synthetic test's known values."""

    models: list[Model]
    parameters: list[list[Parameter]]
    shared: list[Parameter]
    truth: np.ndarray | None


def read_inputs(cfg: Config, say: Callable[[str], None] | None = None) -> Inputs:
    """Each configuration's deck and parameter file, the parameters they share, and the
    truth files (read now: a bad file fails before any work).

    Raises
    ------
    ConfigError
        Naming the parameter or truth file and the parameter (a ValueError too).
    DeckError, ModelError
        For a deck that does not read or does not make a model.
    ValueError
        For parameters shared by name that disagree.
    """
    say = say or (lambda _m: None)
    models, per_config = [], []
    for conf in cfg.configurations:
        model = load_model(conf.deck)
        params = read_parameters(conf.parameters, model)
        say(f"{conf.deck.name}: {model.n_dof} DOF; {len(params)} parameters from "
            f"{conf.parameters.name}")
        models.append(model)
        per_config.append(params)
    shared, _ = share_parameters(per_config, [str(c.parameters) for c in cfg.configurations])
    return Inputs(models, per_config, shared, _truth(cfg, per_config, shared))


def run(cfg: Config, out: str | Path, *, fresh: bool = False, workers: int | None = None,
        starts: int | None = None, engine: Engine | None = None,
        progress: Callable[[str], None] | None = None) -> CalibrationResult:  # fmt: skip
    """Run the calibration of ``cfg`` into the folder ``out`` (see the module docstring).

    ``fresh`` ignores finished starts of an earlier run; ``workers``, ``starts`` and
    ``engine`` (where the starts run: :class:`~femcal.parallel.cluster.Engine`) override
    the configuration's. The finished starts in ``out/starts`` are resumed only
    by a run whose models, settings, tests and files (the decks with their INCLUDEs, the
    parameter, test, sensor and input files) are the same
    (:func:`femcal.calibrate.workflow.fingerprint`). Every file is written whole or not at
    all, so a run stopped at any point (Ctrl-C) leaves no partial file, and the next run
    resumes from the starts it finished.

    Raises
    ------
    ValueError, KeyError
        Naming the file and what is wrong in it (deck, parameters, truth, test files).
    """
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    check_overrides(workers, starts)
    inputs = read_inputs(cfg, say)
    engine = engine or Engine(cfg.engine, workers or cfg.workers, cfg.scheduler)
    with engine.session() as session:
        return _run(cfg, out, inputs, session, fresh=fresh, starts=starts, say=say,
                    progress=progress, t0=t0)  # fmt: skip


def _run(cfg: Config, out: Path, inputs: Inputs, session: Session, *, fresh: bool,
         starts: int | None, say: Callable[[str], None],
         progress: Callable[[str], None] | None, t0: float) -> CalibrationResult:  # fmt: skip
    """:func:`run` once its inputs are read, on an open engine ``session``: a Dask
    cluster identifies the tests' parts and runs the starts."""
    several = len(cfg.configurations) > 1
    pool = None
    if session.engine.kind == "dask":
        parts = any(c.identify is not None for c in cfg.configurations)
        say(f"{'the identification parts and ' if parts else ''}the calibration's starts "
            f"run on {session.engine.describe()}")  # fmt: skip
        pool = session.pool() if parts else None
    models, per_config, truth = inputs.models, inputs.parameters, inputs.truth
    setups = []
    for conf, model, params in zip(cfg.configurations, models, per_config, strict=True):
        data, ident = load_test(conf, out / "identify" / conf.name if several
                                else out / "identify", say, pool)  # fmt: skip
        names = {}
        for points in (conf.sensors, conf.inputs):
            if points is not None:
                names.update(channel_names(points))
        setups.append(TestSetup(conf.name, model, tuple(params), conf.band, data, ident,
                                conf.zeta0, conf.model_units, names))  # fmt: skip
    sources = [f for c in cfg.configurations for f in c.sources]
    result = calibrate_setups(setups, cfg, truth=truth, state=out / "starts", fresh=fresh,
                              starts=starts, session=session, progress=progress,
                              sources=sources)  # fmt: skip
    decks = [c.deck for c in cfg.configurations]
    _write_decks(cfg, decks, per_config, result, out, say)
    result = replace(result, seconds=time.perf_counter() - t0)  # the whole job's run time
    path = write_report_json(out / "report.json", result)
    say(f"wrote {path}")
    pick = choose(((c.name, c.model_form.candidates[0], c.model_form.warning)
                   for c in result.cases if c.model_form and c.model_form.candidates),
                  cfg.augment_fall)  # fmt: skip
    folder = out / AUGMENTED_FOLDER
    if pick is None:
        if folder.is_dir():  # an earlier run's, which no longer follows from this one
            shutil.rmtree(folder)
            say(f"removed {folder}: this run adds no model-form element")
        return result
    try:
        augmented = _augment(cfg, folder, inputs, setups, result, pick, session, fresh=fresh,
                             starts=starts, say=say, progress=progress,
                             sources=sources)  # fmt: skip
    except (FemcalError, ValueError) as e:  # the first calibration stands, reported
        say(f"model form: the element was not added: {message(e)}")
        result = replace(result, augment_error=message(e))
    else:
        result = replace(result, augmented=augmented)
    result = replace(result, seconds=time.perf_counter() - t0)
    path = write_report_json(out / "report.json", result)
    say(f"wrote {path}")
    return result


def _write_decks(cfg: Config, decks: list[Path], per_config: list[list[Parameter]],
                 result: CalibrationResult, out: Path, say: Callable[[str], None]) -> None:
    """Each configuration's calibrated deck (from ``decks``) into ``out``."""
    written: list[Path] = []
    for conf, deck_in, params, case in zip(cfg.configurations, decks, per_config, result.cases,
                                           strict=True):  # fmt: skip
        deck = out / calibrated_deck_name(conf, cfg)
        files = write_calibrated_deck(deck_in, params, result.values[case.index], deck,
                                      config=cfg.path, keep=written)  # fmt: skip
        written += files
        say(f"wrote {deck} ({', '.join(str(f.relative_to(out)) for f in files[1:])} "
            "beside it)")


def _augment(cfg: Config, out: Path, inputs: Inputs, setups: list[TestSetup],
             first: CalibrationResult, pick: tuple[str, Candidate], session: Session, *,
             fresh: bool, starts: int | None, say: Callable[[str], None],
             progress: Callable[[str], None] | None,
             sources: list[Path]) -> Augmentation:  # fmt: skip
    """The calibration again with the element the model-form search named (``pick``: the
    configuration's name and the candidate) added to that configuration's deck as a
    parameter (:mod:`femcal.calibrate.augment`), into ``out``: the augmented deck, its
    state (``out/starts``, resumed as the first run's), the calibrated decks and
    report.json; the verdict set against ``first``.

    Raises
    ------
    ValueError, FemcalError
        When the added cards are not in the model read back (a bulk section that ends in an
        INCLUDE file ends before them), or the deck cannot be written or read back.
    """
    name, cand = pick
    k = [c.name for c in cfg.configurations].index(name)
    conf = cfg.configurations[k]
    taken = {p.name for p in inputs.shared}
    source = read_deck(conf.deck)
    other_elements, other_properties = unread_card_ids(source)
    added = added_element(inputs.models[k], name, replace(cand, value=field_value(cand.value)),
                          taken, other_element_ids=other_elements,
                          other_property_ids=other_properties)  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    deck = write_augmented_deck(conf.deck, element_cards(added), out / conf.deck.name,
                                why="the missing element the model-form search named",
                                deck=source)  # fmt: skip
    model = load_model(deck)
    par = added.parameter
    try:
        current_value(model, par.card, par.id, par.field)
    except ValueError:
        raise ValueError(f"{deck}: the added {par.card} {par.id} was not read back (does "
                         f"{conf.deck}'s bulk data end in an INCLUDE file?)") from None
    say(f"model form: {cand.describe()} would remove about {100 * cand.fall:.0f} % of "
        f"{name}'s deviation; calibrating again with {added.describe()} added as parameter "
        f"{par.name} (bounds {par.lower:.3g} to {par.upper:.3g}), into {out}")  # fmt: skip
    per_config = [list(p) for p in inputs.parameters]
    per_config[k] = [*per_config[k], par]
    setups = list(setups)
    setups[k] = replace(setups[k], model=model, params=tuple(per_config[k]))
    truth = None
    if inputs.truth is not None:  # by name, in the new shared order; the element's unknown
        known = dict(zip((p.name for p in inputs.shared), inputs.truth, strict=True))
        shared, _ = share_parameters(per_config, [str(c.parameters)
                                                  for c in cfg.configurations])  # fmt: skip
        truth = np.array([known.get(p.name, np.nan) for p in shared])
    result = calibrate_setups(setups, cfg, truth=truth, state=out / "starts", fresh=fresh,
                              starts=starts, session=session, progress=progress,
                              sources=sources)  # fmt: skip
    decks = [deck if i == k else c.deck for i, c in enumerate(cfg.configurations)]
    _write_decks(cfg, decks, per_config, result, out, say)
    path = write_report_json(out / "report.json", result)
    say(f"wrote {path}")
    ho1, ho2 = first.holdout, result.holdout
    better, why = verdict(ho1.deviation_calibrated if ho1 else None,
                          ho2.deviation_calibrated if ho2 else None)  # fmt: skip
    return Augmentation(added, result, deck, better, why)
