"""Fuzzing of femcal's FRF readers and the identification behind them.

A small valid FRF set (3 outputs x 2 inputs x 48 frequencies, two modes) is written once in
every format femcal reads, by femcal's own writers (NPZ, CSV, UFF 58 ASCII and binary 58b,
MATLAB with femcal's variables) and, for the LMS Test.Lab layout that femcal only reads, by
``scipy.io.savemat`` in that layout. Each case takes one of these files and mutates it:

- bytes: bits flipped, the file cut at a random point, a range deleted, inserted or
  repeated;
- lines (CSV and UFF, the binary 58b's header lines too): a line deleted, repeated or
  swapped with the next, a field replaced by NaN, infinity, a huge, tiny or empty value or
  garbage, a UFF header field (dataset type, function and ordinate types, number of points,
  abscissa start and step, nodes and directions) or the CSV header changed;
- arrays (NPZ, MATLAB, LMS): a variable or struct field removed, given another type
  (real, text, integer), shape or count, or a value made NaN, infinite, huge or zero;
- data (every format, written by its writer): what the set holds changed, not its form: a
  channel made constant, repeated, real or zero, a spike, extreme scales, noise, a few
  frequencies only.

The mutated file is read by its format's own reader (:attr:`Format.read`, so that the
registry's net, which turns a stray ValueError into a clean message, does not hide it), and
a file that reads is identified over its whole band, with automatic orders up to 10 or, in
every other round of the formats, at order 4 (a cheap run of the real workflow). Each case ends as

- ``ok``: read (and identified) without error;
- ``clean error``: a :class:`~femcal.errors.FemcalError` (femcal's own message, naming
  the file and what is wrong: what the CLI prints as one line);
- ``crash``: any other exception, a bug (a bare ValueError from NumPy or SciPy counts: it
  reaches the user without saying what in the file is wrong);
- ``hang``: the case ran longer than its timeout (``signal.setitimer``, main thread only).

``python -m tests.fuzz.frf --seed 1 --n 5000`` runs a long campaign and prints the counts and
every crash and hang; :func:`write_case` writes one case's file again to keep it as a
regression test.
"""

from __future__ import annotations

import argparse
import io
import re
import tempfile
import time
import traceback
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from femcal.errors import FemcalError
from femcal.identify import Settings, identify
from femcal.testdata.data import FRFData
from femcal.testdata.formats.matlab import write_mat
from femcal.testdata.formats.npz import write_npz
from femcal.testdata.formats.registry import format_of
from femcal.testdata.formats.text import write_csv
from femcal.testdata.formats.uff import write_uff

from .timeout import Timeout, alarm

#: The outcomes of a case, from best to worst.
OUTCOMES = ("ok", "clean error", "crash", "hang")
#: Seconds a case may take before it counts as a hang.
TIMEOUT = 10.0
#: Values a text field is replaced by.
BAD_TEXT = ("nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e309", "1e-320", "0", "-0", "",
            "x", "1,5", "  ", "0x10", "1e", "--1", "9" * 40, "-1", "1.5.2", "\x00", "é")  # fmt: skip
#: Values an array element is replaced by.
BAD_VALUES = (np.nan, np.inf, -np.inf, 1e308, -1e308, 1e-320, 0.0, complex(np.nan, 1.0))
#: A field of a fixed-width or blank-separated line.
_TOKEN = re.compile(rb"\S+")


@dataclass(frozen=True)
class Finding:
    """One fuzz case and how it ended.

    Attributes
    ----------
    case : ``seed:index``, what :func:`write_case` takes to write the file again.
    format : npz, csv, uff, uff58b, mat or lms.
    mutation : what was changed.
    outcome : one of :data:`OUTCOMES`.
    error : ``Type: message`` of the exception (``""`` for ok); for a crash, the last
        frames of its traceback too.
    seconds : how long the case took.
    """

    case: str
    format: str
    mutation: str
    outcome: str
    error: str
    seconds: float


# ----------------------------------------------------------------------------- the valid files


def base_set() -> FRFData:
    """The valid set every case starts from: accelerance of two modes (12 and 31 Hz, 2 %
    damping) at 3 outputs and 2 inputs, 2-49 Hz."""
    f = np.linspace(2.0, 49.0, 48)
    fn, zeta = np.array([12.0, 31.0]), 0.02
    phi = np.array([[1.0, 0.4], [0.6, -0.9], [-0.3, 1.0]])
    L = np.array([[1.0, 0.5], [0.2, -1.0]])
    w, wn = 2 * np.pi * f, 2 * np.pi * fn
    q = -(w**2) / (wn[:, None] ** 2 - w**2 + 2j * zeta * wn[:, None] * w)
    H = np.einsum("ok,ik,kf->oif", phi, L, q)
    return FRFData.from_labels(f, H, ["1:3", "2:3", "3:-1"], ["10:2", "11:3"], "accelerance",
                               "m/s^2/N")  # fmt: skip


def _lms_struct(data: FRFData) -> dict:
    """The Test.Lab export layout of ``data``: one block per input (named FRF, FRF_1, ...),
    values in SI with a display unit g/N."""
    g = 9.80665
    blocks = {}
    for i, inp in enumerate(data.inputs):
        names = np.array([f"Point{o.grid}:{o.direction}/Point{inp.grid}:{inp.direction}"
                          for o in data.outputs], dtype=object)  # fmt: skip
        blocks["FRF" if i == 0 else f"FRF_{i}"] = {
            "x_values": {"start_value": float(data.frequency_hz[0]),
                         "increment": float(np.diff(data.frequency_hz[:2]).sum() or 1.0),
                         "number_of_values": float(len(data.frequency_hz)),
                         "quantity": {"label": "Hz"}},
            "y_values": {"values": data.H[:, i, :].T.copy(),
                         "quantity": {"label": "g/N",
                                      "unit_transformation": {"factor": 1 / g, "offset": 0.0}}},
            "function_record": {"name": names, "type": "FRF"},
        }  # fmt: skip
    return blocks


def _write_lms(path: Path, data: FRFData) -> None:
    import scipy.io

    scipy.io.savemat(path, _lms_struct(data))


#: Each format: (suffix, writer of the valid file).
FORMATS: dict[str, tuple[str, Callable[[Path, FRFData], object]]] = {
    "npz": (".npz", write_npz),
    "csv": (".csv", write_csv),
    "uff": (".uff", write_uff),
    "uff58b": (".uff", lambda p, d: write_uff(p, d, binary=True)),
    "mat": (".mat", write_mat),
    "lms": (".mat", _write_lms),
}


def valid_files(directory: Path) -> dict[str, bytes]:
    """The valid file of every format (its bytes), written into ``directory``."""
    data = base_set()
    out = {}
    for name, (suffix, write) in FORMATS.items():
        path = directory / f"valid_{name}{suffix}"
        write(path, data)
        out[name] = path.read_bytes()
    return out


# ----------------------------------------------------------------------------- mutations

Mutation = tuple[str, bytes]  # (description, the file's new bytes)


def _bytes(rng: np.random.Generator, raw: bytes) -> Mutation:
    """A byte-level mutation anywhere in the file."""
    n = len(raw)
    kind = rng.integers(5)
    if kind == 0:
        b = bytearray(raw)
        at = rng.integers(n, size=int(rng.integers(1, 5)))
        for k in at:
            b[k] ^= 1 << int(rng.integers(8))
        return f"bits flipped at bytes {sorted(int(k) for k in at)}", bytes(b)
    if kind == 1:
        cut = int(rng.integers(n))
        return f"cut at byte {cut} of {n}", raw[:cut]
    a = int(rng.integers(n))
    b = min(n, a + int(rng.integers(1, 64)))
    if kind == 2:
        return f"bytes {a}-{b} deleted", raw[:a] + raw[b:]
    if kind == 3:
        junk = rng.integers(256, size=b - a).astype(np.uint8).tobytes()
        return f"{b - a} random bytes inserted at {a}", raw[:a] + junk + raw[a:]
    return f"bytes {a}-{b} repeated", raw[:b] + raw[a:b] + raw[b:]


def _uff_header_lines(lines: list[bytes]) -> list[int]:
    """Indices of the header lines of the datasets (the 12 lines after each opening -1)."""
    out = []
    opening = True
    for k, line in enumerate(lines):
        if line.rstrip().endswith(b"    -1") or line.strip() == b"-1":
            if opening:
                out += range(k + 1, min(k + 13, len(lines)))
            opening = not opening
    return out


def _replace_token(rng: np.random.Generator, line: bytes, sep: bytes | None) -> tuple[str, bytes]:
    """A field of ``line`` (split at ``sep``, or at runs of blanks) replaced by a bad value,
    right-aligned to the field's width half the time (fixed-width UFF fields)."""
    value = BAD_TEXT[int(rng.integers(len(BAD_TEXT)))].encode()
    if sep is not None:
        fields = line.split(sep)
        j = int(rng.integers(len(fields)))
        fields[j] = value
        return f"field {j + 1} -> {value!r}", sep.join(fields)
    spans = [(m.start(), m.end()) for m in _TOKEN.finditer(line)]
    if not spans:
        return f"blank line -> {value!r}", value
    j = int(rng.integers(len(spans)))
    a, b = spans[j]
    if rng.random() < 0.5:
        value = value.rjust(b - a)[: max(b - a, len(value.strip()))]
    return f"field {j + 1} -> {value!r}", line[:a] + value + line[b:]


def _lines(rng: np.random.Generator, raw: bytes, fmt: str) -> Mutation:
    """A line-level mutation of a text file (CSV, UFF; the header lines of a 58b)."""
    lines = raw.split(b"\n")
    header = _uff_header_lines(lines) if fmt.startswith("uff") else list(range(min(2, len(lines))))
    pool = header if fmt == "uff58b" or rng.random() < 0.4 else range(len(lines) - 1)
    pool = list(pool) or [0]
    k = int(pool[int(rng.integers(len(pool)))])
    kind = rng.integers(5 if fmt != "uff58b" else 2)
    if kind == 0 or kind >= 3:
        sep = b"," if fmt == "csv" else None
        what, new = _replace_token(rng, lines[k], sep)
        lines[k] = new
        return f"line {k + 1}: {what}", b"\n".join(lines)
    if kind == 1:
        del lines[k]
        return f"line {k + 1} deleted", b"\n".join(lines)
    if rng.random() < 0.5:
        lines.insert(k, lines[k])
        return f"line {k + 1} repeated", b"\n".join(lines)
    k = min(k, len(lines) - 2)
    lines[k], lines[k + 1] = lines[k + 1], lines[k]
    return f"lines {k + 1} and {k + 2} swapped", b"\n".join(lines)


def _bad_array(rng: np.random.Generator, value: np.ndarray, name: str) -> tuple[str, object]:
    """One array of a file made wrong: another type, shape or count, or a bad element."""
    v = np.asarray(value)
    kind = int(rng.integers(9))
    if kind == 0 and v.dtype.kind == "c":
        return f"{name} real", v.real.copy()
    if kind == 1:
        return f"{name} as text", np.array([str(x) for x in v.reshape(-1)]).reshape(v.shape)
    if kind == 2 and v.size:
        return f"{name} flattened", v.reshape(-1)
    if kind == 3 and v.ndim:
        return f"{name} one element short", v.reshape(-1)[:-1] if v.ndim == 1 else v[..., :-1]
    if kind == 4:
        return f"{name} empty", v.reshape(-1)[:0]
    if kind == 5 and v.ndim >= 2:
        return f"{name} transposed", v.T.copy()
    if kind == 6 and v.size and v.dtype.kind in "fc":
        w = v.copy()
        bad = BAD_VALUES[int(rng.integers(len(BAD_VALUES)))]
        if v.dtype.kind == "f" and isinstance(bad, complex):
            bad = bad.real
        idx = tuple(int(rng.integers(s)) for s in w.shape)
        w[idx] = bad
        return f"{name}{list(idx)} = {bad}", w
    if kind == 7 and v.ndim and v.size and v.dtype.kind in "fc":
        w = v.copy()
        if w.ndim == 3:
            w[int(rng.integers(w.shape[0]))] = 0
            return f"{name}: one output all zero", w
        return f"{name} reversed", w[::-1].copy()
    if kind == 8 and v.size > 1:
        w = v.copy().reshape(-1)
        w[-1] = w[0]
        return f"{name}: last element repeats the first", w.reshape(v.shape)
    return f"{name} a number", np.float64(7.0)


def _spoil_one(rng: np.random.Generator, arrays: dict[str, np.ndarray]) -> str:
    """Remove one of ``arrays`` (one time in ten) or make it wrong, in place; says which."""
    key = sorted(arrays)[int(rng.integers(len(arrays)))]
    if rng.random() < 0.1:
        del arrays[key]
        return f"{key} removed"
    what, arrays[key] = _bad_array(rng, arrays[key], key)
    return what


def _npz(rng: np.random.Generator, raw: bytes) -> Mutation:
    """An array of the NPZ made wrong (or removed)."""
    with np.load(io.BytesIO(raw)) as z:
        arrays = {k: z[k] for k in z.files}
    what = _spoil_one(rng, arrays)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return what, buf.getvalue()


def _mat(rng: np.random.Generator, raw: bytes) -> Mutation:
    """A variable of femcal's MATLAB layout made wrong (or removed)."""
    import scipy.io

    z = {k: v for k, v in scipy.io.loadmat(io.BytesIO(raw)).items() if not k.startswith("__")}
    what = _spoil_one(rng, z)
    buf = io.BytesIO()
    scipy.io.savemat(buf, z, do_compression=bool(rng.random() < 0.5))
    return what, buf.getvalue()


def _leaves(tree: dict, prefix: str = "") -> Iterator[tuple[str, dict, str]]:
    """(dotted name, parent dict, key) of every field of a nested struct."""
    for k, v in tree.items():
        name = f"{prefix}{k}"
        yield name, tree, k
        if isinstance(v, dict):
            yield from _leaves(v, name + ".")


def _lms(rng: np.random.Generator) -> Mutation:
    """A field of the Test.Lab layout made wrong (or removed)."""
    import scipy.io

    blocks = _lms_struct(base_set())
    fields = list(_leaves(blocks))
    name, parent, key = fields[int(rng.integers(len(fields)))]
    kind = rng.random()
    if kind < 0.15:
        del parent[key]
        what = f"{name} removed"
    elif kind < 0.35 and not isinstance(parent[key], dict):
        bad = (1e15, -3.0, 0.0, np.nan, np.inf, "text", "", 2.5)[int(rng.integers(8))]
        parent[key] = bad
        what = f"{name} = {bad!r}"
    elif isinstance(parent[key], dict):
        parent[key] = "not a struct"
        what = f"{name} not a struct"
    else:
        what, parent[key] = _bad_array(rng, np.asarray(parent[key]), name)
    buf = io.BytesIO()
    scipy.io.savemat(buf, blocks)
    return what, buf.getvalue()


def _changed_data(rng: np.random.Generator) -> tuple[str, FRFData]:
    """The valid set changed in what it holds, not in its form: values a reader takes but
    identification may choke on (a constant, repeated, real or conjugated channel, a spike,
    extreme scales, noise, few frequencies)."""
    d = base_set()
    f, H = d.frequency_hz.copy(), d.H.copy()
    o = int(rng.integers(H.shape[0]))
    kind = int(rng.integers(12))
    if kind == 0:
        H[o] = complex(rng.normal(), rng.normal())
        what = f"output {o + 1} constant"
    elif kind == 1:
        H[o] = H[(o + 1) % H.shape[0]]
        what = f"output {o + 1} repeats the next"
    elif kind == 2:
        scale = 10.0 ** float(rng.choice([-99, -60, -20, 20, 60, 99]))
        H = H * scale
        what = f"H times {scale:g}"
    elif kind == 3:
        k = int(rng.integers(len(f)))
        H[o, :, k] *= 1e6
        what = f"a spike at output {o + 1}, frequency {k + 1}"
    elif kind == 4:
        n = int(rng.integers(1, 9))
        f, H = f[:n], H[:, :, :n]
        what = f"the first {n} frequencies only"
    elif kind == 5:
        step = int(rng.integers(2, 12))
        f, H = f[::step], H[:, :, ::step]
        what = f"every {step}th frequency"
    elif kind == 6:
        scale = 10.0 ** float(rng.choice([-8, -3, 3, 8]))
        f = f * scale
        what = f"frequencies times {scale:g}"
    elif kind == 7:
        H[o] = H[o].real
        what = f"output {o + 1} real"
    elif kind == 8:
        H = H.conj()
        what = "H conjugated"
    elif kind == 9:
        H = rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)
        what = "H random"
    elif kind == 10:
        H[:, int(rng.integers(H.shape[1]))] = 0
        what = "an input zero"
    else:
        H = H + 1e-3 * np.abs(H).max() * rng.normal(size=H.shape)
        what = "H with noise"
    return what, FRFData(f, H, d.outputs, d.inputs, d.quantity, d.units)


def _data(rng: np.random.Generator, fmt: str) -> Mutation:
    """The valid set changed by :func:`_changed_data`, written by the format's writer."""
    what, data = _changed_data(rng)
    suffix, write = FORMATS[fmt]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"data{suffix}"
        try:
            write(path, data)
        except FemcalError:  # a set the format cannot hold (one frequency in UFF)
            return f"data: {what}, not written", b""
        return f"data: {what}", path.read_bytes()


def mutate(rng: np.random.Generator, fmt: str, raw: bytes) -> Mutation:
    """One random mutation of the valid file ``raw`` of format ``fmt``."""
    choice = rng.random()
    if choice < 0.15:
        return _data(rng, fmt)
    if choice < 0.5:
        return _bytes(rng, raw)
    if fmt in ("csv", "uff", "uff58b"):
        return _lines(rng, raw, fmt)
    try:  # a change NumPy or SciPy cannot store is replaced by one of the bytes
        if fmt == "npz":
            return _npz(rng, raw)
        if fmt == "mat":
            return _mat(rng, raw)
        return _lms(rng)
    except (ValueError, TypeError, IndexError):
        return _bytes(rng, raw)


# ----------------------------------------------------------------------------- running


def _identify(data: FRFData, order: int | None) -> None:
    """A cheap identification over the data's whole band (from its first frequency above
    0): the given order, or automatic orders up to 10; a few alternating steps."""
    f = data.frequency_hz
    positive = f[f > 0]
    if len(positive) < 2:
        return
    settings = Settings(max_order=10, max_iter=3)
    identify(data, (float(positive[0]), float(positive[-1])), orders=order, settings=settings)


def run_case(path: Path, *, order: int | None = None,
             timeout: float = TIMEOUT) -> tuple[str, str]:  # fmt: skip
    """Read ``path`` with its format's reader and identify what it reads (at ``order``, or
    automatic orders): (outcome, error text) as the module docstring defines them."""
    reader = format_of(path, "frf").read
    try:
        with alarm(timeout) as fired, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                data = reader(path)
                _identify(data, order)
            except FemcalError as e:
                if fired[0]:
                    return "hang", f"timed out after {timeout:g} s"
                return "clean error", f"{type(e).__name__}: {e}"
            except Exception as e:
                if fired[0]:
                    return "hang", f"timed out after {timeout:g} s"
                frames = "".join(traceback.format_tb(e.__traceback__)[-3:])
                return "crash", f"{type(e).__name__}: {e}\n{frames}"
    except Timeout:
        return "hang", f"timed out after {timeout:g} s"
    if fired[0]:
        return "hang", f"timed out after {timeout:g} s"
    return "ok", ""


def _case(seed: int, index: int, valid: dict[str, bytes]) -> tuple[str, str, bytes]:
    """(format, mutation, bytes) of case ``index`` of ``seed``: formats in turn, each case
    its own random stream, so that any case can be made again alone."""
    fmt = list(FORMATS)[index % len(FORMATS)]
    rng = np.random.default_rng([seed, index])
    what, raw = mutate(rng, fmt, valid[fmt])
    return fmt, what, raw


def write_case(case: str, directory: str | Path) -> Path:
    """Write the file of case ``seed:index`` into ``directory`` again (for a regression
    test); returns its path."""
    seed, index = (int(x) for x in case.split(":"))
    directory = Path(directory)
    with tempfile.TemporaryDirectory() as tmp:
        valid = valid_files(Path(tmp))
    fmt, _, raw = _case(seed, index, valid)
    path = directory / f"case_{seed}_{index}_{fmt}{FORMATS[fmt][0]}"
    path.write_bytes(raw)
    return path


def run_frf_fuzz(seed: int, n: int, *, timeout: float = TIMEOUT) -> list[Finding]:
    """Run cases ``0 .. n-1`` of ``seed`` (formats in turn) and return how each ended."""
    findings = []
    with tempfile.TemporaryDirectory(prefix="femcal-fuzz-frf-") as tmp:
        directory = Path(tmp)
        valid = valid_files(directory)
        for index in range(n):
            fmt, what, raw = _case(seed, index, valid)
            path = directory / f"case{FORMATS[fmt][0]}"
            path.write_bytes(raw)
            t0 = time.perf_counter()
            order = None if index // len(FORMATS) % 2 else 4
            outcome, error = run_case(path, order=order, timeout=timeout)
            findings.append(Finding(f"{seed}:{index}", fmt, what, outcome, error,
                                    time.perf_counter() - t0))  # fmt: skip
    return findings


def summary(findings: list[Finding]) -> str:
    """Counts by outcome and by format and outcome, one line each."""
    total = Counter(f.outcome for f in findings)
    lines = ["all: " + ", ".join(f"{total[o]} {o}" for o in OUTCOMES)]
    for fmt in FORMATS:
        c = Counter(f.outcome for f in findings if f.format == fmt)
        lines.append(f"{fmt}: " + ", ".join(f"{c[o]} {o}" for o in OUTCOMES))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m tests.fuzz.frf --seed S --n N``: run a campaign, print the counts and
    every crash and hang; exit status 1 if there was any."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--timeout", type=float, default=TIMEOUT)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    findings = run_frf_fuzz(args.seed, args.n, timeout=args.timeout)
    seconds = time.perf_counter() - t0
    bad = [f for f in findings if f.outcome in ("crash", "hang")]
    for f in bad:
        print(f"{f.case} {f.format} [{f.mutation}] {f.outcome}: {f.error}")
    print(summary(findings))
    slowest = max(findings, key=lambda f: f.seconds)
    print(f"{len(findings)} cases in {seconds:.1f} s; slowest {slowest.case} "
          f"({slowest.format}, {slowest.seconds:.2f} s)")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
