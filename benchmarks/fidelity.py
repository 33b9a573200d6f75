"""Fidelity against NASTRAN per element, property and material type (issue 26).

    python benchmarks/fidelity.py

Solves every reference deck in ../shared/refdecks as tests/test_conformance.py does (its
``tolerance``, ``KNOWN_GAPS`` and ``refdeck_cases`` are imported; its ``worst_error``
comparison is repeated here without the asserts, so that a deck that does not match still
gives its number), records the element, rigid-element, property and material cards each deck
uses (elements by card, properties and materials only where an element references them), and
prints two markdown tables:

1. per deck: tier, outcome, the worst relative frequency error over the compared modes (and
   at which mode), how that mode's strain energy splits among the element types, and the
   cards the deck uses;
2. per card type: how many decks contain it, the worst error among the tier A/B decks that
   contain it (the decks whose answer the test asserts), the worst error among the compared
   modes that put at least 10 % of their energy in it (strain energy; kinetic energy for
   mass elements and PMASS; none for rigid elements and MPCs), the decks in which it is the
   only card of its group (so the deck's error is its alone), and the tier C and refused
   decks that contain it.

A deck's worst error is over all its modes, so it may come from another element type in the
deck: the energy columns say which type a mode exercises. Variants are listed under their card:
solids by node count, CQUAD8 / CTRIA6 by their midside nodes, PBARL / PBEAML by section type,
PBEAM and PBEAML tapered or not.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections import defaultdict
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # tests/ is a package: reuse the conformance test's rules

#: Reference frequencies all below this: NASTRAN found mechanisms only (compared absolutely,
#: as tests/test_conformance.py's tier C test does).
ALL_ZERO_HZ = 1e-4
#: A mode exercises a card type when the type holds at least this share of its energy.
EXERCISED = 0.10

GROUPS: dict[str, tuple[str, ...]] = {
    "stiffness element": (
        "CBAR", "CBEAM", "CROD", "CONROD", "CTUBE", "CELAS1", "CELAS2", "CELAS3", "CELAS4",
        "CBUSH", "CQUAD4", "CTRIA3", "CQUADR", "CTRIAR", "CQUAD8", "CTRIA6", "CSHEAR", "CHEXA",
        "CPENTA", "CTETRA", "CPYRAM",
    ),
    "mass element": ("CONM1", "CONM2", "CMASS1", "CMASS2", "CMASS3", "CMASS4"),
    "rigid element / MPC": ("RBE2", "RBE3", "RBAR", "MPC"),
    "property": (
        "PBAR", "PBARL", "PBEAM", "PBEAML", "PROD", "PTUBE", "PELAS", "PBUSH", "PMASS",
        "PSHELL", "PCOMP", "PCOMPG", "PSHEAR", "PSOLID",
    ),
    "material": ("MAT1", "MAT2", "MAT8", "MAT9"),
}  # fmt: skip
GROUP_OF = {card: g for g, cards in GROUPS.items() for card in cards}
KINETIC = set(GROUPS["mass element"]) | {"PMASS"}
#: Solid card -> (corner nodes, all nodes).
SOLID_NODES = {"CTETRA": (4, 10), "CPENTA": (6, 15), "CHEXA": (8, 20), "CPYRAM": (5, 13)}
QUADRATIC_SHELLS = {"CQUAD8": 4, "CTRIA6": 3}  # card -> corner nodes


@dataclass
class DeckResult:
    name: str
    tier: str
    outcome: str = ""  # match, gap, tier C, mechanisms, refused, error
    worst: float | None = None
    at: int = 0
    n_modes: int = 0
    tolerance: float = 0.0
    note: str = ""
    seconds: float = 0.0
    #: card type (or "CARD variant") -> elements of it, or property / material cards of it
    #: that elements reference, or rigid-element / MPC cards.
    cards: dict[str, int] = field(default_factory=dict)
    unreferenced: dict[str, int] = field(default_factory=dict)
    #: compared mode -> relative frequency error.
    errors: dict[int, float] = field(default_factory=dict)
    #: card type -> its energy share in each compared mode (same order as ``errors``).
    shares: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def compared(self) -> bool:
        """A relative frequency error whose tolerance the test asserts (tier A/B)."""
        return self.worst is not None and self.tier in ("A", "B")

    def error_text(self) -> str:
        if self.worst is None:
            return {"mechanisms": "0 Hz only", "refused": "refused"}.get(self.outcome, "-")
        return f"{self.worst:.1e}" + (", not matched" if self.outcome in ("gap", "error") else "")

    def exercised(self, card: str) -> tuple[float, int, float] | None:
        """(worst error, modes, largest share) over the compared modes that put at least
        EXERCISED of their energy in ``card``; None if it has no energy measure here."""
        s = self.shares.get(card)
        if s is None:
            return None
        errs = np.array(list(self.errors.values()))
        hit = s >= EXERCISED
        return (float(errs[hit].max()) if hit.any() else np.nan, int(hit.sum()),
                float(s.max()) if len(s) else 0.0)  # fmt: skip


# ------------------------------------------------------------------------- what a deck uses


def _pid_list(entry) -> list[int]:
    if isinstance(entry, dict):
        return [int(p) for p in np.asarray(entry["pid"])]
    return [int(r.pid) for r in entry]


def _rows(entry) -> list:
    """One item per property card: a dict of scalars (tables) or the record."""
    if isinstance(entry, dict):
        n = len(np.asarray(entry["pid"]))
        return [{k: np.asarray(v)[i] for k, v in entry.items()} for i in range(n)]
    return list(entry)


def _mids(row) -> list[int]:
    """Material ids one property card names (MID, MID1-4, plies)."""
    out: list[int] = []
    if isinstance(row, dict):
        vals = [v for k, v in row.items() if k.startswith("mid")]
    else:
        vals = [getattr(row, k, None) for k in ("mid", "mid1", "mid2", "mid3", "mid4")]
        vals += [p.mid for p in getattr(row, "plies", ())]
    for v in vals:
        if isinstance(v, (int, np.integer)) and 0 < v < 10**9:
            out.append(int(v))
    return out


def _variant(card: str, row) -> str | None:
    if card in ("PBARL", "PBEAML"):
        taper = len({tuple(s.dims) for s in getattr(row, "stations", ())}) > 1
        return row.type + (" tapered" if taper else "")
    if card == "PBEAM":
        return "tapered" if len({(s.a, s.i1, s.i2, s.j) for s in row.stations}) > 1 else "uniform"
    return None


def element_labels(model) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, int], dict]:
    """(label -> {element type: mask of its elements}, label -> number of property or
    material cards behind it, cards no element references). Labels are element types and
    their variants, and the property and material types (and variants) elements use."""
    pid_card, pid_variant, pid_mids = {}, {}, {}
    for card, entry in model.properties.items():
        for pid, row in zip(_pid_list(entry), _rows(entry), strict=True):
            pid_card[pid] = card
            pid_variant[pid] = _variant(card, row)
            pid_mids[pid] = _mids(row)
    mid_card = {}
    for card, table in model.materials.items():
        ids = np.asarray(table["mid"]) if isinstance(table, dict) else [r.mid for r in table]
        mid_card.update({int(m): card for m in ids})

    labels: dict[str, dict[str, np.ndarray]] = defaultdict(dict)
    used_pids: set[int] = set()
    used_mids: set[int] = set()
    for etype, block in model.elements.items():
        n = len(block)
        labels[etype][etype] = np.ones(n, bool)
        if etype in SOLID_NODES:
            k = (block.nodes >= 0).sum(axis=1)
            corners, full = SOLID_NODES[etype]
            for v in np.unique(k):
                name = f"{v}-node" if v in (corners, full) else f"{corners}+{v - corners}-node"
                old = labels[f"{etype} {name}"].get(etype, False)
                labels[f"{etype} {name}"][etype] = old | (k == v)
        elif etype in QUADRATIC_SHELLS:
            c = QUADRATIC_SHELLS[etype]
            k = (block.nodes[:, c:] >= 0).sum(axis=1)
            full = block.nodes.shape[1] - c
            for v in np.unique(k):
                name = "some midside nodes omitted"
                if v in (0, full):
                    name = "all midside nodes" if v == full else "midside nodes omitted"
                old = labels[f"{etype} {name}"].get(etype, False)
                labels[f"{etype} {name}"][etype] = old | (k == v)
        pids = np.asarray(block.pids)
        mids_of_el = [list(pid_mids.get(int(p), [])) for p in pids]
        if "mid" in block.data:  # CONROD names its material itself
            for i, m in enumerate(block.data["mid"]):
                if 0 < m < 10**9:
                    mids_of_el[i].append(int(m))
        for pid in set(pids.tolist()) & set(pid_card):
            mask = pids == pid
            used_pids.add(pid)
            for name in (pid_card[pid], f"{pid_card[pid]} {pid_variant[pid]}"):
                if not name.endswith(" None"):
                    old = labels[name].get(etype)
                    labels[name][etype] = mask if old is None else old | mask
        for mcard in set(mid_card.values()):
            mask = np.array([any(mid_card.get(m) == mcard for m in ms) for ms in mids_of_el])
            if mask.any():
                labels[mcard][etype] = mask
        used_mids |= {m for ms in mids_of_el for m in ms}
    counts: dict[str, int] = defaultdict(int)
    for pid in used_pids:
        counts[pid_card[pid]] += 1
        if pid_variant[pid]:
            counts[f"{pid_card[pid]} {pid_variant[pid]}"] += 1
    for mid in used_mids & set(mid_card):
        counts[mid_card[mid]] += 1
    unref: dict[str, int] = defaultdict(int)
    for pid, card in pid_card.items():
        unref[card] += pid not in used_pids
    for mid, card in mid_card.items():
        unref[card] += mid not in used_mids
    return dict(labels), dict(counts), {k: v for k, v in unref.items() if v}


def _subset(block, mask: np.ndarray):
    data = {k: np.asarray(v)[mask] for k, v in block.data.items()}
    comps = None if block.components is None else block.components[mask]
    return replace(block, ids=block.ids[mask], pids=block.pids[mask], nodes=block.nodes[mask],
                   components=comps, data=data, file=block.file[mask],
                   line=block.line[mask])  # fmt: skip


def energy_shares(model, labels, shapes: np.ndarray) -> dict[str, np.ndarray]:
    """label -> its share of each mode's strain energy (kinetic for mass elements and
    PMASS): u^T K_l u / u^T K u with K_l assembled from the label's elements alone."""
    from femcal.assembly import assemble

    U = np.real(np.asarray(shapes))
    full = assemble(model)
    total_k = np.einsum("ij,ij->j", U, full.K @ U)
    total_m = np.einsum("ij,ij->j", U, full.M @ U)
    out = {}
    for label, masks in labels.items():
        base = label.split(" ")[0]
        if GROUP_OF.get(base) not in ("stiffness element", "mass element", "property",
                                      "material"):  # fmt: skip
            continue
        elements = {et: _subset(model.elements[et], m) for et, m in masks.items() if m.any()}
        sub = assemble(replace(model, elements=elements))
        if base in KINETIC:
            out[label] = np.einsum("ij,ij->j", U, sub.M @ U) / total_m
        else:
            out[label] = np.einsum("ij,ij->j", U, sub.K @ U) / total_k
    return out


# ------------------------------------------------------------------------------ comparison


def compare(f: np.ndarray, valid: list[dict]) -> tuple[dict[int, float], str]:
    """tests/test_conformance.py's ``worst_error`` without its asserts: mode -> relative
    error over the valid modes, reference modes below 1e-3 of the highest being required to
    come out below that too; and what breaks that rule ('' if nothing)."""
    fmax = max(m["cycles_hz"] for m in valid)
    if len(f) < len(valid):
        return {}, f"{len(f)} modes computed, {len(valid)} in the reference"
    errors, broken = {}, []
    for m in valid:
        ours, theirs = f[m["mode"] - 1], m["cycles_hz"]
        if theirs < 1e-3 * fmax:
            if abs(ours) >= 1e-3 * fmax:
                broken.append(f"mode {m['mode']} {ours:.3g} Hz (NASTRAN {theirs:.3g} Hz)")
            continue
        errors[m["mode"]] = abs(ours / theirs - 1.0)
    why = ""
    if broken:
        why = ("reference modes below 1e-3 of the highest must stay below it: "
               + ", ".join(broken))  # fmt: skip
    return errors, why


def run_deck(name: str, main: Path, ref: dict) -> DeckResult:
    from tests.test_conformance import KNOWN_GAPS, tolerance

    from femcal.deck import read_deck
    from femcal.errors import FemcalError
    from femcal.model.build import build_model
    from femcal.solve.normal_modes import solve_normal_modes

    valid = [m for m in ref["modes"] if m["valid"]]
    res = DeckResult(name, ref.get("tier", "?"), n_modes=len(valid), tolerance=tolerance(ref))
    deck = read_deck(main)
    model = build_model(deck)
    labels, prop_counts, res.unreferenced = element_labels(model)
    for label, masks in labels.items():
        base = label.split(" ")[0]
        if GROUP_OF.get(base) in ("property", "material"):
            res.cards[label] = prop_counts.get(label, 0)
        elif base in GROUP_OF:
            res.cards[label] = int(sum(m.sum() for m in masks.values()))
    for card in GROUPS["rigid element / MPC"]:
        if card in deck.card_count:
            res.cards[card] = deck.card_count[card]
    t0 = time.perf_counter()
    try:
        modes = solve_normal_modes(model)[0]
    except FemcalError as e:
        res.outcome = "refused"
        msg = str(e).splitlines()[-1].strip()
        msg = msg.split("supported: ", 1)[-1].split(" (femcal solves")[0]
        res.note = ", ".join(part.strip().split(" (")[0] for part in msg.split(";"))
        res.seconds = time.perf_counter() - t0
        return res
    res.seconds = time.perf_counter() - t0
    f = modes.frequencies_hz
    if max(m["cycles_hz"] for m in valid) < ALL_ZERO_HZ:  # mechanisms only
        g = np.abs(f[: len(valid)])
        ok = len(g) == len(valid) and g.max() < ALL_ZERO_HZ
        res.outcome = "mechanisms" if ok else "error"
        res.note = f"NASTRAN's {len(valid)} modes all ~0 Hz; femcal's up to {g.max():.1e} Hz"
        return res
    res.errors, res.note = compare(f, valid)
    if not res.errors:
        res.outcome = "error"
        return res
    res.at = max(res.errors, key=res.errors.get)
    res.worst = res.errors[res.at]
    if res.tier == "C":
        res.outcome = "tier C"
    elif res.worst <= res.tolerance and not res.note:
        res.outcome = "match"
    else:
        res.outcome = "gap" if name in KNOWN_GAPS else "error"
    cols = [m - 1 for m in res.errors]
    res.shares = energy_shares(model, labels, modes.shapes[:, cols])
    return res


# ----------------------------------------------------------------------------------- tables

OUTCOME_TEXT = {
    "match": "match", "gap": "**does not match** (strict xfail)",
    "tier C": "not asserted (tier C)", "mechanisms": "mechanisms only (tier C)",
    "refused": "refused", "error": "**FAILS**",
}  # fmt: skip


def deck_table(results: list[DeckResult]) -> list[str]:
    out = ["| deck | tier | outcome | worst error (mode) | tol | modes | strain energy of that "
           "mode | elements | properties, materials |",
           "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in results:
        top = {c: n for c, n in r.cards.items() if " " not in c}
        elems = ", ".join(f"{c} {n}" for c, n in top.items()
                          if GROUP_OF[c].endswith(("element", "MPC")))  # fmt: skip
        props = ", ".join(f"{c} {n}" for c, n in top.items()
                          if GROUP_OF[c] in ("property", "material"))  # fmt: skip
        err = f"{r.worst:.2e} ({r.at})" if r.worst is not None else ""
        err = "; ".join(t for t in (err, r.note) if t)
        energy = ""
        if r.at and sum(GROUP_OF[c] == "stiffness element" for c in top) > 1:
            i = list(r.errors).index(r.at)
            e = {c: float(s[i]) for c, s in r.shares.items()
                 if c in top and GROUP_OF[c] == "stiffness element"}  # fmt: skip
            energy = ", ".join(f"{c} {100 * v:.0f} %" for c, v in
                               sorted(e.items(), key=lambda kv: -kv[1]) if v >= 0.005)  # fmt: skip
        out.append(f"| {r.name} | {r.tier} | {OUTCOME_TEXT[r.outcome]} | {err} | "
                   f"{r.tolerance:.0e} | {r.n_modes} | {energy} | {elems} | {props} |")  # fmt: skip
    return out


def _alone(card: str, r: DeckResult) -> bool:
    """Whether ``card`` is the only card of its group in the deck (a variant: the only
    variant of its card, and that card alone in its group)."""
    base = card.split(" ")[0]
    same = [c for c in r.cards if " " not in c and GROUP_OF[c] == GROUP_OF[base]]
    if same != [base]:
        return False
    return card == base or [c for c in r.cards if c.startswith(base + " ")] == [card]


def _worst(rs: list[DeckResult]) -> str:
    w = max(rs, key=lambda r: r.worst)
    return f"{w.error_text()} ({w.name})"


def type_table(results: list[DeckResult]) -> list[str]:
    seen = {c for r in results for c in r.cards}
    rows = []
    for base in (c for cards in GROUPS.values() for c in cards):
        rows.append(base)
        rows += sorted(c for c in seen if c.startswith(base + " "))
    out = ["| card | cards (decks) | tier A/B decks | worst error over them | modes with >= 10 % "
           "of the energy in it: worst error (modes; largest share) | alone in its group | "
           "tier C and refused decks |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for card in rows:
        base = card.split(" ")[0]
        label = card if card == base else f"&nbsp;&nbsp;{card}"
        having = [r for r in results if card in r.cards]
        if not having:
            out.append(f"| {label} | 0 | no reference deck | | | | |")
            continue
        n_cards = sum(r.cards[card] for r in having)
        ab = [r for r in having if r.compared]
        good = [r for r in ab if r.outcome == "match"]
        decks = f"{len(ab)}" + (f" ({len(good)} match)" if len(good) < len(ab) else "")
        worst = _worst(ab) if ab else "-"
        if good and len(good) < len(ab):
            worst += f"; {_worst(good)} over the matching"
        ex = [(r, r.exercised(card)) for r in ab]
        ex = [(r, e) for r, e in ex if e is not None]
        if GROUP_OF[base] == "rigid element / MPC":
            exercised = "(no energy of its own)"
        elif not ex:
            exercised = "-"
        else:
            n = sum(e[1] for _, e in ex)
            share = max(e[2] for _, e in ex)
            hit = [(r, e) for r, e in ex if e[1]]
            if hit:
                r, e = max(hit, key=lambda re: re[1][0])
                flag = "" if r.outcome == "match" else ", not matched"
                exercised = f"{e[0]:.1e} ({r.name}{flag}; {n} modes; {100 * share:.0f} %)"
                ok = [(r, e) for r, e in hit if r.outcome == "match"]
                if flag and ok:
                    r, e = max(ok, key=lambda re: re[1][0])
                    exercised += (f"; {e[0]:.1e} ({r.name}; {sum(e[1] for _, e in ok)} modes)"
                                  " over the matching")  # fmt: skip
            else:
                exercised = f"none (largest share {100 * share:.1f} %)"
        alone = [r for r in ab if _alone(card, r)]
        if len(alone) > 3:
            alone_text = f"{len(alone)} decks, worst {_worst(alone)}"
        else:
            alone_text = ", ".join(f"{r.name} ({r.error_text()})" for r in alone)
        other = ", ".join(f"{r.name} ({r.error_text()})" for r in having if not r.compared)
        out.append(f"| {label} | {n_cards} ({len(having)}) | {decks} | {worst} | {exercised} "
                   f"| {alone_text} | {other} |")  # fmt: skip
    return out


def main() -> int:
    from tests.conftest import refdeck_cases

    results = []
    t0 = time.perf_counter()
    for name, main_file, ref in refdeck_cases():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # SOL 111 solved as SOL 103 and the like
            results.append(run_deck(name, main_file, ref))
        r = results[-1]
        print(f"{name}: {r.outcome} {r.error_text()} ({r.seconds:.1f} s)", file=sys.stderr,
              flush=True)  # fmt: skip
    n_ab = sum(r.tier in ("A", "B") for r in results)
    n_match = sum(r.outcome == "match" for r in results if r.tier in ("A", "B"))
    print(f"{len(results)} reference decks, {n_match} of {n_ab} tier A/B match; "
          f"{time.perf_counter() - t0:.0f} s\n")  # fmt: skip
    print("\n".join(deck_table(results)))
    print()
    print("\n".join(type_table(results)))
    unref = {r.name: r.unreferenced for r in results if r.unreferenced}
    if unref:
        print("\nProperty and material cards no element references (not counted above): "
              + "; ".join(f"{n}: " + ", ".join(f"{c} {k}" for c, k in u.items())
                          for n, u in unref.items()))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
