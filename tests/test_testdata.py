"""FRF data sets: NPZ and CSV round trips, labels, errors; the ``femcal frf`` command."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.cli import main
from femcal.deck import read_deck
from femcal.model import EigenRequest
from femcal.model.build import build_model
from femcal.response.frf import modal_frf, point_matrix
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel, FRFData
from femcal.testdata.formats.matlab import read_mat, write_mat
from femcal.testdata.formats.npz import read_npz, write_npz
from femcal.testdata.formats.text import read_csv, write_csv
from femcal.testdata.formats.uff import read_uff, write_uff
from femcal.testdata.runs import assemble_runs

from .conftest import REFDECKS


def sample() -> FRFData:
    rng = np.random.default_rng(2)
    H = rng.normal(size=(3, 2, 5)) + 1j * rng.normal(size=(3, 2, 5))
    return FRFData.from_labels(np.array([1.0, 1.5, 2.0, 7.25, 10.0]), H,
                               ["1001:+Y", "1002:3", "accel 7"], ["55:-X", "56:2"],
                               "accelerance", "mm/s^2 per N")  # fmt: skip


@pytest.mark.parametrize(("write", "read", "name"),
                         [(write_npz, read_npz, "h.npz"), (write_csv, read_csv, "h.csv"),
                          (write_mat, read_mat, "h.mat")])  # fmt: skip
def test_round_trips_keep_values_and_labels(tmp_path, write, read, name):
    d = sample()
    back = read(write(tmp_path / name, d))
    assert np.array_equal(back.frequency_hz, d.frequency_hz)
    assert np.array_equal(back.H, d.H)  # exact: repr of floats in CSV
    assert back.outputs == d.outputs and back.inputs == d.inputs
    assert (back.quantity, back.units) == ("accelerance", "mm/s^2 per N")
    assert not list(tmp_path.glob(".*.tmp"))  # nothing half-written left


def test_labels_name_grid_and_direction():
    assert Channel.parse("1001:+y") == Channel("1001:+y", 1001, "+Y")
    assert Channel.parse("7:3") == Channel("7:3", 7, "3")
    assert Channel.parse("accel 7") == Channel("accel 7")


def test_bad_data_is_refused(tmp_path):
    with pytest.raises(ValueError, match="expected \\(n_out, n_in, n_freq\\)"):
        FRFData.from_labels([1.0, 2.0], np.zeros((1, 1, 3)), ["a"], ["b"])
    with pytest.raises(ValueError, match="quantity"):
        FRFData.from_labels([1.0], np.zeros((1, 1, 1)), ["a"], ["b"], "velocity")
    p = tmp_path / "bad.csv"
    p.write_text("frequency_hz,output,input,real,imag\n1.0,a,b,x,0\n")
    with pytest.raises(ValueError, match=r"bad\.csv:2"):
        read_csv(p)


def test_frf_command_writes_the_modal_frf(tmp_path):
    deck_path = REFDECKS / "cofe_cantilever_cbar" / "noReduction.dat"
    out = tmp_path / "h.npz"
    code = main(["frf", str(deck_path), "--input", "11:2", "--output", "11:2", "--output",
                 "6:6", "--freq", "1:200:7", "--damping", "0.03", "--out", str(out)])  # fmt: skip
    assert code == 0
    d = read_npz(out)
    assert d.H.shape == (2, 1, 29) and d.frequency_hz[0] == 1.0 and d.frequency_hz[-1] == 197.0
    deck = read_deck(deck_path)
    model = build_model(deck)
    modes, _ = solve_normal_modes(model, request=EigenRequest(v2=2 * 197.0, nd=None))
    C = point_matrix(model, [(11, 2), (6, 6)])
    B = point_matrix(model, [(11, 2)]).T
    assert np.allclose(d.H, modal_frf(modes.shapes, modes.radians, C, B, d.frequency_hz, 0.03))
    assert main(["frf", str(deck_path), "--input", "99:2", "--output", "11:2", "--freq",
                 "1:2:1", "--out", str(out)]) == 2  # fmt: skip


def test_uff58_round_trip_keeps_values_and_grid_directions(tmp_path):
    d = sample()
    d = FRFData.from_labels(d.frequency_hz, d.H, ["1001:+Y", "1002:3", "7:-1"],
                            ["55:-X", "56:2"], "accelerance", "mm/s^2/N")  # fmt: skip
    back = read_uff(write_uff(tmp_path / "h.uff", d))
    assert np.allclose(back.H, d.H, rtol=1e-10, atol=1e-12)
    assert np.allclose(back.frequency_hz, d.frequency_hz, rtol=1e-12)
    # directions come back as UFF codes: +Y is 2, -X is -1
    assert [c.label for c in back.outputs] == ["1001:2", "1002:3", "7:-1"]
    assert [(c.grid, c.direction) for c in back.inputs] == [(55, "-1"), (56, "2")]
    assert (back.quantity, back.units) == ("accelerance", "mm/s^2/N")
    with pytest.raises(ValueError, match="GRID:DIRECTION"):
        write_uff(tmp_path / "x.uff", sample())  # "accel 7" names no grid
    assert not list(tmp_path.glob(".*"))


def test_roving_runs_assemble_into_one_mimo_set():
    rng = np.random.default_rng(8)
    f = np.linspace(1.0, 50.0, 12)
    outs = [f"{1000 + k}:{d}" for k in range(8) for d in ("+X", "+Y", "+Z")]  # 24 outputs
    ins = ["55:+Y", "77:+Z"]
    H = rng.normal(size=(24, 2, 12)) + 1j * rng.normal(size=(24, 2, 12))
    runs, maps = [], []
    for inp in range(2):  # one hammer input per run, 6 sensor channels roving over 24 outputs
        for start in range(0, 24, 6):
            local = [f"ch{c}" for c in range(6)]
            runs.append(FRFData.from_labels(f, H[start:start + 6, inp:inp + 1], local,
                                            ["hammer"], "accelerance"))  # fmt: skip
            maps.append({**{f"ch{c}": outs[start + c] for c in range(6)}, "hammer": ins[inp]})
    # a repeated measurement of one pair, with a small error, is averaged
    extra = FRFData.from_labels(f, H[:1, :1] * 1.02, ["ch0"], ["hammer"], "accelerance")
    got = assemble_runs([*runs, extra], [*maps, {"ch0": outs[0], "hammer": ins[0]}])
    assert [c.label for c in got.outputs] == outs and [c.label for c in got.inputs] == ins
    expected = H.copy()
    expected[0, 0] *= 1.01
    assert np.allclose(got.H, expected)
    # all outputs for the first input, the first 6 only for the second: 18 pairs missing
    with pytest.raises(ValueError, match="18 output/input pairs were not measured: 1002:"):
        assemble_runs(runs[:5], maps[:5])
    part = assemble_runs(runs[:4] + runs[4:5], maps[:5], allow_missing=True)
    assert np.isnan(part.H[6:, 1].real).all() and not np.isnan(part.H[:6, 1].real).any()
    other = FRFData.from_labels(f * 2, H[:1, :1], ["a"], ["b"], "accelerance")
    with pytest.raises(ValueError, match="another frequency axis"):
        assemble_runs([runs[0], other])


def test_frf_command_writes_uff_and_mat_and_refuses_other_formats(tmp_path):
    deck_path = str(REFDECKS / "cofe_cantilever_cbar" / "noReduction.dat")
    args = ["frf", deck_path, "--input", "11:2", "--output", "11:2", "--freq", "1:100:9"]
    assert main([*args, "--out", str(tmp_path / "h.npz")]) == 0
    assert main([*args, "--out", str(tmp_path / "h.uff")]) == 0
    a, b = read_npz(tmp_path / "h.npz"), read_uff(tmp_path / "h.uff")
    assert np.allclose(a.H, b.H, rtol=1e-10) and [c.label for c in b.outputs] == ["11:2"]
    assert main([*args, "--out", str(tmp_path / "h.mat")]) == 0
    assert np.allclose(read_mat(tmp_path / "h.mat").H, a.H)
    assert main([*args, "--out", str(tmp_path / "h.txt")]) == 2
    assert not (tmp_path / "h.txt").exists()
