"""The RPC III fuzz harness (:mod:`tests.fuzz.rpc`): a seeded quick run of valid and mutated
files ends in no crash, no hang and no wrong answer, the cases are made again alone from
their ``SEED:K``, and the harness tells the five outcomes apart. The long run is
``benchmarks/fuzz.py --part rpc``; the cases it found are kept below."""

from __future__ import annotations

import time
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from femcal.errors import TimeDataError
from femcal.testdata.timedata import TimeData

from .fuzz import rpc as fuzz

#: About 1.5 s.
SEED, CASES = 23, 1000


def test_quick_seeded_run_has_no_crash_no_hang_and_no_wrong_answer():
    t0 = time.perf_counter()
    findings = fuzz.run_rpc_fuzz(SEED, CASES)
    seconds = time.perf_counter() - t0
    bad = [f"{f.case} [{f.variant}] [{f.mutation}] {f.outcome}: {f.error}" for f in findings
           if f.outcome in ("crash", "hang", "wrong")]  # fmt: skip
    assert not bad, "\n".join(bad[:10])
    outcomes = Counter(f.outcome for f in findings)
    assert set(outcomes) <= set(fuzz.OUTCOMES) and len(findings) == CASES
    # both sides are exercised: files read (valid ones among them) and files refused
    assert outcomes["ok"] > CASES // 4 and outcomes["clean error"] > CASES // 4, outcomes
    assert sum(f.mutation == "none" and f.outcome == "ok" for f in findings) > CASES // 20
    assert seconds < 30, f"{seconds:.1f} s"


def test_cases_are_reproducible_alone(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = fuzz.write_case(f"{SEED}:7", tmp_path / "a")
    b = fuzz.write_case(f"{SEED}:7", tmp_path / "b")
    assert a.name == b.name and a.read_bytes() == b.read_bytes()
    expect = fuzz.expectation(f"{SEED}:7")
    (ra, da), (rb, db) = fuzz.run_case(a, expect), fuzz.run_case(b, expect)
    assert ra == rb and da.replace(str(a), "F") == db.replace(str(b), "F")
    # the same case inside a run is the same file, with the same ending
    run = fuzz.run_rpc_fuzz(SEED, 8)
    assert run[7].case == f"{SEED}:7" and run[7].outcome == ra


@pytest.mark.parametrize("case, what", [
    ("1:93", "NUM_HEADER_BLOCKS = 2^40: a MemoryError reading the header"),
    ("1:2252", "NUM_HEADER_BLOCKS = 10^40 - 1: an OverflowError reading the header"),
    ("1:3966", "CHANNELS = 2^40: a hang making every channel's SCALE before the size check"),
    ("1:802", "PTS_PER_GROUP = 10^90 - 1 on one cut-short group: a ValueError from reshape"),
    ("1:4352", "PTS_PER_GROUP = 10^18 on one group: 'array is too big' from reshape"),
])  # fmt: skip
def test_the_crashes_the_long_run_found_end_cleanly(tmp_path, case, what):
    path = fuzz.write_case(case, tmp_path)
    outcome, detail = fuzz.run_case(path, fuzz.expectation(case))
    assert outcome in ("ok", "clean error"), f"{what}: {outcome}: {detail}"


def _valid_data() -> TimeData:
    return TimeData(0.5, np.array([[1.0, 2.0]]), ("a",), ("mm",))


@pytest.mark.parametrize(("read", "expect", "outcome"), [
    (lambda path: _valid_data(), fuzz.ANY, "ok"),
    (lambda path: (_ for _ in ()).throw(TimeDataError(f"{path}: bad")), fuzz.ANY, "clean error"),
    (lambda path: (_ for _ in ()).throw(TimeDataError("bad, no file named")), fuzz.ANY, "crash"),
    (lambda path: (_ for _ in ()).throw(ValueError("cannot reshape")), fuzz.ANY, "crash"),
    (lambda path: (_ for _ in ()).throw(MemoryError()), fuzz.ANY, "crash"),
    (lambda path: time.sleep(5), fuzz.ANY, "hang"),
    (lambda path: _valid_data(), fuzz.ERROR, "wrong"),
    (lambda path: TimeData(0.5, np.array([[1.0, np.nan]]), ("a",), ("mm",)), fuzz.ANY, "wrong"),
    (lambda path: (_ for _ in ()).throw(TimeDataError(f"{path}: bad")),
     fuzz.Intended(0.5, np.array([[1.0, 2.0]]), ("a",), ("mm",)), "wrong"),
    (lambda path: _valid_data(), fuzz.Intended(0.5, np.array([[1.0, 2.0]]), ("a",), ("mm",)),
     "ok"),
    (lambda path: _valid_data(), fuzz.Intended(0.5, np.array([[1.0, 2.5]]), ("a",), ("mm",)),
     "wrong"),
    (lambda path: _valid_data(), fuzz.Intended(0.5, np.array([[1.0, 2.0]]), ("b",), ("mm",)),
     "wrong"),
])  # fmt: skip
def test_outcomes_are_told_apart(monkeypatch, tmp_path, read, expect, outcome):
    monkeypatch.setattr(fuzz, "format_of", lambda path, kind: SimpleNamespace(read=read))
    got, detail = fuzz.run_case(Path(tmp_path / "x.rsp"), expect, timeout=0.2)
    assert got == outcome, detail


def test_an_allocation_of_what_a_header_claims_is_caught(monkeypatch, tmp_path):
    """The harness's memory cap turns a reader's attempt to allocate terabytes into a
    MemoryError (a crash) at once, on Linux."""
    if fuzz._address_space() is None:
        pytest.skip("no /proc/self/statm: no memory cap here")

    def greedy(path):
        return bytearray(8 << 30)  # 8 GiB

    monkeypatch.setattr(fuzz, "format_of", lambda path, kind: SimpleNamespace(read=greedy))
    got, detail = fuzz.run_case(Path(tmp_path / "x.rsp"), fuzz.ANY)
    assert got == "crash" and detail.startswith("MemoryError"), detail
