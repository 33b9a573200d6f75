"""The FRF fuzz harness (:mod:`tests.fuzz.frf`): a seeded quick run of every format ends in
no crash and no hang, and the harness tells the four outcomes apart."""

from __future__ import annotations

import time
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import pytest

from femcal.testdata.data import FRFError

from .fuzz import frf as fuzz


def test_quick_seeded_run_has_no_crash_and_no_hang():
    t0 = time.perf_counter()
    findings = fuzz.run_frf_fuzz(seed=23, n=300)
    seconds = time.perf_counter() - t0
    bad = [f"{f.case} {f.format} [{f.mutation}] {f.outcome}: {f.error}" for f in findings
           if f.outcome in ("crash", "hang")]  # fmt: skip
    assert not bad, "\n".join(bad)
    assert len(findings) == 300
    assert {f.format for f in findings} == set(fuzz.FORMATS)
    outcomes = Counter(f.outcome for f in findings)
    # both sides are exercised: files that read (and are identified) and files refused
    assert outcomes["ok"] > 20 and outcomes["clean error"] > 100, outcomes
    assert seconds < 30, f"{seconds:.1f} s"


def test_cases_are_reproducible_alone(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = fuzz.write_case("23:7", tmp_path / "a")
    b = fuzz.write_case("23:7", tmp_path / "b")
    assert a.name == b.name and a.read_bytes() == b.read_bytes()
    assert fuzz.run_case(a)[0] == fuzz.run_case(b)[0]


@pytest.mark.parametrize(("read", "outcome"), [
    (lambda path: (_ for _ in ()).throw(FRFError(f"{path}: bad")), "clean error"),
    (lambda path: (_ for _ in ()).throw(IndexError("list index out of range")), "crash"),
    (lambda path: (_ for _ in ()).throw(ValueError("cannot reshape")), "crash"),
    (lambda path: time.sleep(5), "hang"),
])  # fmt: skip
def test_outcomes_are_told_apart(monkeypatch, tmp_path, read, outcome):
    monkeypatch.setattr(fuzz, "format_of", lambda path, kind: SimpleNamespace(read=read))
    got, error = fuzz.run_case(Path(tmp_path / "x.npz"), timeout=0.2)
    assert got == outcome, error
