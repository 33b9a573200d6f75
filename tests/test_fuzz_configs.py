"""A quick seeded run of the calibration-configuration fuzzer (tests/fuzz/configs.py): every
mutated configuration, parameter and truth file is read and checked, or refused with a clean
error naming its file; nothing crashes and nothing invalid is accepted. The long run:
``.venv/bin/python -m tests.fuzz.configs --seed 1 -n 5000``."""

from __future__ import annotations

from collections import Counter

from .fuzz.configs import OUTCOMES, run_config_fuzz


def test_three_hundred_mutated_configurations_end_cleanly():
    findings = run_config_fuzz(seed=23, n=300)
    counts = Counter(f.outcome for f in findings)
    assert set(counts) <= set(OUTCOMES) and sum(counts.values()) == 300
    bad = [f for f in findings if f.outcome in ("crash", "accepted bad input")]
    assert not bad, "\n".join(f"case {f.case} [{f.outcome}] {f.mutation}: {f.exception}"
                              for f in bad[:10])  # fmt: skip
    # the run exercises both sides: inputs read and inputs refused
    assert counts["ok"] >= 10 and counts["clean error"] >= 200


def test_the_same_seed_gives_the_same_cases():
    a, b = run_config_fuzz(seed=5, n=20), run_config_fuzz(seed=5, n=20)
    assert [(f.mutation, f.outcome) for f in a] == [(f.mutation, f.outcome) for f in b]
