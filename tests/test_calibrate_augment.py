"""Model-form augmentation: after a model-form warning, the element the search names is added
to the deck as a parameter and the calibration runs again. On the plate whose test has a
point mass the model lacks, the run with the element finds the mass's place and size and
every hidden parameter, and the held-out data prefer it; the pieces (which candidate, new ids,
the cards, the deck with them, the verdict) are checked alone."""

from __future__ import annotations

import json

import numpy as np
import pytest

from femcal.calibrate.augment import added_element, choose, element_ids, verdict
from femcal.calibrate.config import read_config
from femcal.calibrate.modelform import Candidate
from femcal.calibrate.parameters import current_value, read_parameters, with_values
from femcal.cli import main
from femcal.deck import read_deck
from femcal.io.calibration import (
    calibrated_deck_name,
    element_cards,
    field_value,
    unread_card_ids,
    write_augmented_deck,
)
from femcal.jobs.calibration import run
from femcal.model.build import load_model

from .calib_decks import (
    INS,
    LOADED_PARAMS,
    OUTS,
    TRUE_P,
    plate_deck,
    write_modal_test,
    write_plate,
)

#: The mass the test's plate has and the model lacks (tonne; the plate is about 7 kg) and
#: its grid.
HIDDEN_MASS, HIDDEN_GRID = 0.0005, 10

CONFIG = """
[model]
deck = "plate.bdf"
parameters = "p.toml"

[test]
frf = "test.npz"
truth = "truth.toml"

[calibration]
band = [10.0, 350.0]
zeta0 = 0.02
reduction_modes = 40
starts = 4
workers = 1
seed = 1
max_cycles = 4
noise_sigma = 0.01
identifiable_ratio = 0.1
holdout = "inputs"

[output]
pictures = false
"""


def _mass(kind: str = "point mass", grid: int = 10, component: int = 0,
          value: float = 1e-4, fall: float = 0.2) -> Candidate:  # fmt: skip
    return Candidate(kind, grid, component, np.zeros(3), fall, value)


def _write_truth(path, params, p) -> None:
    """A synthetic test's truth file: each parameter's value at the scaled ``p``."""
    path.write_text("".join(f'[[parameter]]\nname = "{q.name}"\ntrue = {float(q.value(x))!r}\n\n'
                            for q, x in zip(params, p, strict=True)))  # fmt: skip


@pytest.fixture(scope="module")
def lacking(tmp_path_factory):
    """The plate calibrated against a noise-free test of the plate at TRUE_P with a point
    mass the model lacks: (folder, result, progress lines)."""
    d = tmp_path_factory.mktemp("lacking")
    _, params = write_plate(d)
    (d / "true.bdf").write_text(plate_deck().replace(
        "ENDDATA", f"CONM2,601,{HIDDEN_GRID},,{HIDDEN_MASS}\nENDDATA"))  # fmt: skip
    true_model = load_model(d / "true.bdf")
    write_modal_test(d / "test.npz",
                     with_values(true_model, params,
                                 [p.value(x) for p, x in zip(params, TRUE_P, strict=True)]),
                     OUTS, INS)  # fmt: skip
    _write_truth(d / "truth.toml", params, TRUE_P)
    (d / "cal.toml").write_text(CONFIG)
    lines: list[str] = []
    result = run(read_config(d / "cal.toml"), d / "out", progress=lambda m: lines.append(str(m)))
    return d, result, lines


def test_the_missing_mass_is_added_found_and_preferred(lacking):
    _, result, _ = lacking
    form = result.cases[0].model_form
    assert form.warning  # the parameters cannot stand for the mass
    a = result.augmented
    assert a is not None and a.better
    assert "held-out" in a.reason  # judged on data neither calibration saw
    assert a.added.candidate.grid == HIDDEN_GRID and a.added.candidate.kind == "point mass"
    r = a.result
    by = {q.parameter.name: q for q in r.parameters}
    par = a.added.parameter
    assert by[par.name].calibrated == pytest.approx(HIDDEN_MASS, rel=0.01)  # measured 1e-5
    np.testing.assert_allclose(r.p_final[:-1], TRUE_P, atol=0.005)  # measured 1e-4
    assert np.abs(result.p_final - TRUE_P).max() > 0.05  # without it they are biased
    assert r.deviation_after < 1e-3 * result.deviation_after
    assert not r.cases[0].model_form.warning
    assert r.holdout.deviation_calibrated < 1e-3 * result.holdout.deviation_calibrated


def test_the_added_element_has_no_truth_and_the_reports_say_so(lacking, tmp_path):
    """A synthetic test's truth covers the deck's parameters, not the element femcal adds:
    the errors are set against the truth for the others, and the report, its pictures and
    its page are written all the same."""
    from femcal.io.calibration import write_report

    _, result, _ = lacking
    r = result.augmented.result
    *known, added = r.parameters
    assert added.true is None and added.error_pct is None
    assert [q.true for q in known] == pytest.approx([q.parameter.value(x) for q, x in
                                                     zip(known, TRUE_P, strict=True)])
    page = write_report(r, tmp_path, pdf=False).read_text()
    assert "true" in page and (tmp_path / "pictures" / "parameters.png").stat().st_size > 1000


def test_its_files_and_report(lacking):
    d, result, _ = lacking
    out = d / "out" / "augmented"
    par = result.augmented.added.parameter
    deck = (out / "plate.bdf").read_text()
    card = f"CONM2,{par.id},{HIDDEN_GRID},,"
    assert card in deck and deck.index(card) < deck.index("ENDDATA")
    model = load_model(out / "plate.bdf")
    assert current_value(model, "CONM2", par.id, "M") == par.nominal
    calibrated = load_model(out / "plate_calibrated.bdf")
    assert current_value(calibrated, "CONM2", par.id, "M") == pytest.approx(HIDDEN_MASS,
                                                                             rel=0.01)
    rep = json.loads((d / "out" / "report.json").read_text())
    aug = rep["augmented"]
    assert aug["better"] and aug["grid"] == HIDDEN_GRID and aug["deck"] == "augmented/plate.bdf"
    assert aug["parameter"]["calibrated"] == pytest.approx(HIDDEN_MASS, rel=0.01)
    assert any(line.startswith("Model form tested") for line in rep["summary"])
    assert any("prefer the model with the added element" in line for line in rep["summary"])
    own = json.loads((out / "report.json").read_text())
    assert [p["name"] for p in own["parameters"]][-1] == par.name
    assert own["augmented"] is None  # one element per run


def test_a_second_run_resumes_both_calibrations(lacking, tmp_path):
    d, result, _ = lacking
    lines: list[str] = []
    again = run(read_config(d / "cal.toml"), d / "out", progress=lambda m: lines.append(str(m)))
    assert not any(" done: deviation" in m for m in lines)  # every start finished earlier
    np.testing.assert_array_equal(again.augmented.result.p_final,
                                  result.augmented.result.p_final)  # fmt: skip


def test_augment_fall_zero_never_adds(lacking, tmp_path):
    d, _, _ = lacking
    for f in ("plate.bdf", "p.toml", "test.npz", "truth.toml"):
        (tmp_path / f).write_bytes((d / f).read_bytes())
    (tmp_path / "cal.toml").write_text(CONFIG.replace('holdout = "inputs"', 'holdout = "none"\n'
                                                      "augment_fall = 0.0"))  # fmt: skip
    stale = tmp_path / "out" / "augmented"  # an earlier run's, which this one does not make
    stale.mkdir(parents=True)
    (stale / "report.json").write_text("{}")
    result = run(read_config(tmp_path / "cal.toml"), tmp_path / "out")
    assert result.cases[0].model_form.warning and result.augmented is None
    assert not (tmp_path / "out" / "augmented").exists()


def test_choose_takes_the_largest_warned_fall_above_the_threshold():
    a, b, c = _mass(fall=0.3), _mass(fall=0.5), _mass(fall=0.9)
    assert choose([("x", a, True), ("y", b, True), ("z", c, False)], 0.1) == ("y", b)
    assert choose([("x", a, True)], 0.35) is None
    assert choose([("x", a, True)], 0.0) is None  # 0: never
    assert choose([], 0.1) is None


def test_added_elements_take_free_ids_and_unused_names(tmp_path):
    model, params = write_plate(tmp_path)
    taken = {p.name for p in params} | {"added_mass_10"}
    m = added_element(model, "plate", _mass(value=2e-4), taken)
    assert m.element_id == max(element_ids(model)) + 1 and m.property_id is None
    assert (m.parameter.card, m.parameter.id, m.parameter.field) == ("CONM2", m.element_id, "M")
    assert m.parameter.name == "added_mass_10_2"
    assert (m.parameter.lower, m.parameter.nominal, m.parameter.upper) == pytest.approx(
        (2e-5, 2e-4, 2e-3))  # fmt: skip
    s = added_element(model, "plate", _mass("spring to ground", 19, 3, 30.0))
    assert s.parameter.name == "added_spring_19_3" and s.parameter.card == "PELAS"
    assert s.parameter.id == s.property_id and s.property_id > 5  # the plate's PELAS is 5
    with pytest.raises(ValueError, match="no positive size"):
        added_element(model, "plate", _mass(value=0.0))


@pytest.mark.parametrize("candidate, card", [
    (_mass(value=field_value(1.234567891e-4)), "CONM2"),
    (_mass("spring to ground", 19, 3, field_value(31.23456789)), "PELAS"),
])  # fmt: skip
def test_the_deck_with_the_element_reads_back_with_it_and_nothing_else_changed(
        tmp_path, candidate, card):  # fmt: skip
    """Written into another folder, through the deck's INCLUDE, and at the end of a deck
    without ENDDATA: the model read back is the deck's with the element added."""
    (tmp_path / "in").mkdir()
    text = plate_deck().replace("MAT1,1,", "INCLUDE 'mat.bdf'\nMAT1,1,", 1)
    mat = next(x for x in text.splitlines() if x.startswith("MAT1,1,"))
    text = text.replace(mat + "\n", "")
    (tmp_path / "in" / "mat.bdf").write_text(mat + "\n")
    for name, deck in (("with_end.bdf", text), ("no_end.bdf", text.replace("ENDDATA\n", ""))):
        (tmp_path / "in" / name).write_text(deck)
        base = load_model(tmp_path / "in" / name)
        added = added_element(base, "plate", candidate)
        out = write_augmented_deck(tmp_path / "in" / name, element_cards(added),
                                   tmp_path / "out" / name, why="a test")  # fmt: skip
        model = load_model(out)
        par = added.parameter
        assert current_value(model, card, par.id, par.field) == par.nominal
        assert model.n_dof == base.n_dof
        for t, block in base.elements.items():
            np.testing.assert_array_equal(model.elements[t].ids[:len(block)], block.ids)
        assert len(model.elements[added.parameter.card if card == "CONM2" else "CELAS1"]) == (
            len(base.elements["CONM2" if card == "CONM2" else "CELAS1"]) + 1)  # fmt: skip
        assert current_value(model, "MAT1", 1, "E") == current_value(base, "MAT1", 1, "E")


def test_the_verdict_is_the_held_out_data_s_and_open_without_them():
    assert verdict(10.0, 9.0) == (True, "held-out deviation 9 with it against 10 without")
    assert not verdict(10.0, 11.0)[0]
    better, why = verdict(None, None)  # a fit with one more parameter is always closer
    assert better is None and "not judged" in why
    assert verdict(10.0, None)[0] is None


def test_an_added_size_is_what_its_small_field_holds(tmp_path):
    """NASTRAN refuses a small free field of more than 8 characters: the size is rounded to
    what 8 hold before it becomes the parameter's nominal, so the deck and the parameter
    agree."""
    model, _ = write_plate(tmp_path)
    v = field_value(1.234567891e-4)
    assert v == 1.2346e-4
    for c in (_mass(value=v), _mass("spring to ground", 19, 3, field_value(123456.789e3))):
        cards = element_cards(added_element(model, "plate", c))
        assert all(len(f) <= 8 for line in cards for f in line.split(","))


def test_the_command_line_prints_both_calibrations(lacking, capsys):
    d, result, _ = lacking
    assert main(["calibrate", str(d / "cal.toml"), "--out", str(d / "out")]) == 0
    out = capsys.readouterr().out
    par = result.augmented.added.parameter
    assert f"with {result.augmented.added.describe()} added" in out
    assert out.count("\nt ") == 2  # the parameter table without and with the element
    assert par.name in out and "The data prefer the model with the added element" in out


def test_with_two_configurations_the_element_joins_the_one_that_lacks_it(lacking, tmp_path):
    """The plate carrying the mass its model lacks (first), and the plate with a load of its
    own (second; t and rho_steel shared): the element joins the first alone, the load's mass
    stays the second's, each parameter keeps its own truth (the element's parameter comes
    between theirs), and all come back to their hidden values. Without held-out data the
    verdict is left open."""
    d, _, _ = lacking
    _, params = write_plate(tmp_path)
    for f in ("test.npz", "truth.toml"):
        (tmp_path / f).write_bytes((d / f).read_bytes())
    (tmp_path / "loaded.bdf").write_text(plate_deck().replace(
        "ENDDATA", "CONM2,301,17,,0.004\nENDDATA"))  # fmt: skip
    (tmp_path / "loaded.toml").write_text(LOADED_PARAMS)
    loaded = load_model(tmp_path / "loaded.bdf")
    lparams = read_parameters(tmp_path / "loaded.toml", loaded)
    loaded_p = [TRUE_P[0], TRUE_P[2], -0.2]  # t, rho_steel, m_load
    write_modal_test(tmp_path / "loaded.npz", with_values(loaded, lparams, [
        q.value(x) for q, x in zip(lparams, loaded_p, strict=True)]), OUTS[:8], ["17:+Z"])
    _write_truth(tmp_path / "loaded.truth.toml", lparams, loaded_p)
    calibration = CONFIG[CONFIG.index("[calibration]"):].replace('holdout = "inputs"',
                                                                 'holdout = "none"')  # fmt: skip
    (tmp_path / "two.toml").write_text(
        '[[configuration]]\nname = "lacking"\ndeck = "plate.bdf"\nparameters = "p.toml"\n'
        'frf = "test.npz"\ntruth = "truth.toml"\n\n'
        '[[configuration]]\nname = "loaded"\ndeck = "loaded.bdf"\n'
        'parameters = "loaded.toml"\nfrf = "loaded.npz"\ntruth = "loaded.truth.toml"\n\n'
        + calibration)  # fmt: skip
    cfg = read_config(tmp_path / "two.toml")
    result = run(cfg, tmp_path / "out")
    a = result.augmented
    assert a is not None and a.added.configuration == "lacking"
    assert a.better is None and "no held-out" in a.reason
    r = a.result
    names = [q.parameter.name for q in r.parameters]
    added = a.added.parameter.name
    assert names == [p.name for p in params] + [added, "m_load"]
    assert [names[i] for i in r.cases[1].index] == ["t", "rho_steel", "m_load"]
    assert names[r.cases[0].index[-1]] == added
    by = {q.parameter.name: q for q in r.parameters}
    assert by[added].true is None
    assert by["m_load"].true == pytest.approx(0.004 * 0.8)
    assert by[added].calibrated == pytest.approx(HIDDEN_MASS, rel=0.01)
    assert by["m_load"].p == pytest.approx(-0.2, abs=0.005)
    np.testing.assert_allclose([by[p.name].p for p in params], TRUE_P, atol=0.005)
    lacking_deck, loaded_deck = (calibrated_deck_name(c, cfg) for c in cfg.configurations)
    calibrated = load_model(tmp_path / "out" / "augmented" / lacking_deck)
    assert current_value(calibrated, "CONM2", a.added.parameter.id, "M") == pytest.approx(
        HIDDEN_MASS, rel=0.01)  # fmt: skip
    other = load_model(tmp_path / "out" / "augmented" / loaded_deck)
    assert a.added.element_id not in other.elements["CONM2"].ids
    assert any("not judged" in line for line in json.loads(
        (tmp_path / "out" / "report.json").read_text())["summary"])  # fmt: skip


def test_new_ids_pass_the_cards_femcal_reads_but_does_not_model(tmp_path):
    """A damper, its property and a plot element are not in the model, but NASTRAN would
    refuse an added element or property that repeated their ids."""
    (tmp_path / "d.bdf").write_text(plate_deck().replace(
        "ENDDATA", "CDAMP1,900,60,3,3\nPDAMP,60,1.\nPLOTEL,950,1,2\nENDDATA"))  # fmt: skip
    model = load_model(tmp_path / "d.bdf")
    elements, properties = unread_card_ids(read_deck(tmp_path / "d.bdf"))
    assert set(elements) == {900, 950} and properties == [60]
    s = added_element(model, "plate", _mass("spring to ground", 19, 3, 30.0),
                      other_element_ids=elements, other_property_ids=properties)  # fmt: skip
    assert s.element_id == 951 and s.property_id == 61


def test_an_element_that_cannot_be_added_leaves_the_first_calibration_reported(lacking,
                                                                               tmp_path):  # fmt: skip
    """A deck whose bulk data ends in an INCLUDE file: the added cards would come after its
    ENDDATA, so the model read back lacks them. The run says so and reports the first
    calibration."""
    d, _, _ = lacking
    for f in ("p.toml", "test.npz", "truth.toml"):
        (tmp_path / f).write_bytes((d / f).read_bytes())
    lines = plate_deck().splitlines()
    k = lines.index("BEGIN BULK") + 1
    (tmp_path / "plate.bdf").write_text("\n".join([*lines[:k], "INCLUDE 'bulk.bdf'"]) + "\n")
    (tmp_path / "bulk.bdf").write_text("\n".join(lines[k:]) + "\n")
    (tmp_path / "cal.toml").write_text(CONFIG.replace('holdout = "inputs"', 'holdout = "none"'))
    said: list[str] = []
    result = run(read_config(tmp_path / "cal.toml"), tmp_path / "out",
                 progress=lambda m: said.append(str(m)))  # fmt: skip
    assert result.augmented is None and "was not read back" in result.augment_error
    assert any(m.startswith("model form: the element was not added") for m in said)
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["augmented"] is None and "was not read back" in rep["augment_error"]
    assert any("could not be added" in line for line in rep["summary"])
