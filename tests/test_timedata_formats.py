"""Time-history formats through the registry (kind "time"): CSV and NPZ round trips exact, RPC
III through read_time_data / write_time_data; errors naming file, line and column (or key);
``femcal timedata info`` on a CSV file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from femcal.cli import main
from femcal.errors import FRFError, TimeDataError
from femcal.testdata.data import FRFData
from femcal.testdata.formats import read_frf, read_time_data, suffixes, write_frf, write_time_data
from femcal.testdata.formats.timecsv import read_time_csv, write_time_csv
from femcal.testdata.formats.timenpz import read_time_npz
from femcal.testdata.timedata import TimeData


def sample(n: int = 1001, dt: float = 1 / 3000, seed: int = 3) -> TimeData:
    rng = np.random.default_rng(seed)
    values = rng.standard_normal((3, n)) * np.array([[1.0], [2.5e4], [1e-7]])
    return TimeData(dt, values, ("Act 1 disp", "load, front", "acc [z]"), ("mm", "N", "m/s^2"))


def assert_same(back: TimeData, data: TimeData) -> None:
    assert back.dt == data.dt
    assert back.names == data.names and back.units == data.units
    assert back.values.dtype == np.float64
    np.testing.assert_array_equal(back.values, data.values)


def test_the_time_kind_lists_rpc3_csv_and_npz():
    assert suffixes("time") == [".rsp", ".tim", ".drv", ".csv", ".npz"]
    assert suffixes("time", writable=True) == suffixes("time")


@pytest.mark.parametrize("dt", [1 / 3000, 0.1, 1 / 512, 7e-5])
@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_csv_and_npz_round_trip_exactly(tmp_path, suffix, dt):
    data = sample(dt=dt)
    path = write_time_data(tmp_path / f"t{suffix}", data)
    assert_same(read_time_data(path), data)
    assert [p.name for p in tmp_path.iterdir()] == [f"t{suffix}"]  # nothing half-written


def test_csv_layout_and_float32_data(tmp_path):
    data = TimeData(0.5, np.array([[0.1, -2.0, 3e-9]], np.float32), ("a",), ("mm",))
    path = write_time_csv(tmp_path / "f.csv", data)
    lines = path.read_text().splitlines()
    assert lines[:3] == ["time_s,a", "# units: mm", "0.0,0.100000001"]
    back = read_time_csv(path)
    np.testing.assert_array_equal(back.values.astype(np.float32), data.values)
    assert back.dt == 0.5


def test_csv_from_other_tools_units_in_brackets_comments_and_blank_lines(tmp_path):
    path = tmp_path / "lab.csv"
    path.write_text("# exported by the rig\nTime [s],Force [N],Disp [mm],Free\n\n"
                    '0.0,1,2,3\n  \n0.25,4,5,6 # a note\n5e-1, 7 ,"8",9\n')  # fmt: skip
    d = read_time_data(path)
    assert d.names == ("Force", "Disp", "Free") and d.units == ("N", "mm", "")
    assert d.dt == 0.25
    np.testing.assert_array_equal(d.values, [[1, 4, 7], [2, 5, 8], [3, 6, 9]])
    path.write_text("time,a [b]\n# units: s, g\n10.0,1\n10.5,2\n11.0,3\n")
    d = read_time_data(path)  # a units line: names as written; times counted from 0
    assert (d.names, d.units, d.dt, d.n_samples) == (("a [b]",), ("g",), 0.5, 3)


def test_rpc3_through_the_registry(tmp_path):
    data = sample()
    for suffix in (".rsp", ".TIM", ".drv"):
        back = read_time_data(write_time_data(tmp_path / f"r{suffix}", data))
        assert back.names == data.names and back.units == data.units and back.dt == data.dt
        np.testing.assert_array_equal(back.values, data.values.astype(np.float32))
        assert back.header["DATA_TYPE"] == "FLOATING_POINT"


def test_frf_and_time_kinds_share_suffixes_but_not_readers(tmp_path):
    path = write_time_data(tmp_path / "t.csv", sample(n=4))
    with pytest.raises(FRFError, match=r"t\.csv:1: found 'time_s,Act 1 disp"):
        read_frf(path)
    frf = FRFData.from_labels([1.0, 2.0], np.ones((1, 1, 2)), ["1:+X"], ["2:+Y"])
    path = write_frf(tmp_path / "h.csv", frf)
    with pytest.raises(TimeDataError, match=r"h\.csv:2: column 1 is 'frequency_hz'; expected "
                                            "time_s"):  # fmt: skip
        read_time_data(path)
    with pytest.raises(TimeDataError, match="no dt, values, names arrays"):
        read_time_data(write_frf(tmp_path / "h.npz", frf))


def test_bad_suffix_lists_the_time_suffixes(tmp_path):
    known = "expected .rsp, .tim, .drv, .csv, .npz"
    with pytest.raises(TimeDataError, match=f"unknown time-history file type '.uff'; {known}"):
        read_time_data(tmp_path / "a.uff")
    with pytest.raises(TimeDataError, match=f"unknown time-history file type '.mat'; {known}"):
        write_time_data(tmp_path / "a.mat", sample(n=4))
    assert not (tmp_path / "a.mat").exists()
    with pytest.raises(FileNotFoundError):
        read_time_data(tmp_path / "missing.csv")


HEAD = "time_s,a,b\n"


@pytest.mark.parametrize("text, message", [
    ("", r"empty; expected a header row time_s"),
    (HEAD + "0,1,2\n0.1,2,3", r":3: the last line does not end with a line break: is the file "
                              r"cut short\?"),
    (HEAD + "0,1,2\n0.1,2,3\n0.2,4", r":4: the last line does not end"),
    (HEAD, r":1: 0 rows after the header; expected one row per sample, at least two"),
    ("t,a\n0,1\n1,2\n", r":1: column 1 is 't'; expected time_s"),
    ("time_s,a,b,a\n0,1,2,3\n1,2,3,4\n", r":1: column 4 is named 'a' like column 2; expected "
                                         r"each channel name once"),
    ("time_s,a,,b\n0,1,2,3\n1,2,3,4\n", r":1: column 3 has no name"),
    (HEAD + "0,1,2\n0.1,2\n0.2,3,4\n", r":3: 2 fields \(too few\); expected 3: time_s and 2 "
                                       r"channels"),
    (HEAD + "0,1,2\n0.1,2,3,4\n", r":3: 4 fields \(too many\)"),
    (HEAD + "0,1,2\n0.1,x,3\n", r":3: column 2 \('a'\): 'x' is not a number"),
    (HEAD + "0,1,2\n\n0.1,1,nan\n", r":4: column 3 \('b'\) is nan; expected a finite number"),
    (HEAD + "0,1,2\n0.1,1,2\n0.2,1,2\n0.31,1,2\n0.4,1,2\n",
     r":5: time step 0\.11 s from line 4 \(t = 0\.2 to 0\.31\); expected evenly spaced times, "
     r"every step within 1e-06 of the mean step 0\.1 s"),
    (HEAD + "0,1,2\n0.1,1,2\n0.05,1,2\n0.3,1,2\n", r":4: time 0\.05 s is not after 0\.1 s "
                                                   r"\(line 3\)"),
    (HEAD + "# units: mm\n0,1,2\n1,2,3\n", r":2: 1 units for 2 channels"),
    (HEAD + "0,1,2\n# units: mm, N\n1,2,3\n", r":3: a units line among the rows"),
])  # fmt: skip
def test_bad_csv_files_name_file_line_and_column(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(TimeDataError, match=message) as e:
        read_time_data(path)
    assert str(e.value).startswith(str(path))


def test_irregular_steps_within_the_tolerance_are_taken(tmp_path):
    t = np.arange(6) * 0.01
    t[3] += 1e-9  # 1e-7 of dt
    path = tmp_path / "jitter.csv"
    path.write_text("time_s,a\n" + "".join(f"{x!r},1.0\n" for x in t.tolist()))
    assert read_time_data(path).dt == pytest.approx(0.01, rel=1e-12)
    t[3] += 1e-7  # 1e-5 of dt
    path.write_text("time_s,a\n" + "".join(f"{x!r},1.0\n" for x in t.tolist()))
    with pytest.raises(TimeDataError, match=r"jitter\.csv:5: time step"):
        read_time_data(path)


def test_the_csv_writer_refuses_what_it_could_not_read_back(tmp_path):
    with pytest.raises(TimeDataError, match="1 sample: a time-history CSV needs at least two"):
        write_time_csv(tmp_path / "a.csv", TimeData(1.0, np.ones((1, 1)), ("a",), ("",)))
    with pytest.raises(TimeDataError, match="channels 1 and 2 are both named 'a'"):
        write_time_csv(tmp_path / "a.csv", TimeData(1.0, np.ones((2, 3)), ("a", "a"),
                                                    ("", "")))  # fmt: skip
    with pytest.raises(TimeDataError, match=r"channel 'b' sample 2 is inf"):
        write_time_csv(tmp_path / "a.csv", TimeData(1.0, np.array([[0.0, 1, 2], [0, 1, np.inf]]),
                                                    ("a", "b"), ("", "")))  # fmt: skip
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("arrays, message", [
    ({"dt": 0.1, "values": np.ones((2, 3))},
     r"no names array \(it holds dt, values\); expected the arrays dt, values, names"),
    ({"values": np.ones((2, 3))}, r"no dt, names arrays"),
    ({"dt": np.ones(3), "values": np.ones((2, 3)), "names": ["a", "b"]},
     r"dt is a float64 array of shape \(3,\); expected one number"),
    ({"dt": 0.0, "values": np.ones((2, 3)), "names": ["a", "b"]}, r"dt = 0\.0; expected a step"),
    ({"dt": 0.1, "values": np.ones(3), "names": ["a", "b"]},
     r"values is a float64 array of shape \(3,\); expected real numbers of shape \(channels, "
     r"samples\)"),
    ({"dt": 0.1, "values": np.ones((2, 3)), "names": ["a"]},
     r"names is a <U1 array of shape \(1,\); expected 2 strings, one per channel"),
    ({"dt": 0.1, "values": np.ones((2, 3)), "names": ["a", "b"], "units": [1.0, 2.0]},
     r"units is a float64 array of shape \(2,\)"),
    ({"dt": 0.1, "values": [[1.0, 2.0], [3.0, np.nan]], "names": ["a", "b"]},
     r"channel 'b' \(row 1\) sample 1 is nan"),
])  # fmt: skip
def test_bad_npz_files_name_the_key(tmp_path, arrays, message):
    path = tmp_path / "bad.npz"
    np.savez(path, **{k: np.asarray(v) for k, v in arrays.items()})
    with pytest.raises(TimeDataError, match=message) as e:
        read_time_data(path)
    assert str(e.value).startswith(str(path))
    path.write_text("not a zip")
    with pytest.raises(TimeDataError, match="not an NPZ archive"):
        read_time_npz(path)


def test_npz_without_units_has_none(tmp_path):
    path = tmp_path / "u.npz"
    np.savez(path, dt=0.5, values=np.ones((2, 4), np.float32), names=np.array(["a", "b"]))
    d = read_time_data(path)
    assert d.units == ("", "") and d.values.dtype == np.float64 and d.n_samples == 4


def test_timedata_info_reads_csv(tmp_path, capsys):
    data = TimeData(0.5, np.array([[0.0, 2.0, -2.0, 0.0], [1.0, 1.0, 1.0, 1.0]]), ("a", "b"),
                    ("mm", "N"))  # fmt: skip
    path = write_time_data(tmp_path / "x.csv", data)
    assert main(["timedata", "info", str(path), "--json", str(tmp_path / "s.json")]) == 0
    out = capsys.readouterr().out
    assert "2 channels x 4 samples, dt = 0.5 s (2 Hz), 2 s" in out
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["channels"][0] == {"name": "a", "unit": "mm", "max": 2.0, "min": -2.0,
                                "mean": 0.0, "rms": pytest.approx(np.sqrt(2.0))}  # fmt: skip
    path.write_text(path.read_text()[:-1])  # the last line cut
    assert main(["timedata", "info", str(path)]) == 2
    assert f"{path}:6: the last line does not end with a line break" in capsys.readouterr().err


def test_a_name_given_to_two_channels_is_refused_when_asked_for(tmp_path):
    """Two channels of one name: asking for it names both, instead of the first winning."""
    data = TimeData(0.01, np.zeros((3, 8)), ("a", "b", "a"), ("mm",) * 3)
    back = read_time_data(write_time_data(tmp_path / "t.npz", data))
    assert back.channel("b") == 1
    with pytest.raises(TimeDataError, match=r"2 channels are called 'a' \(channels 1, 3\)"):
        back.channel("a")
