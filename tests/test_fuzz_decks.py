"""A quick seeded run of the deck fuzzer (tests/fuzz/decks.py): mutated reference decks never
crash, hang or give modes that the same deck written back by femcal does not give. The long
run (10 000 cases and more) is ``benchmarks/fuzz.py``; what it finds becomes a test in
tests/test_hostile_decks.py."""

from __future__ import annotations

from collections import Counter

from .fuzz.decks import OUTCOMES, run_deck_fuzz

#: 150 cases, about 4 s (the long run is benchmarks/fuzz.py).
SEED, CASES = 20261125, 150


def test_mutated_decks_give_modes_or_a_clean_error():
    findings = run_deck_fuzz(SEED, CASES, timeout=30.0)
    counts = Counter(f.outcome for f in findings)
    bad = [f for f in findings if f.outcome in ("crash", "hang", "wrong")]
    assert not bad, "\n".join(f"seed {f.seed} ({f.deck}) {f.outcome}: {f.mutations}: {f.detail}"
                              for f in bad[:10])  # fmt: skip
    assert set(counts) <= set(OUTCOMES)
    # the run means something: both kinds of answer occur
    assert counts["ok"] >= CASES // 10 and counts["error"] >= CASES // 10
