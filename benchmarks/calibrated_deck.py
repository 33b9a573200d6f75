"""The calibrated deck read by femcal and by pyNastran 1.4.1 to the same model (issue 27).

The bundled hammer frame's 30 parameters are set to values spread over their bounds (seeded)
and written as the calibration writes them (:func:`femcal.io.calibration.write_calibrated_deck`:
the deck's own text with only those fields changed). Then:

* the written deck against the original, line by line: how many lines differ, and that each
  differing line is a calibrated card's (the header's three comment lines apart);
* femcal reads it: every parameter's field holds its value to the written digits;
* pyNastran reads it (its own environment, ``.venv-bench``; ``make bench-parse`` makes it):
  the card counts per type equal femcal's, and each calibrated card's fields (PSHELL T, MAT1
  E, ... as pyNastran names them) equal femcal's values.

Prints a table; exits 1 if any check fails.

    .venv/bin/python benchmarks/calibrated_deck.py
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FRAME = ROOT / "models" / "truck_frame"
PYN = ROOT / ".venv-bench" / "bin" / "python"

#: pyNastran's attribute for each (card, femcal field name) the parameters use.
PYN_FIELDS = {("PSHELL", "T"): ("properties", "t"), ("MAT1", "E"): ("materials", "e"),
              ("PBAR", "A"): ("properties", "A"), ("PROD", "A"): ("properties", "A")}

_PYN_SCRIPT = """
import json, sys
from pyNastran.bdf.bdf import read_bdf
model = read_bdf(sys.argv[1], xref=False, debug=None)
asks = json.loads(sys.argv[2])
out = {"counts": {k: v for k, v in model.card_count.items()}, "values": []}
for group, ident, attr in asks:
    obj = getattr(model, group)[ident]
    v = getattr(obj, attr)
    out["values"].append(float(v[0] if isinstance(v, list) else v))
print(json.dumps(out))
"""


def main() -> int:
    from femcal.calibrate.parameters import current_value, read_parameters
    from femcal.deck import read_deck
    from femcal.io.calibration import write_calibrated_deck
    from femcal.model.build import build_model

    deck = FRAME / "hammer_frame.bdf"
    model = build_model(read_deck(deck))
    params = read_parameters(FRAME / "hammer_frame.params.toml", model)
    rng = np.random.default_rng(27)
    values = np.array([rng.uniform(p.lower, p.upper) for p in params])
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "hammer_frame_calibrated.bdf"
        files = write_calibrated_deck(deck, params, values, out)
        original = deck.read_text().splitlines()
        written = out.read_text().splitlines()
        header = sum(1 for line in written if line.startswith("$ femcal") or
                     line.startswith("$ config") or line.startswith("$ changed"))  # fmt: skip
        body = written[header:]
        differ = [i for i, (a, b) in enumerate(zip(original, body, strict=True)) if a != b]
        src = read_deck(deck)
        card_lines = set()
        for p in params:
            t = src.tables[p.card]
            key = "mid" if p.card.startswith("MAT") else "pid"
            rows = np.flatnonzero(t.columns[key] == p.id)
            card_lines.update(int(t.line[r]) - 1 for r in rows)
        only_calibrated = set(differ) <= card_lines
        back = build_model(read_deck(out))
        femcal_values = [current_value(back, p.card, p.id, p.field) for p in params]
        worst_digits = max(abs(f / v - 1) for f, v in zip(femcal_values, values, strict=True))
        print(f"{len(original)} lines, {header} header lines added; {len(differ)} lines differ, "
              f"all calibrated cards' lines: {only_calibrated}; files {[f.name for f in files]}")
        print(f"femcal reads the values back to {worst_digits:.1e} (relative, the written "
              "digits)")
        ok &= only_calibrated and len(written) == len(original) + header and worst_digits < 5e-6
        if not PYN.exists():
            print(f"pyNastran: {PYN} missing; run `make bench-parse` once to make it")
            return 0 if ok else 1
        asks = []
        for p in params:
            group, attr = PYN_FIELDS[(p.card, p.field)]
            asks.append((group, int(p.id), attr))
        res = subprocess.run([str(PYN), "-c", _PYN_SCRIPT, str(out), json.dumps(asks)],
                             capture_output=True, text=True, check=False)  # fmt: skip
        if res.returncode != 0:
            print("pyNastran failed:", res.stderr.strip().splitlines()[-1:])
            return 1
        pyn = json.loads(res.stdout.strip().splitlines()[-1])
        counts = dict(read_deck(out).card_count)
    print("| parameter | card | id | field | value set | femcal reads | pyNastran reads |")
    print("|---|---|---|---|---|---|---|")
    same = True
    for p, v, f, y in zip(params, values, femcal_values, pyn["values"], strict=True):
        same &= f == y
        print(f"| {p.name} | {p.card} | {p.id} | {p.field} | {v:.10g} | {f:.10g} | {y:.10g} |")
    print(f"pyNastran reads every calibrated field as femcal does: {same}")
    diff = {k: (counts.get(k), pyn["counts"].get(k)) for k in set(counts) | set(pyn["counts"])
            if counts.get(k) != pyn["counts"].get(k) and k != "ENDDATA"}  # fmt: skip
    print(f"card counts that differ (femcal, pyNastran): {diff or 'none'}")
    return 0 if ok and same and not diff else 1


if __name__ == "__main__":
    sys.exit(main())
