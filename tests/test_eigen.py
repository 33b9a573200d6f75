"""Eigensolver paths agree: dense, Lanczos on CHOLMOD, Lanczos on SuperLU; EIGRL semantics."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp

from femcal.cli import main
from femcal.errors import SolverError
from femcal.model import EigenRequest
from femcal.solve import eigen as modal
from femcal.solve.eigen import solve_modes
from femcal.solve.factor import HAVE_CHOLMOD

from .conftest import REFDECKS


def chain(n: int) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Free-free spring-mass chain: exact eigenvalues 2k/m (1 - cos(j pi / n)), j = 0..n-1."""
    main_diag = np.full(n, 2.0)
    main_diag[[0, -1]] = 1.0
    K = sp.diags([main_diag, -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1], format="csr")
    return K * 1e4, sp.identity(n, format="csr") * 2.0


def exact(n: int) -> np.ndarray:
    return 1e4 / 2.0 * 2 * (1 - np.cos(np.arange(n) * np.pi / n))


@pytest.mark.parametrize("backend", ["superlu", "cholmod"])
def test_lanczos_matches_closed_form_with_rigid_mode(backend):
    if backend == "cholmod" and not HAVE_CHOLMOD:
        pytest.skip("scikit-sparse not installed")
    K, M = chain(2000)
    r = solve_modes(K, M, EigenRequest(nd=8), backend=backend)
    assert r.backend == backend
    assert r.eigenvalues[0] == pytest.approx(0.0, abs=1e-6)
    assert r.eigenvalues[1:] == pytest.approx(exact(2000)[1:8], rel=1e-8)
    assert np.allclose(r.generalized_mass, 1.0)


def test_dense_path_and_v1_v2_window(monkeypatch):
    K, M = chain(50)
    lam = exact(50)
    f = np.sqrt(lam) / (2 * np.pi)
    r = solve_modes(K, M, EigenRequest(v1=f[3] * 0.999, v2=f[9] * 1.001, nd=None))
    assert r.backend == "dense" and r.eigenvalues == pytest.approx(lam[3:10], rel=1e-10)
    monkeypatch.setattr(modal, "DENSE_LIMIT", 10)  # same window through Lanczos
    r2 = solve_modes(K, M, EigenRequest(v1=f[3] * 0.999, v2=f[9] * 1.001, nd=None))
    assert r2.backend != "dense" and r2.eigenvalues == pytest.approx(lam[3:10], rel=1e-8)


def test_max_normalisation():
    K, M = chain(30)
    r = solve_modes(K, M, EigenRequest(nd=3, norm="MAX"))
    assert np.allclose(np.abs(r.vectors).max(axis=0), 1.0)


def test_mechanism_is_reported():
    K = sp.diags([1.0, 0.0, 1.0], format="csr")
    M = sp.diags([1.0, 0.0, 1.0], format="csr")
    with pytest.raises(SolverError, match="mechanism"):
        solve_modes(K, M, EigenRequest(nd=2))


def test_cli_solve_writes_table_json_results_and_pictures(tmp_path, capsys):
    deck = REFDECKS / "pyn_bah_wing" / "BAH_Plane_cont_gust_LINE5000000_10FREQs.bdf"
    out = tmp_path / "out"
    args = ["solve", str(deck), "--json", str(tmp_path / "m.json"), "--out", str(out),
            "--png", str(tmp_path / "png"), "--modes", "3"]  # fmt: skip
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "R E A L   E I G E N V A L U E S" in printed
    data = json.loads((tmp_path / "m.json").read_text())
    assert [m["mode"] for m in data["modes"]] == [1, 2, 3]
    assert data["modes"][2]["frequency_hz"] == pytest.approx(2.45402, rel=1e-4)  # NASTRAN 2014.1
    npz = np.load(out / "modes.npz")
    assert npz["shapes"].shape == (data["n_dof"], 3)
    assert (out / "modes.vtu").stat().st_size > 0 and (out / "eigenvalues.txt").exists()
    pngs = sorted((tmp_path / "png").glob("mode_*.png"))
    assert [p.name for p in pngs] == ["mode_001.png", "mode_002.png", "mode_003.png"]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


def test_a_flat_plate_solved_in_parts_gives_the_whole_problems_modes(write, monkeypatch):
    """A flat cantilever plate's membrane and bending DOF do not couple: solved as two
    parts (the membrane's roots checked to lie above the bending's 12th, never iterated
    on), it gives the modes of the problem solved whole."""
    from femcal.deck import read_deck
    from femcal.model.build import build_model
    from femcal.solve.normal_modes import solve_normal_modes

    n = 32
    lines = ["SOL 103", "CEND", "METHOD = 1", "SPC = 1", "BEGIN BULK", "EIGRL,1,,,12",
             "PSHELL,1,1,2.,1,,1", "MAT1,1,2.1e5,,0.3,7.85e-9"]  # fmt: skip
    gid = lambda i, j: j * (n + 1) + i + 1  # noqa: E731
    for j in range(n + 1):
        for i in range(n + 1):
            lines.append(f"GRID,{gid(i, j)},,{500.0 * i / n},{400.0 * j / n},0.")
        lines.append(f"SPC1,1,123456,{gid(0, j)}")
    for j in range(n):
        for i in range(n):
            g = gid(i, j)
            lines.append(f"CQUAD4,{j * n + i + 1},1,{g},{g + 1},{g + n + 2},{g + n + 1}")
    model = build_model(read_deck(write("\n".join([*lines, "ENDDATA", ""]))))
    said: list[str] = []
    parts, _ = solve_normal_modes(model, progress=said.append)
    assert any("2 independent parts" in s for s in said)
    assert any("no root of it is wanted" in s for s in said)
    monkeypatch.setattr(modal, "independent_parts", lambda K, M: [np.arange(K.shape[0])])
    said.clear()
    whole, _ = solve_normal_modes(model, progress=said.append)
    assert not any("independent parts" in s for s in said)
    np.testing.assert_allclose(parts.eigenvalues, whole.eigenvalues, rtol=1e-9)
    mac = (parts.shapes.T @ whole.shapes) ** 2 / np.outer(
        (parts.shapes**2).sum(0), (whole.shapes**2).sum(0))
    # the first five roots are apart: each mode is the same (the rest may pair up)
    assert np.diag(mac)[:5] == pytest.approx(1.0, abs=1e-8)


def test_fill_ordering_is_amd_for_surfaces_and_cholmods_choice_with_solids(tmp_path):
    """Shells, bars and springs make a two-dimensional graph: AMD. A solid element
    anywhere: CHOLMOD's own choice (METIS where AMD fills much). Either ordering gives the
    same roots."""
    from femcal.deck import read_deck
    from femcal.model.build import build_model
    from femcal.solve.factor import factorize
    from femcal.solve.normal_modes import fill_ordering

    shell = ["BEGIN BULK", "PSHELL,1,1,2.,1,,1", "MAT1,1,2.1e5,,0.3,7.85e-9",
             "GRID,1,,0.,0.,0.", "GRID,2,,1.,0.,0.", "GRID,3,,1.,1.,0.", "GRID,4,,0.,1.,0.",
             "CQUAD4,1,1,1,2,3,4"]  # fmt: skip
    solid = ["PSOLID,2,1", *[f"GRID,{g + 4},,{x},{y},1." for g, (x, y) in
                             enumerate(((0., 0.), (1., 0.), (1., 1.), (0., 1.)), start=1)],
             "CHEXA,2,2,1,2,3,4,5,6,", ",7,8"]  # fmt: skip
    (tmp_path / "shell.bdf").write_text("\n".join([*shell, "ENDDATA", ""]))
    (tmp_path / "solid.bdf").write_text("\n".join([*shell, *solid, "ENDDATA", ""]))
    assert fill_ordering(build_model(read_deck(tmp_path / "shell.bdf"))) == "amd"
    assert fill_ordering(build_model(read_deck(tmp_path / "solid.bdf"))) == "default"
    K, M = chain(3000)
    if HAVE_CHOLMOD:
        roots = {o: solve_modes(K, M, EigenRequest(nd=6), ordering=o).eigenvalues
                 for o in ("default", "amd")}  # fmt: skip
        np.testing.assert_allclose(roots["amd"], roots["default"], rtol=1e-10, atol=1e-8)
    with pytest.raises(ValueError, match="ordering 'metis'"):
        factorize(K, ordering="metis")
