"""The CLI: femcal info prints a summary and writes its JSON."""

import json

from femcal.cli import main

from .conftest import REFDECKS


def test_info_json_on_a_reference_deck(tmp_path, capsys):
    out = tmp_path / "info.json"
    deck = REFDECKS / "pyn_bwb" / "bwb_freq.bdf"
    assert main(["info", str(deck), "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["sol"] == 111 and data["n_grids"] == 10135 and data["n_dof"] == 60810
    assert data["cards"]["GRID"] == 10135 and data["cards"]["CQUAD4"] == 9236
    assert data["unsupported"]["CAERO1"] == 11
    printed = capsys.readouterr().out
    assert "not used by SOL 103" in printed and "CAERO1 \u00d711" in printed


def test_info_bad_deck_exits_2_with_location(write, capsys):
    path = write("SOL 103\nCEND\nBEGIN BULK\nGRID    1       0       1.x\n")
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "deck.bdf:4: GRID field 4 (X1): found '1.x'; expected a real" in err


def test_info_missing_file(tmp_path, capsys):
    assert main(["info", str(tmp_path / "nope.bdf")]) == 2
    assert "No such file" in capsys.readouterr().err


def test_a_command_loads_its_own_module_only():
    """``femcal solve`` does not import what identification and the rig need (SciPy's
    signal and statistics packages, about a second of start-up): the parser is built for
    the command named."""
    import subprocess
    import sys

    code = ("import sys; from femcal.cli import build_parser; "
            "build_parser('solve').parse_args(['solve', 'deck.bdf']); "
            "print(sorted(m for m in ('femcal.identify', 'femcal.rig', 'scipy.signal', "
            "'scipy.stats', 'femcal.cli.identify') if m in sys.modules))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)  # fmt: skip
    assert out.stdout.strip() == "[]"
