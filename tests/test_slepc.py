"""The optional SLEPc backend (:mod:`femcal.solve.slepc`) against the default solver.

The backend runs where ``make setup-slepc`` made ``.venv-slepc/`` (Debian's petsc4py and
slepc4py on Debian's Python) and Open MPI's ``mpirun`` exists; the suite itself runs in
``.venv``, where petsc4py is absent, so the backend is run by subprocess under ``mpirun -n 1``
and ``-n 2`` and its results are compared here with the default solver's, in process. Without
``.venv-slepc`` or ``mpirun`` those tests are skipped, saying why; the tests of what works
without petsc4py (the import, the message, the row split) always run.

Agreement: the frequencies to 1e-8 (relative) of the default solver's. Rigid-body roots
(below 1e-3 of the highest frequency) are rounding noise in both solvers, so they must only
both be that small. For the highest roots of a spectrum solved whole, the default solver's
own shift-invert (dense, at the same shift) resolves lambda only to about 1e-15 times
(lambda - sigma) / (lambda_1 - sigma) relative, which the tolerance allows for (only
``yeti_full_cbar_rbe2``'s top 20 of 278 modes need it; SLEPc matches the exact solution of
that deck to 1e-12).
"""

from __future__ import annotations

import importlib.util
import itertools
import json
import shutil
import subprocess
import sys
import warnings
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from femcal.cli import main
from femcal.deck import read_deck
from femcal.model.build import build_model
from femcal.solve.eigen import default_shift
from femcal.solve.normal_modes import a_set_problem, solve_normal_modes

from .conftest import REFDECKS, ROOT, refdeck_cases

SLEPC_VENV = ROOT / ".venv-slepc"
SLEPC_PYTHON = SLEPC_VENV / "bin" / "python"
SLEPC_FEMCAL = SLEPC_VENV / "bin" / "femcal"
MPIRUN = shutil.which("mpirun")
#: mpirun as root, and 2 ranks on a machine that may have fewer cores.
MPI_FLAGS = ("--allow-run-as-root", "--oversubscribe")
RANKS = (1, 2)
#: Reference decks the backend is compared on: every deck the default solver solves, but
#: pyn_modes_elements (all its roots are 0 Hz mechanisms: rounding noise in any solver) and
#: pyn_bwb (51 386 DOF: in the slow set).
SKIPPED_DECKS = {"pyn_modes_elements", "pyn_bwb", "cofe_cantilever_cbar_guyan",
                 "yeti_outboard_extseout"}  # fmt: skip
FAST_DECKS = [(name, main) for name, main, _ in refdeck_cases() if name not in SKIPPED_DECKS]
#: The clamped plate of benchmarks/eigen_vs_calculix.py (1 m x 1 m x 5 mm steel, one edge
#: clamped, 20 modes): its mesh sizes here, the fast one and the slow one.
PLATE_FAST, PLATE_SLOW = 30, 100
#: Relative frequency agreement asked of the backend (issue 28).
RTOL = 1e-8

#: Run by .venv-slepc's Python under mpirun: solve each deck with the SLEPc backend and, on
#: rank 0, write its modes to OUT/<i>.npz (or its error to OUT/<i>.txt).
DRIVER = """
import sys, warnings
from pathlib import Path
import numpy as np
warnings.simplefilter("ignore")
from femcal.deck import read_deck
from femcal.errors import FemcalError
from femcal.model.build import build_model
from femcal.solve.slepc import mpi_rank_and_size, solve_normal_modes_slepc
rank, _ = mpi_rank_and_size()
out = Path(sys.argv[1])
for i, deck in enumerate(sys.argv[2:]):
    try:
        solved = solve_normal_modes_slepc(build_model(read_deck(deck)))
    except FemcalError as e:
        if rank == 0:
            (out / f"{i}.txt").write_text(f"{type(e).__name__}: {e}")
        continue
    if solved is not None:
        m = solved[0]
        np.savez(out / f"{i}.npz", eigenvalues=m.eigenvalues, shapes=m.shapes,
                 generalized_mass=m.generalized_mass, backend=m.backend)
"""


@cache
def why_no_slepc() -> str | None:
    """Why the backend cannot run here, or None when it can."""
    if not SLEPC_PYTHON.exists():
        return f"{SLEPC_VENV.name}/ not present (make setup-slepc makes it)"
    if MPIRUN is None:
        return "mpirun not found (make setup-slepc installs Open MPI)"
    probe = subprocess.run([str(SLEPC_PYTHON), "-c", "import petsc4py, slepc4py, femcal"],
                           capture_output=True, text=True, timeout=60)  # fmt: skip
    if probe.returncode:
        return f"petsc4py/slepc4py do not import in {SLEPC_VENV.name}: {probe.stderr[-200:]}"
    return None


needs_slepc = pytest.mark.skipif(why_no_slepc() is not None, reason=str(why_no_slepc()))


def mpirun(ranks: int, *args: str | Path, timeout: float = 600) -> subprocess.CompletedProcess:
    cmd = [str(MPIRUN), "-n", str(ranks), *MPI_FLAGS, *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def plate_deck(n: int, folder: Path) -> Path:
    """benchmarks/eigen_vs_calculix.py's clamped plate deck of n x n CQUAD4 in ``folder``."""
    spec = importlib.util.spec_from_file_location(
        "eigen_vs_calculix", ROOT / "benchmarks" / "eigen_vs_calculix.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    bench.WORK = folder
    folder.mkdir(parents=True, exist_ok=True)
    return bench.nastran_deck(n)


def run_slepc(ranks: int, decks: list[Path], out: Path) -> list[dict | str]:
    """Each deck solved by the backend on ``ranks`` ranks: a dict of its modes' arrays, or
    the error's text."""
    out.mkdir(parents=True, exist_ok=True)
    done = mpirun(ranks, SLEPC_PYTHON, "-c", DRIVER, out, *decks)
    assert done.returncode == 0, done.stderr[-3000:]
    results: list[dict | str] = []
    for i in range(len(decks)):
        if (out / f"{i}.txt").exists():
            results.append((out / f"{i}.txt").read_text())
        else:
            with np.load(out / f"{i}.npz") as z:
                results.append({k: z[k] for k in z.files})
    return results


@cache
def default_solution(deck: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(eigenvalues, shapes, sigma) of the default solver, and the shift both use."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = build_model(read_deck(deck))
        problem = a_set_problem(model)
        sigma = default_shift(problem.K, problem.M)
        modes, _ = solve_normal_modes(model)
    return modes.eigenvalues, modes.shapes, sigma


def assert_same_frequencies(lam_slepc: np.ndarray, lam_default: np.ndarray, sigma: float):
    """The frequencies agree to RTOL (see the module's docstring for the allowances)."""
    assert len(lam_slepc) == len(lam_default), (len(lam_slepc), len(lam_default))
    hz = lambda lam: np.sign(lam) * np.sqrt(np.abs(lam)) / (2 * np.pi)  # noqa: E731
    fs, fd = hz(lam_slepc), hz(lam_default)
    fmax = np.abs(fd).max()
    rigid = np.abs(fd) < 1e-3 * fmax
    assert (np.abs(fs[rigid]) < 1e-3 * fmax).all(), (fs[rigid], fd[rigid])
    el = ~rigid
    if not el.any():
        return
    spread = (lam_default[el] - sigma) / (lam_default.min() - sigma)
    allowed = np.maximum(RTOL, 1e-15 * spread)
    err = np.abs(fs[el] / fd[el] - 1.0)
    worst = int(np.argmax(err / allowed))
    assert (err <= allowed).all(), (f"mode {np.flatnonzero(el)[worst] + 1}: {fs[el][worst]!r} "
                                    f"Hz against {fd[el][worst]!r} Hz, {err[worst]:.2e}")


# --- without petsc4py (the main suite's .venv) --------------------------------------------


def test_the_backend_module_imports_without_petsc4py():
    """femcal.solve.slepc imports petsc4py only when it solves."""
    code = ("import sys; import femcal.solve.slepc, femcal.cli.solve; "
            "assert 'petsc4py' not in sys.modules and 'slepc4py' not in sys.modules")  # fmt: skip
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_without_petsc4py_the_command_says_how_to_install(capsys):
    if importlib.util.find_spec("petsc4py") is not None:
        pytest.skip("petsc4py is installed in this Python")
    deck = REFDECKS / "cofe_cantilever_cbar" / "noReduction.dat"
    assert main(["solve", str(deck), "--backend", "slepc"]) == 2
    err = capsys.readouterr().err
    assert "petsc4py" in err and "make setup-slepc" in err, err


def test_row_blocks_split_like_petsc():
    from femcal.solve.slepc import row_block

    for n, size in [(10, 3), (2, 4), (241200, 2), (7, 1)]:
        blocks = [row_block(n, r, size) for r in range(size)]
        assert blocks[0][0] == 0 and blocks[-1][1] == n
        assert all(a[1] == b[0] for a, b in itertools.pairwise(blocks))
        sizes = [b - a for a, b in blocks]
        assert max(sizes) - min(sizes) <= 1 and sizes == sorted(sizes, reverse=True)


# --- with the backend --------------------------------------------------------------------


@pytest.fixture(scope="module", params=RANKS, ids=[f"{r}rank" for r in RANKS])
def slepc_refdecks(request, tmp_path_factory):
    """(ranks, {deck name: the backend's result}) for the fast decks and the small plate."""
    if why_no_slepc():
        pytest.skip(why_no_slepc())
    ranks = request.param
    work = tmp_path_factory.mktemp(f"slepc{ranks}")
    plate = plate_deck(PLATE_FAST, work / "plate")
    names = [n for n, _ in FAST_DECKS] + ["plate"]
    decks = [d for _, d in FAST_DECKS] + [plate]
    results = run_slepc(ranks, decks, work / "out")
    return ranks, dict(zip(names, zip(decks, results, strict=True), strict=True))


@needs_slepc
@pytest.mark.parametrize("name", [n for n, _ in FAST_DECKS])
def test_reference_deck_frequencies_match_the_default_solver(slepc_refdecks, name):
    _, results = slepc_refdecks
    deck, got = results[name]
    assert isinstance(got, dict), got
    assert str(got["backend"]) == "slepc"
    lam, _, sigma = default_solution(deck)
    assert_same_frequencies(got["eigenvalues"], lam, sigma)


@needs_slepc
def test_clamped_plate_frequencies_and_shapes_match(slepc_refdecks):
    """The plate: 20 distinct roots, so the shapes (rotations, massless with lumped mass,
    included) must agree too, to the default Lanczos' vector tolerance."""
    _, results = slepc_refdecks
    deck, got = results["plate"]
    assert isinstance(got, dict), got
    lam, shapes, sigma = default_solution(deck)
    assert len(lam) == 20
    assert_same_frequencies(got["eigenvalues"], lam, sigma)
    ours = got["shapes"] * np.sign(np.einsum("ik,ik->k", got["shapes"], shapes))
    err = np.abs(ours - shapes).max(axis=0) / np.abs(shapes).max(axis=0)
    assert err.max() < 1e-6, err
    np.testing.assert_allclose(got["generalized_mass"], 1.0, rtol=1e-12)


@needs_slepc
@pytest.mark.parametrize("ranks", RANKS)
def test_command_under_mpirun_prints_once_and_writes_json(tmp_path, ranks):
    deck = REFDECKS / "pyn_plate_py" / "plate_py.dat"
    out = tmp_path / "modes.json"
    done = mpirun(ranks, SLEPC_FEMCAL, "solve", deck, "--backend", "slepc", "--json", out)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.count("R E A L   E I G E N V A L U E S") == 1  # rank 0 alone prints
    assert done.stderr.count("reading ") == 1
    data = json.loads(out.read_text())
    assert data["solver"] == "slepc"
    lam, _, sigma = default_solution(deck)
    assert_same_frequencies(np.array([m["eigenvalue"] for m in data["modes"]]), lam, sigma)


@needs_slepc
def test_command_error_is_reported_once(tmp_path):
    """An error every rank meets (a refused deck) is printed by rank 0 alone, exit 2."""
    deck = REFDECKS / "cofe_cantilever_cbar_guyan" / "guyanReduction.dat"
    done = mpirun(2, SLEPC_FEMCAL, "solve", deck, "--backend", "slepc")
    assert done.returncode != 0
    assert done.stderr.count("femcal solve: ") == 1, done.stderr
    assert "ASET" in done.stderr


@needs_slepc
@pytest.mark.slow
@pytest.mark.parametrize("ranks", RANKS)
def test_larger_models_match(tmp_path, ranks):
    """The 100 x 100 plate (61 206 DOF) and pyn_bwb (51 386 DOF, free-free, 20 modes)."""
    plate = plate_deck(PLATE_SLOW, tmp_path / "plate")
    bwb = REFDECKS / "pyn_bwb" / "bwb_freq.bdf"
    results = run_slepc(ranks, [plate, bwb], tmp_path / "out")
    for deck, got in zip([plate, bwb], results, strict=True):
        assert isinstance(got, dict), got
        lam, _, sigma = default_solution(deck)
        assert_same_frequencies(got["eigenvalues"], lam, sigma)
