"""The calibration workflow end to end on a small deck: a noise-free test made from a
perturbed model is calibrated back to its parameters; report, calibrated deck, resume, CLI,
configuration errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from femcal.calibrate.config import read_config
from femcal.calibrate.parameters import current_value, with_values
from femcal.cli import main
from femcal.deck import read_deck
from femcal.jobs.calibration import run
from femcal.model import EigenRequest
from femcal.model.build import build_model
from femcal.response.frf import channel_matrix, modal_frf
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel, FRFData
from femcal.testdata.formats.npz import write_npz

from .calib_decks import PARAMS_TOML, plate_deck, write_plate

TRUE_P = np.array([0.08, -0.05, 0.06, 0.1, -0.1, 0.12, 0.2, -0.15, 0.1])
OUTS = [*(f"{g}:+Z" for g in (3, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28)), "28:+X", "14:+Y"]
INS = ["28:+Z", "11:+Y"]
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
    modes, _ = solve_normal_modes(true_model, request=EigenRequest(nd=40))
    outs = [Channel.parse(s) for s in OUTS]
    ins = [Channel.parse(s) for s in INS]
    f = np.arange(2.0, 750.0, 0.25)
    H = modal_frf(modes.shapes, modes.radians, channel_matrix(true_model, outs),
                  channel_matrix(true_model, ins).T, f, 0.02, "accelerance")  # fmt: skip
    write_npz(d / "test.npz", FRFData(f, H, tuple(outs), tuple(ins), "accelerance", "mm/s^2/N"))
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
    # the calibrated deck carries the calibrated values
    back = build_model(read_deck(d / "out" / conf["calibrated_deck"]))
    for par, row in zip(params, rep["parameters"], strict=True):
        assert current_value(back, par.card, par.id, par.field) == pytest.approx(
            row["calibrated"], rel=1e-12)


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
    assert "Parameters" in text and "posterior" in text and "Summary" in text
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
    """A start is resumed only by a run whose model, parameters, settings and test are the
    same: the fingerprint changes with any of them, not with file names or worker counts."""
    from dataclasses import replace

    from femcal.calibrate.workflow import fingerprint

    d, params, outcome, _ = study
    cfg = read_config(d / "cal.toml")
    case = outcome.cases[0]
    model, f, H = case.model, case.freq, case.H_test

    def key_of(model=model, params=params, cfg=cfg, n=10, H=H, zeta0=0.02):
        return fingerprint([(model, params, f, H, zeta0)], cfg, n)

    key = key_of()
    moved = replace(model, files=["/elsewhere/plate.bdf"])
    conf = replace(cfg.configurations[0], deck=tmp_path / "x.bdf")
    assert key_of(moved, cfg=replace(cfg, workers=1, configurations=(conf,))) == key
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

LOADED_PARAMS = "".join(
    "\n[[parameter]]" + block for block in PARAMS_TOML.split("[[parameter]]")
    if 'name = "t"' in block or 'name = "rho_steel"' in block) + """
[[parameter]]
name = "m_load"
card = "CONM2"
id = 301
field = "M"
lower_rel = -0.5
upper_rel = 0.5
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
    modes, _ = solve_normal_modes(truth, request=EigenRequest(nd=40))
    outs = [Channel.parse(s) for s in OUTS[:8]]
    ins = [Channel.parse("17:+Z")]
    f = np.arange(2.0, 750.0, 0.25)
    H = modal_frf(modes.shapes, modes.radians, channel_matrix(truth, outs),
                  channel_matrix(truth, ins).T, f, 0.02, "accelerance")  # fmt: skip
    write_npz(tmp_path / "loaded.npz", FRFData(f, H, tuple(outs), tuple(ins), "accelerance",
                                               "mm/s^2/N"))  # fmt: skip
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
