"""Decks a hostile (or hurried) user writes: each gives the right answer or a clear error that
names file:line, card, field and id, never a silent wrong answer or a traceback."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from femcal.atomic import remove_stale_temporaries, write_lines
from femcal.cli import EXIT_INTERNAL, EXIT_INTERRUPTED, main
from femcal.deck.reader import read_deck
from femcal.errors import DeckError, FemcalWarning, ModelError, ResourceError, SolverError
from femcal.model.analysis import EigenRequest
from femcal.model.build import load_model
from femcal.solve import eigen
from femcal.solve.normal_modes import solve_normal_modes

ROOT = Path(__file__).resolve().parents[1]


def plate(nx: int = 8, ny: int = 6, *, E: str = "7.+4", rho: str = "2.7-9", nd: int = 10,
          head: str = "", bulk: str = "") -> str:  # fmt: skip
    """A free-free aluminium plate (mm, tonne, s) of nx x ny CQUAD4; six rigid-body modes."""
    lines = ["SOL 103", "CEND", "METHOD = 1", *head.splitlines(), "BEGIN BULK",
             f"EIGRL,1,,,{nd}", "PSHELL,1,1,3.,1,,1", f"MAT1,1,{E},,.33,{rho}"]  # fmt: skip
    gid = lambda i, j: 1 + i + (nx + 1) * j  # noqa: E731
    for j in range(ny + 1):
        for i in range(nx + 1):
            lines.append(f"GRID,{gid(i, j)},,{400.0 * i / nx!r},{300.0 * j / ny!r},0.")
    for j in range(ny):
        for i in range(nx):
            lines.append(f"CQUAD4,{1 + i + nx * j},1,{gid(i, j)},{gid(i + 1, j)},"
                         f"{gid(i + 1, j + 1)},{gid(i, j + 1)}")  # fmt: skip
    lines += [*bulk.splitlines(), "ENDDATA"]
    return "\n".join(lines) + "\n"


def elastic_hz(path: Path) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemcalWarning)
        modes, _ = solve_normal_modes(load_model(path))
    return modes.frequencies_hz[6:]


# ----------------------------------------------------------------- case control and SOL


def test_a_misspelt_case_control_command_is_an_error_that_suggests_the_command(write):
    path = write(plate(head="SCP = 1"))
    with pytest.raises(DeckError) as e:
        read_deck(path)
    assert f"{path}:4: CASE CONTROL command: found 'SCP'" in str(e.value)
    assert "did you mean SPC?" in str(e.value)


def test_an_unknown_command_unlike_any_that_changes_the_modes_warns(write):
    # MBDEXPORT (MSC's flexible-body export) was once missing from the list; commands femcal
    # does not know and that look like none of METHOD, SPC, MPC ... are read past with a word
    path = write(plate(head="MBDEXPORT RECURDYN FLEXBODY=YES\nFROBNICATE = 3"))
    with pytest.warns(FemcalWarning, match=f"{path}:5: case control command FROBNICATE is not "
                      "one femcal knows; it is left alone"):  # fmt: skip
        deck = read_deck(path)
    assert deck.case.value("METHOD") == "1"


def test_abbreviated_and_unused_case_control_commands_still_read(write):
    deck = read_deck(write(plate(head="DISP = ALL\nSPCF(PLOT) = ALL\nECHO = NONE\nMEFFMASS = YES")))
    assert deck.case.value("DISPLACEMENT") == "ALL"


@pytest.mark.parametrize("key, cards", [("SPC", "SPC, SPC1 or SPCADD"), ("MPC", "MPC or MPCADD")])
def test_a_selected_set_without_cards_is_solved_without_it_with_nastrans_warning(write, key,
                                                                                 cards):  # fmt: skip
    # MSC Nastran goes on with user warning 2053 (reference deck ekm_cbar_suport); femcal does
    # the same, and says so with the file:line of the command.
    path = write(plate(head=f"{key} = 77", nd=8))
    with pytest.warns(FemcalWarning, match=rf"{path}:4: case control {key} = 77: no {cards} "
                      "card defines set 77"):  # fmt: skip
        model = load_model(path)
    free = write(plate(nd=8), "free.bdf")
    modes, _ = solve_normal_modes(model)
    np.testing.assert_allclose(modes.frequencies_hz[6:], elastic_hz(free), rtol=1e-10)


def test_an_spcadd_of_an_undefined_set_warns_naming_the_union(write):
    path = write(plate(head="SPC = 5", bulk="SPCADD,5,1,2\nSPC1,1,3,1"))
    with pytest.warns(FemcalWarning, match=r"set 2 \(through SPCADD 5\)"):
        load_model(path)


@pytest.mark.parametrize("sol", ["101", "10", "SESTATIC"])
def test_a_solution_femcal_does_not_run_is_solved_as_sol_103_with_a_warning(write, sol):
    path = write(plate().replace("SOL 103", f"SOL {sol}"))
    with pytest.warns(FemcalWarning, match=f"SOL {sol}, which femcal does not run"):
        modes, _ = solve_normal_modes(load_model(path))
    np.testing.assert_allclose(modes.frequencies_hz[6:], elastic_hz(write(plate(), "b.bdf")),
                               rtol=1e-10)  # fmt: skip


def test_method_without_a_value_names_its_line(write):
    path = write(plate().replace("METHOD = 1", "METHOD ="))
    with pytest.raises(ModelError, match=rf"{path}:3: case control METHOD = : expected a set id"):
        solve_normal_modes(load_model(path))


# ----------------------------------------------------------------- values out of range


@pytest.mark.parametrize("mat, message", [
    ("MAT1,1,7.+4,,.33,-2.7-9", "MAT1 1 field RHO = -2.7e-09: expected a real >= 0"),
    ("MAT1,1,-7.+4,,.33,2.7-9", "MAT1 1 field E = -70000: expected a real >= 0"),
    ("MAT1,1,7.+4,,-1.5,2.7-9", "MAT1 1 field NU = -1.5: expected a Poisson's ratio in (-1, 0.5]"),
])  # fmt: skip
def test_material_constants_no_material_has_are_errors(write, mat, message):
    text = plate().replace("MAT1,1,7.+4,,.33,2.7-9", mat)
    path = write(text)
    line = text.splitlines().index(mat) + 1
    with pytest.raises(ModelError) as e:
        load_model(path)
    assert f"{path}:{line}: {message}" in str(e.value)


def test_a_real_beyond_double_precision_is_an_error_in_its_field(write):
    path = write(plate(E="1.+400"))
    with pytest.raises(DeckError, match=r"MAT1 field 3 \(E\): found '1\.\+400'; expected a real "
                       "within double precision"):  # fmt: skip
        read_deck(path)


@pytest.mark.parametrize("gid", ["0", "-1"])
def test_grid_ids_below_one_are_errors(write, gid):
    path = write(plate(bulk=f"GRID,{gid},,0.,0.,9."))
    with pytest.raises(ModelError, match=f"GRID {gid} field ID = {gid}: expected an id from 1 to"):
        load_model(path)


def test_grid_ids_beyond_64_bits_are_errors_not_overflows(write):
    path = write(plate(bulk="GRID,9223372036854775808,,0.,0.,9."))
    with pytest.raises(DeckError, match=r"GRID field 2 \(ID\): found '9223372036854775808'; "
                       "expected an integer of magnitude below 2\\^63"):  # fmt: skip
        read_deck(path)


@pytest.mark.parametrize("card", ["CQUAD4,999,1,1,2,2,11", "CHEXA,999,9,1,2,11,10,1,2\n,11,10",
                                  "CTRIA3,999,1,1,1,2"])  # fmt: skip
def test_an_element_that_names_a_grid_twice_is_an_error(write, card):
    path = write(plate(bulk=f"{card}\nPSOLID,9,1"))
    with pytest.raises(ModelError, match=f"{card.split(',')[0]} 999 names GRID .* more than once"):
        load_model(path)


@pytest.mark.parametrize("eigrl, found, expected", [
    ("EIGRL,1,,,0", "0", "an integer > 0"),
    ("EIGRL,1,,,-5", "-5", "an integer > 0"),
    ("EIGRL,1,100.,10.,5", "10.", "a frequency above V1 = 100."),
])  # fmt: skip
def test_eigrl_requests_that_ask_for_nothing_are_errors(write, eigrl, found, expected):
    path = write(plate().replace("EIGRL,1,,,10", eigrl))
    with pytest.raises(DeckError, match=f"EIGRL field .*found '{found}'; expected {expected}"):
        read_deck(path)


# ----------------------------------------------------------------- the eigen solution


def test_a_massless_model_is_an_error_on_both_solution_paths(write, monkeypatch):
    path = write(plate(rho="0."))
    model = load_model(path)
    with pytest.raises(SolverError, match="the model has no mass on its free DOF"):
        solve_normal_modes(model)
    monkeypatch.setattr(eigen, "DENSE_LIMIT", 10)
    with pytest.raises(SolverError, match="the model has no mass on its free DOF"):
        solve_normal_modes(model)


@pytest.mark.parametrize("dense_limit", [100_000, 10])
@pytest.mark.parametrize("E, rho", [("7.-8", "2.7-9"), ("7.+4", "2.7+3"), ("7.+16", "2.7-9")])
def test_the_modes_do_not_depend_on_the_unit_system(write, monkeypatch, dense_limit, E, rho):
    # E x 1e-12 (a modulus of 7e-8), rho x 1e12 (kg/m^3 in an mm-N-MPa deck), E x 1e12: every
    # eigenvalue scales by the same factor, and so must the modes femcal finds, on the dense
    # and the Lanczos path, free-free (six rigid-body modes) as they are. A shift fixed at
    # 1 Hz put the first two far above the spectrum (wrong modes, or ARPACK failing) and the
    # third far below it (the elastic modes dropped as infinite).
    monkeypatch.setattr(eigen, "DENSE_LIMIT", dense_limit)
    nominal = elastic_hz(write(plate(), "nominal.bdf"))
    scaled = elastic_hz(write(plate(E=E, rho=rho), "scaled.bdf"))
    factor = np.sqrt(float(E.replace("+", "e+").replace("-", "e-")) / 7e4
                     / (float(rho.replace("+", "e+").replace("-", "e-")) / 2.7e-9))  # fmt: skip
    assert len(scaled) == len(nominal) == 4
    np.testing.assert_allclose(scaled, nominal * factor, rtol=1e-7)


def test_a_stiff_rod_pair_keeps_its_elastic_modes(write):
    # Two free rods, 1 mm long, unit area, steel: each has a rigid axial mode and one at
    # omega^2 = 2 k / m (lumped masses m = rho A L / 2, k = E A / L), 1.65 MHz, 2e12 times the
    # 1 Hz shift. The dense solution took them for massless directions.
    text = ("SOL 103\nCEND\nMETHOD = 1\nBEGIN BULK\nEIGRL,1,,,4\nGRID,1,,0.,0.,0.\n"
            "GRID,2,,1.,0.,0.\nGRID,3,,5.,0.,0.\nGRID,4,,6.,0.,0.\nCROD,1,1,1,2\nCROD,2,1,3,4\n"
            "PROD,1,1,1.\nMAT1,1,2.1+5,,.3,7.8-9\nENDDATA\n")  # fmt: skip
    modes, _ = solve_normal_modes(load_model(write(text)))
    omega2 = 2 * 2.1e5 / (7.8e-9 / 2)
    np.testing.assert_allclose(modes.eigenvalues[2:], [omega2, omega2], rtol=1e-9)
    assert np.abs(modes.eigenvalues[:2]).max() < 1e-6 * omega2


def test_nd_above_the_dof_is_capped_with_a_warning(write):
    path = write(plate(nx=2, ny=1, nd=500))
    with pytest.warns(FemcalWarning, match="ND = 500 roots asked for, the model has 36 free DOF"):
        modes, _ = solve_normal_modes(load_model(path))
    assert len(modes.eigenvalues) == 18  # the lumped mass leaves the 18 rotations massless


def test_a_request_too_big_for_memory_is_an_error_before_allocating(write, monkeypatch):
    import femcal.resources as res

    monkeypatch.setattr(res, "available_memory_bytes", lambda: 1_000_000)
    monkeypatch.setattr(eigen, "DENSE_LIMIT", 10)
    model = load_model(write(plate()))
    with pytest.raises(ResourceError, match=r"roots of 378 DOF would need .* of memory; 976\.6 "
                       "KiB is available"):  # fmt: skip
        solve_normal_modes(model, request=EigenRequest(nd=150))


# ----------------------------------------------------------------- files


def test_include_reads_only_regular_files(write, tmp_path):
    path = write(plate(bulk="INCLUDE '/dev/zero'\nINCLUDE '.'"))
    with pytest.raises(DeckError) as e:
        read_deck(path)
    text = str(e.value)
    assert "INCLUDE: found '/dev/zero'; expected a regular file" in text
    assert f"INCLUDE: found '{tmp_path}'; expected a regular file" in text
    with pytest.raises(DeckError, match="/dev/zero: deck; expected a regular file"):
        read_deck("/dev/zero")


def test_a_deck_past_the_size_limit_is_an_error(write):
    inc = write("GRID,1000,,0.,0.,1.\n" * 50, "big.inc")
    path = write(plate(bulk=f"INCLUDE '{inc.name}'"))
    size = path.stat().st_size
    read_deck(path, max_bytes=size + inc.stat().st_size)
    with pytest.raises(DeckError, match=r"INCLUDE: found .*big\.inc'; expected a deck of at most"):
        read_deck(path, max_bytes=size + 100)


def test_temporary_files_of_killed_writers_are_removed_by_the_next_writer(tmp_path):
    from femcal.atomic import _host

    target = tmp_path / "modes.npz"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    host = _host()
    stale = tmp_path / f".modes.npz.{host}.{dead}.abc123xy.npz"
    live = tmp_path / f".modes.npz.{host}.{os.getppid()}.abc123xy.npz"  # a running process's
    other_host = tmp_path / f".modes.npz.elsewhere.{dead}.abc123xy.npz"  # a shared folder's
    other_target = tmp_path / f".modes.npz.2024.{host}.{dead}.abc123xy.npz"  # modes.npz.2024's
    for f in (stale, live, other_host, other_target):
        f.write_text("part")
    assert remove_stale_temporaries(target) == [stale]
    write_lines(tmp_path / "other.txt", ["x"])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [live.name, other_host.name, other_target.name, "other.txt"])


@pytest.mark.parametrize("when", ["made", "written"])
def test_ctrl_c_while_a_file_is_written_leaves_no_temporary_file(tmp_path, monkeypatch, when):
    """Ctrl-C right after the temporary file is made (before its name is returned by the
    call that makes it), or while it is written: the interruption goes on, and neither the
    target nor the temporary file is left."""
    import femcal.atomic

    real_open = os.open

    def open_then_interrupt(name, flags, mode=0o777, *args, **kwargs):
        fd = real_open(name, flags, mode, *args, **kwargs)
        if when == "made" and Path(name).parent == tmp_path:
            os.close(fd)
            raise KeyboardInterrupt
        return fd

    def write(tmp):
        Path(tmp).write_text("part")
        if when == "written":
            raise KeyboardInterrupt

    monkeypatch.setattr(femcal.atomic.os, "open", open_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        femcal.atomic.write_atomic(tmp_path / "start_001.json", write)
    assert list(tmp_path.iterdir()) == []


def test_an_unwritable_output_is_named_not_its_temporary_file(tmp_path):
    """The writer's temporary file is femcal's business: an error names the file asked for
    (/proc takes no new files, even for root)."""
    with pytest.raises(OSError) as e:
        write_lines("/proc/femcal-out.json", ["x"])
    assert e.value.filename == "/proc/femcal-out.json"
    assert ".femcal-out.json." not in str(e.value)


# ----------------------------------------------------------------- the command line


def test_solve_out_naming_a_file_is_a_clear_error(write, capsys):
    path = write(plate())
    f = write("x", "taken")
    assert main(["solve", str(path), "--out", str(f)]) == 2
    assert capsys.readouterr().err.strip().endswith(f"--out {f}: expected a folder, but {f} is a file")


def test_warnings_reach_the_console_as_one_line(write, capsys):
    assert main(["solve", str(write(plate().replace("SOL 103", "SOL 101")))]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if not ln.startswith("[")]
    assert err == ["femcal solve: warning: the deck asks for SOL 101, which femcal does not run: "
                   "it is solved as SOL 103 (normal modes)"]  # fmt: skip


def test_an_unexpected_exception_is_one_line_not_a_traceback(write, capsys, monkeypatch):
    from femcal.cli import solve

    def broken(args):
        raise IndexError("index 3 is out of bounds")

    monkeypatch.setattr(solve, "run", broken)
    assert main(["solve", "x.bdf"]) == EXIT_INTERNAL
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "internal error (IndexError: index 3 is out of bounds); this is a bug" in err
    monkeypatch.setenv("FEMCAL_TRACEBACK", "1")
    with pytest.raises(IndexError):
        main(["solve", "x.bdf"])


def test_ctrl_c_ends_a_command_with_one_line_and_status_130(tmp_path):
    # 400 modes of the truck frame (87 000 DOF), interrupted in the Lanczos iteration; the
    # modes files it was asked for are not there, not even in part
    deck = ROOT / "models" / "truck_frame" / "hammer_frame.bdf"
    proc = subprocess.Popen([sys.executable, "-m", "femcal", "solve", str(deck), "--modes",
                             "400", "--out", str(tmp_path / "out")], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    err = []
    for line in proc.stderr:
        err.append(line.rstrip("\n"))
        if "Lanczos:" in line:
            time.sleep(0.5)
            proc.send_signal(signal.SIGINT)
            break
    err += proc.stderr.read().splitlines()
    assert proc.wait(timeout=60) == EXIT_INTERRUPTED, err
    assert [ln for ln in err if not ln.startswith("[")] == ["femcal solve: interrupted"]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


# ----------------------------------------------------------------- cases the fuzzer found


def test_an_id_list_with_an_id_beyond_64_bits_is_an_error(write):
    # fuzz seed 178: SPC1 G6 = 2^63 overflowed in the grid lookup
    path = write(plate(head="SPC = 1", bulk="SPC1,1,123456,1,,,,,9223372036854775808"))
    with pytest.raises(DeckError, match=r"SPC1 field 9: found '9223372036854775808'; expected an "
                       "integer of magnitude below 2\\^63"):  # fmt: skip
        read_deck(path)


def test_spc1_thru_fixes_the_grids_of_the_range_that_exist_without_listing_them(write):
    # QRG SPC1: the points of the THRU form need not exist. 1 THRU 99999999 is every grid,
    # read without a list of 1e8 ids.
    model = load_model(write(plate(head="SPC = 1", bulk="SPC1,1,3,1,THRU,99999999")))
    fixed = model.constraints.fixed
    assert len(fixed) == model.n_grids and set(model.dof_owner(fixed)[1]) == {3}


def test_a_thru_range_of_a_hundred_million_ids_in_a_list_is_an_error_not_a_memory_grab(write):
    path = write(plate(head="SPC = 1", bulk="SPC1,1,123456,1,2,5,THRU,99999999"))
    with pytest.raises(DeckError, match="SPC1 field 8: found '99999999'; expected a THRU range "
                       "that, with the card's other ids, lists at most 10000000"):  # fmt: skip
        read_deck(path)


def test_latin1_letters_survive_reading_and_writing_back(write, tmp_path):
    # fuzz seed 1292: 'ÿ'.upper() is 'Ÿ', which latin-1 (the writer's encoding) cannot hold
    from femcal.deck.writer import write_deck

    path = tmp_path / "latin1.bdf"
    path.write_bytes(plate(bulk="PLOTEL,9001,1,2\nVM,ÿé").encode("latin-1"))
    back = write_deck(read_deck(path), tmp_path / "back.bdf")
    assert "ÿé" in back.read_text(encoding="latin-1")


def test_quadratic_solids_without_density_are_massless_not_nan(write):
    # fuzz seed 1477: HRZ lumping of a CTETRA with RHO = 0 divided 0 by 0
    from femcal.elements.solid import solid_matrices

    xyz = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [.5, 0, 0], [.5, .5, 0],
                     [0, .5, 0], [0, 0, .5], [.5, 0, .5], [0, .5, .5]]], float)  # fmt: skip
    _, M = solid_matrices("TETRA10", xyz, np.eye(6)[None] * 1e3, np.zeros(1))
    assert np.all(M == 0)


def test_xy_output_blocks_are_read_past(write):
    deck = read_deck(write(plate(head="OUTPUT(XYOUT)\nXYPLOT DISP /1(T3)\nXTITLE = x")))
    assert deck.case.value("METHOD") == "1"


def test_mat1_whose_e_and_g_give_no_poisson_ratio_is_an_error(write):
    # fuzz seed 104066: E = 210000, G = -0., NU blank -> NU = E / (2 G) - 1 = -inf, NaN in K
    path = write(plate().replace("MAT1,1,7.+4,,.33,2.7-9", "MAT1,1,7.+4,-0.,,2.7-9"))
    with pytest.raises(ModelError, match=r"MAT1 1: E = 70000 and G = -0 without NU give NU = E / "
                       r"\(2 G\) - 1 = -inf; expected G other than 0, or NU"):  # fmt: skip
        load_model(path)
    # a finite NU outside (-1, 0.5] is a stick model's E and G, which rods and bars use as given
    load_model(write(plate().replace("MAT1,1,7.+4,,.33,2.7-9", "MAT1,1,2.1+5,2.+4,,7.85-9"),
                     "stick.bdf"))


def test_bars_of_a_material_without_shear_modulus_have_no_torsional_stiffness(write):
    # fuzz seed 104066: MAT1 G = -0. with E and NU given: the bar's section compliance
    # divided by G and the AUTOSPC eigen solution met NaN. The QRG allows G = 0 (MAT1 G >=
    # 0; E alone gives G = 0): no torsional stiffness, the modes those of G blank
    text = (HEAD_BAR + "MAT1,1,2.1+5,-0.,.3,7.85-9\nENDDATA\n")
    f = solve_normal_modes(load_model(write(text)))[0].frequencies_hz
    blank = solve_normal_modes(load_model(write(text.replace("2.1+5,-0.,.3", "2.1+5,,"),
                                                "b.bdf")))[0].frequencies_hz
    assert np.isfinite(f).all() and f == pytest.approx(blank, abs=1e-6)


HEAD_BAR = ("SOL 103\nCEND\nMETHOD = 1\nBEGIN BULK\nEIGRL,1,,,3\nGRID,1,,0.,0.,0.\n"
            "GRID,2,,100.,0.,0.\nGRID,3,,200.,0.,0.\nCBAR,1,1,1,2,0.,0.,1.\nCBAR,2,1,2,3,0.,0.,1.\n"
            "PBAR,1,1,10.,20.,30.,40.\n")  # fmt: skip


@pytest.mark.parametrize("command", [
    ["calibrate", "cal.toml"],
    ["synth-test", "deck.bdf", "--params", "p", "--sensors", "s", "--inputs", "i"],
    ["model", "truck-frame"],
])  # fmt: skip
def test_out_naming_a_file_is_refused_before_any_work(write, capsys, command):
    f = write("x", "taken")
    assert main([*command, "--out", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"femcal {command[0]}: --out {f}: expected a folder, but {f} is a file"]


def test_a_density_that_puts_k_over_m_beyond_double_precision_is_an_error(write):
    # fuzz seed 717: RHO = 1e-300 beside a 1080 t CONM2; the median K_ii / M_ii overflowed and
    # the shift with it
    path = write(plate(E="7.+10", rho="1.-306", bulk="CONM2,99,1,,1080."))
    with pytest.raises(SolverError, match=r"stiffness-to-mass ratios K_ii / M_ii .* are beyond "
                       r"double precision"):  # fmt: skip
        solve_normal_modes(load_model(path))


def test_an_include_name_with_a_nul_character_is_an_error(write):
    # fuzz seed 8115: a NUL byte in an INCLUDE line reached os.stat
    path = write(plate(bulk="INCLUDE 'a\0b.inc'"))
    with pytest.raises(DeckError, match=r"INCLUDE: found .*; expected a file name without NUL"):
        read_deck(path)


def test_spc1_thru_is_written_back_as_a_range(write, tmp_path):
    from femcal.deck.writer import write_deck

    deck = read_deck(write(plate(head="SPC = 1", bulk="SPC1,1,3,5,THRU,99999999")))
    back = read_deck(write_deck(deck, tmp_path / "back.bdf"))
    assert back.records_of("SPC1")[0].ranges == ((5, 99999999),)


def test_a_negative_ply_thickness_is_an_error(write):
    # fuzz seed 203162: PCOMP ply T = -1.e30 gave NaN stiffness
    path = write(plate(bulk="PCOMP,6\n,1,0.1\n,1,-1.e30"))
    with pytest.raises(DeckError, match=r"PCOMP field 3: found '-1\.e30'; expected a ply "
                       r"thickness >= 0"):  # fmt: skip
        read_deck(path)


def test_a_stiffness_that_overflows_is_an_error(write):
    # every value in range, their products beyond double precision
    path = write(plate(E="1.7+308"))
    with pytest.raises(SolverError, match="K holds entries beyond double precision"):
        solve_normal_modes(load_model(path))


def test_bulk_cards_and_executive_statements_in_case_control_are_errors(write):
    # a line left on the wrong side of BEGIN BULK or CEND would otherwise be dropped
    path = write(plate(head="CBAR,1,1,1,2,0.,0.,1.\nSOL 101"))
    with pytest.raises(DeckError) as e:
        read_deck(path)
    assert f"{path}:4: CASE CONTROL command: found 'CBAR'; expected a case control command (a " \
           "bulk data card belongs after BEGIN BULK)" in str(e.value)
    assert f"{path}:5: CASE CONTROL command: found 'SOL'; expected a case control command " \
           "(executive control belongs before CEND)" in str(e.value)


@pytest.mark.parametrize(("name", "kind"), [
    ("hammer_test.uff", "a universal file (FRFs or shapes: femcal identify or correlate"),
    ("hammer_test.mat", "a MATLAB file (FRFs: femcal identify reads it)"),
    ("rig_test.rsp", "an RPC III time history (femcal timedata reads it)"),
    ("rig_test.drv", "an RPC III drive file"),
    ("hammer_calibration.toml", "a configuration (femcal calibrate or study reads it)"),
])  # fmt: skip
def test_a_file_that_is_not_a_deck_is_one_line_naming_what_it_is(name, kind, capsys):
    """The shipped test files given where a deck is expected: one line that says what the
    file is and which command reads it (was tens of thousands of card errors and binary)."""
    path = ROOT / "models" / "truck_frame" / name
    for command in (["info"], ["solve"]):
        assert main([*command, str(path)]) == 2
        err = [x for x in capsys.readouterr().err.splitlines() if not x.startswith("[")]
        assert len(err) == 1, err  # (solve's progress lines aside)
        assert err[0].startswith(f"femcal {command[0]}: {path}: deck; expected a NASTRAN "
                                 f"deck (text cards), not {kind}"), err  # fmt: skip


def test_binary_data_is_named_and_a_stray_control_byte_is_reported_at_its_card(write):
    rng = np.random.default_rng(1)
    blob = write(bytes(rng.integers(0, 256, 4096, dtype=np.uint8)).decode("latin-1"), "x.bdf")
    with pytest.raises(DeckError, match=r"x\.bdf: deck; expected a NASTRAN deck \(text cards\), "
                       r"not a text file: it holds binary data$"):  # fmt: skip
        read_deck(blob)
    stray = write(HEAD_BAR + "GRID,9,,0.,\x01,0.\nENDDATA\n", "stray.bdf")
    with pytest.raises(DeckError, match=r"stray\.bdf:\d+: GRID"):
        read_deck(stray)
