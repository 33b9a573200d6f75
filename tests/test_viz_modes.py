"""Mode shapes that move and that compare (issue 27): the VTU's arrays (grid ids, each mode's
translations and rotations in basic, element ids, property ids and types, the frequencies)
read back with meshio and with VTK's reader (pyvista, as ParaView reads it) equal to the
solve; rotations in basic whatever the CD frames; springs and rigid elements as cells; an
animated GIF of the ladder frame has its frames and they move; ``femcal solve --gif``."""

from __future__ import annotations

import itertools

import meshio
import numpy as np
import pytest
import pyvista as pv
from PIL import Image, ImageSequence

from femcal.cli import main
from femcal.deck import read_deck
from femcal.io.modes import (
    ELEMENT_TYPE_CODES,
    basic_rotations,
    basic_translations,
    element_cells,
    write_vtu,
)
from femcal.model.build import build_model, load_model
from femcal.solve.normal_modes import solve_normal_modes
from femcal.viz.animate import animate_modes, phases

from .test_punch import CD_DECK, LADDER


@pytest.fixture(scope="module")
def ladder():
    model = load_model(LADDER)
    modes, _ = solve_normal_modes(model)
    return model, modes


def mode_names(mesh) -> list[str]:
    return sorted(k for k in mesh.point_data if k.startswith("mode_") and "rotation" not in k)


def test_vtu_arrays_read_back_with_meshio_equal_the_solve(tmp_path, ladder):
    model, modes = ladder
    path = write_vtu(tmp_path / "modes.vtu", modes, model)
    m = meshio.read(path)
    k = len(modes.eigenvalues)
    np.testing.assert_array_equal(m.points, model.xyz)
    np.testing.assert_array_equal(m.point_data["grid_id"], model.node_ids)
    t, r = basic_translations(modes, model), basic_rotations(modes, model)
    names = mode_names(m)
    assert len(names) == k
    for i, name in enumerate(names):
        assert name == f"mode_{i + 1:03d}_{modes.frequencies_hz[i]:.4g}Hz"
        np.testing.assert_array_equal(m.point_data[name], t[:, :, i])
        np.testing.assert_array_equal(m.point_data[f"{name}_rotation"], r[:, :, i])
        # every grid of the ladder frame is in basic: the solved components 4-6 themselves
        rows = model.dof_start[:, None] + 3 + np.arange(3)
        np.testing.assert_array_equal(m.point_data[f"{name}_rotation"], modes.shapes[rows, i])
    np.testing.assert_array_equal(m.field_data["frequencies_hz"], modes.frequencies_hz)
    # cells: 36 CBAR (lines), the CONM2 and 12 grounded CELAS2 (points), 3 RBE2 legs (lines)
    codes = {c.type: None for c in m.cells}
    assert set(codes) == {"line", "vertex"}
    etype = np.concatenate(m.cell_data["element_type"])
    eid = np.concatenate(m.cell_data["element_id"])
    pid = np.concatenate(m.cell_data["property_id"])
    cells = [c for c in m.cells for _ in range(len(c.data))]
    by_code = {code: name for name, code in ELEMENT_TYPE_CODES.items()}
    seen = {}
    for c, e, p in zip(etype, eid, pid, strict=True):
        seen.setdefault(by_code[int(c)], []).append((int(e), int(p)))
    bars = model.elements["CBAR"]
    assert seen["CBAR"] == list(zip(bars.ids.tolist(), bars.pids.tolist(), strict=True))
    assert {p for _, p in seen["CBAR"]} == {1, 2}  # rails PBAR 1, cross members PBARL 2
    assert seen["CONM2"] == [(401, -1)]
    assert seen["CELAS2"] == [(i, -1) for i in range(601, 613)]
    assert seen["RBE2"] == [(501, -1)] * 3
    rbe2 = [cell for cell, c in zip(cells, etype, strict=True) if c == ELEMENT_TYPE_CODES["RBE2"]]
    assert all(cell.type == "line" for cell in rbe2)
    legs = {tuple(model.node_ids[row].tolist()) for c in m.cells if c.type == "line"
            for row in c.data}  # fmt: skip
    assert {(301, 7), (301, 8), (301, 9)} <= legs
    for name in ("CBAR", "CONM2", "CELAS2", "RBE2"):
        assert m.field_data[f"element_type_{name}"].tolist() == [ELEMENT_TYPE_CODES[name]]


def test_vtu_arrays_read_back_with_vtk_as_paraview_reads_them(tmp_path, ladder):
    model, modes = ladder
    path = write_vtu(tmp_path / "modes.vtu", modes, model)
    g = pv.read(path)
    assert g.n_points == model.n_nodes and g.n_cells == 36 + 1 + 12 + 3
    np.testing.assert_array_equal(g.point_data["grid_id"], model.node_ids)
    t, r = basic_translations(modes, model), basic_rotations(modes, model)
    for i, f in enumerate(modes.frequencies_hz):
        name = f"mode_{i + 1:03d}_{f:.4g}Hz"
        np.testing.assert_array_equal(g.point_data[name], t[:, :, i])
        np.testing.assert_array_equal(g.point_data[f"{name}_rotation"], r[:, :, i])
    codes = g.cell_data["element_type"]
    assert np.bincount(codes)[[12, 19, 20, 22]].tolist() == [36, 12, 1, 3]
    np.testing.assert_array_equal(g.cell_data["element_id"][codes == 12],
                                  model.elements["CBAR"].ids)  # fmt: skip
    np.testing.assert_array_equal(g.field_data["frequencies_hz"], modes.frequencies_hz)
    assert g.field_data["element_type_RBE2"].tolist() == [22]
    # "Warp By Vector" of a mode moves the grids by its translations
    warped = g.warp_by_vector(f"mode_001_{modes.frequencies_hz[0]:.4g}Hz", factor=2.0)
    np.testing.assert_allclose(warped.points, model.xyz + 2.0 * t[:, :, 0], atol=1e-9)


def test_vtu_rotations_and_translations_are_in_basic_whatever_the_cd_frames(tmp_path, write):
    """GRID 3 of the cantilever solved in a CD frame along (1, 1, 1): its rotations and
    translations in the VTU are those of the same model in basic (up to each mode's sign)."""
    arrays = []
    for cd, name in (("", "basic"), ("7", "rotated")):
        model = build_model(read_deck(write(CD_DECK.format(cd=cd), f"{name}.bdf")))
        modes, _ = solve_normal_modes(model)
        m = meshio.read(write_vtu(tmp_path / f"{name}.vtu", modes, model))
        arrays.append((m, modes))
    (m0, _), (m1, _) = arrays
    assert mode_names(m0) == mode_names(m1)
    turned = 0
    for name in mode_names(m0):
        t0, t1 = m0.point_data[name], m1.point_data[name]
        r0, r1 = m0.point_data[f"{name}_rotation"], m1.point_data[f"{name}_rotation"]
        both0, both1 = np.hstack([t0, r0]), np.hstack([t1, r1])
        ref = np.unravel_index(np.argmax(np.abs(both0)), both0.shape)
        sign = np.sign(both0[ref] * both1[ref])
        scale = np.abs(both0).max()
        assert np.abs(sign * both1 - both0).max() <= 1e-8 * scale
        turned += np.abs(r0[2]).max() > 1e-3 * np.abs(r0).max()  # GRID 3 (CD 7) rotates
    assert turned >= 2


def test_every_drawn_card_has_an_element_type_code():
    from femcal.io.modes import _CELLS, _SOLID_CELLS, _SPRINGS, RIGID_TYPES

    cards = {*_CELLS, *(name for name, _ in _SOLID_CELLS), *_SPRINGS, *RIGID_TYPES}
    assert cards <= set(ELEMENT_TYPE_CODES)
    assert len(set(ELEMENT_TYPE_CODES.values())) == len(ELEMENT_TYPE_CODES)


def test_springs_between_grids_are_lines_and_to_ground_points(write):
    deck = CD_DECK.format(cd="").replace("SPC1,1", "CELAS2,20,1000.,2,2,4,2\n"
                                         "CELAS2,21,500.,4,3\nSPC1,1")  # fmt: skip
    model = build_model(read_deck(write(deck)))
    blocks = {(b.element_type, b.kind): b for b in element_cells(model)}
    line, point = blocks[("CELAS2", "line")], blocks[("CELAS2", "vertex")]
    assert line.ids.tolist() == [20] and model.node_ids[line.nodes].tolist() == [[2, 4]]
    assert point.ids.tolist() == [21] and model.node_ids[point.nodes].tolist() == [[4]]
    plain = {(b.element_type, b.kind) for b in element_cells(model, springs=False, rigid=False)}
    assert ("CELAS2", "line") not in plain and ("CBAR", "line") in plain


def frames_of(path) -> list[np.ndarray]:
    with Image.open(path) as im:
        return [np.asarray(f.convert("RGB")).astype(int) for f in ImageSequence.Iterator(im)]


def test_gif_of_the_ladder_frame_has_its_frames_and_moves(tmp_path, ladder):
    model, modes = ladder
    n = 8
    (path,) = animate_modes(modes, model, tmp_path, which=[1], n_frames=n, fps=10,
                            window=(400, 300), title="ladder")  # fmt: skip
    assert path.name == "mode_002.gif" and not list(tmp_path.glob(".*"))
    with Image.open(path) as im:
        assert im.n_frames == n and im.info["loop"] == 0
        assert im.info["duration"] == 100  # ms
    frames = frames_of(path)
    assert all(f.shape == (300, 400, 3) for f in frames)
    changed = [int((a != b).any(axis=2).sum()) for a, b in itertools.pairwise(frames)]
    assert min(changed) > 100  # every frame differs from the one before: the shape moves
    # the two extremes (sin = +1, -1) differ far more than the drawing's own noise
    assert int((frames[n // 4] != frames[3 * n // 4]).any(axis=2).sum()) > 2000
    np.testing.assert_allclose(phases(n)[[0, n // 4, n // 2, 3 * n // 4]], [0, 1, 0, -1],
                               atol=1e-12)  # fmt: skip


def test_gif_options_are_checked(tmp_path, ladder):
    model, modes = ladder
    with pytest.raises(ValueError, match="at least 2 frames"):
        animate_modes(modes, model, tmp_path, n_frames=1)
    with pytest.raises(ValueError, match="positive frame rate"):
        animate_modes(modes, model, tmp_path, fps=0)


def test_solve_writes_the_vtu_and_gifs_from_the_command_line(tmp_path, capsys):
    out, gif = tmp_path / "out", tmp_path / "gif"
    code = main(["solve", str(LADDER), "--out", str(out), "--gif", str(gif), "--gif-modes", "1"])
    assert code == 0
    assert [p.name for p in sorted(gif.iterdir())] == ["mode_001.gif"]
    with Image.open(gif / "mode_001.gif") as im:
        assert im.n_frames == 24
    m = meshio.read(out / "modes.vtu")
    assert "grid_id" in m.point_data and "element_type" in m.cell_data
    assert "wrote 1 animations" in capsys.readouterr().err
    assert main(["solve", str(LADDER), "--gif-modes", "2"]) == 2
    assert "expected --gif DIR too" in capsys.readouterr().err
    assert main(["solve", str(LADDER), "--gif", str(gif), "--gif-modes", "0"]) == 2
    assert "expected a number of modes >= 1" in capsys.readouterr().err
