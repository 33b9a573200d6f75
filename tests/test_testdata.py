"""FRF data sets: NPZ and CSV round trips, labels, errors; the ``femcal frf`` command."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from femcal.cli import main
from femcal.deck import read_deck
from femcal.model import EigenRequest
from femcal.model.build import build_model
from femcal.response.frf import modal_frf, point_matrix
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel, FRFData, FRFError
from femcal.testdata.formats import read_frf
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
    args = ["frf", deck_path, "--input", "11:2", "--output", "11:2", "--freq", "1:200:9"]
    assert main([*args, "--out", str(tmp_path / "h.npz")]) == 0
    assert main([*args, "--out", str(tmp_path / "h.uff")]) == 0
    a, b = read_npz(tmp_path / "h.npz"), read_uff(tmp_path / "h.uff")
    assert np.allclose(a.H, b.H, rtol=1e-10) and [c.label for c in b.outputs] == ["11:2"]
    assert main([*args, "--out", str(tmp_path / "h.mat")]) == 0
    assert np.allclose(read_mat(tmp_path / "h.mat").H, a.H)
    assert main([*args, "--out", str(tmp_path / "h.txt")]) == 2
    assert not (tmp_path / "h.txt").exists()


# ----------------------------------------------------------------------------- bad files
# Each file is the smallest that shows one way an FRF file can be wrong; every one must end
# as an FRFError (a FemcalError) naming the file, where in it and what was expected.


def small() -> FRFData:
    """2 outputs x 1 input x 6 frequencies with GRID:DIR labels (UFF can hold them)."""
    f = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    H = np.array([[1 + 1j, 2 - 1j, 3 + 2j, 1 - 3j, 2 + 2j, 1 + 1j]])
    return FRFData.from_labels(f, np.stack([H, 2 * H]), ["1:3", "2:3"], ["9:2"], "receptance",
                               "m/N")  # fmt: skip


def npz_of(path, f, H, outs=("1:3", "2:3"), ins=("9:2",)):
    """An NPZ in femcal's layout from raw arrays (the writer would refuse bad ones)."""
    np.savez(path, frequency_hz=f, H=H, output_labels=np.array(outs),
             input_labels=np.array(ins), quantity=np.array("receptance"), units=np.array("m/N"))
    return path


def test_frequencies_must_be_finite_and_increasing(tmp_path):
    d = small()
    for value, found in ((np.nan, "is nan"), (np.inf, "is inf"), (-1.0, "is -1.0"),
                         (2.0, r"\(2.0 Hz\) repeats frequency 2"),
                         (1.5, r"\(1.5 Hz\) is below frequency 2")):  # fmt: skip
        f = d.frequency_hz.copy()
        f[2] = value
        p = npz_of(tmp_path / "f.npz", f, d.H)
        with pytest.raises(FRFError, match=rf"f\.npz: frequency_hz: frequency 3 of 6 {found}"):
            read_frf(p)
    # in a CSV the message names the line
    text = write_csv(tmp_path / "f.csv", d).read_text().replace("\n3.0,1:3", "\nnan,1:3", 1)
    (tmp_path / "f.csv").write_text(text)
    with pytest.raises(FRFError, match=r"f\.csv:5: frequency_hz is nan; expected a finite"):
        read_frf(tmp_path / "f.csv")
    # and the FRFData container refuses them too
    with pytest.raises(FRFError, match="frequency 2 of 2 is nan"):
        FRFData.from_labels([1.0, np.nan], np.ones((1, 1, 2)), ["a"], ["b"])


def test_real_frfs_are_refused(tmp_path):
    d = small()
    with pytest.raises(FRFError, match=r"r\.npz: H holds real \(float64\) values; expected "
                       "complex FRFs"):  # fmt: skip
        read_frf(npz_of(tmp_path / "r.npz", d.frequency_hz, d.H.real))
    import scipy.io

    scipy.io.savemat(tmp_path / "r.mat", {"frequency_hz": d.frequency_hz, "H": d.H.real,
                                          "output_labels": np.array(["1:3", "2:3"], object),
                                          "input_labels": np.array(["9:2"], object),
                                          "quantity": "receptance"})  # fmt: skip
    with pytest.raises(FRFError, match=r"r\.mat: H holds real"):
        read_frf(tmp_path / "r.mat")
    # a UFF 58 record of real ordinates (type 4): named by its dataset and line
    import pyuff

    sets = [pyuff.prepare_58(binary=0, id1="x", id2="m/N", id3="x", id4="x", id5="x",
                             func_type=4, rsp_node=o + 1, rsp_dir=3, ref_node=9, ref_dir=2,
                             ord_data_type=4, abscissa_spacing=1, abscissa_spec_data_type=18,
                             ordinate_spec_data_type=8, orddenom_spec_data_type=13,
                             data=d.H[o, 0].real.copy(), x=d.frequency_hz)
            for o in range(2)]  # fmt: skip
    pyuff.UFF(str(tmp_path / "r.uff")).write_sets(sets, mode="overwrite")
    with pytest.raises(FRFError, match=r"r\.uff:1: dataset 1: ordinate data type 4 is real; "
                       "expected complex FRFs"):  # fmt: skip
        read_frf(tmp_path / "r.uff")


def test_values_that_are_not_finite_name_output_input_and_frequency(tmp_path):
    d = small()
    H = d.H.copy()
    H[1, 0, 3] = complex(np.nan, 1.0)
    with pytest.raises(FRFError, match=r"n\.npz: output 2:3 / input 9:2 at 4 Hz: H is "
                       r"\(nan\+1j\); expected finite"):  # fmt: skip
        read_frf(npz_of(tmp_path / "n.npz", d.frequency_hz, H))
    text = write_csv(tmp_path / "n.csv", d).read_text().splitlines()
    text[3] = "3.0,1:3,9:2,inf,2.0"
    (tmp_path / "n.csv").write_text("\n".join(text) + "\n")
    with pytest.raises(FRFError, match=r"n\.csv:4: output 1:3 / input 9:2 at 3 Hz: H is "
                       r"\(inf\+2j\)"):  # fmt: skip
        read_frf(tmp_path / "n.csv")
    text = write_uff(tmp_path / "n.uff", d).read_text().splitlines()
    first = next(k for k, line in enumerate(text) if line.startswith("   ") and "e" in line
                 and k > 12)  # fmt: skip
    text[first] = "nan".rjust(20) + text[first][20:]
    (tmp_path / "n.uff").write_text("\n".join(text) + "\n")
    with pytest.raises(FRFError, match=r"n\.uff:1: dataset 1: output 1:3 / input 9:2 at 1 Hz: "
                       r"H is \(nan"):  # fmt: skip
        read_frf(tmp_path / "n.uff")


def test_a_uff_cut_short_or_without_a_pair_names_where(tmp_path):
    d = FRFData.from_labels(small().frequency_hz, np.ones((6, 1, 6)) * (1 + 1j),
                            [f"{k}:3" for k in range(1, 7)], ["9:2"], "receptance")  # fmt: skip
    raw = write_uff(tmp_path / "full.uff", d).read_bytes()
    lines = raw.split(b"\n")
    # cut inside the third of six datasets: not 2 of 6 outputs, but an error
    (tmp_path / "cut.uff").write_bytes(raw[: int(0.4 * len(raw))])
    with pytest.raises(FRFError, match=r"cut\.uff:\d+: dataset 3 has no closing '    -1' line: "
                       "the file ends inside it"):  # fmt: skip
        read_frf(tmp_path / "cut.uff")
    # a whole dataset of a 2 x 2 grid missing: the pair is named
    two = FRFData.from_labels(d.frequency_hz, np.ones((2, 2, 6)) * (1 + 1j), ["1:3", "2:3"],
                              ["9:2", "8:1"], "receptance")  # fmt: skip
    lines = write_uff(tmp_path / "two.uff", two).read_bytes().split(b"\n")
    starts = [k for k, line in enumerate(lines) if line == b"    -1"]
    del lines[starts[4]:starts[6]]  # the third dataset: output 2:3, input 9:2
    (tmp_path / "gap.uff").write_bytes(b"\n".join(lines))
    with pytest.raises(FRFError, match=r"gap\.uff: 1 of 4 output/input pairs have no dataset: "
                       "2:3/9:2"):  # fmt: skip
        read_frf(tmp_path / "gap.uff")
    # text after the last dataset (the start of one cut short)
    (tmp_path / "tail.uff").write_bytes(raw + b"    58\n")
    with pytest.raises(FRFError, match=r"tail\.uff:\d+: text outside any dataset"):
        read_frf(tmp_path / "tail.uff")


def test_pyuff_failures_become_errors_naming_the_dataset(tmp_path):
    text = write_uff(tmp_path / "v.uff", small()).read_text().splitlines()
    starts = [k for k, line in enumerate(text) if line == "    -1"]
    k = starts[2] + 14  # a data line of the second dataset
    text[k] = "abc" + text[k][3:]
    (tmp_path / "v.uff").write_text("\n".join(text) + "\n")
    with pytest.raises(FRFError, match=rf"v\.uff:{starts[2] + 1}: dataset 2: pyuff cannot read "
                       r"it \(ValueError: could not convert string to float"):  # fmt: skip
        read_frf(tmp_path / "v.uff")
    # a data line lost: the header's number of points says so
    text = write_uff(tmp_path / "l.uff", small()).read_text().splitlines()
    del text[14]
    (tmp_path / "l.uff").write_text("\n".join(text) + "\n")
    with pytest.raises(FRFError, match=r"l\.uff:1: dataset 1: the header gives 6 points "
                       r"\(record 7\), the data hold 4"):  # fmt: skip
        read_frf(tmp_path / "l.uff")


def test_csv_without_rows_or_cut_short_or_repeating_a_row(tmp_path):
    p = tmp_path / "h.csv"
    p.write_text("# quantity=receptance units=m/N\nfrequency_hz,output,input,real,imag\n")
    with pytest.raises(FRFError, match=r"h\.csv:2: no rows after the header"):
        read_frf(p)
    p.write_text("")
    with pytest.raises(FRFError, match=r"h\.csv: no header; expected frequency_hz,output"):
        read_frf(p)
    text = write_csv(tmp_path / "c.csv", small()).read_text()
    (tmp_path / "c.csv").write_text(text[:200])  # cut inside a row
    with pytest.raises(FRFError, match=r"c\.csv:\d+: the last line does not end with a line "
                       "break: is the file cut short"):  # fmt: skip
        read_frf(tmp_path / "c.csv")
    rows = text.splitlines()
    (tmp_path / "c.csv").write_text("\n".join([*rows, rows[4]]) + "\n")
    with pytest.raises(FRFError, match=rf"c\.csv:{len(rows) + 1}: output 1:3 / input 9:2 at "
                       "3 Hz is given again \\(first on line 5\\)"):  # fmt: skip
        read_frf(tmp_path / "c.csv")
    (tmp_path / "c.csv").write_text("\n".join(rows[:5] + rows[6:]) + "\n")
    with pytest.raises(FRFError, match=r"c\.csv: output 1:3 / input 9:2 has no row at 4 Hz"):
        read_frf(tmp_path / "c.csv")


def test_uff_writer_refuses_what_uff_cannot_hold(tmp_path):
    d = small()
    one = FRFData(d.frequency_hz[:1], d.H[:, :, :1], d.outputs, d.inputs, d.quantity)
    with pytest.raises(FRFError, match="1 frequency; a UFF 58 file"):
        write_uff(tmp_path / "one.uff", one)
    assert not (tmp_path / "one.uff").exists()
    # unevenly spaced ASCII abscissae are E13.5 fields: 1000 and 1000.001 Hz would be one
    close = FRFData(np.array([999.0, 1000.0, 1000.001]), d.H[:, :, :3], d.outputs, d.inputs,
                    d.quantity)  # fmt: skip
    with pytest.raises(FRFError, match=r"frequencies 1000\.0 and 1000\.001 Hz become one "
                       r"\(1000 Hz\) in UFF 58's 6 significant digits"):  # fmt: skip
        write_uff(tmp_path / "close.uff", close)
    back = read_frf(write_uff(tmp_path / "close.uff", close, binary=True))  # doubles there
    np.testing.assert_array_equal(back.frequency_hz, close.frequency_hz)


def test_ctrl_c_inside_pyuff_stays_an_interruption(tmp_path, monkeypatch):
    import pyuff

    def read_sets(self, setn=None, header_only=False):
        try:  # what pyuff's bare except makes of a Ctrl-C while it reads
            raise KeyboardInterrupt
        except BaseException:
            raise Exception("Error when reading data-set(s).") from None

    path = write_uff(tmp_path / "k.uff", small())
    monkeypatch.setattr(pyuff.UFF, "read_sets", read_sets)
    with pytest.raises(KeyboardInterrupt):
        read_frf(path)


@st.composite
def frf_sets(draw) -> FRFData:
    """A valid set: 1-3 outputs, 1-2 inputs, 2-12 increasing frequencies, finite complex
    values of any sign and a wide range of magnitudes (zero among them)."""
    p, m, n = draw(st.integers(1, 3)), draw(st.integers(1, 2)), draw(st.integers(2, 12))
    steps = draw(st.lists(st.floats(1e-3, 1e3), min_size=n, max_size=n))
    f = draw(st.floats(0.0, 100.0)) + np.cumsum(steps)
    parts = st.one_of(st.just(0.0), st.floats(1e-30, 1e30), st.floats(-1e30, -1e-30))
    values = draw(st.lists(parts, min_size=2 * p * m * n, max_size=2 * p * m * n))
    H = np.array(values[::2]) + 1j * np.array(values[1::2])
    outs = [f"{k + 1}:{'+-'[k % 2]}{'XYZ'[k % 3]}" for k in range(p)]
    return FRFData.from_labels(f, H.reshape(p, m, n), outs, [f"{90 + k}:3" for k in range(m)],
                               draw(st.sampled_from(["receptance", "accelerance"])), "m/N")


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(frf_sets(), st.sampled_from([".npz", ".csv", ".mat", ".uff"]))
def test_every_format_gives_back_what_it_was_given(tmp_path, data, suffix):
    from femcal.testdata.formats import write_frf

    try:
        back = read_frf(write_frf(tmp_path / f"p{suffix}", data))
    except FRFError as e:  # frequencies UFF's 6 significant digits cannot tell apart
        assert suffix == ".uff" and "6 significant digits" in str(e)
        return
    # UFF's text has 12 significant digits for values, 6 for frequencies (E13.5)
    uff = suffix == ".uff"
    np.testing.assert_allclose(back.frequency_hz, data.frequency_hz, rtol=1e-5 if uff else 0)
    np.testing.assert_allclose(back.H, data.H, rtol=1e-11 if uff else 0, atol=0)
    assert back.quantity == data.quantity and len(back.outputs) == len(data.outputs)


def test_sensor_files_that_break_are_errors_naming_file_and_line(tmp_path):
    from femcal.errors import ConfigError
    from femcal.testdata.points import read_points

    short = tmp_path / "short.csv"
    short.write_text("label,grid,directions\nA,1\n")
    with pytest.raises(ConfigError, match=f"{short}:2: a short row; expected label, grid and "
                       "directions"):  # fmt: skip
        read_points(short)
    latin = tmp_path / "latin.csv"
    latin.write_bytes("label,grid,directions\n\xe9,1,3\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=f"{latin}: not UTF-8 text"):
        read_points(latin)


@pytest.mark.parametrize("suffix", [".npz", ".mat"])
def test_coherence_of_estimated_frfs_round_trips(tmp_path, suffix):
    from dataclasses import replace

    from femcal.testdata.formats import read_frf, write_frf

    data = FRFData.from_labels([1.0, 2.0, 3.0], np.ones((2, 1, 3)) * (1 + 2j), ["1:3", "2:3"],
                               ["5:3"], "accelerance", "mm/s^2/N")  # fmt: skip
    assert read_frf(write_frf(tmp_path / f"a{suffix}", data)).coherence is None
    coh = np.array([[0.5, 1.0, 0.25], [0.9, 0.2, 0.0]])
    back = read_frf(write_frf(tmp_path / f"b{suffix}", replace(data, coherence=coh)))
    assert np.array_equal(back.coherence, coh)
    with pytest.raises(FRFError, match=r"coherence has shape \(3,\); expected \(n_out"):
        replace(data, coherence=np.ones(3))
    with pytest.raises(FRFError, match=r"outside \[0, 1\]"):
        replace(data, coherence=coh * 3)


@pytest.mark.parametrize("suffix", [".npz", ".mat", ".uff"])
def test_coherence_of_each_frf_round_trips(tmp_path, suffix):
    """An impact test's ordinary coherence, one per FRF (each hammer point measured on its
    own), through every format; UFF keeps it as function type 6 datasets."""
    from dataclasses import replace

    from femcal.testdata.formats import read_frf, write_frf

    data = FRFData.from_labels([1.0, 2.0, 3.0], np.ones((2, 3, 3)) * (1 + 2j), ["1:3", "2:3"],
                               ["5:3", "6:3", "7:3"], "accelerance", "mm/s^2/N")  # fmt: skip
    coh = np.linspace(0.0, 1.0, 18).reshape(2, 3, 3)
    back = read_frf(write_frf(tmp_path / f"b{suffix}", replace(data, coherence=coh)))
    assert back.coherence.shape == (2, 3, 3)
    # the text UFF holds 13 significant digits; the others the numbers themselves
    np.testing.assert_allclose(back.coherence, coh, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.H, data.H)


def test_uff_multiple_coherence_is_said_to_be_left_out_and_unknown_quantity_is_said(tmp_path):
    from dataclasses import replace

    import pyuff

    from femcal.errors import FemcalWarning
    from femcal.testdata.formats.uff import read_uff, write_uff, write_uff_sets

    data = FRFData.from_labels([1.0, 2.0, 3.0], np.ones((2, 1, 3)) * (1 + 2j), ["1:3", "2:3"],
                               ["5:3"], "accelerance", "mm/s^2/N")  # fmt: skip
    with pytest.warns(FemcalWarning, match="the multiple coherence is not written"):
        write_uff(tmp_path / "m.uff", replace(data, coherence=np.full((2, 3), 0.5)))
    assert read_uff(tmp_path / "m.uff").coherence is None
    # a writer that leaves the ordinate's quantity unknown (0): taken as receptance, and said
    sets = [pyuff.prepare_58(binary=0, id1="FRF", func_type=4, rsp_node=1, rsp_dir=3,
                             ref_node=5, ref_dir=3, ord_data_type=6, abscissa_spacing=1,
                             abscissa_spec_data_type=18, ordinate_spec_data_type=0,
                             orddenom_spec_data_type=13, data=np.ones(3) * (1 + 1j),
                             x=np.array([1.0, 2.0, 3.0]))]  # fmt: skip
    write_uff_sets(tmp_path / "q.uff", sets)
    with pytest.warns(FemcalWarning, match=r"ordinate data type 0 \(record 8\) names no "
                      "response per force"):
        assert read_uff(tmp_path / "q.uff").quantity == "receptance"


def test_channel_names_cover_the_other_directions_of_a_listed_point(tmp_path):
    """A test often measures three directions where the file lists one: the others take
    the point's name with their own direction; a listed direction keeps its own point's."""
    from femcal.testdata.points import channel_names

    path = tmp_path / "s.csv"
    path.write_text("label,grid,x,y,z,directions\nS_V,17006,0,0,0,3\nS_L,17006,0,0,0,2\n"
                    "S_X,1970,0,0,0,-1\n")  # fmt: skip
    names = channel_names(path)
    assert names["17006:3"] == names["17006:+Z"] == "S_V +Z"
    assert names["17006:2"] == "S_L +Y"  # listed: its own point's name
    assert names["17006:1"] == "S_V +X"  # not listed: the grid's first point
    assert names["1970:-1"] == "S_X -X" and names["1970:1"] == "S_X +X"
    assert "55:1" not in names
