"""``femcal init``: a parameter proposal and a commented calibration configuration for one's
own deck (femcal.jobs.init, femcal.cli.init), on the bundled hammer frame and a small plate."""

from __future__ import annotations

import argparse
import contextlib
import io
import itertools
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import femcal.cli
import femcal.jobs.init as init_job
from femcal.calibrate.config import KEYS, read_config
from femcal.calibrate.parameters import read_parameters
from femcal.cli import init as init_cli
from femcal.jobs.init import (
    InitError,
    comment_label,
    length_unit,
    propose_band,
    run_init,
    write_init,
)
from femcal.model.build import load_model
from femcal.model.element_types import ELEMENT_PROPERTIES
from femcal.testdata import read_frf
from femcal.testdata.data import FRFData
from femcal.testdata.formats import write_frf
from tests.calib_decks import plate_deck

ROOT = Path(__file__).resolve().parents[1]
FRAME = ROOT / "models" / "truck_frame"
DECK, TEST = FRAME / "hammer_frame.bdf", FRAME / "hammer_test.uff"
SENSORS, INPUTS = FRAME / "hammer_frame.sensors.csv", FRAME / "hammer_frame.inputs.csv"


def parse(*argv: object) -> argparse.Namespace:
    """``femcal init ARGV...`` parsed by a parser holding only the init subcommand."""
    parser = argparse.ArgumentParser(prog="femcal")
    sub = parser.add_subparsers(dest="command", required=True)
    init_cli.add_parser(sub)
    return parser.parse_args(["init", *map(str, argv)])


def frame_args(out: Path, *extra: object, sensors: Path = SENSORS) -> list[object]:
    return [DECK, "--sensors", sensors, "--inputs", INPUTS, "--test", TEST, "--out", out,
            *extra]  # fmt: skip


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    """The command on the hammer frame (through its own parser), its console and the
    proposal the job returned."""
    out = tmp_path_factory.mktemp("init") / "start"
    kept = {}

    def keep(*args, **kwargs):
        kept["result"] = run_init(*args, **kwargs)
        return kept["result"]

    stdout, stderr = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(init_job, "run_init", keep)
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            status = init_cli.run(parse(*frame_args(out)))
    proposal, files = kept["result"]
    return {"status": status, "out": out, "stdout": stdout.getvalue(), "proposal": proposal,
            "files": files, "model": load_model(DECK)}  # fmt: skip


def test_the_written_files_pass_the_calibrations_readers(frame):
    out = frame["out"]
    assert frame["status"] == 0
    params_path, config_path = out / "hammer_frame.params.toml", out / "hammer_frame_calibration.toml"
    assert (frame["files"].parameters, frame["files"].config) == (params_path, config_path)
    cfg = read_config(config_path)
    (conf,) = cfg.configurations
    assert conf.deck == DECK.resolve() and conf.test_frf == TEST.resolve()
    assert conf.sensors == SENSORS.resolve() and conf.inputs == INPUTS.resolve()
    assert conf.parameters == params_path.resolve()
    assert conf.model_units == "mm/s^2/N" and conf.zeta0 is None  # the identified median
    # paths are written relative to the folder, not absolute
    doc = tomllib.loads(config_path.read_text())
    assert not Path(doc["model"]["deck"]).is_absolute()
    assert (out / doc["model"]["deck"]).resolve() == DECK.resolve()
    params = read_parameters(params_path, frame["model"])
    assert [p.name for p in params] == [q.name for q in frame["proposal"].parameters]
    # the console says what was written and what to run next
    text = frame["stdout"]
    assert f"wrote {params_path}: {len(params)} parameters" in text
    assert f"wrote {config_path}: band" in text
    assert f"next: femcal calibrate {config_path} --out {out / 'out'}" in text


def used_properties(model, card: str) -> set[int]:
    """Ids of the ``card`` properties some element names."""
    pids: set[int] = set()
    for etype, block in model.elements.items():
        if card in (ELEMENT_PROPERTIES.get(etype) or ()):
            pids |= {int(p) for p in block.pids}
    return pids & {int(p) for p in model.properties[card]["pid"]}


def used_materials(model) -> set[int]:
    """Ids of the MAT1 cards a used property names."""
    mids: set[int] = set()
    for card, table in model.properties.items():
        if not isinstance(table, dict):
            continue
        used = np.isin(table["pid"], list(used_properties(model, card)))
        for col in ("mid", "mid1", "mid2", "mid3"):
            if col in table:
                mids |= {int(m) for m in table[col][used] if m > 0}
    return mids & {int(m) for m in model.materials["MAT1"]["mid"]}


def test_every_used_thickness_and_modulus_with_the_decks_value_and_bounds_around_it(frame):
    model = frame["model"]
    params = read_parameters(frame["out"] / "hammer_frame.params.toml", model)
    by_key = {(p.card, p.id, p.field): p for p in params}
    shells, mats = model.properties["PSHELL"], model.materials["MAT1"]
    pshell = used_properties(model, "PSHELL")
    mat1 = used_materials(model)
    assert pshell == set(range(1, 11)) and mat1 == set(range(1, 14))  # the deck's, all used
    assert {i for c, i, f in by_key if (c, f) == ("PSHELL", "T")} == pshell
    assert {i for c, i, f in by_key if (c, f) == ("MAT1", "E")} == mat1
    for pid in pshell:
        p = by_key[("PSHELL", pid, "T")]
        t = float(shells["t"][shells["pid"] == pid][0])
        assert p.nominal == t
        assert p.lower == pytest.approx(0.8 * t) and p.upper == pytest.approx(1.2 * t)
    for mid in mat1:
        p = by_key[("MAT1", mid, "E")]
        e = float(mats["e"][mats["mid"] == mid][0])
        assert p.nominal == e
        assert p.lower == pytest.approx(0.9 * e) and p.upper == pytest.approx(1.1 * e)
    # the deck's bolts and bellows: PBAR A and the PBUSH's positive stiffnesses, nothing else
    assert {(c, f) for c, _, f in by_key} == {("PSHELL", "T"), ("MAT1", "E"), ("PBAR", "A"),
                                              ("PBUSH", "K1"), ("PBUSH", "K2"), ("PBUSH", "K3")}
    # descriptions name the card, the deck's name for it and its elements
    side_rail = by_key[("PSHELL", 1, "T")].description
    n_rail = int((model.elements["CQUAD4"].pids == 1).sum())
    assert side_rail.startswith("PSHELL 1 T (mm), side rail, 8 mm: ")
    assert f"{n_rail:,} CQUAD4".replace(",", " ") in side_rail
    assert "6 CTRIA3" in by_key[("PSHELL", 6, "T")].description
    assert "384 CHEXA (property 20)" in by_key[("MAT1", 6, "E")].description


def test_the_proposal_is_ordered_by_how_much_the_bands_modes_move(frame):
    q = frame["proposal"].parameters
    s = [p.sensitivity for p in q]
    # falling, up to ties within SENSITIVITY_TIE of the largest (mirror-image parts: their
    # sensitivities differ in the last digits by the order of the floating-point operations)
    tie = init_job.SENSITIVITY_TIE * s[0]
    assert all(a >= b - tie for a, b in itertools.pairwise(s)), s
    kinds = list(init_job.RULES)
    for a, b in itertools.pairwise(q):  # a tie is ordered by kind, then id
        if abs(a.sensitivity - b.sensitivity) <= tie:
            assert (kinds.index((a.card, a.field)), a.id) < (kinds.index((b.card, b.field)),
                                                             b.id), (a.name, b.name)
    # a modulus moves a frequency by at most half its own change; the side rail moves them
    # most, the bellows and bolts least
    assert all(0 <= x <= 0.5 + 1e-6 for p, x in zip(q, s, strict=True) if p.field == "E")
    top = {p.name for p in q[:5]}
    assert {"E_MAT1_1", "T_PSHELL_1"} <= top
    assert q[-1].card == "PBAR" and s[-1] < 1e-3 * s[0]
    # the shells and the tie tube (PBAR 40) are the moduli 1-10 but 6 (the cast brackets)
    share = {p.name: p.mass_share for p in q}
    assert sum(x for n, x in share.items() if n.startswith("T_PSHELL")) + share["A_PBAR_40"] \
        == pytest.approx(sum(share[f"E_MAT1_{i}"] for i in range(1, 11) if i != 6), rel=1e-6)


def test_the_band_lies_in_the_test_and_holds_the_first_flexible_modes(frame):
    data = read_frf(TEST)
    f = data.frequency_hz
    b = frame["proposal"].band
    cfg = read_config(frame["out"] / "hammer_frame_calibration.toml")
    (conf,) = cfg.configurations
    assert conf.band == b.band and conf.identify.band == b.identify_band
    assert conf.identify.splits is None  # chosen from the CMIF; the FE splits a comment
    assert "# splits = [" + ", ".join(repr(float(s)) for s in b.splits) + "]" in (
        frame["out"] / "hammer_frame_calibration.toml").read_text()
    lo, hi = conf.band
    assert f[0] <= lo < hi <= f[-1]
    assert f[0] <= conf.identify.band[0] <= lo and hi <= conf.identify.band[1] <= f[-1]
    # the six modes on the bellows (below 4 Hz) are support modes; the frame's first
    # flexible mode (13.95 Hz) is in the band, with room below it
    assert len(b.support_hz) == 6 and max(b.support_hz) < 4.0
    assert b.flexible_hz[0] == pytest.approx(13.95, abs=0.01)
    assert lo < 0.75 * b.flexible_hz[0] and lo > max(b.support_hz)
    assert hi == pytest.approx(f[-1] / 1.5, rel=0.02)
    assert b.band_modes_hz == tuple(x for x in b.flexible_hz if lo <= x <= hi)
    assert all(conf.identify.band[0] < s < conf.identify.band[1] for s in b.splits)


def test_every_key_is_commented_and_every_setting_is_written(frame):
    text = (frame["out"] / "hammer_frame_calibration.toml").read_text()
    lines = text.splitlines()
    keys = [(n, ln) for n, ln in enumerate(lines) if re.match(r"^\w+ = ", ln)]
    assert keys
    for n, ln in keys:
        assert lines[n - 1].startswith("# "), ln
    written = {ln.split(" = ")[0] for _, ln in keys}
    commented = {m.group(1) for m in re.finditer(r"^# (\w+) = ", text, re.MULTILINE)}
    assert KEYS["calibration"] <= written | commented
    assert KEYS["test.identify"] <= written | commented
    assert {"deck", "parameters", "units"} <= written
    params = (frame["out"] / "hammer_frame.params.toml").read_text().splitlines()
    for ln in params:
        if re.match(r"^\w+ = ", ln):
            assert " # " in ln, ln


def test_a_sensor_on_a_grid_the_deck_lacks_is_named_with_its_line(tmp_path):
    lines = SENSORS.read_text().splitlines()
    lines[4] = lines[4].replace(lines[4].split(",")[1], "999999", 1)
    bad = tmp_path / "sensors.csv"
    bad.write_text("\n".join(lines) + "\n")
    label = lines[4].split(",")[0]
    with pytest.raises(InitError, match=rf"sensors\.csv:5: sensor '{label}': no GRID 999999 in "
                       rf".*hammer_frame\.bdf"):  # fmt: skip
        init_cli.run(parse(*frame_args(tmp_path / "out", sensors=bad)))
    assert not (tmp_path / "out").exists()
    # through femcal's command line: one line, exit status 2
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        status = femcal.cli.main(["init", *map(str, frame_args(tmp_path / "out",
                                                                sensors=bad))])  # fmt: skip
    assert status == 2
    (line,) = [ln for ln in err.getvalue().splitlines() if ln.startswith("femcal init:")]
    assert line == err.getvalue().splitlines()[-1]  # after the progress lines, if any
    assert f"{bad}:5:" in line and "999999" in line


def test_a_test_channel_on_a_grid_the_deck_lacks_is_named(tmp_path):
    data = read_frf(TEST)
    outputs = [c.label for c in data.outputs]
    outputs[4] = "999999:2"
    bad = tmp_path / "test.npz"
    write_frf(bad, FRFData.from_labels(data.frequency_hz, data.H, outputs,
                                       [c.label for c in data.inputs], data.quantity,
                                       data.units))  # fmt: skip
    with pytest.raises(InitError, match=r"channel '999999:2' \(output 5 of 72\): no GRID "
                       r"999999"):  # fmt: skip
        run_init(DECK, bad, tmp_path / "out", sensors=SENSORS, inputs=INPUTS)


def test_existing_files_are_left_alone_without_force(frame, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    mine = out / "hammer_frame_calibration.toml"
    mine.write_text("# my own\n")
    with pytest.raises(InitError, match=r"hammer_frame_calibration\.toml: already exists"):
        init_cli.run(parse(*frame_args(out)))
    assert mine.read_text() == "# my own\n"
    assert not (out / "hammer_frame.params.toml").exists()  # nothing half-written
    # with force, both are (re)written and read back
    files = write_init(frame["proposal"], out, force=True)
    assert files.config == mine and read_config(mine).configurations[0].deck == DECK.resolve()
    with pytest.raises(InitError, match="already exists"):
        write_init(frame["proposal"], out)


# ----------------------------------------------------------------------------- a small plate


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    """The calibration tests' plate with a PSHELL and a MAT1 no element uses, and a test
    (values do not matter to init: only its frequencies and channels) over 1-400 Hz."""
    folder = tmp_path_factory.mktemp("plate")
    text = plate_deck().replace("PSHELL,1,1,5.,1,,1",
                                "PSHELL,1,1,5.,1,,1\nPSHELL,7,3,2.,3,,3\n"
                                "MAT1,3,70000.,,.33,2.7-9")  # fmt: skip
    (folder / "plate.bdf").write_text(text)
    f = np.linspace(1.0, 400.0, 800)
    rng = np.random.default_rng(1)
    H = rng.normal(size=(2, 1, len(f))) + 1j * rng.normal(size=(2, 1, len(f)))
    write_frf(folder / "test.npz", FRFData.from_labels(f, H, ["28:3", "25:+Z"], ["27:3"],
                                                       "accelerance", "g/N"))  # fmt: skip
    proposal, files = run_init(folder / "plate.bdf", folder / "test.npz", folder / "start")
    return {"folder": folder, "proposal": proposal, "files": files,
            "model": load_model(folder / "plate.bdf")}  # fmt: skip


def test_unused_cards_are_not_proposed_and_every_kind_is(plate):
    q = plate["proposal"]
    keys = {(p.card, p.id, p.field) for p in q.parameters}
    assert ("PSHELL", 7, "T") not in keys and ("MAT1", 3, "E") not in keys
    assert any("PSHELL 7 T (no element uses PSHELL 7)" in s for s in q.skipped)
    assert keys == {("PSHELL", 1, "T"), ("MAT1", 1, "E"), ("MAT1", 2, "E"), ("PBAR", 2, "A"),
                    ("PROD", 3, "A"), ("PBUSH", 4, "K1"), ("PBUSH", 4, "K2"),
                    ("PBUSH", 4, "K3"), ("PELAS", 5, "K")}  # fmt: skip
    params = read_parameters(plate["files"].parameters, plate["model"])
    assert len(params) == 9
    k = {p.name: p for p in params}["K3_PBUSH_4"]
    assert (k.nominal, k.lower, k.upper) == (60.0, 30.0, 90.0)
    assert "PSHELL 7" in plate["files"].parameters.read_text()  # said why it is missing


def test_a_clamped_plate_and_a_test_in_g_per_newton(plate):
    q = plate["proposal"]
    cfg = read_config(plate["files"].config)
    (conf,) = cfg.configurations
    # no support springs carry the plate's modes: the first mode is the first flexible one
    assert q.restrained and not q.band.support_hz
    assert q.length_unit == "mm" and conf.model_units == "mm/s^2/N"  # g/N is converted
    assert conf.sensors is None and conf.identify.band[1] <= 400.0
    assert 0.63 * q.band.flexible_hz[0] <= conf.band[0] <= 0.7 * q.band.flexible_hz[0]
    assert "residual = false" in plate["files"].config.read_text()


# ----------------------------------------------------------------------------- pieces


def test_names_from_the_comment_above_a_card():
    assert comment_label("$ PSHELL 1: side rail, 8 mm\n", "PSHELL", 1) == "side rail, 8 mm"
    assert comment_label("$ MAT1 13: bolts", "MAT1", 1) == ""  # another card's
    assert comment_label('$HMNAME PROP                   3"cross_member_4" 1', "PSHELL",
                         3) == "cross member 4"  # fmt: skip
    assert comment_label("$ Femap Property 4 : Floor Panel", "PSHELL", 4) == "Floor Panel"
    assert comment_label("$ Elements and Element Properties for region : rail_left", "PSHELL",
                         9) == "rail left"  # fmt: skip
    assert comment_label("$ shell properties", "PSHELL", 1) == ""  # a header names no card
    assert comment_label("$------------------", "PSHELL", 1) == ""


def test_bands_and_their_errors():
    f = np.array([0.0, 0.0, 1.2, 14.0, 35.7, 42.7, 57.7, 95.8, 101.7, 112.3, 128.5])
    flex = f > 10.0
    b = propose_band(f, flex, (0.05, 150.0), capped=False)
    assert b.band == (9.8, 100.0) and b.identify_band == (9.8, 120.0)
    assert b.splits == (74.0,)  # 4 modes below, 3 above, in the widest balanced gap
    assert b.support_hz == (0.0, 0.0, 1.2)
    # the test starts above 0.7 x the first flexible mode: the band starts with the test
    assert propose_band(f, flex, (12.3, 150.0), capped=False).band[0] == 12.3
    # the solve stopped at its mode count: the band's top comes down below the last mode
    assert propose_band(f, flex, (0.05, 400.0), capped=True).band[1] == 85.0
    with pytest.raises(InitError, match=r"no flexible mode below the test's top"):
        propose_band(f[:3], flex[:3], (0.05, 5.0), capped=False)
    with pytest.raises(InitError, match=r"first flexible mode is at 14 Hz"):
        propose_band(f[:4], flex[:4], (0.05, 15.0), capped=False)


def test_the_decks_units_from_its_materials(frame, plate):
    assert length_unit(frame["model"]) == "mm"
    assert frame["proposal"].frf_units == "mm/s^2/N"
    from dataclasses import replace

    model = plate["model"]
    mats = dict(model.materials["MAT1"])
    mats["e"], mats["rho"] = mats["e"] * 1e6, mats["rho"] * 1e12  # Pa and kg/m^3
    assert length_unit(replace(model, materials={"MAT1": mats})) == "m"
    mats["rho"] = mats["rho"] * 1e3  # no structural material
    assert length_unit(replace(model, materials={"MAT1": mats})) is None
