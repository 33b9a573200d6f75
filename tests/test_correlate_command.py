"""``femcal correlate``: the shipped hammer test against the nominal hammer frame, checked
against an independent computation (the deck solved and the test identified here, paired by
the largest MAC) and the hidden truth; the files it writes; the errors it gives."""

from __future__ import annotations

import contextlib
import csv
import io
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from femcal import cli
from femcal.correlate import mac
from femcal.identify import identify
from femcal.io.identified import read_model, write_model
from femcal.io.modes import write_npz as write_modes
from femcal.jobs.correlate import IDENTIFY_MARGIN
from femcal.model import EigenRequest
from femcal.model.build import load_model
from femcal.response.frf import channel_matrix
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata import read_frf
from femcal.testdata.data import Channel
from femcal.testdata.formats import write_frf
from femcal.testdata.points import point_label, read_points
from femcal.viz.webview import read_webview

from .browser import assert_verdict_first_at_1024, needs_browser

ROOT = Path(__file__).resolve().parents[1]
FRAME = ROOT / "models" / "truck_frame"
DECK, TEST = FRAME / "hammer_frame.bdf", FRAME / "hammer_test.uff"
SENSORS, TRUTH = FRAME / "hammer_frame.sensors.csv", FRAME / "hammer_test.truth.toml"
BAND = (10.0, 100.0)


def run(*argv: object) -> tuple[int, str, str]:
    """Run ``femcal correlate ARGV...``: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(["correlate", *map(str, argv)])
    return status, out.getvalue(), err.getvalue()


def read_table(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def independent():
    """The deck solved, the test identified (over the band widened as the command does) and
    each test mode in the band paired with the FE mode of largest MAC, here."""
    model = load_model(DECK)
    fe, _ = solve_normal_modes(model, request=EigenRequest(v2=1.5 * BAND[1], nd=None))
    data = read_frf(TEST)
    ident = identify(data, (BAND[0] / IDENTIFY_MARGIN, BAND[1] * IDENTIFY_MARGIN))
    sel = (ident.frequency_hz >= BAND[0]) & (ident.frequency_hz <= BAND[1])
    keep = ~ident.suspect
    C = channel_matrix(model, [c for c, k in zip(ident.outputs, keep, strict=True) if k])
    M = mac(ident.shapes[keep][:, sel], C @ fe.shapes)
    best = M.argmax(axis=1)
    f_test = ident.frequency_hz[sel]
    f_fe = fe.frequencies_hz[best]
    return {"model": model, "modes": fe, "ident": ident, "test_hz": f_test,
            "damping": ident.damping_ratio[sel], "fe_mode": best + 1, "fe_hz": f_fe,
            "diff": (f_test - f_fe) / f_fe * 100, "mac": M.max(axis=1)}  # fmt: skip


@pytest.fixture(scope="module")
def deck_run(tmp_path_factory):
    """The command on the deck and the shipped UFF file, with the sensors file."""
    out = tmp_path_factory.mktemp("correlate")
    status, stdout, stderr = run(DECK, TEST, "--band", *BAND, "--sensors", SENSORS,
                                 "--out", out)  # fmt: skip
    return {"status": status, "out": out, "stdout": stdout, "stderr": stderr}


@pytest.fixture(scope="module")
def saved(independent, tmp_path_factory):
    """The independent FE modes and identified model as ``femcal solve --out`` and ``femcal
    identify --out`` write them."""
    folder = tmp_path_factory.mktemp("saved")
    write_modes(folder / "modes.npz", independent["modes"], independent["model"])
    write_model(folder / "model.npz", independent["ident"])
    return folder


def test_the_hammer_test_pairs_its_five_modes_with_the_nominal_frame(deck_run, independent):
    assert deck_run["status"] == 0, deck_run["stderr"]
    rows = read_table(deck_run["out"] / "correlation.csv")
    assert len(rows) == 5 and all(r["fe_mode"] for r in rows)  # all paired, no FE mode left
    ind = independent
    np.testing.assert_allclose([float(r["test_hz"]) for r in rows], ind["test_hz"], rtol=1e-6)
    np.testing.assert_allclose([float(r["test_damping_pct"]) for r in rows],
                               100 * ind["damping"], atol=1e-4)  # fmt: skip
    assert [int(r["fe_mode"]) for r in rows] == list(ind["fe_mode"])
    np.testing.assert_allclose([float(r["fe_hz"]) for r in rows], ind["fe_hz"], rtol=1e-6)
    np.testing.assert_allclose([float(r["frequency_difference_pct"]) for r in rows],
                               ind["diff"], atol=1e-5)  # fmt: skip
    macs = np.array([float(r["mac"]) for r in rows])
    np.testing.assert_allclose(macs, ind["mac"], atol=1e-6)
    assert (macs > 0.99).all()
    # the test modes are the hidden frame's (the truth file's modes in the band)
    text = TRUTH.read_text()
    truth = np.array([float(x) for x in re.search(r"frequency_hz = \[([^\]]*)\]",
                                                  text).group(1).split(",")])  # fmt: skip
    truth = truth[(truth >= BAND[0]) & (truth <= BAND[1])]
    np.testing.assert_allclose(ind["test_hz"], truth, rtol=1e-3)
    # the nominal frame is 4.3 % soft in its first elastic mode, within 1.2 % in the others
    diff = np.array([float(r["frequency_difference_pct"]) for r in rows])
    assert 4.0 < diff[0] < 4.6 and np.abs(diff[1:]).max() < 1.5
    # one console line per pair, and the totals
    lines = deck_run["stdout"].splitlines()
    assert sum(" ~ " in line for line in lines) == 5
    assert "5 of 5 test modes in 10-100 Hz paired" in lines[-1]
    assert "identifying the test FRFs over 8.33333-120 Hz" in deck_run["stderr"]


def test_mac_matrix_and_page(deck_run, independent):
    out = deck_run["out"]
    with open(out / "mac.csv", newline="") as fh:
        table = list(csv.reader(fh))
    head, body = table[0], table[1:]
    assert head[:2] == ["test_mode", "test_hz"] and len(body) == 5
    fe_hz = independent["modes"].frequencies_hz
    window = np.flatnonzero((fe_hz >= BAND[0] / 1.5) & (fe_hz <= BAND[1] * 1.5))
    assert head[2:] == [f"FE {j + 1} ({fe_hz[j]:.3f} Hz)" for j in window]
    M = np.array([[float(v) for v in row[2:]] for row in body])
    assert ((M >= 0) & (M <= 1)).all()
    rows = read_table(out / "correlation.csv")
    for k, r in enumerate(rows):  # each pair's MAC is its row's largest, in its column
        col = list(window).index(int(r["fe_mode"]) - 1)
        assert M[k, col] == pytest.approx(float(r["mac"]), abs=1e-6) and M[k].argmax() == col
    page = (out / "correlation.html").read_text()
    assert not re.search(r"(src|href)\s*=\s*[\"']?\s*(https?:|//)", page, re.IGNORECASE)
    assert "<link" not in page
    # the 3-D viewer's data and its script, inline
    assert re.findall(r"<script\b[^>]*>", page) == [
        '<script type="application/json" class="femcal-data" id="femcal-data">', "<script>"]
    images = re.findall(r"<img src='([^']*)'", page)
    # the frequency scatter, the MAC matrix, the AutoMAC, the CoMAC, the component plot
    assert len(images) == 5
    assert all(s.startswith("data:image/png;base64,iVBOR") for s in images)
    assert page.count("<tr>") >= 1 + 5 + 1 + 5  # the paired table and the MAC table


def test_the_viewer_draws_each_pair_on_the_model(deck_run):
    view = read_webview(deck_run["out"] / "correlation.html")
    rows = read_table(deck_run["out"] / "correlation.csv")
    o = view["overlay"]
    # the paired FE modes, on the deck's faces (14 510 CQUAD4, 6 CTRIA3, the CHEXA's skins)
    assert [m["mode"] for m in view["modes"]] == [int(r["fe_mode"]) for r in rows]
    assert [p["label"].split(" / ")[0] for p in o["pairs"]] == [
        f"test {r['test_mode']} ({float(r['test_hz']):.2f} Hz)" for r in rows]
    assert view["n_faces"] > 14_510 and view["unit"] == "mm" and not any(
        m["rigid"] for m in view["modes"])  # fmt: skip
    # the FE shape at each sensor is the drawn mode's motion there, seen along the sensors'
    # directions; the test's agrees with it as the pairs' MAC says (over 0.99)
    model = load_model(DECK)
    row = {int(g): n for n, g in enumerate(view["grid_ids"])}
    grid_of, codes_of = {}, {}
    for label, grid, code in read_points(SENSORS):
        grid_of[label] = grid
        codes_of.setdefault(label, []).append(code)
    names = o["sensor_names"]
    assert sorted(names) == sorted(grid_of) and len(names) == o["n_sensors"]
    grids = [grid_of[name] for name in names]
    np.testing.assert_allclose(o["sensor_points"], model.xyz[model.node_index(grids)],
                               atol=1e-3)  # fmt: skip
    for n, pair in enumerate(o["pairs"]):
        fe = o["fe"][n]
        motion = view["shapes"][pair["mode"]][[row[g] for g in grids]]
        for s, name in enumerate(names):
            axes = [c - 1 for c in codes_of[name] if 1 <= c <= 3]
            np.testing.assert_allclose(fe[s, axes], motion[s, axes], rtol=0,
                                       atol=1e-5 * np.abs(motion).max())  # fmt: skip
        t = o["test"][n].ravel()
        m = (t @ fe.ravel()) ** 2 / ((t @ t) * (fe.ravel() @ fe.ravel()))
        assert m > 0.99 and pair["mac"] > 0.99


@needs_browser
def test_the_page_opens_on_its_verdict_and_fits_1024_pixels(deck_run, tmp_path):
    assert_verdict_first_at_1024(deck_run["out"] / "correlation.html", tmp_path / "c.png")


def test_saved_modes_and_an_identified_model_with_sensor_labels(saved, independent, tmp_path):
    # the identified model's channels relabelled by the sensors' names (L01:+X ...): the
    # sensors file places them where the grid labels were
    ident = read_model(saved / "model.npz")
    where = {(g, code): label for label, g, code in read_points(SENSORS)}
    named = tuple(Channel.parse(f"{where[(c.grid, int(c.direction))]}:"
                                f"{point_label(c.grid, int(c.direction)).split(':')[1]}")
                  for c in ident.outputs)  # fmt: skip
    assert named[0].label == "L01:+X" and named[0].grid is None
    write_model(tmp_path / "named.npz", replace(ident, outputs=named))
    status, _, stderr = run(saved / "modes.npz", tmp_path / "named.npz", "--band", *BAND,
                            "--sensors", SENSORS, "--out", tmp_path / "o")
    assert status == 0, stderr
    assert "identifying" not in stderr and "solving" not in stderr  # both read, not made
    rows = read_table(tmp_path / "o" / "correlation.csv")
    assert [int(r["fe_mode"]) for r in rows] == list(independent["fe_mode"])
    view = read_webview(tmp_path / "o" / "correlation.html")  # no deck: the grids as points
    assert (view["n_faces"], view["n_edges"], view["overlay"]["n_pairs"]) == (0, 0, len(rows))
    assert view["n_points"] == len(load_model(DECK).node_ids) and view["unit"] == ""
    np.testing.assert_allclose([float(r["mac"]) for r in rows], independent["mac"], atol=1e-6)
    np.testing.assert_allclose([float(r["frequency_difference_pct"]) for r in rows],
                               independent["diff"], atol=1e-5)  # fmt: skip
    # without the sensors file the names place nothing: an error naming the channel
    status, _, stderr = run(saved / "modes.npz", tmp_path / "named.npz")
    assert status == 2
    assert "channel 'L01:+X' (output 1 of 72) names no grid (and 71 more" in stderr
    assert "--sensors" in stderr


def test_the_verdict_comes_first_and_names_a_reversed_and_a_misdirected_sensor(saved,
                                                                               tmp_path):
    """The identified model with one sensor's sign flipped and another's direction
    mislabelled: the page opens on the verdict, CoMAC and the sign agreement name both (and
    only them), on the page and the console."""
    ident = read_model(saved / "model.npz")
    labels = [c.label for c in ident.outputs]
    flip, turn = labels.index("455:3"), labels.index("1716:3")
    shapes = ident.shapes.copy()
    shapes[flip] *= -1
    outputs = list(ident.outputs)
    outputs[turn] = Channel.parse("1716:2")  # a +Z accelerometer entered as +Y
    write_model(tmp_path / "odd.npz", replace(ident, shapes=shapes, outputs=tuple(outputs)))
    status, stdout, stderr = run(saved / "modes.npz", tmp_path / "odd.npz", "--band", *BAND,
                                 "--sensors", SENSORS, "--out", tmp_path / "o")  # fmt: skip
    assert status == 0, stderr
    suspects = [x for x in stdout.splitlines() if x.startswith("Suspect channel")]
    assert len(suspects) == 2, stdout
    assert any("(455:3)" in x and "likely sign" in x for x in suspects), suspects
    assert any("1716:2" in x and "moves unlike" in x for x in suspects), suspects
    page = (tmp_path / "o" / "correlation.html").read_text()
    assert re.search(r"<h2[^>]*>(.*?)</h2>", page).group(1) == "Verdict"
    verdict = page[page.index("id='verdict'"):page.index("</section>")]
    assert "likely sign" in verdict and "1716:2" in verdict
    assert page.index("id='verdict'") < page.index("Paired modes") < page.index("Provenance")


def test_fewer_fe_modes_leave_a_test_mode_unpaired(saved, tmp_path):
    status, stdout, stderr = run(saved / "modes.npz", saved / "model.npz", "--band", *BAND,
                                 "--modes", 10, "--out", tmp_path)  # fmt: skip
    assert status == 0, stderr
    rows = read_table(tmp_path / "correlation.csv")
    assert [r["fe_mode"] for r in rows] == ["7", "8", "9", "10", ""]  # 96.9 Hz: no FE 11
    assert rows[4]["mac"] == "" and float(rows[4]["test_hz"]) == pytest.approx(96.9, abs=0.1)
    assert "no FE mode pairs with it" in stdout


def test_channels_on_grids_the_deck_lacks_are_named_before_any_work(tmp_path, saved):
    data = read_frf(TEST)
    outputs = list(data.outputs)
    outputs[4] = Channel.parse("999999:2")
    outputs[5] = Channel.parse("999999:3")
    bad = tmp_path / "bad.npz"
    write_frf(bad, type(data)(data.frequency_hz, data.H, tuple(outputs), data.inputs,
                              data.quantity, data.units))  # fmt: skip
    status, stdout, stderr = run(DECK, bad, "--band", *BAND, "--out", tmp_path / "o")
    assert status == 2 and stdout == ""
    last = stderr.strip().splitlines()[-1]
    assert last.startswith(f"femcal correlate: {bad}: channel '999999:2' (output 5 of 72): "
                           f"no GRID 999999 in {DECK} (and 1 more channels, grids 999999)")
    assert "identifying" not in stderr and "solving" not in stderr
    assert not (tmp_path / "o").exists()
    # the same with the saved modes and identified model
    ident = read_model(saved / "model.npz")
    moved = (*ident.outputs[:-1], Channel.parse("424242:+Z"))
    write_model(tmp_path / "moved.npz", replace(ident, outputs=moved))
    status, _, stderr = run(saved / "modes.npz", tmp_path / "moved.npz")
    assert status == 2
    assert "channel '424242:+Z' (output 72 of 72): no GRID 424242 in" in stderr


@pytest.mark.parametrize("args, expected", [
    (["--band", 100, 10], "--band 100 10: expected 0 < F1 < F2"),
    (["--band", 10, 100, "--modes", 0], "--modes 0: expected a number of modes >= 1"),
    (["--band", 10, 100, "--split", 200], "--split 200: expected a frequency inside"),
    (["--band", 10, 100, "--identify-band", 20, 120], "--identify-band 20 120: expected it "
     "to hold --band 10 100"),
    (["--band", 10, 100, "--min-mac", 2], "--min-mac 2: expected a MAC in [0, 1]"),
    ([], "FRFs to identify need a band (--band F1 F2"),
    (["--band", 10, 200], "band 10-200 Hz: outside the data's 0.05-150 Hz"),
])  # fmt: skip
def test_bad_options_are_one_line_errors(args, expected):
    status, stdout, stderr = run(DECK, TEST, *args)
    assert status == 2 and stdout == ""
    assert expected in stderr.strip().splitlines()[-1]


def test_an_output_folder_that_is_a_file_is_refused(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    status, _, stderr = run(DECK, TEST, "--band", *BAND, "--out", blocker)
    assert status == 2 and "--out" in stderr and "is a file" in stderr


@pytest.mark.slow
def test_a_test_handed_over_transposed_pairs_the_same_modes(tmp_path, deck_run):
    """The hammer test as 2 outputs x 72 inputs (reciprocity): its shapes come out at the 72
    sensor positions, which the sensors file places, and the same five pairs come out."""
    from femcal.testdata.data import FRFData

    data = read_frf(TEST)
    flipped = write_frf(tmp_path / "flipped.npz",
                        FRFData(data.frequency_hz, np.swapaxes(data.H, 0, 1), data.inputs,
                                data.outputs, data.quantity, data.units))  # fmt: skip
    status, stdout, stderr = run(DECK, flipped, "--band", *BAND, "--sensors", SENSORS,
                                 "--out", tmp_path / "out")  # fmt: skip
    assert status == 0, stderr
    assert "5 of 5 test modes in 10-100 Hz paired" in stdout.splitlines()[-1]
    a = read_table(deck_run["out"] / "correlation.csv")
    b = read_table(tmp_path / "out" / "correlation.csv")
    assert [r["fe_mode"] for r in a] == [r["fe_mode"] for r in b]
    np.testing.assert_allclose([float(r["test_hz"]) for r in b],
                               [float(r["test_hz"]) for r in a], rtol=1e-6)


def test_a_pair_with_a_better_mac_elsewhere_and_a_channel_left_out_are_doubted(saved,
                                                                              tmp_path):
    """Test mode 2 made alike FE mode 3 (but less than test mode 3 is): it still pairs with
    FE mode 2, and the verdict says its MAC with FE mode 3 is higher. A channel the
    identification calls suspect is left out with its reason and the band it was found
    in."""
    ident = read_model(saved / "model.npz")
    sel = np.flatnonzero((ident.frequency_hz >= BAND[0]) & (ident.frequency_hz <= BAND[1]))
    shapes = ident.shapes.copy()
    a, b = (shapes[:, k] / np.linalg.norm(shapes[:, k]) for k in sel[1:3])
    shapes[:, sel[1]] = 0.66 * a + 0.75 * b * np.exp(-1j * np.angle(np.vdot(b, a)))
    suspect = np.zeros(len(ident.suspect), bool)
    suspect[0] = True
    write_model(tmp_path / "mixed.npz", replace(ident, shapes=shapes, suspect=suspect))
    status, stdout, stderr = run(saved / "modes.npz", tmp_path / "mixed.npz", "--band", *BAND,
                                 "--out", tmp_path / "o")  # fmt: skip
    assert status == 0, stderr
    rows = read_table(tmp_path / "o" / "correlation.csv")
    fe2, fe3 = int(rows[1]["fe_mode"]), int(rows[2]["fe_mode"])
    assert fe3 != fe2
    doubt = [x for x in stdout.splitlines() if x.startswith("Test mode 2 ")]
    assert len(doubt) == 1, stdout
    assert f"pairs with FE mode {fe2}" in doubt[0]
    assert f"its MAC with FE mode {fe3}" in doubt[0] and "which pairs with test mode 3" in doubt[0]
    left = [x for x in stdout.splitlines() if "is left out: the identification over" in x]
    label = ident.shape_channels[0].label
    assert len(left) == 1 and left[0].startswith(f"Channel {label} ")
    lo, hi = ident.band
    assert f"over {lo:g}-{hi:g} Hz calls it suspect" in left[0] and "times the median" in left[0]
    page = (tmp_path / "o" / "correlation.html").read_text()
    verdict = page[page.index("id='verdict'"):page.index("</section>")]
    assert "class='sentence'" in verdict and "Test mode 2 (" in verdict
    assert f"identified over {lo:g}-{hi:g} Hz" in page
