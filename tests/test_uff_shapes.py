"""Mode shapes as universal files (datasets 164, 15, 82, 55): the ladder frame's grids, trace
lines and FE modes read back with pyuff; shapes in basic whatever the CD frames; identified
(complex and real) modes; ``femcal solve --uff [--at]`` and ``femcal identify --out``."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import pyuff

from femcal.cli import main
from femcal.deck import read_deck
from femcal.errors import FemcalWarning
from femcal.identify.workflow import IdentifiedModel
from femcal.io.modes import basic_translations
from femcal.io.uff_shapes import (
    Grids,
    ModeShapes,
    TraceLines,
    fe_shapes,
    identified_shapes,
    mesh_edges,
    model_grids,
    read_uff_shapes,
    sensor_wireframe,
    trace_line_nodes,
    trace_line_pairs,
    write_uff_shapes,
)
from femcal.model.build import build_model, load_model
from femcal.response.statespace import StateSpace
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel

from .test_punch import CD_DECK, LADDER

#: Sensors on the ladder frame: rail ends and thirds, the middle cross member's centre.
SENSORS = [1, 5, 10, 15, 101, 105, 110, 115, 202]


@pytest.fixture(scope="module")
def ladder():
    model = load_model(LADDER)
    modes, _ = solve_normal_modes(model)
    return model, modes


def read_sets(path) -> list[dict]:
    sets = pyuff.UFF(str(path)).read_sets()
    return [sets] if isinstance(sets, dict) else sets


def pairs_of(edges) -> set[tuple[int, int]]:
    return {(int(a), int(b)) for a, b in np.sort(np.asarray(edges), axis=1)}


def close(got, want, scale, rel=1e-5) -> bool:
    """Equal to the format's precision (E13.5: 6 significant digits) relative to ``scale``."""
    return bool(np.all(np.abs(np.asarray(got) - np.asarray(want)) <= rel * scale))


def test_ladder_frame_grids_edges_and_modes_read_back_with_pyuff(tmp_path, ladder):
    model, modes = ladder
    edges = mesh_edges(model)
    # 36 CBARs and the RBE2 spider's three legs to the battery box (CELAS2 to ground none)
    assert len(edges) == 39 and {(7, 301), (8, 301), (9, 301), (1, 201)} <= pairs_of(edges)
    grids = model_grids(model, units="mm")
    path = write_uff_shapes(tmp_path / "ladder.unv", grids, [fe_shapes(modes, model)],
                            TraceLines(edges, "ladder frame"))  # fmt: skip
    sets = read_sets(path)
    types = [s["type"] for s in sets]
    assert types == [164, 15, 82] + [55] * 12  # 40 points: one trace line dataset
    units = sets[0]
    assert units["length"] == pytest.approx(1000.0) and units["force"] == pytest.approx(1.0)
    nodes = sets[1]
    np.testing.assert_array_equal(np.asarray(nodes["node_nums"], float), model.node_ids)
    xyz = np.column_stack([nodes["x"], nodes["y"], nodes["z"]])
    assert close(xyz, model.xyz, 3500.0)
    assert np.asarray(nodes["disp_cs"]).max() == 0 and np.asarray(nodes["def_cs"]).max() == 0
    trace = sets[2]
    assert trace["id"].strip() == "ladder frame"
    drawn = trace_line_pairs(trace["nodes"])
    assert len(drawn) == len(edges) and pairs_of(drawn) == pairs_of(edges)  # each line once
    basic = basic_translations(modes, model)  # (n, 3, k)
    for k, s in enumerate(sets[3:]):
        assert (s["analysis_type"], s["data_ch"], s["spec_data_type"], s["data_type"],
                s["n_data_per_node"]) == (2, 2, 8, 2, 3)  # fmt: skip
        assert (s["load_case"], s["mode_n"]) == (1, k + 1)
        assert s["freq"] == pytest.approx(modes.frequencies_hz[k], rel=1e-5)
        assert s["modal_m"] == pytest.approx(modes.generalized_mass[k], rel=1e-5)
        assert s["modal_damp_vis"] == 0.0
        assert f"mode {k + 1}:" in s["id2"]
        np.testing.assert_array_equal(s["node_nums"], model.node_ids)
        got = np.column_stack([s["r1"], s["r2"], s["r3"]])
        assert close(got, basic[:, :, k], np.abs(basic[:, :, k]).max())
    back = read_uff_shapes(path)  # femcal's own reading of the same file
    np.testing.assert_array_equal(back.grids.ids, model.node_ids)
    assert pairs_of(back.trace_pairs) == pairs_of(edges) and len(back.shapes) == 12


def test_shapes_at_the_sensors_with_a_wireframe_along_the_mesh(tmp_path, ladder):
    model, modes = ladder
    wire = pairs_of(sensor_wireframe(model, SENSORS))
    # along each rail in a row, across the end cross members, and through the middle one
    rails = {(1, 5), (5, 10), (10, 15), (101, 105), (105, 110), (110, 115)}
    across = {(1, 101), (15, 115), (5, 202), (105, 202)}
    assert rails | across <= wire
    assert not {(1, 10), (1, 15), (5, 15), (1, 115)} & wire  # no line jumps a sensor
    shapes = fe_shapes(modes, model, SENSORS)
    full = fe_shapes(modes, model)
    rows = model.node_index(SENSORS)
    np.testing.assert_array_equal(shapes.values, full.values[:, rows])
    path = write_uff_shapes(tmp_path / "sensors.uff", model_grids(model, SENSORS), [shapes],
                            TraceLines(sensor_wireframe(model, SENSORS)))  # fmt: skip
    back = read_uff_shapes(path)
    np.testing.assert_array_equal(back.grids.ids, SENSORS)
    assert pairs_of(back.trace_pairs) == wire
    assert [s["type"] for s in read_sets(path)][:2] == [15, 82]  # no units given: no 164
    for k, s in enumerate(back.shapes):
        np.testing.assert_array_equal(s["node_nums"], SENSORS)
        got = np.column_stack([s["r1"], s["r2"], s["r3"]])
        assert close(got, shapes.values[k], np.abs(shapes.values[k]).max())


def test_fe_shapes_are_in_basic_whatever_the_cd_frames(write):
    basic = build_model(read_deck(write(CD_DECK.format(cd=""), "basic.bdf")))
    rotated = build_model(read_deck(write(CD_DECK.format(cd=7), "rotated.bdf")))
    m0 = solve_normal_modes(basic)[0]
    s0, s1 = fe_shapes(m0, basic), fe_shapes(solve_normal_modes(rotated)[0], rotated)
    bending = 0
    for k in range(s0.n_modes):
        v0, v1 = s0.values[k], s1.values[k]
        ref = np.unravel_index(np.argmax(np.abs(v0)), v0.shape)
        sign = np.sign(v0[ref] * v1[ref])
        scale = np.abs(m0.shapes[:, k]).max()  # rotations too: a torsion mode barely moves
        assert np.abs(sign * v1 - v0).max() <= 1e-8 * scale
        bending += np.abs(v0[2]).max() > 1e-3 * scale  # GRID 3 (CD 7) moves
    assert bending >= 2


def _identified(outputs: list[str], shapes: np.ndarray, f: np.ndarray,
                zeta: np.ndarray) -> IdentifiedModel:  # fmt: skip
    """An identified model with given shapes (outputs x modes); its state-space part is a
    placeholder (the shapes file does not use it)."""
    p, k = shapes.shape
    w = 2 * np.pi * f
    poles = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
    system = StateSpace(np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((p, 1)), np.zeros((p, 1)))
    return IdentifiedModel(system, np.zeros(1, bool), poles, f, zeta, shapes,
                           np.ones((1, k), complex), tuple(Channel.parse(c) for c in outputs),
                           (Channel.parse("5:+Z"),), "accelerance", "mm/s^2/N", (1.0, 30.0),
                           np.zeros(p), np.zeros(p, bool))  # fmt: skip


def test_identified_modes_as_complex_and_real_shapes(write, tmp_path):
    rotated = build_model(read_deck(write(CD_DECK.format(cd=7))))
    frame = rotated.cd_frames[rotated.node_index(3)[0]]
    outputs = ["2:+X", "2:+Y", "2:+Z", "4:+Z", "4:-Z", "3:1", "3:3", "4:+RX", "hammer"]
    rng = np.random.default_rng(5)
    shapes = rng.normal(size=(9, 2)) + 1j * rng.normal(size=(9, 2))
    shapes[4] = -shapes[3]  # 4:-Z measures the same motion as 4:+Z
    f, zeta = np.array([12.5, 31.0]), np.array([0.01, 0.025])
    ident = _identified(outputs, shapes, f, zeta)
    with pytest.warns(FemcalWarning, match=r"2 channel\(s\) left out .*4:\+RX, hammer"):
        s = identified_shapes(ident, rotated)
    np.testing.assert_array_equal(s.grid_ids, [2, 3, 4])
    np.testing.assert_allclose(s.values[:, 0], shapes[0:3].T)  # triaxial: the components
    np.testing.assert_allclose(s.values[:, 2], np.c_[0 * f, 0 * f, shapes[3]])  # uniaxial
    # components 1 and 3 of GRID 3 are along its CD frame's x and z axes
    np.testing.assert_allclose(s.values[:, 1] @ frame[:, [0, 2]], shapes[5:7].T, atol=1e-12)
    np.testing.assert_allclose(s.values[:, 1] @ frame[:, 1], 0, atol=1e-12)
    grids = model_grids(rotated, [2, 3, 4])
    path = write_uff_shapes(tmp_path / "test.unv", grids, [s],
                            TraceLines(sensor_wireframe(rotated, [2, 3, 4])))  # fmt: skip
    sets = [d for d in read_sets(path) if d["type"] == 55]
    assert len(sets) == 2
    for k, d in enumerate(sets):
        assert (d["analysis_type"], d["data_type"], d["data_ch"]) == (3, 5, 2)
        assert d["eig"] == pytest.approx(ident.poles[k], rel=1e-5)
        assert abs(d["modal_a"]) == 0 and abs(d["modal_b"]) == 0
        got = np.column_stack([d["r1"], d["r2"], d["r3"]])
        assert close(got, s.values[k], np.abs(s.values[k]).max())
    assert pairs_of(read_uff_shapes(path).trace_pairs) == {(2, 3), (3, 4)}
    # the same modes as real normal modes with their damping, after the FE modes (case 2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemcalWarning)
        real = identified_shapes(ident, rotated, real=True)
    fe = fe_shapes(solve_normal_modes(rotated)[0], rotated, [2, 3, 4])
    path = write_uff_shapes(tmp_path / "both.unv", grids, [fe, real])
    sets = [d for d in read_sets(path) if d["type"] == 55]
    assert [d["load_case"] for d in sets] == [1] * fe.n_modes + [2, 2]
    for k, d in enumerate(sets[fe.n_modes:]):
        assert (d["analysis_type"], d["data_type"]) == (2, 2)
        assert d["freq"] == pytest.approx(f[k], rel=1e-5)
        assert d["modal_damp_vis"] == pytest.approx(zeta[k], rel=1e-5)
        got = np.column_stack([d["r1"], d["r2"], d["r3"]])
        assert close(got, s.values[k].real, np.abs(s.values[k]).max())


def test_long_trace_lines_are_split_into_datasets_of_at_most_250_points(tmp_path):
    ids = np.arange(1, 602)
    chain = np.column_stack([ids[:-1], ids[1:]])
    star = np.column_stack([np.full(30, 1000), np.arange(2000, 2030)])
    pairs = np.r_[chain, star]
    nodes = trace_line_nodes(pairs)
    assert max(len(n) for n in nodes) <= 250
    grids = Grids(np.r_[ids, 1000, np.arange(2000, 2030)], np.zeros((632, 3)))
    path = write_uff_shapes(tmp_path / "long.unv", grids, trace_lines=TraceLines(pairs))
    sets = [s for s in read_sets(path) if s["type"] == 82]
    assert len(sets) == len(nodes) >= 3
    assert [s["trace_num"] for s in sets] == list(range(1, len(sets) + 1))
    drawn = np.concatenate([trace_line_pairs(s["nodes"]) for s in sets])
    assert len(drawn) == len(pairs) and pairs_of(drawn) == pairs_of(pairs)


def test_bad_inputs_are_refused(tmp_path, ladder):
    model, modes = ladder
    with pytest.raises(ValueError, match="no GRID 999 in the model"):
        model_grids(model, [1, 999])
    with pytest.raises(ValueError, match="no GRID 999"):
        fe_shapes(modes, model, [999])
    grids = model_grids(model, [1, 2])
    shapes = fe_shapes(modes, model, [1, 5])
    with pytest.raises(ValueError, match=r"shape grid\(s\) 5 are not among the file's grids"):
        write_uff_shapes(tmp_path / "x.unv", grids, [shapes])
    with pytest.raises(ValueError, match=r"trace line grid\(s\) 3 are not among"):
        write_uff_shapes(tmp_path / "x.unv", grids, trace_lines=TraceLines([[1, 3]]))
    with pytest.raises(ValueError, match="expected \\(modes, grids, 3\\)"):
        ModeShapes([1, 2], np.zeros((2, 3, 3)), [1.0, 2.0])
    with pytest.raises(ValueError, match="nothing to write"):
        write_uff_shapes(tmp_path / "x.unv")
    assert not (tmp_path / "x.unv").exists()


def test_cli_solve_writes_the_universal_file_at_every_grid_or_the_sensors(tmp_path, capsys,
                                                                          ladder):  # fmt: skip
    model, modes = ladder
    everything = tmp_path / "all.unv"
    assert main(["solve", str(LADDER), "--uff", str(everything)]) == 0
    back = read_uff_shapes(everything)
    np.testing.assert_array_equal(back.grids.ids, model.node_ids)
    assert pairs_of(back.trace_pairs) == pairs_of(mesh_edges(model))
    assert len(back.shapes) == 12
    sensors = tmp_path / "sensors.csv"
    sensors.write_text("label,grid,x,y,z,directions\n"
                       + "".join(f"S{g},{g},0,0,0,123\n" for g in SENSORS))  # fmt: skip
    at = tmp_path / "at" / "sensors.uff"
    assert main(["solve", str(LADDER), "--uff", str(at), "--at", str(sensors),
                 "--pch", str(tmp_path / "at" / "modes.pch")]) == 0  # fmt: skip
    assert "sensors.uff (12 shapes at 9 grids)" in capsys.readouterr().err
    back = read_uff_shapes(at)
    np.testing.assert_array_equal(back.grids.ids, SENSORS)
    assert pairs_of(back.trace_pairs) == pairs_of(sensor_wireframe(model, SENSORS))
    want = fe_shapes(modes, model, SENSORS)
    for k, s in enumerate(back.shapes):
        assert s["freq"] == pytest.approx(modes.frequencies_hz[k], rel=1e-5)
        got = np.column_stack([s["r1"], s["r2"], s["r3"]])
        assert close(got, want.values[k], np.abs(want.values[k]).max())
    assert (tmp_path / "at" / "modes.pch").is_file()


@pytest.mark.parametrize(("args", "expected"), [
    (["--uff", "{t}/modes.txt"], r"--uff .*modes\.txt: suffix '\.txt'; expected \.unv or \.uff"),
    (["--uff", "{t}"], r"--uff .*: is a directory; expected a file name"),
    (["--uff", "{t}/afile/m.unv"], r"--uff .*afile/m\.unv: .*afile is a file, not a directory"),
    (["--at", "{t}/s.csv"], r"--at .*s\.csv: chooses the grids of --uff; expected --uff FILE"),
    (["--uff", "{t}/m.unv", "--at", "{t}/missing.csv"], r"No such file or directory"),
])  # fmt: skip
def test_cli_refuses_bad_uff_paths_before_solving(tmp_path, capsys, args, expected):
    (tmp_path / "afile").write_text("x")
    argv = ["solve", str(tmp_path / "not-read.bdf"), *[a.format(t=tmp_path) for a in args]]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(expected, err[0]), err
    assert not (tmp_path / "m.unv").exists()


def test_cli_solve_refuses_sensors_the_deck_does_not_have(tmp_path, capsys):
    sensors = tmp_path / "s.csv"
    sensors.write_text("label,grid,x,y,z,directions\nA,1,0,0,0,3\nB,999,0,0,0,3\n")
    argv = ["solve", str(LADDER), "--uff", str(tmp_path / "m.unv"), "--at", str(sensors)]
    assert main(argv) == 2
    assert "--at" in capsys.readouterr().err and not (tmp_path / "m.unv").exists()


def test_cli_identify_writes_the_identified_shapes_on_the_decks_grids(tmp_path, capsys, ladder):
    from femcal.response.frf import channel_matrix, modal_frf
    from femcal.testdata.data import FRFData
    from femcal.testdata.formats.npz import write_npz

    model, modes = ladder
    outputs = [Channel.parse(c) for c in ("1:+X", "1:+Y", "1:+Z", "5:+Z", "10:+Z", "15:+Z",
                                          "101:+Z", "110:+Z", "115:+Y", "115:+Z", "202:+Z")]
    inputs = [Channel.parse("5:+Z"), Channel.parse("110:+Y")]
    f = np.arange(1.0, 14.0, 0.02)
    keep = modes.frequencies_hz < 20
    S, W = modes.shapes[:, keep], modes.radians[keep]
    H = modal_frf(S, W, channel_matrix(model, outputs), channel_matrix(model, inputs).T, f,
                  0.02)  # fmt: skip
    src = write_npz(tmp_path / "frf.npz", FRFData(f, H, tuple(outputs), tuple(inputs)))
    out = tmp_path / "id"
    assert main(["identify", str(src), "--band", "2", "12", "--out", str(out),
                 "--geometry", str(LADDER)]) == 0  # fmt: skip
    assert "identified_shapes.unv: 5 shapes, 8 grids" in capsys.readouterr().err
    back = read_uff_shapes(out / "identified_shapes.unv")
    grids = sorted({c.grid for c in outputs})
    np.testing.assert_array_equal(back.grids.ids, grids)
    assert pairs_of(back.trace_pairs) == pairs_of(sensor_wireframe(model, grids))
    assert [s["analysis_type"] for s in back.shapes] == [3] * 5
    fe = fe_shapes(modes, model, grids)
    for k, s in enumerate(back.shapes):  # the test's modes are the model's, at its grids
        assert abs(s["eig"].imag) / (2 * np.pi) == pytest.approx(
            modes.frequencies_hz[k] * np.sqrt(1 - 0.02**2), rel=1e-3)
        test = np.column_stack([s["r1"], s["r2"], s["r3"]]).ravel()
        measured = np.abs(test) > 0
        phi = fe.values[k].ravel()[measured]
        t = test[measured]
        assert abs(np.vdot(t, phi)) ** 2 / (np.vdot(t, t).real * (phi @ phi)) > 0.999  # MAC
    # without --geometry: the shapes alone (on the grids a reader has by their ids)
    assert main(["identify", str(src), "--band", "2", "12", "--out", str(tmp_path / "bare")]) == 0
    types = [s["type"] for s in read_sets(tmp_path / "bare" / "identified_shapes.unv")]
    assert types == [55] * 5
    # a geometry deck without the test's grids is refused before the work, as is one
    # without --out
    other = tmp_path / "other.bdf"
    other.write_text(CD_DECK.format(cd=""))
    assert main(["identify", str(src), "--band", "2", "12", "--out", str(tmp_path / "no"),
                 "--geometry", str(other)]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert re.search(r"--geometry .*other\.bdf: no GRID for channel 5:\+Z \(\d+ more\)", err)
    assert not (tmp_path / "no" / "model.npz").exists()
    assert main(["identify", str(src), "--band", "2", "12", "--geometry", str(LADDER)]) == 2
    assert "expected --out DIR too" in capsys.readouterr().err
