"""The house rules of ``docs/ARCHITECTURE.md``, checked on the source itself.

* **Layers** point down only: root modules < ``models`` < ``ensembles`` < ``features`` <
  ``rul`` < ``experiments`` (``pdmkit/__init__``, ``__main__`` and ``_entry`` sit on top).
* **Nothing private crosses a folder**: a private module (``pdmkit.models.ode._simulate``)
  or a private name (``_run``) may be imported only from inside the package that owns it
  (``pdmkit.models.ode`` and below); root private modules (``pdmkit._checks``) and a
  layer's shared private modules (``pdmkit.models._xp``) serve everything under them.
* **No import cycles** between pdmkit's modules, counting imports inside functions.

Each rule has a list of the places that still break it, each with its reason: the
debt, written down. The test fails when a new place breaks a rule, and also when a
listed place no longer does (so the list shrinks as the code is mended).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {"models": 1, "ensembles": 2, "features": 3, "rul": 4, "experiments": 5}
TOP = {"pdmkit", "pdmkit.__main__", "pdmkit._entry"}

#: (importer, imported module or module:name) -> why it is still there
PRIVATE_DEBT: dict[tuple[str, str], str] = {}


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(["pdmkit", *parts])


def _sources() -> dict[str, Path]:
    out = {}
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in {"tests", "benchmarks", "examples", "build", ".venv", "docs"}:
            continue
        if any(p.startswith(".") for p in rel.parts) or "showcases" in rel.parts:
            continue
        out[_module_name(path)] = path
    return out


SOURCES = _sources()


def _package_of(module: str) -> str:
    path = SOURCES.get(module)
    return (
        module
        if path is not None and path.name == "__init__.py"
        else module.rpartition(".")[0]
    )


def _imports(module: str) -> list[tuple[str, str | None, int]]:
    """``(imported module, imported name or None, line)`` for every pdmkit import."""
    path = SOURCES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = _package_of(module)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [
                (a.name, None, node.lineno)
                for a in node.names
                if a.name.startswith("pdmkit")
            ]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            if not target.startswith("pdmkit"):
                continue
            for a in node.names:
                sub = f"{target}.{a.name}"
                if sub in SOURCES:  # `from pdmkit.models import ode`: a module
                    out.append((sub, None, node.lineno))
                else:
                    out.append((target, a.name, node.lineno))
    return out


def _layer(module: str, importer: bool = False) -> int:
    if module in TOP:
        return 99 if importer else 0
    parts = module.split(".")
    return LAYERS.get(parts[1], 0) if len(parts) > 1 else 0


def _owner(module: str, name: str | None) -> str:
    """The package a private module or name belongs to ('' when nothing is private)."""
    parts = module.split(".")
    for i, p in enumerate(parts):
        if p.startswith("_"):
            return ".".join(parts[:i])
    if name is not None and name.startswith("_") and not name.startswith("__"):
        return _package_of(module)
    return ""


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def test_the_source_tree_is_found() -> None:
    assert "pdmkit.models.ode._simulate" in SOURCES
    assert "pdmkit.experiments._cli" in SOURCES
    assert _owner("pdmkit.models.ode._simulate", None) == "pdmkit.models.ode"
    assert _owner("pdmkit.models.ode", "_run") == "pdmkit.models.ode"
    assert _owner("pdmkit._checks", "check_int") == "pdmkit"
    assert _owner("pdmkit.models.ode", "simulate_ode") == ""


def test_imports_point_down_the_layers() -> None:
    up = [
        f"{m}:{line} imports {target}"
        for m in SOURCES
        for target, _, line in _imports(m)
        if _layer(target) > _layer(m, importer=True)
    ]
    assert not up, "imports pointing up the layers:\n" + "\n".join(up)


def test_nothing_private_crosses_a_folder() -> None:
    found = defaultdict(list)
    for m in SOURCES:
        for target, name, line in _imports(m):
            owner = _owner(target, name)
            if owner and not _inside(m, owner) and m not in TOP:
                found[(m, target)].append(f"{m}:{line} takes {target}:{name or '*'}")
    new = {k: v for k, v in found.items() if k not in PRIVATE_DEBT}
    assert not new, "private names crossing folders:\n" + "\n".join(
        line for v in new.values() for line in v
    )
    mended = sorted(set(PRIVATE_DEBT) - set(found))
    assert not mended, f"mended, remove from PRIVATE_DEBT: {mended}"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


#: import cycles still there (modules of each), with the reason
CYCLE_DEBT: dict[tuple[str, ...], str] = {}


@pytest.mark.parametrize("include_packages", [False])
def test_no_import_cycles(include_packages: bool) -> None:
    """Module-to-module edges (imports of a package's ``__init__`` count as edges to the
    module that defines the name, so re-exports do not make cycles)."""
    graph: dict[str, set[str]] = defaultdict(set)
    for m in SOURCES:
        if SOURCES[m].name == "__init__.py":
            continue
        for target, name, _ in _imports(m):
            if target not in SOURCES:
                continue
            if SOURCES[target].name == "__init__.py" and name is not None:
                target = _defining_module(target, name)
            if target != m and SOURCES[target].name != "__init__.py":
                graph[m].add(target)
    cycles = [tuple(c) for c in _cycles(graph)]
    new = [c for c in cycles if c not in CYCLE_DEBT]
    assert not new, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in new)


def _lazy_map(package: str) -> dict[str, str]:
    """A package's ``_LAZY = {name: "module"}`` (names imported on first use)."""
    tree = ast.parse(SOURCES[package].read_text(encoding="utf-8"))
    for node in tree.body:
        target = (
            getattr(node, "target", None) or (getattr(node, "targets", None) or [None])[0]
        )
        if isinstance(target, ast.Name) and target.id == "_LAZY":
            return {k: f"{package}.{v}" for k, v in ast.literal_eval(node.value).items()}
    return {}


def _defining_module(package: str, name: str) -> str:
    """The module a package's ``__init__`` takes ``name`` from, directly or through its
    lazy map (the package itself if neither)."""
    for target, imported, _ in _imports(package):
        if imported == name:
            if SOURCES.get(target) is not None and SOURCES[target].name == "__init__.py":
                return _defining_module(target, name)
            return target
    return _lazy_map(package).get(name, package)


# ------------------------------------------------------------ imports inside functions
#: Third-party packages that cost a good part of a second to import, or start machinery
#: (the import-weight test's list, plus the optional extras).
HEAVY = {
    "sklearn", "scipy", "pandas", "pyarrow", "torch", "matplotlib", "tqdm", "dask",
    "distributed", "control", "starlette", "uvicorn", "plotly", "selenium", "lifelines",
}  # fmt: skip
#: Modules that must import lightly: what ``pdmkit``, ``pdmkit --help`` and
#: ``import pdmkit.<layer>`` load (``tests/test_import_weight.py`` holds their weight).
LIGHT_ROOTS = (
    "pdmkit",
    "pdmkit._entry",
    "pdmkit.errors",
    "pdmkit._progress",
    "pdmkit.experiments._cli",
    *(f"pdmkit.{layer}" for layer in LAYERS),
)

#: (importer, imported module) -> why the import stays inside a function
LAZY_DEBT: dict[tuple[str, str], str] = {}


def _module_level(module: str) -> tuple[set[str], set[str], list[tuple[str, int]]]:
    """(pdmkit modules imported at module level, heavy packages imported at module
    level, [(pdmkit module imported inside a function, line)]) of ``module``; names
    taken from a package resolve to the module defining them (lazy maps too)."""
    tree = ast.parse(SOURCES[module].read_text(encoding="utf-8"))
    inner = {
        node.lineno
        for f in ast.walk(tree)
        if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef)
        for node in ast.walk(f)
        if isinstance(node, ast.Import | ast.ImportFrom)
    }
    heavy = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom) and node.lineno not in inner:
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""] * (not node.level)
            )
            heavy |= {n.split(".")[0] for n in names} & HEAVY
    top, in_functions = set(), []
    for target, name, line in _imports(module):
        if target not in SOURCES:
            continue
        defining = target
        if SOURCES[target].name == "__init__.py" and name is not None:
            defining = _defining_module(target, name)
        if line in inner:
            in_functions.append((defining, line))
        else:  # importing a.b.c runs a/__init__ and a/b/__init__ too
            parts = defining.split(".")
            top |= {".".join(parts[:k]) for k in range(2, len(parts) + 1)} & set(SOURCES)
            top.add(target)
    return top, heavy, in_functions


def test_imports_inside_functions_only_keep_modules_light() -> None:
    """An import of pdmkit's own code inside a function hides coupling from the reader
    (and from the module's import list); it is kept only where it defers weight:

    * it loads a heavy package (scipy, scikit-learn, torch, ...) that the importing
      module does not load already, e.g. ``pdmkit.models`` from a workflow that only
      sometimes fits a model; or
    * the importing module must stay light (what ``import pdmkit``, ``pdmkit --help``
      and ``import pdmkit.<layer>`` load) and the target is not loaded with it yet.

    Any other one belongs at the top of the module.
    """
    info = {m: _module_level(m) for m in SOURCES}
    closures: dict[str, set[str]] = {}

    def closure(m: str) -> set[str]:
        if m not in closures:
            seen, stack = {m}, [m]
            while stack:
                for t in info[stack.pop()][0]:
                    if t not in seen:
                        seen.add(t)
                        stack.append(t)
            closures[m] = seen
        return closures[m]

    def heavy(m: str) -> set[str]:
        return set().union(*(info[x][1] for x in closure(m)))

    light = set().union(*(closure(root) for root in LIGHT_ROOTS))
    found = defaultdict(list)
    for m in SOURCES:
        for target, line in info[m][2]:
            defers_heavy = bool(heavy(target) - heavy(m))
            keeps_light = m in light and target not in closure(m)
            in_cycle = any(m in c and target in c for c in CYCLE_DEBT)
            if not (defers_heavy or keeps_light or in_cycle):
                found[(m, target)].append(f"{m}:{line} imports {target} in a function")
    new = {k: v for k, v in found.items() if k not in LAZY_DEBT}
    assert not new, "imports that belong at the top of their module:\n" + "\n".join(
        line for v in new.values() for line in v
    )
    mended = sorted(set(LAZY_DEBT) - set(found))
    assert not mended, f"mended, remove from LAZY_DEBT: {mended}"
