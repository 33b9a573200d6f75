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
from femcal.calibrate.parameters import current_value, with_values
from femcal.cli import main
from femcal.io.calibration import element_cards, field_value, write_augmented_deck
from femcal.jobs.calibration import run
from femcal.model.build import load_model

from .calib_decks import INS, OUTS, TRUE_P, plate_deck, write_modal_test, write_plate

#: The mass the test's plate has and the model lacks (tonne; the plate is about 7 kg) and
#: its grid.
HIDDEN_MASS, HIDDEN_GRID = 0.0005, 10

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
    for f in ("plate.bdf", "p.toml", "test.npz"):
        (tmp_path / f).write_bytes((d / f).read_bytes())
    (tmp_path / "cal.toml").write_text(CONFIG.replace('holdout = "inputs"', 'holdout = "none"\n'
                                                      "augment_fall = 0.0"))  # fmt: skip
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


def test_the_verdict_is_the_held_out_data_s_when_there_are_some():
    assert verdict(10.0, 9.0, 5.0, 1.0, 0.1)[0]
    assert not verdict(10.0, 11.0, 5.0, 1.0, 0.1)[0]  # a better fit is not enough
    assert verdict(None, None, 5.0, 4.0, 0.1)[0]  # without: the fall against the threshold
    better, why = verdict(None, None, 5.0, 4.8, 0.1)
    assert not better and "no held-out" in why


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
    """The plate tested bare, and tested again carrying the mass the model lacks: the element
    is added to the second configuration's deck alone, its parameter is that
    configuration's own, and the shared parameters come back to their hidden values."""
    d, _, _ = lacking
    _, params = write_plate(tmp_path)
    (tmp_path / "lacking.npz").write_bytes((d / "test.npz").read_bytes())
    bare = with_values(load_model(tmp_path / "plate.bdf"), params,
                       [p.value(x) for p, x in zip(params, TRUE_P, strict=True)])  # fmt: skip
    write_modal_test(tmp_path / "bare.npz", bare, OUTS, INS)
    calibration = CONFIG[CONFIG.index("[calibration]"):].replace('holdout = "inputs"',
                                                                 'holdout = "none"')  # fmt: skip
    (tmp_path / "two.toml").write_text("".join(
        f'[[configuration]]\nname = "{n}"\ndeck = "plate.bdf"\nparameters = "p.toml"\n'
        f'frf = "{n}.npz"\n\n' for n in ("bare", "lacking")) + calibration)  # fmt: skip
    result = run(read_config(tmp_path / "two.toml"), tmp_path / "out")
    a = result.augmented
    assert a is not None and a.better and a.added.configuration == "lacking"
    r = a.result
    names = [q.parameter.name for q in r.parameters]
    assert names == [p.name for p in params] + [a.added.parameter.name]
    assert len(r.cases[0].index) == len(params) and r.cases[1].index[-1] == len(params)
    assert r.values[-1] == pytest.approx(HIDDEN_MASS, rel=0.01)
    np.testing.assert_allclose(r.p_final[:-1], TRUE_P, atol=0.005)
    written = sorted(p.name for p in (tmp_path / "out" / "augmented").glob("*.bdf"))
    lacking_deck = next(n for n in written if "lacking" in n and "changes" not in n)
    bare_deck = next(n for n in written if "bare" in n and "changes" not in n)
    calibrated = load_model(tmp_path / "out" / "augmented" / lacking_deck)
    assert current_value(calibrated, "CONM2", a.added.parameter.id, "M") == pytest.approx(
        HIDDEN_MASS, rel=0.01)  # fmt: skip
    bare_model = load_model(tmp_path / "out" / "augmented" / bare_deck)
    assert a.added.element_id not in bare_model.elements["CONM2"].ids  # the plate's tip mass
