"""The package's shape, read from the source (ast, imports inside functions included): no
import cycles; imports that point one way along the pipeline; nothing that solves imports the
deck layer, even through another module or a package's ``__init__``; the calibrator draws no
pictures; a small root; a public API that imports nothing heavy."""

from __future__ import annotations

import ast
import subprocess
import sys
from functools import cache
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "femcal"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in PKG.rglob("*.py")}


def _is_module(name: str) -> bool:
    return name in MODULES


@cache
def imports_of(name: str) -> frozenset[str]:
    """Every femcal module (and outside top-level package) that ``name`` imports anywhere
    in its text; ``from pkg import sub`` counts as importing the submodule."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            subs = [f"{target}.{a.name}" for a in node.names if _is_module(f"{target}.{a.name}")]
            out.update(subs)
            if len(subs) < len(node.names):
                out.add(target)
    return frozenset(out)


def _parents(name: str) -> list[str]:
    parts = name.split(".")
    return [".".join(parts[:k]) for k in range(1, len(parts))]


@cache
def reaches(name: str) -> frozenset[str]:
    """Every module executed when ``name`` is imported: its imports, their package
    ``__init__`` files and theirs, transitively (outside packages by top-level name)."""
    seen: set[str] = set()
    todo = [name, *_parents(name)]
    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        if not _is_module(m):
            continue
        for dep in imports_of(m):
            if dep.startswith("femcal"):
                todo += [d for d in (dep, *_parents(dep)) if _is_module(d)]
            else:
                seen.add(dep.split(".")[0])
    return frozenset(seen)


def test_no_module_imports_itself_back():
    graph = {m: {d for d in imports_of(m) if _is_module(d) and d != m} for m in MODULES}
    state: dict[str, int] = {}
    cycles: list[list[str]] = []

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for d in sorted(graph[m]):
            if state.get(d) == 1:
                cycles.append([*path[path.index(d):], d] if d in path else [m, d])
            elif d not in state:
                visit(d, [*path, d])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    assert not cycles, f"import cycles: {cycles[:5]}"


#: The layers that may read a deck: the deck layer, the model builder from cards, and the
#: edges (files in and out, command line, bundled generators, the lazy public API).
DECK_READERS = ("femcal.deck", "femcal.model.build", "femcal.model.build_constraints",
                "femcal.model.build_checks",
                "femcal.model.build_analysis", "femcal.io", "femcal.jobs", "femcal.cli",
                "femcal.examples", "femcal.__main__")  # fmt: skip


def _below_the_model(name: str) -> bool:
    return name != "femcal" and not any(name == r or name.startswith(r + ".")
                                        for r in DECK_READERS)  # fmt: skip


@pytest.mark.parametrize("name", sorted(m for m in MODULES if _below_the_model(m)))
def test_nothing_below_the_model_imports_the_deck_layer(name):
    assert not any(m == "femcal.deck" or m.startswith("femcal.deck.") for m in reaches(name))


def test_the_solving_side_is_checked():
    # the parametrised check above covers these layers (and more)
    for layer in ("elements", "properties", "model", "assembly", "solve", "response",
                  "testdata", "identify", "correlate", "calibrate"):  # fmt: skip
        assert any(m.startswith(f"femcal.{layer}") and _below_the_model(m) for m in MODULES)
    # and the check sees a real import: the deck layer's own reader reaches it
    assert "femcal.deck.fields" in reaches("femcal.model.build")


PICTURES = ("matplotlib", "pyvista", "vtk", "femcal.viz")


@pytest.mark.parametrize("name", sorted(m for m in MODULES if m.startswith("femcal.calibrate")))
def test_the_calibrator_draws_no_pictures(name):
    drawn = {m for m in reaches(name) if any(m == p or m.startswith(p + ".") for p in PICTURES)}
    assert not drawn, f"{name} reaches {sorted(drawn)}"


#: The layers in pipeline order. A module may import its own layer and those before it, never
#: one after it; the first group is the utilities every layer may use.
LAYERS = (
    ("femcal.errors", "femcal.markers", "femcal.atomic", "femcal.resources", "femcal.parallel"),
    ("femcal.deck",),
    ("femcal.model",),
    ("femcal.properties", "femcal.elements"),
    ("femcal.assembly",),
    ("femcal.solve",),
    ("femcal.response",),
    ("femcal.testdata",),
    ("femcal.correlate",),
    ("femcal.identify",),
    ("femcal.calibrate",),
    ("femcal.rig",),
    ("femcal.io", "femcal.viz"),
    ("femcal.jobs", "femcal.examples", "femcal.cli", "femcal.__main__"),
)


def _layer(name: str) -> int | None:
    for rank, group in enumerate(LAYERS):
        if any(name == g or name.startswith(g + ".") for g in group):
            return rank
    return None


def test_every_module_has_a_layer():
    assert [m for m in MODULES if m != "femcal" and _layer(m) is None] == []


@pytest.mark.parametrize("name", sorted(m for m in MODULES if m != "femcal"))
def test_imports_point_one_way(name):
    later = sorted(d for d in imports_of(name) if d.startswith("femcal") and _is_module(d)
                   and (_layer(d) or 0) > _layer(name))  # fmt: skip
    assert not later, f"{name} (layer {_layer(name)}) imports later layers: {later}"


def test_at_most_six_modules_at_the_root():
    loose = sorted(p.name for p in PKG.glob("*.py"))
    assert len(loose) <= 6, loose


def test_public_api_and_version():
    code = ("import sys, femcal; print(femcal.__version__); "
            "print(sorted(m for m in ('numpy', 'scipy', 'matplotlib', 'pyvista', 'vtk') "
            "if m in sys.modules)); "
            "[getattr(femcal, n) for n in femcal.__all__]; print('ok')")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split("\n")  # fmt: skip
    from femcal import __version__

    assert out[0] == __version__ and __version__.count(".") == 2
    assert out[1] == "[]"  # `import femcal` loads none of them
    assert out[2] == "ok"  # every public name resolves
    cli = subprocess.run([sys.executable, "-m", "femcal", "--version"], capture_output=True,
                         text=True, check=True)  # fmt: skip
    assert cli.stdout.strip() == f"femcal {__version__}"
