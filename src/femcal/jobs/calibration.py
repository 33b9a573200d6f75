"""A calibration from its configuration file (:mod:`femcal.calibrate.config`), files in and
files out.

Reads the deck, the parameters and the test (FRFs, identified first if the configuration
asks, or an identified model), runs :func:`femcal.calibrate.workflow.calibrate` with its
state in ``out/starts`` (a stopped run resumes), and writes ``out/report.json``, the
calibrated deck and, when identified here, ``out/identify/`` (model.npz, identify.json).
The pictures and ``report.html`` are :func:`femcal.io.calibration.write_report`'s.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from ..calibrate.config import Config
from ..calibrate.parameters import read_parameters, read_truth
from ..calibrate.result import CalibrationResult
from ..calibrate.workflow import calibrate
from ..identify import IdentifiedModel, Settings, identify
from ..io.calibration import calibrated_deck_name, write_calibrated_deck, write_report_json
from ..io.identified import read_model, write_model, write_summary
from ..model.build import load_model
from ..testdata.data import FRFData, convert_units
from ..testdata.formats import read_frf


def load_test(cfg: Config, out: Path, say: Callable[[str], None]
              ) -> tuple[FRFData | None, IdentifiedModel | None]:  # fmt: skip
    """The measured FRFs (in the model's units) and the identified model: identified here
    (written to ``out/identify``) or read from the configuration's file.

    Raises
    ------
    ValueError
        For units that do not convert, or an identified model in other units than the
        model's.
    """
    data = read_frf(cfg.test_frf) if cfg.test_frf is not None else None
    if data is not None and cfg.model_units and data.units and data.units != cfg.model_units:
        data = convert_units(data, cfg.model_units)
        say(f"test FRFs converted to {cfg.model_units}")
    ident = None
    if cfg.identify is not None:
        s = cfg.identify
        say(f"identifying the test FRFs over {s.band[0]:g}-{s.band[1]:g} Hz")
        ident = identify(data, s.band, splits=s.splits, orders=s.orders,
                         settings=Settings(gamma=s.gamma, beta=s.beta, max_order=s.max_order),
                         progress=say)  # fmt: skip
        write_model(out / "identify" / "model.npz", ident)
        write_summary(out / "identify" / "identify.json", ident)
    elif cfg.test_model is not None:
        ident = read_model(cfg.test_model)
        say(f"identified test model read from {cfg.test_model}")
        if cfg.model_units and ident.units and ident.units != cfg.model_units:
            raise ValueError(f"{cfg.test_model}: the identified model is in {ident.units}, the "
                             f"FE model in {cfg.model_units}")  # fmt: skip
    return data, ident


def run(cfg: Config, out: str | Path, *, fresh: bool = False, workers: int | None = None,
        starts: int | None = None,
        progress: Callable[[str], None] | None = None) -> CalibrationResult:  # fmt: skip
    """Run the calibration of ``cfg`` into the folder ``out`` (see the module docstring).

    ``fresh`` ignores finished starts of an earlier run; ``workers`` and ``starts``
    override the configuration's.

    Raises
    ------
    ValueError, KeyError
        Naming the file and what is wrong in it (deck, parameters, truth, test files).
    """
    say = progress or (lambda _m: None)
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = load_model(cfg.deck)
    params = read_parameters(cfg.parameters, model)
    # a synthetic test's known values, for the report only (read now: a bad file fails fast)
    truth = read_truth(cfg.test_truth, params) if cfg.test_truth is not None else None
    say(f"{cfg.deck.name}: {model.n_dof} DOF; {len(params)} parameters from "
        f"{cfg.parameters.name}")
    data, ident = load_test(cfg, out, say)
    result = calibrate(model, params, cfg, data=data, identified=ident, truth=truth,
                       state=out / "starts", fresh=fresh, workers=workers, starts=starts,
                       progress=progress)  # fmt: skip
    write_calibrated_deck(cfg.deck, params, result.values, out / calibrated_deck_name(cfg))
    result = replace(result, seconds=time.perf_counter() - t0)  # the whole job's run time
    path = write_report_json(out / "report.json", result)
    say(f"wrote {path} and {out / calibrated_deck_name(cfg)}")
    return result
