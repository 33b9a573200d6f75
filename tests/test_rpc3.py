"""RPC III time histories: femcal's writer and reader round trip, and files written here field by
field to MTS's published layout (another writer's choices: big-endian, blank padding, keywords
in another order, several frames per group, a last group cut short) read right."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from femcal.errors import TimeDataError
from femcal.testdata.formats.rpc3 import read_header, read_rpc3, write_rpc3
from femcal.testdata.timedata import TimeData


def sample(n_ch: int = 3, n: int = 5000, seed: int = 1) -> TimeData:
    rng = np.random.default_rng(seed)
    values = rng.standard_normal((n_ch, n)) * np.array([[1.0], [250.0], [0.01]])[:n_ch]
    return TimeData(1 / 512, values, tuple(f"ch {c}" for c in range(n_ch)),
                    ("mm", "N", "g")[:n_ch])  # fmt: skip


def test_floats_round_trip_exactly_in_single_precision(tmp_path):
    data = sample()
    back = read_rpc3(write_rpc3(tmp_path / "a.rsp", data))
    assert back.names == data.names and back.units == data.units and back.dt == data.dt
    np.testing.assert_array_equal(back.values, data.values.astype(np.float32))
    assert back.header["DATA_TYPE"] == "FLOATING_POINT"


def test_short_integers_round_trip_within_half_a_step(tmp_path):
    data = sample(n=3001)  # prime to 1024: frames of one point, a padded last group
    path = write_rpc3(tmp_path / "a.tim", data, data_type="SHORT_INTEGER")
    back = read_rpc3(path)
    step = np.abs(data.values).max(axis=1) / 32767
    assert back.values.shape == data.values.shape
    assert np.all(np.abs(back.values - data.values) <= 0.5 * step[:, None] * (1 + 1e-9))
    assert path.stat().st_size % 2 == 0 and read_header(path)[1] % 512 == 0


def _record(key: str, value: str, pad: bytes) -> bytes:
    return key.encode().ljust(32, pad) + value.encode().ljust(96, pad)


def write_by_hand(path: Path, values_int: np.ndarray, scales: list[float], *, ppf: int,
                  ppg: int, cut_last: bool, order: str = ">", pad: bytes = b" ") -> None:
    """An RPC III file of short integers written record by record, as another tool might."""
    n_ch, n = values_int.shape
    keys = [("DELTA_T", "1.953125E-03"), ("DATA_TYPE", "SHORT_INTEGER"),
            ("PTS_PER_GROUP", str(ppg)), ("CHANNELS", str(n_ch)), ("FRAMES", str(n // ppf)),
            ("PTS_PER_FRAME", str(ppf)), ("FILE_TYPE", "TIME_HISTORY")]  # fmt: skip
    for c in range(n_ch):
        keys += [(f"SCALE.CHAN_{c + 1}", f"{scales[c]:.6E}"), (f"DESC.CHAN_{c + 1}", f"Act {c + 1}"),
                 (f"UNITS.CHAN_{c + 1}", "mm")]  # fmt: skip
    n_params = len(keys) + 3
    blocks = -(-n_params // 4) + 1  # a spare block, as some writers leave
    fmt = "BINARY_IEEE_BIG_END" if order == ">" else "BINARY_IEEE_LITTLE_END"
    head = b"".join(_record(k, v, pad) for k, v in
                    [("FORMAT", fmt), ("NUM_HEADER_BLOCKS", str(blocks)),
                     ("NUM_PARAMS", str(n_params)), *keys])  # fmt: skip
    head = head.ljust(blocks * 512, b"\0")
    n_groups = -(-n // ppg)
    body = b""
    for g in range(n_groups):
        for c in range(n_ch):
            chunk = values_int[c, g * ppg:(g + 1) * ppg]
            if not cut_last:
                chunk = np.concatenate([chunk, np.zeros(ppg - len(chunk), np.int64)])
            body += chunk.astype(order + "i2").tobytes()
    path.write_bytes(head + body)


@pytest.mark.parametrize("cut_last", [False, True])
@pytest.mark.parametrize("order", [">", "<"])
def test_a_file_written_field_by_field_to_the_published_layout_reads_right(tmp_path, cut_last,
                                                                            order):  # fmt: skip
    rng = np.random.default_rng(7)
    ints = rng.integers(-32767, 32768, size=(3, 20))
    scales = [0.5, 2.0e-3, 10.0]
    path = tmp_path / "other.rsp"
    write_by_hand(path, ints, scales, ppf=4, ppg=8, cut_last=cut_last, order=order)
    data = read_rpc3(path)
    assert data.names == ("Act 1", "Act 2", "Act 3") and data.units == ("mm",) * 3
    assert data.dt == pytest.approx(1 / 512)
    np.testing.assert_allclose(data.values, ints * np.array(scales)[:, None], rtol=1e-6)


@pytest.mark.parametrize("damage, message", [
    (lambda b: b[:-7], r"bytes of data after the header; 3 channels x 20 points \(5 frames of "
                       r"4\) in 3 groups of 8 need"),
    (lambda b: b[:700], r"the header is cut short at byte 700"),
    (lambda b: b[:300], r"300 bytes; expected an RPC III header"),
    (lambda b: _record("NUM_PARAMS", "22", b" ") + b[128:256] + b[:128] + b[384:],
     r"header record 1 is 'NUM_PARAMS'; expected FORMAT"),
    (lambda b: b.replace(b"CHANNELS" + b" " * 24 + b"3".ljust(96),
                         b"CHANNELS" + b" " * 24 + b"4".ljust(96)),
     r"3 groups of 8 need"),
    (lambda b: b.replace(b"FRAMES" + b" " * 26 + b"5".ljust(96),
                         b"FRAMES" + b" " * 26 + b"x".ljust(96)),
     r"FRAMES = 'x'; expected a whole number"),
])  # fmt: skip
def test_broken_files_are_errors_naming_file_and_keyword(tmp_path, damage, message):
    good = tmp_path / "good.rsp"
    write_by_hand(good, np.ones((3, 20), np.int64), [1.0, 1.0, 1.0], ppf=4, ppg=8,
                  cut_last=False)  # fmt: skip
    bad = tmp_path / "bad.rsp"
    bad.write_bytes(damage(good.read_bytes()))
    with pytest.raises(TimeDataError, match=message) as e:
        read_rpc3(bad)
    assert str(bad) in str(e.value)


def test_missing_keywords_and_bad_values_are_named(tmp_path):
    good = tmp_path / "good.rsp"
    write_by_hand(good, np.ones((1, 8), np.int64), [1.0], ppf=4, ppg=8, cut_last=False)
    raw = good.read_bytes()
    no_dt = raw.replace(b"DELTA_T".ljust(32), b"DELTA_X".ljust(32))
    (tmp_path / "no_dt.rsp").write_bytes(no_dt)
    with pytest.raises(TimeDataError, match="no DELTA_T keyword"):
        read_rpc3(tmp_path / "no_dt.rsp")
    with pytest.raises(TimeDataError, match="holds NaN or infinite samples"):
        write_rpc3(tmp_path / "nan.rsp", TimeData(0.01, np.array([[0.0, np.nan]]), ("a",),
                                                  ("",)))  # fmt: skip
    assert not (tmp_path / "nan.rsp").exists()


def test_timedata_info_prints_and_writes_each_channel(tmp_path, capsys):
    import json

    from femcal.cli import main

    data = TimeData(0.5, np.array([[0.0, 2.0, -2.0, 0.0], [1.0, 1.0, 1.0, 1.0]]), ("a", "b"),
                    ("mm", "N"))  # fmt: skip
    path = write_rpc3(tmp_path / "x.tim", data)
    assert main(["timedata", "info", str(path), "--json", str(tmp_path / "s.json")]) == 0
    out = capsys.readouterr().out
    assert "2 channels x 4 samples, dt = 0.5 s (2 Hz), 2 s" in out
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["dt"] == 0.5 and s["n_samples"] == 4
    assert s["channels"][0] == {"name": "a", "unit": "mm", "max": 2.0, "min": -2.0,
                                "mean": 0.0, "rms": pytest.approx(np.sqrt(2.0))}  # fmt: skip
    assert main(["timedata", "info", str(tmp_path / "s.json")]) == 2
    assert ("unknown time-history file type '.json'; expected .rsp, .tim, .drv, .csv, .npz"
            in capsys.readouterr().err)  # fmt: skip
