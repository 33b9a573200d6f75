"""RPC III time histories: femcal's writer and reader round trip, and files written here field by
field to MTS's published layout (another writer's choices: big-endian, blank padding, keywords
in another order, several frames per group, a last group cut short) read right.

Below: one test per robustness fix of the reader (the crashes the fuzz harness
tests/fuzz/rpc.py found, sizes checked against the file before anything is allocated, what
is read and what is refused), and files built byte by byte as public writers build them
(pyRPC3 by galuszkm and by Kevin0Jung, rpc3-file, FEDEM, MTS's own example header)."""

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


def test_floats_beyond_single_precision_are_refused_not_written_as_inf(tmp_path):
    data = sample()
    big = TimeData(data.dt, data.values * 1e40, data.names, data.units)
    with pytest.raises(TimeDataError, match=r"channel 'ch 0' reaches .* beyond the largest "
                                            r"single-precision number"):  # fmt: skip
        write_rpc3(tmp_path / "a.rsp", big)
    assert not (tmp_path / "a.rsp").exists()
    back = read_rpc3(write_rpc3(tmp_path / "b.rsp", big, data_type="SHORT_INTEGER"))
    assert np.isfinite(back.values).all()  # short integers with a large SCALE hold it


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


# ----------------------------------------------------------------------------- robustness
# Each test below is one fix of the reader, found by the fuzz harness (tests/fuzz/rpc.py) or by
# reading other writers' code; the files are built field by field.


def _pack(records: list[tuple[str, str]], *, blocks: int | None = None, pad: bytes = b"\0",
          encoding: str = "ascii") -> bytes:
    """Header records (the first three included) padded to ``blocks`` whole blocks."""
    raw = b"".join(k.encode(encoding).ljust(32, pad) + v.encode(encoding).ljust(96, pad)
                   for k, v in records)  # fmt: skip
    return raw.ljust((blocks or -(-len(records) // 4)) * 512, pad)


def _small(keys: list[tuple[str, str]], *, blocks: str | None = None, n_params: str | None = None,
           fmt: str = "BINARY_IEEE_LITTLE_END", encoding: str = "ascii") -> bytes:
    """A header: FORMAT, NUM_HEADER_BLOCKS, NUM_PARAMS (from ``keys`` unless given), ``keys``."""
    n = len(keys) + 3
    records = [("FORMAT", fmt), ("NUM_HEADER_BLOCKS", blocks or str(-(-n // 4))),
               ("NUM_PARAMS", n_params or str(n)), *keys]  # fmt: skip
    return _pack(records, blocks=-(-n // 4), encoding=encoding)


#: Two channels of four points in one group: 16 bytes of short integers.
KEYS = [("CHANNELS", "2"), ("DELTA_T", "0.5"), ("PTS_PER_FRAME", "4"), ("FRAMES", "1"),
        ("PTS_PER_GROUP", "4"), ("DESC.CHAN_1", "a"), ("DESC.CHAN_2", "b")]  # fmt: skip
DATA = np.array([[1, 2, 3, 4], [-1, -2, -3, -4]], "<i2").tobytes()


def _with(keys: list[tuple[str, str]], **changes: str) -> list[tuple[str, str]]:
    return [(k, changes.get(k.replace(".", "_"), v)) for k, v in keys]


@pytest.mark.parametrize("blocks", ["4294967296", "1099511627776", "9" * 40, "1" + "0" * 18])
def test_a_header_bigger_than_the_file_is_refused_before_it_is_read(tmp_path, blocks):
    """Fuzz cases 1:93 and 1:2252: NUM_HEADER_BLOCKS = 2^40 was read as one read() of half a
    petabyte (a MemoryError), 10^40 - 1 as an OverflowError."""
    import tracemalloc

    path = tmp_path / "big.rsp"
    path.write_bytes(_small(KEYS, blocks=blocks) + DATA)
    tracemalloc.start()
    try:
        with pytest.raises(TimeDataError, match=rf"NUM_HEADER_BLOCKS = {blocks} asks for") as e:
            read_rpc3(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(path) in str(e.value) and "cut short at byte 1552" in str(e.value)
    assert peak < 1 << 20


@pytest.mark.parametrize("key, value", [("CHANNELS", "1099511627776"), ("FRAMES", "10" * 9),
                                        ("PTS_PER_FRAME", "4" * 30), ("CHANNELS", "1000000")])  # fmt: skip
def test_counts_of_terabytes_are_refused_before_anything_per_channel_is_made(tmp_path, key,
                                                                               value):  # fmt: skip
    """Fuzz case 1:3966: CHANNELS = 2^40 made every channel's SCALE, DESC and UNITS before the
    data size was checked (a hang, then a MemoryError)."""
    import signal
    import time
    import tracemalloc

    def ring(signum, frame):
        raise TimeoutError("reading took more than 5 s: something is made per channel")

    path = tmp_path / "huge.rsp"
    path.write_bytes(_small(_with(KEYS, **{key: value})) + DATA)
    previous = signal.signal(signal.SIGALRM, ring)
    signal.setitimer(signal.ITIMER_REAL, 5.0)
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        with pytest.raises(TimeDataError, match="16 bytes of data after the header") as e:
            read_rpc3(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert str(path) in str(e.value) and time.perf_counter() - t0 < 1.0 and peak < 1 << 20


@pytest.mark.parametrize("ppg", ["8", "1000000000000000000", "9" * 90])
def test_one_group_cut_short_reads_whatever_points_per_group_says(tmp_path, ppg):
    """Fuzz cases 1:802 and 1:4352: a single group cut short (each channel's points, then the
    next channel's) with PTS_PER_GROUP beyond the points was reshaped to (0, channels,
    PTS_PER_GROUP): a ValueError from NumPy. It is a plain file: read it."""
    path = tmp_path / "one.rsp"
    path.write_bytes(_small(_with(KEYS, PTS_PER_GROUP=ppg)) + DATA)
    data = read_rpc3(path)
    np.testing.assert_array_equal(data.values, [[1, 2, 3, 4], [-1, -2, -3, -4]])


def test_values_in_windows_1252_and_latin_1_are_read_keywords_must_be_ascii(tmp_path):
    """µm/m, °C and € as python rpc3-file (Latin-1) and pyRPC3 (Windows-1252) write them; a
    keyword that is not ASCII is a damaged header."""
    keys = [*KEYS, ("UNITS.CHAN_1", "µm/m"), ("UNITS.CHAN_2", "°C €/kWh")]
    path = tmp_path / "units.rsp"
    path.write_bytes(_small(keys, encoding="cp1252") + DATA)
    assert read_rpc3(path).units == ("µm/m", "°C €/kWh")
    raw = path.read_bytes().replace(b"\x80", b"\x81")  # no character in Windows-1252
    path.write_bytes(raw)
    assert read_rpc3(path).units == ("µm/m", "°C \x81/kWh")
    path.write_bytes(_small([*KEYS, ("ÜNITS.CHAN_1", "mm")], encoding="latin-1") + DATA)
    with pytest.raises(TimeDataError, match=r"header record 11: keyword 'ÜNITS.CHAN_1' is not "
                                            r"ASCII text; expected an RPC III keyword"):  # fmt: skip
        read_rpc3(path)


def test_empty_records_among_num_params_are_skipped_a_value_without_keyword_is_not(tmp_path):
    """Readers skip unused records counted in NUM_PARAMS (pyRPC3, rpc3-file); femcal refused
    them."""
    path = tmp_path / "gaps.rsp"
    path.write_bytes(_small([*KEYS[:3], ("", ""), *KEYS[3:], ("", "")]) + DATA)
    data = read_rpc3(path)
    assert data.names == ("a", "b") and "" not in data.header
    path.write_bytes(_small([*KEYS, ("", "lost")]) + DATA)
    with pytest.raises(TimeDataError, match="header record 11 has the value 'lost' and no "
                                            "keyword"):  # fmt: skip
        read_rpc3(path)


def test_keywords_in_lower_case_are_the_same_keywords(tmp_path):
    """FEDEM's reader upper-cases the keywords; femcal ignored ``desc.chan_1`` (a channel
    named 'channel 1') and refused ``format``."""
    keys = [(k.lower(), v) for k, v in KEYS]
    path = tmp_path / "lower.rsp"
    path.write_bytes(_pack([("format", "binary_ieee_little_end"), ("num_header_blocks", "3"),
                            ("num_params", "10"), *keys]) + DATA)  # fmt: skip
    data = read_rpc3(path)
    assert data.names == ("a", "b") and data.header["DESC.CHAN_1"] == "a"
    path.write_bytes(_small([*KEYS, ("desc.chan_1", "again")]) + DATA)
    with pytest.raises(TimeDataError, match=r"keyword DESC.CHAN_1 given twice \(records 9 and 11\)"):
        read_rpc3(path)


def test_scale_applies_to_short_integers_only(tmp_path):
    """SCALE is the 16-bit converter's step (MTS); pyRPC3, rpc3-file, RPC3.js and the
    rpc_reader apply it to SHORT_INTEGER data only. femcal multiplied floats by it too."""
    floats = np.array([[1.5, 2.5, 3.5, 4.5], [0.25, 0.5, 0.75, 1.0]], "<f4")
    keys = [*KEYS, ("DATA_TYPE", "FLOATING_POINT"), ("SCALE.CHAN_1", "2.5"),
            ("SCALE.CHAN_2", "not used")]  # fmt: skip
    path = tmp_path / "floats.rsp"
    path.write_bytes(_small(keys) + floats.tobytes())
    np.testing.assert_array_equal(read_rpc3(path).values, floats)
    keys = [*KEYS, ("SCALE.CHAN_1", "2.5"), ("SCALE.CHAN_2", "0")]  # a zero channel's SCALE
    path.write_bytes(_small(keys) + DATA)
    np.testing.assert_array_equal(read_rpc3(path).values, [[2.5, 5, 7.5, 10], [0, 0, 0, 0]])


def test_samples_that_are_not_finite_numbers_are_refused(tmp_path):
    """A float that is NaN or infinite, or a SCALE that makes the values overflow, read as
    such: the CSV and NPZ readers refuse them, so does this one now."""
    floats = np.array([[1.0, 2.0, np.nan, 4.0], [1.0, 1.0, 1.0, np.inf]], "<f4")
    path = tmp_path / "nan.rsp"
    path.write_bytes(_small([*KEYS, ("DATA_TYPE", "FLOATING_POINT")]) + floats.tobytes())
    with pytest.raises(TimeDataError, match=r"channel 1 \('a'\) sample 2 \(t = 1 s\) is nan; "
                                            "expected finite numbers"):  # fmt: skip
        read_rpc3(path)
    path.write_bytes(_small([*KEYS, ("SCALE.CHAN_2", "1e308")]) + DATA)
    with pytest.raises(TimeDataError, match=r"SCALE.CHAN_2 = 1e308 times the stored short "
                                            r"integers of channel 2 \('b'\) overflows"):  # fmt: skip
        read_rpc3(path)


@pytest.mark.parametrize("extra, message", [
    (1, None), (511, None),
    (512, r"need 16 \(or 16 with the last group cut short\), and at most 511 bytes more"),
])  # fmt: skip
def test_bytes_after_the_data_up_to_a_record(tmp_path, extra, message):
    """A writer may pad the file to whole 512-byte records, FEDEM's writes one sample past
    the end; more than a record's rest was read as if nothing were there (a float file
    without its DATA_TYPE read as garbage short integers)."""
    path = tmp_path / "tail.rsp"
    path.write_bytes(_small(KEYS) + DATA + b"\x01" * extra)
    if message is None:
        np.testing.assert_array_equal(read_rpc3(path).values[1], [-1, -2, -3, -4])
    else:
        with pytest.raises(TimeDataError, match=message):
            read_rpc3(path)


@pytest.mark.parametrize("change, message", [
    ({"FORMAT": "ASCII"}, r"FORMAT = ASCII: RPC III data written as text are not read; expected "
                          "one of BINARY_IEEE_LITTLE_END, BINARY_IEEE_BIG_END, BINARY"),
    ({"FORMAT": "BINARY_VAX"}, r"FORMAT = 'BINARY_VAX'; expected one of"),
    ({"FILE_TYPE": "CONFIGURATION"}, r"FILE_TYPE = CONFIGURATION: a configuration file holds "
                                     "a header and no data; expected TIME_HISTORY"),
    ({"FILE_TYPE": "MATRIX"}, r"FILE_TYPE = 'MATRIX'; expected TIME_HISTORY"),
    ({"TIME_TYPE": "CONFIG_RESP"}, r"TIME_TYPE = CONFIG_RESP: a configuration file holds a "
                                   r"header and no data; expected a time history"),
    ({"TIME_TYPE": "6"}, r"TIME_TYPE = 6: a configuration file"),
    ({"HALF_FRAMES": "1"}, r"HALF_FRAMES = 1: half frames are not read; expected 0"),
    ({"DATA_TYPE": "LONG"}, r"DATA_TYPE = 'LONG'; expected SHORT_INTEGER, FLOATING_POINT or "
                            "DOUBLE_PRECISION"),
    ({"SAMPLES": "5"}, r"SAMPLES = 5; expected at most the 4 points of FRAMES x PTS_PER_FRAME "
                       r"\(1 x 4\)"),
    ({"SAMPLES": "0"}, r"SAMPLES = 0; expected a whole number >= 1"),
    ({"FRAMES": "1_0"}, r"FRAMES = '1_0'; expected a whole number"),
    ({"DELTA_T": "0x10"}, r"DELTA_T = '0x10'; expected a number"),
])  # fmt: skip
def test_what_is_not_read_is_refused_naming_the_keyword(tmp_path, change, message):
    keys = [(k, change.pop(k, v)) for k, v in KEYS] + list(change.items())
    fmt = dict(keys).pop("FORMAT", "BINARY_IEEE_LITTLE_END")
    path = tmp_path / "no.rsp"
    path.write_bytes(_small([(k, v) for k, v in keys if k != "FORMAT"], fmt=fmt) + DATA)
    with pytest.raises(TimeDataError, match=message) as e:
        read_rpc3(path)
    assert str(path) in str(e.value)


def test_numbers_in_the_notations_writers_use(tmp_path):
    """Counts with a sign or leading zeros, reals with a FORTRAN exponent or a bare point."""
    keys = _with(KEYS, CHANNELS="+002", FRAMES="  0001 ", DELTA_T="5.0D-01")
    path = tmp_path / "numbers.rsp"
    path.write_bytes(_small([*keys, ("SCALE.CHAN_1", "1."), ("SCALE.CHAN_2", ".5E+1")]) + DATA)
    data = read_rpc3(path)
    assert data.dt == 0.5
    np.testing.assert_array_equal(data.values, [[1, 2, 3, 4], [-5, -10, -15, -20]])


# ----------------------------------------------------------------------------- other writers
# Files built byte by byte the way public RPC III writers build them (their source read, not
# run: the repository and path are in each docstring), and read here.


def _demultiplex(stored: np.ndarray, ppg: int) -> bytes:
    """Channels x points (the padded length, a whole number of groups) in groups."""
    n_ch, n = stored.shape
    return b"".join(stored[c, g * ppg:(g + 1) * ppg].tobytes()
                    for g in range(n // ppg) for c in range(n_ch))  # fmt: skip


def test_pyrpc3_galuszkm_writer(tmp_path):
    """galuszkm/pyRPC3, src/pyRPC3/writer.py (``write_rpc3``): FORMAT ``BINARY``, 13 common
    keywords then DESC, UNITS, SCALE, LOWER_LIMIT "1", UPPER_LIMIT "-1" per channel, NUL
    padded, NUM_HEADER_BLOCKS = ceil(NUM_PARAMS / 4); PTS_PER_FRAME 1024 and one group of all
    the frames, each channel padded with its last value; short integers
    ``(values / factor).astype(int16)`` with factor = largest magnitude / 32767 written
    ``8.6E`` (0 for a channel of zeros); DELTA_T ``8.6E``; DATE ``h:m:s d-m-y``."""
    rng = np.random.default_rng(3)
    values = [rng.standard_normal(1500) * 40.0, np.zeros(1500), rng.standard_normal(1500)]
    names, units, dt = ["FDO_54xLoc_sh", "ACC 76z Glob", "D_23magLo"], ["N", "m/s^2", "mm"], 1 / 200
    pts_per_frame = 1024
    frames = -(-1500 // pts_per_frame)
    ppg = frames * pts_per_frame
    ints, scales = [], []
    for v in values:
        factor = np.abs([v.max(), v.min()]).max() / (2**15 - 1)
        ints.append((v / factor).astype(np.int16) if factor > 0 else v.astype(np.int16))
        scales.append(format(factor, "8.6E"))
    keys = ["FORMAT", "NUM_HEADER_BLOCKS", "NUM_PARAMS", "FILE_TYPE", "TIME_TYPE", "DELTA_T",
            "CHANNELS", "DATE", "REPEATS", "DATA_TYPE", "PTS_PER_FRAME", "PTS_PER_GROUP",
            "FRAMES"]  # fmt: skip
    n_params = len(keys) + 5 * len(values)
    vals = ["BINARY", str(-(-n_params // 4)), str(n_params), "TIME_HISTORY", "RESPONSE",
            format(dt, "8.6E"), str(len(values)), "9:5:3 1-2-2024", "1", "SHORT_INTEGER",
            str(pts_per_frame), str(ppg), str(frames)]  # fmt: skip
    for c in range(len(values)):
        keys += [f"{k}{c + 1}" for k in ("DESC.CHAN_", "UNITS.CHAN_", "SCALE.CHAN_",
                                         "LOWER_LIMIT.CHAN_", "UPPER_LIMIT.CHAN_")]  # fmt: skip
        vals += [names[c], units[c], scales[c], "1", "-1"]
    head = b"".join(k.encode().ljust(32, b"\x00") + v.encode().ljust(96, b"\x00")
                    for k, v in zip(keys, vals, strict=True))  # fmt: skip
    head = head.ljust(512 * int(vals[1]), b"\x00")
    body = b"".join(np.pad(d, (0, ppg - len(d)), "constant", constant_values=d[-1]).tobytes()
                    for d in ints)  # fmt: skip
    path = tmp_path / "pyrpc3.rsp"
    path.write_bytes(head + body)

    data = read_rpc3(path)
    assert data.names == tuple(names) and data.units == tuple(units)
    assert data.dt == float(format(dt, "8.6E")) and data.values.shape == (3, 2048)
    for c in range(3):
        want = np.pad(ints[c], (0, ppg - 1500), "constant", constant_values=ints[c][-1])
        np.testing.assert_array_equal(data.values[c], want * float(scales[c]))
    assert data.header["SCALE.CHAN_2"] == "0.000000E+00" and not data.values[1].any()


def test_rpc3_file_a_ma72_writer(tmp_path):
    """a-ma72/rpc3-file, src/rpc3.py (``write``): FORMAT ``BINARY``, the keywords in the order
    of its ``make_params`` (DATA_TYPE first, then FILE_TYPE, DATE, OPERATION, ...), values
    ``str()`` of Python and NumPy numbers encoded Latin-1, NUL padding, every record of the
    last block written (the unused ones empty), NUM_PARAMS = keywords + 2 and
    NUM_HEADER_BLOCKS = (NUM_PARAMS + 3) // 4; PTS_PER_FRAME = PTS_PER_GROUP (a power of 2),
    FRAMES = ceil(SAMPLES / PTS_PER_GROUP), SAMPLES the real length, the last group padded with
    each channel's last value; short integers ``(data / scale).astype(int16)`` with scale =
    largest magnitude / 32752 (INT_FULL_SCALE). Read: SAMPLES points, not the padding."""
    rng = np.random.default_rng(4)
    data_in = [rng.standard_normal(700) * 3.0, rng.standard_normal(700) * 1e3]
    names, units, dt, ppg = ["Strain gauge 3", "Spindle Fx (LF)"], ["µm/m", "N"], 0.001, 256
    samples = 700
    params: dict[str, object] = {"DATA_TYPE": "SHORT_INTEGER", "FORMAT": "BINARY",
                                 "FILE_TYPE": "TIME_HISTORY", "DATE": "2024-01-31T12:00:00",
                                 "OPERATION": "Python rpc3 1.0.0rc4", "CHANNELS": 2,
                                 "TIME_TYPE": "RESPONSE", "DELTA_T": dt, "PTS_PER_FRAME": ppg,
                                 "PTS_PER_GROUP": ppg, "FRAMES": (samples + ppg - 1) // ppg,
                                 "SAMPLES": samples, "BYPASS_FILTER": 0, "HALF_FRAMES": 0,
                                 "INT_FULL_SCALE": 2**15 - 16, "REPEATS": 1, "PART.CHAN_1": 1,
                                 "PART.NCHAN_1": 2, "PARTITIONS": 1}  # fmt: skip
    scales = []
    for i, d in enumerate(data_in, 1):
        scale = max(abs(d.min()), abs(d.max())) / (2**15 - 16)
        params[f"SCALE.CHAN_{i}"] = scale if scale != 0 else 1.0
        params[f"DESC.CHAN_{i}"] = names[i - 1]
        params[f"LOWER_LIMIT.CHAN_{i}"] = d.min()
        params[f"UPPER_LIMIT.CHAN_{i}"] = d.max()
        params[f"MAP.CHAN_{i}"] = i
        params[f"UNITS.CHAN_{i}"] = units[i - 1]
        scales.append(params[f"SCALE.CHAN_{i}"])
    params["NUM_PARAMS"] = len(params) + 2
    params["NUM_HEADER_BLOCKS"] = (params["NUM_PARAMS"] + 3) // 4
    head, n_params = b"", params["NUM_PARAMS"]
    rest = iter([])
    for i in range(params["NUM_HEADER_BLOCKS"] * 4):
        if i < n_params:
            if i < 3:
                key = ("FORMAT", "NUM_HEADER_BLOCKS", "NUM_PARAMS")[i]
                value = params.pop(key)
                if i == 2:
                    rest = iter(params.items())
            else:
                key, value = next(rest)
        else:
            key, value = "", ""
        head += key.encode().ljust(32, b"\0") + str(value).encode("latin-1").ljust(96, b"\0")
    body = b""
    for g in range(params["FRAMES"]):
        for i, d in enumerate(data_in):
            buffer = d[g * ppg:(g + 1) * ppg]
            if buffer.size < ppg:
                buffer = np.append(buffer, np.ones(ppg - buffer.size) * d[-1])
            body += (buffer / scales[i]).astype("<i2").tobytes()
    ints = [(d / s).astype("<i2") for d, s in zip(data_in, scales, strict=True)]
    path = tmp_path / "rpc3file.rsp"
    path.write_bytes(head + body)

    data = read_rpc3(path)
    assert data.names == tuple(names) and data.units == ("µm/m", "N") and data.dt == dt
    assert data.values.shape == (2, samples)
    for c in range(2):
        np.testing.assert_array_equal(data.values[c], ints[c] * float(str(scales[c])))
        assert np.abs(data.values[c] - data_in[c]).max() <= scales[c]


def test_pyrpc3_kevin0jung_writer(tmp_path):
    """Kevin0Jung/pyRPC3, src/writter.py (``_write_header``, ``_write_data``,
    ``normalize_int16``) with ``RPC3WriteOptions(format_type="BINARY_IEEE_BIG_END",
    pts_per_frame=256)``: frames of 256 points, 2 frames a group, every group full (zeros
    after the data, FRAMES = ceil(n / 256) counting them), keywords FORMAT ... OPERATION, per
    channel DESC, UNITS, SCALE, LOWER_LIMIT, UPPER_LIMIT, then BYPASS_FILTER, PARTITIONS,
    PART.CHAN_1, PART.NCHAN_1, MAP.CHAN_n; values Windows-1252, NUL padded; reals ``.6E``;
    short integers ``rint(values / scale)`` clipped to int16, scale = largest magnitude /
    32768 (INT_FULL_SCALE)."""
    rng = np.random.default_rng(5)
    channels = [("Kraft längs", "kN", rng.standard_normal(700) * 12.0),
                ("Kosten", "€/h", rng.standard_normal(700))]  # fmt: skip
    ppf, fpg, full_scale = 256, 2, 32768
    ppg = ppf * fpg
    frames = -(-700 // ppf)
    total = -(-frames // fpg) * ppg
    payloads, scales = [], []
    for _, _, v in channels:
        scale = float(np.max(np.abs(v))) / full_scale
        ints = np.clip(np.rint(v / scale), -32768, 32767).astype(np.int16)
        padded = np.zeros(total, np.int16)
        padded[:ints.size] = ints
        payloads.append(padded.astype(">i2"))
        scales.append(scale)
    records = [("FORMAT", "BINARY_IEEE_BIG_END"), ("NUM_HEADER_BLOCKS", "0"), ("NUM_PARAMS", "0"),
               ("FILE_TYPE", "TIME_HISTORY"), ("DATA_TYPE", "SHORT_INTEGER"),
               ("TIME_TYPE", "RESPONSE"), ("DELTA_T", f"{1 / 409.6:.6E}"),
               ("PTS_PER_FRAME", str(ppf)), ("PTS_PER_GROUP", str(ppg)), ("CHANNELS", "2"),
               ("FRAMES", str(frames)), ("HALF_FRAMES", "0"), ("REPEATS", "0"),
               ("INT_FULL_SCALE", str(full_scale)), ("DATE", "9:5:3 1-2-2024"),
               ("OPERATION", "Codex RPC3 Converter")]  # fmt: skip
    for i, (name, unit, _) in enumerate(channels, 1):
        records += [(f"DESC.CHAN_{i}", name), (f"UNITS.CHAN_{i}", unit),
                    (f"SCALE.CHAN_{i}", f"{scales[i - 1]:.6E}"),
                    (f"LOWER_LIMIT.CHAN_{i}", f"{-1.0:.6E}"),
                    (f"UPPER_LIMIT.CHAN_{i}", f"{1.0:.6E}")]  # fmt: skip
    records += [("BYPASS_FILTER", "0"), ("PARTITIONS", "1"), ("PART.CHAN_1", "1"),
                ("PART.NCHAN_1", "2"), ("MAP.CHAN_1", "1"), ("MAP.CHAN_2", "2")]  # fmt: skip
    blocks = -(-len(records) // 4)
    records[1], records[2] = ("NUM_HEADER_BLOCKS", str(blocks)), ("NUM_PARAMS", str(len(records)))
    head = b"".join(k.encode("windows-1252", "replace").ljust(32, b"\x00")
                    + v.encode("windows-1252", "replace").ljust(96, b"\x00") for k, v in records)  # fmt: skip
    head += b"\x00" * (512 * blocks - len(head))
    body = bytearray()  # _write_data
    for g in range(len(payloads[0]) // ppg):
        for channel_data in payloads:
            body.extend(channel_data[g * ppg:(g + 1) * ppg].tobytes())
    path = tmp_path / "kevin.rsp"
    path.write_bytes(head + bytes(body))

    data = read_rpc3(path)
    assert data.names == ("Kraft längs", "Kosten") and data.units == ("kN", "€/h")
    assert data.values.shape == (2, frames * ppf)
    for c in range(2):
        want = payloads[c][:frames * ppf].astype(np.float64) * float(f"{scales[c]:.6E}")
        np.testing.assert_array_equal(data.values[c], want)
        assert not data.values[c, 700:].any()


def _fedem_file(n_ch: int, data_type: str, big: bool, values: np.ndarray, units: list[str],
                dt: float) -> tuple[bytes, list[str], int]:
    """An RPC III file as openfedem/fedem-foundation's FiRPC3File writes it (see the test)."""
    m = values.shape[1]
    ppf, ppg = 1024, 2048
    while m < ppf / 2 and ppf > 256:
        ppf //= 2
    frames = -(-m // ppf)
    n_params = 21 + n_ch * 6
    blocks = -(-n_params // 4)
    size = {"SHORT_INTEGER": 2, "FLOATING_POINT": 4, "DOUBLE_PRECISION": 8}[data_type]
    order = ">" if big else "<"
    head = bytearray(blocks * 512)

    def put(key: str, value: str, numb: int) -> None:  # writeString: text and one NUL
        pos = (numb - 1) * 128
        head[pos:pos + len(key) + 1] = key.encode() + b"\0"
        v = value.encode()[:95]
        head[pos + 32:pos + 32 + len(v) + 1] = v + b"\0"

    floats = data_type != "SHORT_INTEGER"
    put("FORMAT", "BINARY_IEEE_BIG_END" if big else "BINARY_IEEE_LITTLE_END", 1)
    put("NUM_HEADER_BLOCKS", str(blocks), 2)
    put("NUM_PARAMS", str(n_params), 3)
    put("DELTA_T", f"{np.float32(dt):e}", 4)
    put("PTS_PER_FRAME", str(ppf), 5)
    put("FRAMES", str(frames), 6)
    k = 7
    for key, value in [("FILE_TYPE", "TIME_HISTORY"), ("TIME_TYPE", "RESPONSE"),
                       ("DATA_TYPE", data_type), ("PARTITIONS", "1"), ("PART.CHAN_1", "1"),
                       ("PART.NCHAN_1", str(n_ch)), ("PTS_PER_GROUP", str(ppg)),
                       ("CHANNELS", str(n_ch)), ("BYPASS_FILTER", "1" if floats else "0"),
                       ("HALF_FRAMES", "0"), ("REPEATS", "0"), ("INT_FULL_SCALE", "32752")]:  # fmt: skip
        put(key, value, k)
        k += 1
    body = bytearray(n_ch * ppg * size)  # one group: the writer seeks, the gaps are zeros
    scale_texts = []
    for ch in range(1, n_ch + 1):
        y = values[ch - 1]
        if floats:
            scale_text, stored = "1", y.astype(order + ("f8" if size == 8 else "f4"))
        else:
            absmax = max(abs(float(y.max())), abs(float(y.min())))
            scale = absmax / 32752.0
            scale_text = f"{np.float32(scale):e}"
            stored = np.trunc(y / scale).astype(order + "i2")  # (short)(f/myChannelScale)
        scale_texts.append(scale_text)
        for name, text in [(f"SCALE.CHAN_{ch}", scale_text), (f"MAP.CHAN_{ch}", str(ch)),
                           (f"UPPER_LIMIT.CHAN_{ch}", f"{np.float32(y.max()):e}"),
                           (f"LOWER_LIMIT.CHAN_{ch}", f"{np.float32(y.min()):e}"),
                           (f"DESC.CHAN_{ch}", f"{ch}"), (f"UNITS.CHAN_{ch}", units[ch - 1] or
                                                          "NONE")]:  # fmt: skip
            put(name, text, k)
            k += 1
        shift = (ch - 1) * ppg * size
        raw = stored.tobytes()
        body[shift:shift + len(raw)] = raw
        # "Pad the group with zeros": grpPos = endPos+1 .. PTS_PER_GROUP, one past the end
        end = shift + (ppg + 1) * size
        if len(body) < end:
            body.extend(bytes(end - len(body)))
        body[shift + m * size:end] = bytes(end - shift - m * size)
    put("PARENT_1", "", k)
    put("DATE", "Thu Oct  5 14:19:14 1995\n", k + 1)  # ctime(), newline and all
    put("OPERATION", "FEDEM", k + 2)
    return bytes(head) + bytes(body), scale_texts, frames * ppf


@pytest.mark.parametrize("data_type, big", [("SHORT_INTEGER", False),
                                            ("DOUBLE_PRECISION", True),
                                            ("FLOATING_POINT", True)])  # fmt: skip
def test_fedem_writer(tmp_path, data_type, big):
    """openfedem/fedem-foundation, src/FiDeviceFunctions/FiRPC3File.C
    (``preliminaryDeviceWrite``, ``setData``, ``initTHChannel``, ``concludingDeviceWrite``):
    FORMAT little- or big-endian; records at fixed places (DELTA_T, PTS_PER_FRAME and FRAMES
    4-6) each a text and one NUL; reals ``%e`` of a float; DATA_TYPE ``DOUBLE_PRECISION``
    (its own, 64-bit) or ``FLOATING_POINT`` with SCALE 1 and BYPASS_FILTER 1, or short
    integers ``(short)(f / scale)`` with scale = largest magnitude / 32752; per channel
    SCALE, MAP, UPPER_LIMIT, LOWER_LIMIT, DESC, UNITS (``NONE`` when none); DATE from
    ``ctime()`` with its newline; PTS_PER_GROUP 2048; the last group padded with zeros one
    sample too far (a sample past the end of the data)."""
    rng = np.random.default_rng(6)
    values = rng.standard_normal((3, 1000)) * np.array([[1.0], [300.0], [1e-3]])
    raw, scales, n = _fedem_file(3, data_type, big, values, ["mm", "", "g"], 1 / 512)
    path = tmp_path / "fedem.rsp"
    path.write_bytes(raw)
    data = read_rpc3(path)
    assert data.names == ("1", "2", "3") and data.units == ("mm", "NONE", "g")
    assert data.dt == float(f"{np.float32(1 / 512):e}") and data.values.shape == (3, n)
    assert data.header["DATE"] == "Thu Oct  5 14:19:14 1995" and data.header["PARENT_1"] == ""
    for c in range(3):
        if data_type == "SHORT_INTEGER":
            want = np.trunc(values[c] / (np.abs(values[c]).max() / 32752.0)) * float(scales[c])
        else:
            want = values[c].astype("f8" if data_type == "DOUBLE_PRECISION" else "f4")
        np.testing.assert_array_equal(data.values[c, :1000], want)
        assert not data.values[c, 1000:].any()


def test_fedem_reader_takes_headers_byte_swapped_in_pairs(tmp_path):
    """openfedem/fedem-foundation, src/FiDeviceFunctions/FiRPC3File.C (``initialDeviceRead``,
    ``readChars``): a header that starts ``OFMRTA`` holds its strings as 16-bit words of the
    other byte order, each pair of bytes swapped; FEDEM reads such files, the data in the byte
    order FORMAT names. Here the MTS example header below, swapped."""
    raw, ints = _mts_4ch_drv()
    head = bytearray(raw[:12 * 512])
    head[0::2], head[1::2] = raw[1:12 * 512:2], raw[0:12 * 512:2]
    assert head.startswith(b"OFMRTA")
    path = tmp_path / "swapped.drv"
    path.write_bytes(bytes(head) + raw[12 * 512:])
    data = read_rpc3(path)
    assert data.names[0] == "left front vert" and data.header["PARENT_1"] == \
        r"d:\dahlenp\data\4ch_nt.drv"  # fmt: skip
    np.testing.assert_array_equal(data.values, ints)


def _mts_4ch_drv() -> tuple[bytes, np.ndarray]:
    """4CH.DRV of MTS's "RPC File Formats" (Figure 6-5: its header as DUMP_RPC3 prints it; the
    document is in Kevin0Jung/pyRPC3, RPC3_Format.txt): 45 records in 12 blocks, 4 channels
    of 12 frames of 1024 short integers in groups of 2048, SCALE ``1.``."""
    records = [("FORMAT", "BINARY_IEEE_LITTLE_END"), ("NUM_HEADER_BLOCKS", "12"),
               ("NUM_PARAMS", "45"), ("FILE_TYPE", "TIME_HISTORY"),
               ("DATA_TYPE", "SHORT_INTEGER"), ("TIME_TYPE", "DRIVE"),
               ("DELTA_T", "4.882813E-03"), ("PTS_PER_FRAME", "1024"), ("CHANNELS", "4"),
               ("PTS_PER_GROUP", "2048"), ("BYPASS_FILTER", "0"), ("HALF_FRAMES", "0"),
               ("REPEATS", "0"), ("FRAMES", "12")]  # fmt: skip
    for c in range(1, 5):
        records += [(f"SCALE.CHAN_{c}", "1."), (f"UPPER_LIMIT.CHAN_{c}", "1."),
                    (f"LOWER_LIMIT.CHAN_{c}", "-1."), (f"MAP.CHAN_{c}", str(c))]  # fmt: skip
    records += [("PARTITIONS", "1"), ("PART.CHAN_1", "1"), ("PART.NCHAN_1", "4")]
    descs = ["left front vert", "right front vert", "left rear vert", "right rear vert"]
    for c, desc in enumerate(descs, 1):
        records += [(f"DESC.CHAN_{c}", desc), (f"UNITS.CHAN_{c}", "in")]
    records += [("DATE", "05-Oct-95 14:19:14"), ("OPERATION", "TAD"),
                ("PARENT_1", r"d:\dahlenp\data\4ch_nt.drv"), ("INT_FULL_SCALE", "32752")]  # fmt: skip
    assert len(records) == 45
    ints = np.random.default_rng(8).integers(-32752, 32753, size=(4, 12 * 1024))
    return _pack(records, blocks=12) + _demultiplex(ints.astype("<i2"), 2048), ints


def test_the_mts_4ch_drv_example(tmp_path):
    """The header of MTS's own example file (see ``_mts_4ch_drv``) with data: read as MTS
    documents it (values = stored numbers x SCALE 1.)."""
    raw, ints = _mts_4ch_drv()
    path = tmp_path / "4CH.DRV"
    path.write_bytes(raw)
    data = read_rpc3(path)
    assert data.dt == 4.882813e-03 and data.units == ("in",) * 4
    assert data.names == ("left front vert", "right front vert", "left rear vert",
                          "right rear vert")  # fmt: skip
    np.testing.assert_array_equal(data.values, ints)
    assert data.header["INT_FULL_SCALE"] == "32752" and data.header["TIME_TYPE"] == "DRIVE"
