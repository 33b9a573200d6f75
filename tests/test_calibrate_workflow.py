"""The calibration workflow end to end on a small deck: a noise-free test made from a
perturbed model is calibrated back to its parameters; report, calibrated deck, resume, CLI,
configuration errors."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from femcal.calibrate.config import read_config
from femcal.calibrate.parameters import current_value, with_values
from femcal.cli import main
from femcal.deck import read_deck
from femcal.jobs.calibration import run
from femcal.model.build import build_model
from femcal.testdata.data import Channel

from .calib_decks import (
    INS,
    LOADED_PARAMS,
    OUTS,
    PARAMS_TOML,
    TRUE_P,
    plate_deck,
    write_modal_test,
    write_plate,
)
from .processes import alive, children

CONFIG = """
[model]
deck = "plate.bdf"
parameters = "p.toml"

[test]
frf = "test.npz"

[calibration]
band = [10.0, 350.0]
zeta0 = 0.02
reduction_modes = 40
starts = 10
workers = 2
seed = 1
max_cycles = 8
noise_sigma = 0.01
identifiable_ratio = 0.1
"""


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    d = tmp_path_factory.mktemp("study")
    model, params = write_plate(d)
    true_model = with_values(model, params, [p.value(x) for p, x in zip(params, TRUE_P,
                                                                        strict=True)])  # fmt: skip
    write_modal_test(d / "test.npz", true_model, OUTS, INS)
    (d / "cal.toml").write_text(CONFIG)
    lines: list[str] = []
    outcome = run(read_config(d / "cal.toml"), d / "out", progress=lines.append)
    return d, params, outcome, lines


def test_noise_free_test_is_calibrated_back_to_its_parameters(study):
    _, params, outcome, _ = study
    for par, row, true in zip(params, outcome.parameters, TRUE_P, strict=True):
        assert row.identifiable, par.name  # every parameter is informed here
        assert abs(row.calibrated / par.value(true) - 1) < 1e-3, par.name
    assert outcome.deviation_after < 1e-6 * outcome.deviation_before
    assert outcome.settled


def test_settled_cycles_search_again_and_stop_when_nothing_lower_is_found(study):
    # once settled at the (here global) minimum, the multi-start search runs again on the
    # last surrogate; it finds that minimum again, so the run stops there
    _, _, outcome, lines = study
    assert outcome.restarts == 1
    last = outcome.cycles[-1]
    assert last.searched and last.search_best_deviation <= 1e-6 * outcome.deviation_before
    assert any("the search found no lower minimum elsewhere" in line for line in lines)
    assert not any(c.from_search for c in outcome.cycles)


def test_report_holds_what_the_issue_asks(study):
    d, params, _, _ = study
    rep = json.loads((d / "out" / "report.json").read_text())
    for row in rep["parameters"]:
        assert {"name", "nominal", "calibrated", "lower", "upper", "crlb"} <= set(row)
        assert row["crlb"] > 0
    conf = rep["configurations"][0]
    for row in conf["modes"]:
        assert {"test_hz", "fe_before_hz", "fe_after_hz", "mac_before", "mac_after"} <= set(row)
    assert set(rep["deviation"]) >= {"before", "after"}
    assert len(rep["starts"]) == 10
    # without an identified model there are no test modes to pair
    assert conf["modes"] == []
    # the calibrated deck carries the calibrated values, to the digits its 8-character free
    # fields hold (7 for 5.123456, 5 for .0021999 or 7.8512-9)
    back = build_model(read_deck(d / "out" / conf["calibrated_deck"]))
    for par, row in zip(params, rep["parameters"], strict=True):
        assert current_value(back, par.card, par.id, par.field) == pytest.approx(
            row["calibrated"], rel=5e-5)


def test_a_second_run_resumes_from_the_finished_starts(study):
    d, _, outcome, _ = study
    lines: list[str] = []
    again = run(read_config(d / "cal.toml"), d / "out", progress=lines.append)
    # the ten starts of cycle 1 and of each search again, and the later cycles' single starts
    searches = outcome.restarts
    assert sum("start" in line and "finished earlier" in line and "/10:" in line
               for line in lines) == 10 * (1 + searches)  # fmt: skip
    assert not any("iteration" in line for line in lines)  # nothing was run again
    np.testing.assert_allclose(again.p_final, outcome.p_final, rtol=0, atol=1e-12)


def test_report_pictures_and_page(study):
    from femcal.io.calibration import write_report

    d, _, outcome, _ = study
    page = write_report(outcome, d / "out")
    text = page.read_text()
    assert "Parameters" in text and "posterior" in text
    # the verdict first, the evidence next, the provenance last
    order = [text.index(f"id='{x}'") for x in ("verdict", "parameters", "runs", "provenance")]
    assert order == sorted(order)
    assert re.search(r"<h2[^>]*>.*?</h2>", text).group(0) == "<h2>Verdict</h2>"
    assert "misfit, root mean square (log10)" in text
    assert ("worst frequency error" in text) == bool(outcome.cases[0].modes)
    for name in ("frf.png", "parameters.png", "history.png"):
        assert (d / "out" / "pictures" / name).stat().st_size > 1000


def test_cli_and_configuration_errors(study, tmp_path, capsys):
    d, _, _, _ = study
    assert main(["calibrate", str(d / "cal.toml"), "--out", str(d / "out"), "--no-pictures"]) == 0
    printed = capsys.readouterr().out
    assert "deviation:" in printed and "E_steel" in printed
    bad = tmp_path / "bad.toml"
    bad.write_text(CONFIG.replace('deck = "plate.bdf"', f'deck = "{d / "plate.bdf"}"')
                   .replace('parameters = "p.toml"', f'parameters = "{d / "p.toml"}"')
                   .replace('frf = "test.npz"', f'frf = "{d / "test.npz"}"')
                   .replace("band = [10.0, 350.0]\n", ""))  # fmt: skip
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "[calibration] needs band" in capsys.readouterr().err
    bad.write_text(bad.read_text().replace("zeta0 = 0.02", 'band = [10.0, 350.0]\nzeta0 = "median"'))
    with pytest.raises(ValueError, match="needs an identified test model"):
        read_config(bad)
    bad.write_text(CONFIG.replace("starts = 10", 'starts = "many"'))
    (tmp_path / "plate.bdf").write_text(plate_deck())
    (tmp_path / "p.toml").write_text(PARAMS_TOML.replace("id = 300", 'id = "tip"'))
    (tmp_path / "test.npz").write_bytes((d / "test.npz").read_bytes())
    with pytest.raises(ValueError, match=r"\[calibration\] starts = 'many': expected a whole"):
        read_config(bad)
    bad.write_text(CONFIG)
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "p.toml: parameter m_tip: id = 'tip': expected a whole number" in (
        capsys.readouterr().err)
    bad.write_text(CONFIG.replace("[calibration]", '[calibration]\nloss = "abs"'))
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.rstrip().endswith(  # the message whole, quotes and all
        "loss = 'abs': expected \"huber\" or \"squared\"")
    bad.write_text(CONFIG.replace('frf = "test.npz"', 'frf = "nothere.npz"'))
    with pytest.raises(FileNotFoundError):
        read_config(bad)


def test_identified_test_modes_are_paired_before_and_after(study):
    d, params, _, _ = study
    (d / "ident.toml").write_text(CONFIG.replace("zeta0 = 0.02", 'zeta0 = "median"')
                                  .replace("[calibration]", "[test.identify]\nband = [10.0, 560.0]\nsplits = [100.0, 260.0, 450.0]\n"
                                           "\n[calibration]")
                                  )  # fmt: skip
    out = run(read_config(d / "ident.toml"), d / "out_ident")
    assert (d / "out_ident" / "identify" / "model.npz").is_file()
    case = out.cases[0]
    assert case.zeta0 == pytest.approx(0.02, rel=0.01)  # the identified damping
    assert len(case.modes) >= 4
    # the identified model misses the data by up to 0.2 in log10 near some channels'
    # antiresonances (LS fits weigh the peaks), and the log metric weighs those misses as
    # much as the peaks: the parameters come back within a few per cent, not exactly. A mode
    # that starts within that bias (mode 2: -0.30 %) may end on the other side of it.
    for m in case.modes:
        assert abs(m.frequency_error_after_pct) < 0.5  # measured up to 0.33 %
        if abs(m.frequency_error_before_pct) > 0.5:
            assert abs(m.frequency_error_after_pct) < abs(m.frequency_error_before_pct)
        assert m.mac_after > 0.995
    assert out.deviation_after < 0.5 * out.deviation_before
    # the parameters move towards the truth as a whole, except the spring and bush, which act
    # at a single point and are the least reliable (measured: k_spring ends 0.31 and k_bush
    # 0.13 from the truth); this is bias from the identification, not noise, so the CRLB (a
    # noise bound) does not cover it
    names = [q.name for q in params]
    rest = [k for k, name in enumerate(names) if name not in ("k_spring", "k_bush")]
    error_before = np.linalg.norm(TRUE_P[rest])
    error_after = np.linalg.norm((out.p_final - TRUE_P)[rest])
    assert error_after < 0.7 * error_before  # measured 0.38
    for name in ("t", "E_steel", "rho_steel", "m_tip"):  # mass and plate stiffness
        k = [q.name for q in params].index(name)
        assert abs(out.p_final[k] - TRUE_P[k]) < 0.04, name


def test_a_bad_calibration_key_is_named_in_its_own_section_beside_test_identify(study,
                                                                                 tmp_path):
    d, _, _, _ = study
    bad = tmp_path / "bad.toml"
    for name in ("plate.bdf", "p.toml", "test.npz"):
        (tmp_path / name).write_bytes((d / name).read_bytes())
    bad.write_text(CONFIG.replace("[calibration]", "[test.identify]\nband = [10.0, 700.0]\n\n"
                                  "[calibration]").replace("starts = 10", 'starts = "many"'))
    with pytest.raises(ValueError, match=r"\[calibration\] starts = 'many': expected a whole"):
        read_config(bad)
    bad.write_text(CONFIG.replace("[calibration]", "[test.identify]\nband = [10.0, 700.0]\n"
                                  "gamma = \"x\"\n\n[calibration]"))  # fmt: skip
    with pytest.raises(ValueError, match=r"\[test.identify\] gamma = 'x': expected a number"):
        read_config(bad)


def test_a_synthetic_tests_truth_sets_each_error_against_its_posterior(study, tmp_path):
    """[test] truth (the hidden values of a synthetic test) adds each parameter's true value,
    its error and |error| / posterior std to the report; it does not change the run (the finished
    starts are resumed)."""
    from femcal.calibrate.parameters import read_truth
    from femcal.io.calibration import write_report

    d, params, outcome, _ = study
    lines = ["# the plate's hidden values"]
    for par, x in zip(params, TRUE_P, strict=True):
        lines += ["[[parameter]]", f'name = "{par.name}"', f'card = "{par.card}"',
                  f"id = {par.id}", f"true = {float(par.value(x))!r}", ""]  # fmt: skip
    (d / "truth.toml").write_text("\n".join(lines))
    (d / "truth_cal.toml").write_text(CONFIG.replace('frf = "test.npz"',
                                                     'frf = "test.npz"\ntruth = "truth.toml"'))
    again = run(read_config(d / "truth_cal.toml"), d / "out")
    np.testing.assert_allclose(again.p_final, outcome.p_final, rtol=0, atol=1e-12)
    rep = json.loads((d / "out" / "report.json").read_text())
    assert rep["configurations"][0]["truth"] == str(d / "truth.toml")
    for par, row, x in zip(params, again.parameters, TRUE_P, strict=True):
        assert row.true == pytest.approx(par.value(x), rel=1e-14)
        assert row.true_p == pytest.approx(x, abs=1e-12)
        assert row.error_pct == pytest.approx(100 * (row.calibrated / row.true - 1))
        assert abs(row.error_pct) < 0.1
        assert row.error_over_std == pytest.approx(abs(row.p - x) / row.posterior_std_p)
    for row, typed in zip(rep["parameters"], again.parameters, strict=True):  # the JSON too
        assert (row["true"], row["error_pct"]) == (typed.true, typed.error_pct)
    assert "|error| / posterior std" in write_report(again, d / "out").read_text()
    # a truth file that does not cover the parameters, or names another field
    bad = tmp_path / "t.toml"
    bad.write_text("\n".join(lines[: 1 + 6 * 3]))
    with pytest.raises(ValueError, match=rf"t.toml: parameter {params[3].name}: not in the file"):
        read_truth(bad, params)
    bad.write_text("\n".join(lines).replace(f'card = "{params[0].card}"', 'card = "PBAR"', 1))
    with pytest.raises(ValueError, match=rf"parameter {params[0].name}: card = 'PBAR'"):
        read_truth(bad, params)
    # the run reads it before any work, so a bad file fails at once
    (d / "bad_truth.toml").write_text(bad.read_text())
    (d / "bad_truth_cal.toml").write_text(
        CONFIG.replace('frf = "test.npz"', 'frf = "test.npz"\ntruth = "bad_truth.toml"'))
    with pytest.raises(ValueError, match=r"bad_truth.toml: parameter .*: card = 'PBAR'"):
        run(read_config(d / "bad_truth_cal.toml"), tmp_path / "never")
    assert not (tmp_path / "never" / "starts").exists()


def test_the_residual_flag_must_be_a_boolean(study, tmp_path):
    d, _, _, _ = study
    for name in ("plate.bdf", "p.toml", "test.npz"):
        (tmp_path / name).write_bytes((d / name).read_bytes())
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG.replace("[calibration]", "[calibration]\nresidual = true"))
    assert read_config(cfg).residual is True
    cfg.write_text(CONFIG.replace("[calibration]", '[calibration]\nresidual = "yes"'))
    with pytest.raises(ValueError, match=r"\[calibration\] residual = 'yes': expected true or"):
        read_config(cfg)


def _config_beside_the_study(study, tmp_path):
    """The study's configuration, deck, parameters and test copied to tmp_path."""
    d = study[0]
    for name in ("plate.bdf", "p.toml", "test.npz"):
        (tmp_path / name).write_bytes((d / name).read_bytes())
    cfg = tmp_path / "c.toml"
    cfg.write_text(CONFIG)
    return cfg


def _read_with(cfg, lines: str):
    """The study's configuration with ``lines`` added to [calibration], read from ``cfg``."""
    cfg.write_text(CONFIG.replace("[calibration]", "[calibration]\n" + lines))
    return read_config(cfg)


def test_modal_hz_and_exact_gradient_keys(study, tmp_path):
    cfg = _config_beside_the_study(study, tmp_path)
    c = read_config(cfg)
    assert c.exact_gradient is True and c.modal_hz == 0.0  # the defaults
    assert c.enrich_hz == 0.0  # no derivative vectors with the correction
    c = _read_with(cfg, "modal_hz = 150\nexact_gradient = false")
    assert c.exact_gradient is False and c.modal_hz == 150.0
    assert c.enrich_hz == 1.5 * 350.0  # without it: 1.5 x the band's top
    with pytest.raises(ValueError, match=r"\[calibration\] modal_hz = -1.0: expected a freq"):
        _read_with(cfg, "modal_hz = -1")
    with pytest.raises(ValueError, match=r"\[calibration\] exact_gradient = 1: expected true"):
        _read_with(cfg, "exact_gradient = 1")


def test_restart_keys(study, tmp_path):
    cfg = _config_beside_the_study(study, tmp_path)
    c = read_config(cfg)
    assert (c.restarts, c.restart_fall) == (2, 0.01)  # the defaults
    c = _read_with(cfg, "restarts = 0\nrestart_fall = 0.05")
    assert (c.restarts, c.restart_fall) == (0, 0.05)
    with pytest.raises(ValueError, match=r"\[calibration\] restarts = -1: expected 0 or more"):
        _read_with(cfg, "restarts = -1")
    with pytest.raises(ValueError, match=r"restart_fall = 1.5: expected a fraction in \[0, 1\)"):
        _read_with(cfg, "restart_fall = 1.5")


def test_keys_of_earlier_versions_name_what_replaced_them(study, tmp_path):
    cfg = _config_beside_the_study(study, tmp_path)
    with pytest.raises(ValueError, match=r"\[calibration\] identifiable_crlb is replaced by "
                                         r"identifiable_ratio"):  # fmt: skip
        _read_with(cfg, "identifiable_crlb = 0.05")
    with pytest.raises(ValueError, match=r"regularization is replaced by the prior"):
        _read_with(cfg, "regularization = 1.0")
    with pytest.raises(ValueError, match=r"bounds_sigma = -1.0: expected a positive number"):
        _read_with(cfg, "bounds_sigma = -1")
    c = _read_with(cfg, "bounds_sigma = 2.0\nhold_ratio = 0.95")
    assert (c.bounds_sigma, c.hold_ratio, c.identifiable_ratio) == (2.0, 0.95, 0.1)


def test_a_misspelt_key_is_an_error(study, tmp_path):
    cfg = _config_beside_the_study(study, tmp_path)
    with pytest.raises(ValueError, match=r"\[calibration\]: unknown key 'max_cylces' \(expected"):
        _read_with(cfg, "max_cylces = 3")
    cfg.write_text(CONFIG + "\n[outputs]\npictures = false\n")
    with pytest.raises(ValueError, match=r"the top level: unknown key 'outputs'"):
        read_config(cfg)


def test_finished_starts_are_kept_under_what_decides_them(study, tmp_path):
    """A start is resumed only by a run whose model, parameters, settings, test and files are
    the same: the fingerprint changes with any of them, not with file names or worker counts."""
    from dataclasses import replace

    from femcal.calibrate.workflow import fingerprint

    d, params, outcome, _ = study
    cfg = read_config(d / "cal.toml")
    case = outcome.cases[0]
    model, f, H = case.model, case.freq, case.H_test

    def key_of(model=model, params=params, cfg=cfg, n=10, H=H, zeta0=0.02):
        return fingerprint([(model, params, f, H, zeta0)], cfg, n)

    key = key_of()
    (tmp_path / "elsewhere").mkdir()
    copy = tmp_path / "elsewhere" / "plate.bdf"
    copy.write_bytes((d / "plate.bdf").read_bytes())
    moved = replace(model, files=[str(copy)])
    conf = replace(cfg.configurations[0], deck=tmp_path / "x.bdf")
    assert key_of(moved, cfg=replace(cfg, workers=1, configurations=(conf,))) == key
    copy.write_text(copy.read_text() + "$ a comment\n")  # the same arrays, another file
    assert key_of(moved) != key
    changed = with_values(model, params[:1], [params[0].nominal * 1.01])
    assert key_of(changed) != key
    assert key_of(params=params[1:]) != key
    assert key_of(cfg=replace(cfg, metric="complex-log")) != key
    assert key_of(n=9) != key
    assert key_of(H=H * 1.001) != key
    assert key_of(zeta0=0.021) != key


MULTI = """
[[configuration]]
name = "bare"
deck = "plate.bdf"
parameters = "p.toml"
frf = "test.npz"

[[configuration]]
name = "loaded"
deck = "loaded.bdf"
parameters = "loaded.toml"
frf = "loaded.npz"
band = [10.0, 300.0]

[calibration]
band = [10.0, 350.0]
zeta0 = 0.02
reduction_modes = 40
starts = 6
workers = 2
seed = 1
max_cycles = 8
noise_sigma = 0.01
identifiable_ratio = 0.1
"""

def test_two_configurations_share_their_parameters_by_name(study, tmp_path):
    """The plate and the same plate carrying a load, each with its own test: the parameters
    the two parameter files share by name (t, rho_steel) are one, the load's mass is the
    second configuration's own; a noise-free pair of tests is calibrated back to all ten."""
    from femcal.calibrate.parameters import read_parameters

    d, params, _, _ = study
    for name in ("plate.bdf", "p.toml", "test.npz"):
        (tmp_path / name).write_bytes((d / name).read_bytes())
    (tmp_path / "loaded.bdf").write_text(plate_deck().replace("ENDDATA", "CONM2,301,17,,0.004\n"
                                                              "ENDDATA"))  # fmt: skip
    (tmp_path / "loaded.toml").write_text(LOADED_PARAMS)
    from femcal.model.build import load_model

    loaded = load_model(tmp_path / "loaded.bdf")
    lparams = read_parameters(tmp_path / "loaded.toml", loaded)
    true_l = {"t": TRUE_P[0], "rho_steel": TRUE_P[2], "m_load": -0.2}
    truth = with_values(loaded, lparams, [p.value(true_l[p.name]) for p in lparams])
    write_modal_test(tmp_path / "loaded.npz", truth, OUTS[:8], ["17:+Z"])
    (tmp_path / "multi.toml").write_text(MULTI)
    cfg = read_config(tmp_path / "multi.toml")
    assert [c.name for c in cfg.configurations] == ["bare", "loaded"]
    assert cfg.configurations[1].band == (10.0, 300.0)
    out = run(cfg, tmp_path / "out")
    names = [r.parameter.name for r in out.parameters]
    assert names == [p.name for p in params] + ["m_load"]
    assert [names[i] for i in out.cases[1].index] == ["t", "rho_steel", "m_load"]
    want = dict(zip([p.name for p in params], TRUE_P, strict=True)) | {"m_load": -0.2}
    for row in out.parameters:
        assert row.p == pytest.approx(want[row.parameter.name], abs=1e-3), row.parameter.name
    assert out.deviation_after < 1e-6 * out.deviation_before
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert [c["name"] for c in rep["configurations"]] == ["bare", "loaded"]
    back = build_model(read_deck(tmp_path / "out" / rep["configurations"][1]["calibrated_deck"]))
    assert current_value(back, "CONM2", 301, "M") == pytest.approx(0.004 * 0.8, rel=1e-3)
    # a shared parameter must mean the same in both files
    (tmp_path / "loaded.toml").write_text(LOADED_PARAMS.replace("lower_rel = -0.2\nupper_rel = "
                                                                "0.2", "lower_rel = -0.1\n"
                                                                "upper_rel = 0.2", 1))  # fmt: skip
    with pytest.raises(ValueError, match=r"parameter t: lower .* in .*p.toml but .* in "
                                         r".*loaded.toml"):  # fmt: skip
        run(read_config(tmp_path / "multi.toml"), tmp_path / "out2")
    # both forms at once, or two configurations of one name, are refused
    (tmp_path / "both.toml").write_text(CONFIG + MULTI.split("[calibration]")[0])
    with pytest.raises(ValueError, match=r"\[model\] and \[test\], or \[\[configuration\]\]"):
        read_config(tmp_path / "both.toml")
    (tmp_path / "same.toml").write_text(MULTI.replace('name = "loaded"', 'name = "bare"'))
    with pytest.raises(ValueError, match=r"a configuration named 'bare' is already given"):
        read_config(tmp_path / "same.toml")


def test_each_input_held_out_in_turn_is_predicted_by_the_calibration_without_it(study):
    """Two inputs: two folds. Noise-free and without model-form difference, the calibration
    without either input predicts it (and comes back to the truth); a held-out prediction
    worse than the nominal one makes the summary warn."""
    from dataclasses import replace

    from femcal.calibrate.holdout import HoldOut
    from femcal.io.calibration import summary_lines

    _, _, outcome, _ = study
    ho = outcome.holdout
    assert ho.kind == "inputs" and [f.name for f in ho.folds] == [f"input {c}" for c in INS]
    for fold in ho.folds:
        assert fold.better and fold.deviation_calibrated < 1e-4 * fold.deviation_nominal
        np.testing.assert_allclose(fold.p, TRUE_P, atol=2e-3)
        parts = 2 if outcome.config.metric == "complex-log" else 1
        assert fold.rows.sum() == parts * len(OUTS) * len(outcome.cases[0].freq)
    assert any(line.startswith("Held-out prediction: calibrated without each input's FRFs")
               for line in summary_lines(outcome))  # fmt: skip
    worse = HoldOut("inputs", tuple(replace(f, deviation_calibrated=2 * f.deviation_nominal)
                                    for f in ho.folds))  # fmt: skip
    lines = summary_lines(replace(outcome, holdout=worse))
    assert any(line.startswith("Warning: calibrated without each input's FRFs in turn, the "
                               "model predicts the held-out data worse") for line in lines)


def test_hold_out_plans_by_sensors_and_their_errors(study):
    from femcal.calibrate.cases import TestSetup, prepare_case
    from femcal.calibrate.holdout import fold_plan

    d, params, outcome, _ = study
    cfg = read_config(d / "cal.toml")
    case0 = outcome.cases[0]
    setup = TestSetup("plate", case0.model, tuple(params), (10.0, 350.0), case0.data, None, 0.02)
    case = prepare_case(setup, np.arange(len(params)), cfg, lambda _m: None)
    kind, plan = fold_plan([case], "sensors", 4, cfg.metric)
    assert kind == "sensors" and len(plan) == 4
    held = np.sum([rows for _, _, rows in plan], axis=0)
    assert held.max() == 1 and held.sum() == held.size  # every residual held out once
    # the grids 28 and 14 have two channels each: their directions go together
    for _, _, rows in plan:
        outs = rows.reshape(len(case.outputs), -1).any(axis=1)
        grids = {case.outputs[o].grid for o in np.flatnonzero(outs)}
        assert all(outs[o] for o, ch in enumerate(case.outputs) if ch.grid in grids)
    with pytest.raises(ValueError, match="only 12 sensor positions"):
        fold_plan([case], "sensors", 13, cfg.metric)
    one = replace_inputs(case, 1)
    with pytest.raises(ValueError, match=r"needs two inputs or more; configuration plate has "
                                         r"one \(28:\+Z\)"):  # fmt: skip
        fold_plan([one], "inputs", 4, cfg.metric)
    assert fold_plan([one], "auto", 4, cfg.metric)[0] == "sensors"
    cfg_path = d / "cal.toml"
    bad = d / "bad_holdout.toml"
    bad.write_text(cfg_path.read_text().replace("identifiable_ratio = 0.1",
                                                'identifiable_ratio = 0.1\nholdout = "folds"'))
    with pytest.raises(ValueError, match=r"holdout = 'folds': expected one of 'auto'"):
        read_config(bad)
    bad.write_text(cfg_path.read_text().replace("identifiable_ratio = 0.1",
                                                'identifiable_ratio = 0.1\n'
                                                'holdout = "configurations"'))  # fmt: skip
    with pytest.raises(ValueError, match="needs two configurations or more"):
        read_config(bad)


def replace_inputs(case, n: int):
    """The case with only its first n inputs."""
    from dataclasses import replace

    return replace(case, inputs=case.inputs[:n], H_test=case.H_test[:, :n])


# ----------------------------------------------------------------------------------------
# Reliability (issue 23): the calibration's inputs are checked whole, one cycle calibrates,
# a resumed run never reuses starts of other files, and Ctrl-C leaves nothing half-done.

TINY = """
[model]
deck = "main.bdf"
parameters = "p.toml"

[test]
frf = "test.npz"

[calibration]
band = [10.0, 350.0]
zeta0 = 0.02
reduction_modes = 40
starts = 2
workers = 1
seed = 1
max_cycles = 1
noise_sigma = 0.01
identifiable_ratio = 0.1
holdout = "none"

[output]
pictures = false
"""

_PROPERTY_CARDS = ("MAT1", "PSHELL", "PBAR", "PROD", "PBUSH", "PELAS")


def _deck_with_includes() -> dict[str, str]:
    """The plate deck as three files: main.bdf INCLUDEs props.bdf, which INCLUDEs mats.bdf
    (the materials)."""
    lines = plate_deck().splitlines()
    props = [x for x in lines if x.startswith(_PROPERTY_CARDS[1:])]
    mats = [x for x in lines if x.startswith("MAT1")]
    rest = [x for x in lines if not x.startswith(_PROPERTY_CARDS)]
    k = rest.index("BEGIN BULK") + 1
    return {"main.bdf": "\n".join([*rest[:k], "INCLUDE 'props.bdf'", *rest[k:]]) + "\n",
            "props.bdf": "\n".join(["INCLUDE 'mats.bdf'", *props]) + "\n",
            "mats.bdf": "\n".join(mats) + "\n"}  # fmt: skip


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """A folder with the plate deck split by INCLUDEs, its nine parameters, a noise-free test
    of TRUE_P and a configuration of one start per worker and one cycle (about a second)."""
    d = tmp_path_factory.mktemp("tiny")
    model, params = write_plate(d)
    for name, text in _deck_with_includes().items():
        (d / name).write_text(text)
    truth = with_values(model, params, [p.value(x) for p, x in zip(params, TRUE_P, strict=True)])
    write_modal_test(d / "test.npz", truth, OUTS, INS)
    (d / "cal.toml").write_text(TINY)
    return d


def _tiny_copy(tiny, tmp_path, config: str = TINY):
    """The tiny study's files copied to tmp_path, with ``config`` as cal.toml; its path."""
    for f in tiny.iterdir():
        if f.is_file():
            (tmp_path / f.name).write_bytes(f.read_bytes())
    (tmp_path / "cal.toml").write_text(config)
    return tmp_path / "cal.toml"


def test_one_cycle_gives_a_calibrated_result(tiny, tmp_path):
    """max_cycles = 1: cycle 1's search on the nominal surrogate, then a cycle that checks its
    candidate on the full model (the nominal was reported as the calibration before)."""
    out = run(read_config(_tiny_copy(tiny, tmp_path)), tmp_path / "out")
    assert [c.cycle for c in out.cycles] == [1, 2] and out.cycles[1].accepted
    assert out.deviation_after < 1e-3 * out.deviation_before  # measured 1.8e-5
    np.testing.assert_allclose(out.p_final, TRUE_P, atol=0.01)
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert all(row["calibrated"] != row["nominal"] for row in rep["parameters"])


def test_settings_made_in_code_are_checked_before_any_work(tiny, tmp_path):
    from dataclasses import replace

    from femcal.calibrate.config import ConfigError
    from femcal.calibrate.workflow import calibrate
    from femcal.model.build import load_model

    cfg = read_config(_tiny_copy(tiny, tmp_path))
    model = load_model(tmp_path / "main.bdf")
    with pytest.raises(ConfigError, match=r"cal.toml: \[calibration\] max_cycles = 0: expected "
                                          r"a whole number of at least 1"):  # fmt: skip
        calibrate(model, [], replace(cfg, max_cycles=0))
    with pytest.raises(ConfigError, match=r"\[calibration\] hold_ratio = 1.5: expected a "
                                          r"fraction in \(0, 1\]"):  # fmt: skip
        calibrate(model, [], replace(cfg, hold_ratio=1.5))


def test_a_change_to_an_included_file_starts_afresh(tiny, tmp_path):
    """The resume fingerprint covers every file the run reads, the deck's INCLUDEs (here two
    levels deep) among them: a changed file runs the starts again, even a change that leaves
    the model as it was (a comment); an unchanged run resumes."""
    cfg = _tiny_copy(tiny, tmp_path)

    def finished_earlier() -> int:
        lines: list[str] = []
        run(read_config(cfg), tmp_path / "out", progress=lines.append)
        return sum("finished earlier" in line for line in lines)

    assert finished_earlier() == 0
    assert finished_earlier() == 2  # both starts of cycle 1 resumed
    with open(tmp_path / "mats.bdf", "a") as fh:
        fh.write("$ checked again\n")
    assert finished_earlier() == 0
    with open(tmp_path / "p.toml", "a") as fh:
        fh.write("# bounds reviewed\n")
    assert finished_earlier() == 0


def test_the_channels_compared_enter_the_fingerprint(tiny):
    """The same FRFs read as other sensors (or another quantity) are another test."""
    from femcal.calibrate.parameters import read_parameters
    from femcal.calibrate.workflow import fingerprint
    from femcal.model.build import load_model

    model = load_model(tiny / "main.bdf")
    params = read_parameters(tiny / "p.toml", model)
    cfg = read_config(tiny / "cal.toml")
    f, H = np.array([10.0, 20.0]), np.ones((1, 1, 2), complex)

    def key(*channels):
        return fingerprint([(model, params, f, H, 0.02)], cfg, 2, channels=[channels])

    a, b = Channel.parse("3:+Z"), Channel.parse("4:+Z")
    assert key((a,), (b,), "accelerance") == key((a,), (b,), "accelerance")
    assert key((a,), (b,), "accelerance") != key((b,), (b,), "accelerance")
    assert key((a,), (b,), "accelerance") != key((a,), (b,), "mobility")


ONE_PARAMETER = """
[[parameter]]
name = "t"
card = "PSHELL"
id = 1
field = "T"
"""


@pytest.mark.parametrize("bounds, error", [
    ("lower = 6.0\nupper = 4.0", r"parameter t: lower = 6.0 is above upper = 4.0: expected "
                                 r"lower < upper \(bounds are not swapped for you\)"),
    ("lower_rel = 0.2\nupper_rel = -0.2", r"parameter t: lower_rel = 0.2 \(6.0\) is above "
                                          r"upper_rel = -0.2 \(4.0\)"),
    ("lower = 5.0\nupper = 5.0", r"parameter t: lower = 5.0 equals upper = 5.0: nothing to "
                                 r"calibrate"),
    ("lower = 4.0\nlower_rel = -0.2\nupper = 6.0", r"parameter t: both lower and lower_rel are "
                                                   r"given; give one"),
    ("lower = 4.0\nupper = 6.0\nupper_rel = 0.2", r"parameter t: both upper and upper_rel are "
                                                   r"given"),
    ("upper = 6.0", r"parameter t: missing lower \(or lower_rel\)"),
    ("lower = 4.0\nuper = 6.0", r"parameter t: unknown key 'uper' \(expected one of "
                                r"card, confidence, .*\); did you mean 'upper'\?"),
    ("lower = 5.5\nupper = 6.0", r"parameter t: bounds \[5.5, 6.0\] must hold the nominal 5.0 "
                                 r"\(the deck's PSHELL 1 T\)"),
    ("lower_rel = -1.0\nupper_rel = 0.2", r"parameter t: lower_rel = -1.0 \(0.0\): expected a "
                                          r"positive lower bound"),
    ("nominal = 6.0\nlower = 4.0\nupper = 7.0", r"parameter t: nominal 6.0 but the deck has "
                                                 r"5.0"),
    ('lower = "4"\nupper = 6.0', r"parameter t: lower = '4': expected a number"),
    ("lower = nan\nupper = 6.0", r"parameter t: lower = nan: expected a number"),
    ("lower = 4.0\nupper = inf", r"parameter t: upper = inf: expected a number"),
    ("lower = 4.0\nupper = 6.0\nconfidence = true", r"parameter t: confidence = True: "
                                                    r"expected a number"),
    # found by the fuzzer (tests/fuzz/configs.py): a relative bound that overflows
    ("lower = 4.0\nupper_rel = 1e308", r"parameter t: upper_rel = 1e\+308: expected a "
                                       r"fraction of the nominal \(5.0\) that keeps the bound "
                                       r"finite"),
])  # fmt: skip
def test_parameter_file_errors_name_the_file_parameter_and_keys(tiny, tmp_path, bounds, error):
    from femcal.calibrate.config import ConfigError
    from femcal.calibrate.parameters import read_parameters
    from femcal.model.build import load_model

    (tmp_path / "p.toml").write_text(ONE_PARAMETER + bounds + "\n")
    with pytest.raises(ConfigError, match=r"p\.toml: " + error):
        read_parameters(tmp_path / "p.toml", load_model(tiny / "main.bdf"))


@pytest.mark.parametrize("text, error", [
    ("[[parameters]]\nname = \"t\"\n", r"the top level: unknown key 'parameters' \(expected one "
                                       r"of parameter\); did you mean 'parameter'\?"),
    ("parameter = [1, 2]\n", r"parameter #1 = 1: expected a \[\[parameter\]\] table"),
    (ONE_PARAMETER.replace('"t"', "5"), r"parameter #1: name = 5: expected a name"),
    (ONE_PARAMETER.replace("id = 1", "id = true") + "lower = 4.0\nupper = 6.0\n",
     r"parameter t: id = True: expected a whole number"),
    ("\xff\xfe garbage", r"not valid TOML"),
])  # fmt: skip
def test_malformed_parameter_files(tiny, tmp_path, text, error):
    from femcal.calibrate.config import ConfigError
    from femcal.calibrate.parameters import read_parameters
    from femcal.model.build import load_model

    (tmp_path / "p.toml").write_text(text)
    with pytest.raises(ConfigError, match=r"p\.toml: " + error):
        read_parameters(tmp_path / "p.toml", load_model(tiny / "main.bdf"))


def test_a_small_nominal_must_match_the_decks_too(tiny, tmp_path):
    """Found by the fuzzer (tests/fuzz/configs.py): a density's nominal of 1e-12 against the
    deck's 7.85e-9 passed as equal (an absolute tolerance of 1e-8)."""
    from femcal.calibrate.config import ConfigError
    from femcal.calibrate.parameters import read_parameters
    from femcal.model.build import load_model

    (tmp_path / "p.toml").write_text('[[parameter]]\nname = "rho"\ncard = "MAT1"\nid = 1\n'
                                     'field = "RHO"\nnominal = 1e-12\nlower_rel = -0.2\n'
                                     "upper_rel = 0.2\n")  # fmt: skip
    with pytest.raises(ConfigError, match=r"parameter rho: nominal 1e-12 but the deck has "
                                          r"7.85e-09"):  # fmt: skip
        read_parameters(tmp_path / "p.toml", load_model(tiny / "main.bdf"))


def test_bounds_may_mix_absolute_and_relative_sides(tiny, tmp_path):
    from femcal.calibrate.parameters import read_parameters
    from femcal.model.build import load_model

    (tmp_path / "p.toml").write_text(ONE_PARAMETER + "lower = 4.0\nupper_rel = 0.3\n")
    (par,) = read_parameters(tmp_path / "p.toml", load_model(tiny / "main.bdf"))
    assert (par.lower, par.upper) == (4.0, 6.5)
    assert par.p_lower == pytest.approx(-0.2) and par.p_upper == pytest.approx(0.3)


@pytest.mark.parametrize("table, key, near", [
    ("[model]", "dekc", "deck"),
    ("[test]", "fr", "frf"),
    ("[test.identify]", "bnad", "band"),
    ("[calibration]", "max_cylces", "max_cycles"),
    ("[output]", "picture", "pictures"),
])  # fmt: skip
def test_an_unknown_key_in_any_table_is_named_with_the_nearest(tiny, tmp_path, table, key,
                                                              near):  # fmt: skip
    text = TINY.replace("\n[calibration]", "\n[test.identify]\nband = [10.0, 500.0]\n\n"
                        "[calibration]") if table == "[test.identify]" else TINY  # fmt: skip
    cfg = _tiny_copy(tiny, tmp_path, text.replace(table + "\n", f"{table}\n{key} = 1\n", 1))
    with pytest.raises(ValueError, match=rf"cal\.toml: {re.escape(table)}: unknown key {key!r} "
                                         rf"\(expected one of .*\); did you mean {near!r}\?"):
        read_config(cfg)


def test_an_unknown_key_of_a_listed_configuration_is_named(tiny, tmp_path):
    text = ('[[configuration]]\ndeck = "main.bdf"\nparameters = "p.toml"\nfrf = "test.npz"\n'
            "zeta = 0.02\n\n[calibration]" + TINY.split("[calibration]")[1])
    with pytest.raises(ValueError, match=r"\[\[configuration\]\] 1: unknown key 'zeta' .*did "
                                         r"you mean 'zeta0'\?"):  # fmt: skip
        read_config(_tiny_copy(tiny, tmp_path, text))


@pytest.mark.parametrize("line, error", [
    ("max_cycles = 0", r"max_cycles = 0: expected a whole number of at least 1"),
    ("starts = 0", r"starts = 0: expected a whole number from 1 to 10000"),
    ("starts = 20000", r"starts = 20000: expected a whole number from 1 to 10000 \(each start "
                       r"is a Levenberg-Marquardt run\)"),
    ("workers = -2", r"workers = -2: expected a whole number from 1 to 256"),
    ("zeta0 = 1e-9", r"zeta0 = 1e-09 with band 10-350 Hz and samples_per_bandwidth = 3.0 "
                     r"needs more than 100000 frequencies"),
    ("starts = true", r"starts = True: expected a whole number"),
    ("starts = 2.5", r"starts = 2.5: expected a whole number"),
    ("seed = -1", r"seed = -1: expected a whole number, 0 or more"),
    ("max_iterations = 0", r"max_iterations = 0: expected a whole number of at least 1"),
    ("huber_c = 0", r"huber_c = 0.0: expected a positive number"),
    ("noise_sigma = -0.1", r"noise_sigma = -0.1: expected 0 \(estimate it\)"),
    ("noise_sigma = nan", r"noise_sigma = nan: expected a number"),
    ("hold_ratio = 1.5", r"hold_ratio = 1.5: expected a fraction in \(0, 1\]"),
    ("identifiable_ratio = 0", r"identifiable_ratio = 0.0: expected a fraction in \(0, 1\]"),
    ("hold_ratio = 0.05", r"identifiable_ratio = 0.1: expected at most hold_ratio \(0.05\)"),
    ("samples_per_bandwidth = 0", r"samples_per_bandwidth = 0.0: expected a number in \(0, 100\]"),
    ("settle = 0", r"settle = 0.0: expected a positive change of p below 1"),
    ("modal_hz = inf", r"modal_hz = inf: expected a number"),
    ("crlb_bands = 5", r"crlb_bands = 5: expected a list of bands"),
    ("crlb_bands = [[40.0, 10.0]]", r"crlb_bands: expected 0 < f_lo < f_hi"),
    ('metric = 5', r"metric = 5: expected \"log-magnitude\" or \"complex-log\""),
])  # fmt: skip
def test_every_calibration_number_is_checked_for_its_range(tiny, tmp_path, line, error):
    key = line.split(" = ")[0]
    text = re.sub(rf"^{key} = .*\n", "", TINY, flags=re.MULTILINE)  # the tiny study's own
    cfg = _tiny_copy(tiny, tmp_path, text.replace("[calibration]\n", f"[calibration]\n{line}\n"))
    with pytest.raises(ValueError, match=r"cal\.toml: (\[calibration\]|configuration main:) "
                                         + error):  # fmt: skip
        read_config(cfg)


@pytest.mark.parametrize("old, new, error", [
    ("band = [10.0, 350.0]", "band = [350.0, 10.0]", r"\[calibration\] band: expected 0 < f_lo"),
    ("band = [10.0, 350.0]", "band = [-1.0, 350.0]", r"\[calibration\] band: expected 0 < f_lo"),
    ("band = [10.0, 350.0]", 'band = "12"', r"\[calibration\] band: expected \[f_lo, f_hi\]"),
    ("zeta0 = 0.02", "zeta0 = 1.5", r"zeta0 = 1.5: expected 0 < zeta0 < 1"),
    ("zeta0 = 0.02", 'zeta0 = "0.02"', r"zeta0 = '0.02': expected \"median\" or a damping"),
    ('deck = "main.bdf"', "deck = 3", r"\[model\] deck = 3: expected a file name"),
    ('deck = "main.bdf"', 'deck = "main.bdf"\nunits = 5', r"\[model\] units = 5: expected a "
                                                           r"string"),
    ("[calibration]", "[test.identify]\nband = [10.0, 500.0]\nsplits = [600.0]\n\n"
     "[calibration]", r"splits = \[600.0\]: expected increasing frequencies inside the band"),
    ("[calibration]", "[test.identify]\nband = [10.0, 500.0]\nsplits = [100.0]\n"
     "orders = [10]\n\n[calibration]", r"orders = \[10\]: expected one order per part, 2"),
    ("[calibration]", "[test.identify]\nband = [10.0, 500.0]\ngamma = 1.0\n\n[calibration]",
     r"gamma = 1.0: expected a number above 1"),
    ("[calibration]", "[test.identify]\nband = [10.0, 500.0]\nbeta = 1.2\n\n[calibration]",
     r"beta = 1.2: expected a number above gamma"),
    ("[calibration]", "[test.identify]\nsplits = [100.0]\n\n[calibration]",
     r"\[test.identify\] needs band"),
])  # fmt: skip
def test_bands_damping_files_and_identification_are_checked(tiny, tmp_path, old, new, error):
    cfg = _tiny_copy(tiny, tmp_path, TINY.replace(old, new, 1))
    with pytest.raises(ValueError, match=r"cal\.toml: .*" + error):
        read_config(cfg)


def test_a_missing_or_folder_file_is_named_with_its_key(tiny, tmp_path):
    cfg = _tiny_copy(tiny, tmp_path, TINY.replace('frf = "test.npz"', 'frf = "gone.npz"'))
    with pytest.raises(FileNotFoundError, match=r"cal\.toml: \[test\] frf: no such file"):
        read_config(cfg)
    (tmp_path / "folder").mkdir()
    cfg.write_text(TINY.replace('frf = "test.npz"', 'frf = "folder"'))
    with pytest.raises(IsADirectoryError, match=r"cal\.toml: \[test\] frf: a folder"):
        read_config(cfg)


def test_the_command_line_prints_one_line_for_inverted_bounds(tiny, tmp_path, capsys):
    cfg = _tiny_copy(tiny, tmp_path)
    (tmp_path / "p.toml").write_text(ONE_PARAMETER + "lower = 6.0\nupper = 4.0\n")
    assert main(["calibrate", str(cfg), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("femcal calibrate: ")
    assert "p.toml: parameter t: lower = 6.0 is above upper = 4.0" in err
    assert not (tmp_path / "out" / "starts").exists()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("engine", ["local", "dask"])
def test_ctrl_c_ends_the_workers_and_leaves_no_partial_file(tiny, tmp_path, engine):
    """SIGINT to the command's process group (Ctrl-C in a terminal) while the starts run in
    two worker processes (local, or a Dask LocalCluster's): the command ends at once, without
    tracebacks from the workers and without leaving them behind; every file in --out is
    whole, and the next run resumes from the starts that finished."""
    if engine == "dask":
        pytest.importorskip("distributed")
    cfg = _tiny_copy(tiny, tmp_path, TINY.replace("starts = 2", "starts = 40")
                     .replace("workers = 1", f'workers = 2\nengine = "{engine}"'))  # fmt: skip
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "femcal", "calibrate", str(cfg), "--out",
                             str(out), "--verbose"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)  # fmt: skip
    try:
        seen = []
        for line in proc.stderr:  # the starts run in the workers once they report (--verbose:
            seen.append(line)     # a local worker's iterations, a Dask worker's finished start)
            if " iteration " in line or " done: deviation " in line:
                break
        workers = children(proc.pid)
        os.killpg(proc.pid, signal.SIGINT)
        err = "".join(seen) + proc.stderr.read()
        assert proc.wait(timeout=20) != 0
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert workers  # the pool was running
    assert "Process ForkProcess" not in err and "Process SpawnProcess" not in err
    assert err.count("Traceback") <= 1  # the workers print none (the parent's is the CLI's)
    deadline = time.monotonic() + 5
    while any(alive(p) for p in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [p for p in workers if alive(p)]
    files = [f for f in out.rglob("*") if f.is_file()]
    assert not [f for f in files if f.name.startswith(".")]  # no temporary file left
    saved = [f for f in files if f.name.startswith("start_")]
    for f in files:
        if f.suffix == ".json":
            json.loads(f.read_text())  # whole
    if engine == "dask":  # the resume reads the same files whichever engine wrote them
        return
    lines: list[str] = []
    run(read_config(cfg), out, progress=lines.append)
    assert sum("finished earlier" in line for line in lines) >= len(saved)


def test_a_damping_that_asks_for_too_many_frequencies_is_refused(study):
    # zeta0 = "median" takes the identified damping, which the configuration check cannot
    # see: 1e-9 would ask for 1e10 metric frequencies
    from femcal.calibrate.cases import TestSetup, prepare_case
    from femcal.errors import ConfigError

    d, params, outcome, _ = study
    cfg = read_config(d / "cal.toml")
    case0 = outcome.cases[0]
    setup = TestSetup("plate", case0.model, tuple(params), (10.0, 350.0), case0.data, None, 1e-9)
    with pytest.raises(ConfigError, match=r"zeta0 = 1e-09 and 3 samples per bandwidth over "
                       r"10-350 Hz ask for 5.\d+e\+09 frequencies, more than 100000"):  # fmt: skip
        prepare_case(setup, np.arange(len(params)), cfg, lambda _m: None)


def test_integers_beyond_64_bits_in_the_tomls_are_config_errors(tmp_path):
    # TOML integers have no bound: math.isfinite and np.isfinite raised on them
    from femcal.calibrate.config import read_config
    from femcal.errors import ConfigError

    for name in ("d.bdf", "p.toml", "t.npz"):
        (tmp_path / name).write_text("")
    cfg = tmp_path / "cal.toml"
    cfg.write_text('[model]\ndeck = "d.bdf"\nparameters = "p.toml"\n[test]\nfrf = "t.npz"\n'
                   "[calibration]\nband = [10.0, 100.0]\nzeta0 = 0.02\n"
                   f"seed = {10**400}\n")  # fmt: skip
    with pytest.raises(ConfigError, match="seed = 1000"):
        read_config(cfg)


def test_a_roving_hammer_test_is_compared_in_its_reciprocal_layout(tmp_path):
    """A test handed over as 2 outputs x 14 hammer points (the plate's set transposed): the
    identified model's shapes are at the 14 points, and the case compares the FRFs with
    those points as outputs, so it is the case of the set as 14 x 2, to round-off."""
    import warnings

    from femcal.calibrate.cases import TestSetup, prepare_case
    from femcal.identify import identify
    from femcal.testdata.data import FRFData
    from femcal.testdata.formats import read_frf

    model, params = write_plate(tmp_path)
    write_modal_test(tmp_path / "test.npz", model, OUTS, INS)
    (tmp_path / "cal.toml").write_text(CONFIG)
    cfg = read_config(tmp_path / "cal.toml")
    data = read_frf(tmp_path / "test.npz")
    flipped = FRFData(data.frequency_hz, np.swapaxes(data.H, 0, 1), data.inputs, data.outputs,
                      data.quantity, data.units)  # fmt: skip
    cases, said = [], []
    for d in (data, flipped):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ident = identify(d, (8.0, 420.0))
        setup = TestSetup("plate", model, tuple(params), (10.0, 350.0), d, ident, 0.02)
        cases.append(prepare_case(setup, np.arange(len(params)), cfg, said.append))
    a, b = cases
    assert [c.label for c in b.outputs] == [c.label for c in a.outputs] == OUTS
    assert [c.label for c in b.inputs] == INS
    np.testing.assert_allclose(b.test_hz, a.test_hz, rtol=1e-9)
    np.testing.assert_allclose(b.H_test, a.H_test, rtol=1e-6, atol=1e-9 * np.abs(a.H_test).max())
    assert any("a roving-hammer test: compared in its reciprocal layout" in s for s in said)
