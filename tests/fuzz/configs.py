"""Fuzzing of calibration inputs: a valid small calibration (the plate of
:mod:`tests.calib_decks`: its deck, its nine parameters, a configuration that names every file
and sets every key) is mutated case by case, and only what a calibration reads before any
work is run on it: :func:`femcal.calibrate.config.read_config` and
:func:`femcal.jobs.calibration.read_inputs` (the decks, the parameter files, the parameters
shared by name, the truth files); no surrogate, no search.

The mutations (:data:`MUTATIONS`): a key deleted, a value of the wrong type, a number out of
range (zero, negative, huge, NaN, infinity), an unknown key (a near miss of a known one, or a
stray word), bounds swapped, equal or given twice, a file missing (or a folder, or another
file), a table emptied, the TOML text garbled (cut, bytes inserted, a line repeated, binary),
and any two or three of them at once.

Each case ends in one of four outcomes:

``ok``
    read and checked, and what was read holds what the checks promise (bounds ordered,
    positive and holding the nominal; bands ordered; damping in (0, 1); every setting in its
    range): the mutation was harmless (an optional key deleted, say);
``clean error``
    an error the command line prints as one line (a :class:`~femcal.errors.FemcalError`, a
    ValueError or KeyError, a missing file or folder) whose message names the file it is
    about;
``accepted bad input``
    read without error although what was read breaks a promise above (a silent wrong
    answer);
``crash``
    any other exception (a bug: the command line would report an internal error), or an
    error whose message names no file.

Run many cases from the command line::

    .venv/bin/python -m tests.fuzz.configs --seed 1 -n 5000
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import random
import re
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from femcal.calibrate.config import SETTINGS, Config, read_config
from femcal.errors import FemcalError
from femcal.jobs.calibration import Inputs, read_inputs

from ..calib_decks import PARAMS_TOML, plate_deck

#: The outcomes of a case (see the module docstring).
OUTCOMES = ("ok", "clean error", "accepted bad input", "crash")


@dataclass(frozen=True)
class Finding:
    """One fuzz case: its number, the mutations applied (``kind: what``, joined by ``; ``),
    its outcome (one of :data:`OUTCOMES`) and the exception's type and text ("" when ok)."""

    case: int
    mutation: str
    outcome: str
    exception: str


# ------------------------------------------------------------------------------ the base

#: The plate's parameter bounds as the base file gives them: some absolute, some relative,
#: with nominal values, descriptions and confidences here and there.
_ABSOLUTE = {"t": (4.0, 6.0, 5.0), "A_bar": (96.0, 144.0, None), "m_tip": (0.001, 0.003, 0.002)}


def base_parameters() -> dict:
    """The nine plate parameters of :data:`tests.calib_decks.PARAMS_TOML` as a document."""
    import tomllib

    doc = tomllib.loads(PARAMS_TOML)
    for k, item in enumerate(doc["parameter"]):
        if item["name"] in _ABSOLUTE:
            lo, hi, nominal = _ABSOLUTE[item["name"]]
            del item["lower_rel"], item["upper_rel"]
            item["lower"], item["upper"] = lo, hi
            if nominal is not None:
                item["nominal"] = nominal
        if k % 3 == 0:
            item["description"] = f"parameter {k + 1}"
        if k % 4 == 1:
            item["confidence"] = 0.05
    return doc


def base_config(several: bool) -> dict:
    """A configuration that names every file and sets every key; ``several``: as two
    [[configuration]] entries (the same deck twice, their parameters shared by name)."""
    test = {"frf": "test.npz", "truth": "truth.toml", "sensors": "s.csv", "inputs": "i.csv",
            "identify": {"band": [10.0, 500.0], "splits": [100.0, 260.0], "orders": "auto",
                         "max_order": 24, "gamma": 1.43, "beta": 100.0}}  # fmt: skip
    cal = {"band": [10.0, 350.0], "zeta0": "median", "samples_per_bandwidth": 3.0,
           "metric": "log-magnitude", "loss": "huber", "huber_c": 2.0, "reduction_modes": 40,
           "surrogate": "exact", "enrich_hz": 0.0, "enrich_vectors": 40, "residual": False,
           "modal_hz": 0.0, "exact_gradient": True, "starts": 4, "workers": 2, "seed": 1,
           "max_iterations": 30, "max_cycles": 3, "settle": 1e-3, "restarts": 1,
           "restart_fall": 0.01, "bounds_sigma": 3.0, "noise_sigma": 0.01, "hold_ratio": 0.99,
           "identifiable_ratio": 0.5, "crlb_bands": [[10.0, 100.0], [100.0, 350.0]],
           "holdout": "auto", "holdout_folds": 4, "exclude_suspect_channels": True}  # fmt: skip
    out = {"pictures": False}
    if not several:
        return {"model": {"deck": "plate.bdf", "parameters": "p.toml", "units": "mm/s^2/N"},
                "test": test, "calibration": cal, "output": out}  # fmt: skip
    entries = []
    for name, band in (("bare", [10.0, 350.0]), ("again", [10.0, 300.0])):
        entries.append({"name": name, "deck": "plate.bdf", "parameters": "p.toml",
                        "units": "mm/s^2/N", "band": band, "zeta0": 0.02,
                        **{k: v for k, v in test.items() if k != "identify"},
                        "identify": dict(test["identify"])})  # fmt: skip
    return {"configuration": entries, "calibration": cal, "output": out}


def base_truth(params: dict) -> dict:
    """Each parameter's true value: its nominal moved by a few per cent."""
    nominal = {"t": 5.0, "E_steel": 210000.0, "rho_steel": 7.85e-9, "A_bar": 120.0,
               "I1_bar": 900.0, "A_rod": 30.0, "k_bush": 60.0, "k_spring": 25.0,
               "m_tip": 0.002}  # fmt: skip
    return {"parameter": [{"name": p["name"], "card": p["card"], "id": p["id"],
                           "true": nominal[p["name"]] * 1.03} for p in params["parameter"]]}


# ------------------------------------------------------------------------------ TOML out

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: object) -> str:
    k = str(k)
    return k if _BARE.match(k) else json.dumps(k, ensure_ascii=False)


def _value(v: object) -> str:
    """A TOML value (inline tables and arrays for nested values)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML for {v!r}")


def _is_table_array(v: object) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def dumps(doc: dict) -> str:
    """``doc`` as TOML text: its values first, then its tables ([name]) and arrays of
    tables ([[name]]), nested ones under dotted names."""
    lines: list[str] = []

    def table(d: dict, prefix: str) -> None:
        for k, v in d.items():
            if not isinstance(v, dict) and not _is_table_array(v):
                lines.append(f"{_key(k)} = {_value(v)}")
        for k, v in d.items():
            name = prefix + _key(k)
            if isinstance(v, dict):
                lines.extend(["", f"[{name}]"])
                table(v, name + ".")
            elif _is_table_array(v):
                for item in v:
                    lines.extend(["", f"[[{name}]]"])
                    table(item, name + ".")

    table(doc, "")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------ one case


@dataclass
class Case:
    """What one case writes: the documents (by file name), texts that replace a document's
    TOML, and files left out or made folders; ``invalid`` says why the case must end in an
    error, when its mutation makes the input invalid whatever else happens (an unknown key,
    bounds swapped, a file missing ...), else None."""

    docs: dict[str, dict]
    texts: dict[str, bytes]
    absent: set[str]
    folders: set[str]
    invalid: str | None = None


#: The files a base case writes besides the documents (their content is not read by the
#: checks; the deck is).
_OTHER_FILES = {"test.npz": b"PK\x05\x06" + bytes(18), "s.csv": b"label,grid,directions\nA,7,123\n",
                "i.csv": b"label,grid,direction\nH,28,3\n"}  # fmt: skip
_FILE_KEYS = ("deck", "parameters", "frf", "model", "truth", "sensors", "inputs")
_ALL_FILES = ("cal.toml", "p.toml", "truth.toml", "plate.bdf", *_OTHER_FILES)


def _slots(doc: object, path: tuple = ()) -> list[tuple]:
    """Every (container, key, path) of a document, nested ones included."""
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for k, v in items:
        out.append((doc, k, (*path, k)))
        out += _slots(v, (*path, k))
    return out


def _tables(doc: object, path: tuple = ()) -> list[tuple[dict, tuple]]:
    """Every table of a document (the document itself first), with its path."""
    out = [(doc, path)] if isinstance(doc, dict) else []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for k, v in items:
        out += _tables(v, (*path, k))
    return out


def _where(path: tuple) -> str:
    return ".".join(str(p) for p in path) or "(top)"


def _pick_doc(case: Case, rng: random.Random) -> tuple[str, dict]:
    name = rng.choices(["cal.toml", "p.toml", "truth.toml"], [5, 4, 1])[0]
    return name, case.docs[name]


_WRONG = ["text", "", "auto", "median", 0, 1, -1, 7, 2.5, True, False, [], [1, 2],
          ["a"], {}, {"x": 1}, math.nan, math.inf, -math.inf, 1e308, -1e-300]
_NUMBERS = [0, 0.0, -1, -1.0, -1e-9, 1e-300, 1.0, 1, 2, 1e9, 10**12, 2**63 - 1, -(2**63),
            math.nan, math.inf, -math.inf, 0.5, 0.999999, 1.000001, 100, 101]


def _delete_key(case: Case, rng: random.Random) -> str:
    name, doc = _pick_doc(case, rng)
    slots = [s for s in _slots(doc) if isinstance(s[0], dict)]
    container, key, path = rng.choice(slots)
    del container[key]
    return f"{name}: {_where(path)} deleted"


def _wrong_type(case: Case, rng: random.Random) -> str:
    name, doc = _pick_doc(case, rng)
    container, key, path = rng.choice(_slots(doc))
    container[key] = copy.deepcopy(rng.choice(_WRONG))
    return f"{name}: {_where(path)} = {container[key]!r}"


def _out_of_range(case: Case, rng: random.Random) -> str:
    name, doc = _pick_doc(case, rng)
    slots = [s for s in _slots(doc) if isinstance(s[0][s[1]], int | float)
             and not isinstance(s[0][s[1]], bool)]  # fmt: skip
    container, key, path = rng.choice(slots)
    old = container[key]
    new = rng.choice([*_NUMBERS, -old, old * 1e6, old / 1e6, old + 1])
    container[key] = new
    return f"{name}: {_where(path)} = {new!r} (was {old!r})"


def _typo(word: str, rng: random.Random) -> str:
    if len(word) < 2:
        return word + "x"
    k = rng.randrange(len(word) - 1)
    how = rng.choice(["swap", "drop", "double", "case"])
    if how == "swap":
        return word[:k] + word[k + 1] + word[k] + word[k + 2:]
    if how == "drop":
        return word[:k] + word[k + 1:]
    if how == "double":
        return word[:k] + word[k] + word[k:]
    return word[:k] + word[k].swapcase() + word[k + 1:]


def _unknown_key(case: Case, rng: random.Random) -> str:
    name, doc = _pick_doc(case, rng)
    table, path = rng.choice(_tables(doc))
    known = [k for k in table if isinstance(k, str)]
    key = _typo(rng.choice(known), rng) if known and rng.random() < 0.7 else rng.choice(
        ["colour", "x", "regularization", "identifiable_crlb", "Band", "deck ", "ñ"])
    if key in table:
        key += "_"
    table[key] = rng.choice([1, "a", True, [1.0]])
    if name != "truth.toml":  # (a truth file may carry more than the checks read)
        case.invalid = f"unknown key {key!r}"
    return f"{name}: {_where(path)}: key {key!r} added"


def _bounds(case: Case, rng: random.Random) -> str:
    params = [p for p in case.docs["p.toml"].get("parameter", []) if isinstance(p, dict)]
    if not params:
        return _delete_key(case, rng)
    p = rng.choice(params)
    pairs = [("lower", "upper"), ("lower_rel", "upper_rel")]
    how = rng.choice(["swap", "equal", "both", "lower only", "mix", "nominal outside",
                      "through zero"])  # fmt: skip
    lo, hi = next(((a, b) for a, b in pairs if a in p and b in p), ("lower", "upper"))
    if how == "swap" and lo in p and hi in p:
        p[lo], p[hi] = p[hi], p[lo]
        case.invalid = "bounds swapped"
    elif how == "equal" and lo in p:
        p[hi] = p[lo]
        case.invalid = "bounds equal"
    elif how == "both":
        p["lower"], p["lower_rel"] = 1.0, -0.1
        case.invalid = "lower and lower_rel"
    elif how == "lower only":
        p.pop("upper", None)
        p.pop("upper_rel", None)
        case.invalid = "no upper bound"
    elif how == "mix":
        p.pop("upper", None)
        p["upper_rel"] = 0.25
    elif how == "nominal outside":
        p["nominal"] = rng.choice([1e-12, 1e12, -1.0])
        case.invalid = "a nominal other than the deck's"
    else:
        p.pop("lower", None)
        p["lower_rel"] = rng.choice([-1.0, -1.5, -0.999999])
        if p["lower_rel"] <= -1:
            case.invalid = "a lower bound of zero or less"
    return f"p.toml: parameter {p.get('name')!r}: bounds {how}"


def _missing_file(case: Case, rng: random.Random) -> str:
    how = rng.choice(["key", "absent", "folder"])
    if how == "key":
        slots = [s for s in _slots(case.docs["cal.toml"]) if s[1] in _FILE_KEYS]
        container, key, path = rng.choice(slots)
        container[key] = rng.choice(["gone.bdf", ".", "", "/no/such/dir/x", "sub/", "p.toml",
                                     "cal.toml", "test.npz", "a\u0000b", "truth.toml"])
        if container[key] in ("gone.bdf", ".", "", "/no/such/dir/x", "sub/", "a\u0000b"):
            case.invalid = f"{key} = {container[key]!r}"
        return f"cal.toml: {_where(path)} = {container[key]!r}"
    name = rng.choice(_ALL_FILES[1:])
    (case.absent if how == "absent" else case.folders).add(name)
    case.invalid = f"{name} missing"
    return f"{name} {'not written' if how == 'absent' else 'is a folder'}"


def _empty_table(case: Case, rng: random.Random) -> str:
    name, doc = _pick_doc(case, rng)
    tables = _tables(doc)
    table, path = rng.choice(tables)
    table.clear()
    if rng.random() < 0.3:  # or an array of tables emptied
        arrays = [s for s in _slots(doc) if _is_table_array(s[0][s[1]])]
        if arrays:
            container, key, path = rng.choice(arrays)
            container[key] = []
    return f"{name}: {_where(path)} emptied"


def _garbage(case: Case, rng: random.Random) -> str:
    name = rng.choice(["cal.toml", "p.toml", "truth.toml"])
    text = dumps(case.docs[name]).encode()
    how = rng.choice(["cut", "insert", "repeat line", "binary", "empty", "colon", "bom"])
    if how == "cut":
        text = text[: rng.randrange(len(text))]
    elif how == "insert":
        k = rng.randrange(len(text))
        text = text[:k] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 4))) + text[k:]
    elif how == "repeat line":
        lines = text.split(b"\n")
        k = rng.randrange(len(lines))
        text = b"\n".join([*lines[: k + 1], lines[k], *lines[k + 1:]])
    elif how == "binary":
        text = bytes(rng.randrange(256) for _ in range(64))
    elif how == "empty":
        text = b""
    elif how == "colon":
        text = text.replace(b" = ", b": ", 1)
    else:
        text = b"\xef\xbb\xbf" + text
    case.texts[name] = text
    if how in ("binary", "colon", "bom") or (how == "empty" and name != "truth.toml"):
        case.invalid = f"{name}: {how}"
    return f"{name}: text {how}"


#: The mutations, by kind.
MUTATIONS: dict[str, Callable[[Case, random.Random], str]] = {
    "delete key": _delete_key,
    "wrong type": _wrong_type,
    "out of range": _out_of_range,
    "unknown key": _unknown_key,
    "bounds": _bounds,
    "missing file": _missing_file,
    "empty table": _empty_table,
    "garbage": _garbage,
}


# ------------------------------------------------------------------------------ checks


def _broken_promise(cfg: Config, inputs: Inputs) -> str | None:
    """What a configuration and its inputs read without error break of the checks'
    promises (None: nothing)."""
    for conf in cfg.configurations:
        lo, hi = conf.band
        if not 0 < lo < hi < math.inf:
            return f"configuration {conf.name}: band {conf.band}"
        if conf.zeta0 is not None and not 0 < conf.zeta0 < 1:
            return f"configuration {conf.name}: zeta0 {conf.zeta0}"
        for f in (conf.deck, conf.parameters, *conf.sources):
            if not f.is_file():
                return f"configuration {conf.name}: {f} is not a file"
    for key, s in SETTINGS.items():
        v = getattr(cfg, key)
        if not (key == "noise_sigma" and v is None) and not (math.isfinite(v) and s.accepts(v)):
            return f"[calibration] {key} = {v!r}"
    for params in inputs.parameters:
        for p in params:
            values = (p.lower, p.nominal, p.upper)
            if not all(math.isfinite(x) for x in values) or not 0 < p.lower < p.upper:
                return f"parameter {p.name}: bounds {p.lower}, {p.upper}"
            if not p.lower <= p.nominal <= p.upper:
                return f"parameter {p.name}: nominal {p.nominal} outside [{p.lower}, {p.upper}]"
            if not p.p_lower <= 0 <= p.p_upper:
                return f"parameter {p.name}: p bounds {p.p_lower}, {p.p_upper}"
    if inputs.truth is not None and not all(math.isfinite(x) for x in inputs.truth):
        return f"truth {inputs.truth}"
    return None


def _names_a_file(error: BaseException, folder: Path) -> bool:
    """Whether the error's message (or an OSError's filename) names a file of the case."""
    text = f"{error} {getattr(error, 'filename', '') or ''}"
    return str(folder) in text or any(name in text for name in _ALL_FILES)


#: What the command line prints as one line (femcal.cli; the calibrate command catches
#: ValueError and KeyError, the entry point FemcalError and the file errors).
CLEAN = (FemcalError, ValueError, KeyError, FileNotFoundError, IsADirectoryError,
         NotADirectoryError, PermissionError)


def check_case(folder: Path, invalid: str | None = None) -> tuple[str, str]:
    """Read and check the case written in ``folder`` (its cal.toml): (outcome, exception
    text). ``invalid``: why the case must end in an error (None: it may be read)."""
    try:
        cfg = read_config(folder / "cal.toml")
        inputs = read_inputs(cfg)
    except CLEAN as e:
        text = f"{type(e).__name__}: {e}"
        if not _names_a_file(e, folder):
            return "crash", "names no file: " + text
        return "clean error", text
    except Exception as e:  # every other exception is the finding
        tb = e.__traceback__
        while tb is not None and tb.tb_next is not None:
            tb = tb.tb_next
        at = f" (at {tb.tb_frame.f_code.co_filename}:{tb.tb_lineno})" if tb else ""
        return "crash", f"{type(e).__name__}: {e}{at}"
    broken = _broken_promise(cfg, inputs) or (f"expected an error: {invalid}" if invalid
                                              else None)  # fmt: skip
    return ("accepted bad input", broken) if broken else ("ok", "")


def _write(case: Case, folder: Path, deck: str) -> None:
    """Write the case's files into ``folder``."""
    folder.mkdir(parents=True)
    files = {"plate.bdf": deck.encode(), **_OTHER_FILES}
    for name, doc in case.docs.items():
        files[name] = case.texts.get(name, dumps(doc).encode())
    for name, data in files.items():
        if name in case.folders:
            (folder / name).mkdir()
        elif name not in case.absent:
            (folder / name).write_bytes(data)


def make_case(k: int, rng: random.Random) -> tuple[Case, str]:
    """Case k: a base (one configuration, or two every fifth time) and one to three
    mutations (one in two cases, two in three of the rest); and how it was mutated."""
    params = base_parameters()
    docs = {"cal.toml": base_config(several=rng.random() < 0.2), "p.toml": params,
            "truth.toml": base_truth(params)}  # fmt: skip
    case = Case(docs, {}, set(), set())
    n = rng.choices([1, 2, 3], [3, 2, 1])[0]
    done = []
    for _ in range(n):
        kind = rng.choice(list(MUTATIONS))
        try:
            done.append(f"{kind}: {MUTATIONS[kind](case, rng)}")
        except (IndexError, KeyError, TypeError, ValueError, AttributeError):
            done.append(f"{kind}: nothing to mutate")  # an earlier mutation left no target
    if n > 1:  # a later mutation may take back what made an earlier one invalid
        case.invalid = None
    return case, "; ".join(done)


def run_config_fuzz(seed: int, n: int) -> list[Finding]:
    """``n`` cases from ``seed`` (the same seed, the same cases): each written to a folder
    of its own, read and checked (see the module docstring); one :class:`Finding` each."""
    rng = random.Random(seed)
    deck = plate_deck()
    findings = []
    with tempfile.TemporaryDirectory(prefix="femcal-fuzz-") as tmp:
        for k in range(n):
            case, mutation = make_case(k, rng)
            folder = Path(tmp) / f"case{k:05d}"
            _write(case, folder, deck)
            outcome, text = check_case(folder, case.invalid)
            findings.append(Finding(k, mutation, outcome, text.replace(str(folder), "<case>")))
    return findings


def main(argv: list[str] | None = None) -> int:
    """Run the fuzzer and print the outcomes, then each case that is not ok or a clean
    error; exit 1 if there is any."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("-n", type=int, default=1000)
    parser.add_argument("--show", type=int, default=0, help="also print this many clean errors")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    findings = run_config_fuzz(args.seed, args.n)
    seconds = time.perf_counter() - t0
    counts = Counter(f.outcome for f in findings)
    print(f"{len(findings)} cases (seed {args.seed}) in {seconds:.1f} s: "
          + ", ".join(f"{counts[o]} {o}" for o in OUTCOMES))
    bad = [f for f in findings if f.outcome in ("crash", "accepted bad input")]
    shown = [f for f in findings if f.outcome == "clean error"][: args.show]
    for f in bad + shown:
        print(f"case {f.case} [{f.outcome}] {f.mutation}\n    {f.exception}")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
