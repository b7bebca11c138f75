"""Modules a newcomer can read: no module over 800 lines, no function over 80 lines.

A function's length counts its code, not its docstring (numpydoc docstrings with
runnable examples are wanted, and long). A place that must stay over is listed below
with the reason; the test fails on a new one, and on a listed one that is no longer
over. Both lists are empty: every module and function is within the limits.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_MODULE_LINES = 800
MAX_FUNCTION_LINES = 80
_SKIP = {"tests", "benchmarks", "examples", "build", "docs"}

#: module -> why it is still longer than MAX_MODULE_LINES
LONG_MODULES: dict[str, str] = {}

#: "module:function" -> why it is still longer than MAX_FUNCTION_LINES
LONG_FUNCTIONS: dict[str, str] = {}


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in _SKIP or any(p.startswith(".") for p in rel.parts):
            continue
        if "showcases" in rel.parts:  # model files shipped as data
            continue
        yield rel.as_posix(), path.read_text(encoding="utf-8")


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    body = node.body
    doc = (
        isinstance(body[0], ast.Expr)
        and isinstance(body[0].value, ast.Constant)
        and isinstance(body[0].value.value, str)
    )
    first = body[1].lineno if doc and len(body) > 1 else body[0].lineno
    return node.end_lineno - first + 1


def _long_modules() -> dict[str, int]:
    return {
        name: text.count("\n")
        for name, text in _modules()
        if text.count("\n") > MAX_MODULE_LINES
    }


def _long_functions() -> dict[str, int]:
    out = {}
    for name, text in _modules():
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = _code_lines(node)
                if n > MAX_FUNCTION_LINES:
                    out[f"{name}:{node.name}"] = n
    return out


def test_the_counter_counts_code_not_docstrings() -> None:
    fn = ast.parse('def f():\n    """Doc.\n\n    More.\n    """\n    a = 1\n    return a\n')
    assert _code_lines(fn.body[0]) == 2


def test_no_module_is_longer_than_800_lines() -> None:
    found = _long_modules()
    new = {k: v for k, v in found.items() if k not in LONG_MODULES}
    assert not new, f"modules over {MAX_MODULE_LINES} lines: {new}"
    mended = sorted(set(LONG_MODULES) - set(found))
    assert not mended, f"no longer over, remove from LONG_MODULES: {mended}"


def test_no_function_is_longer_than_80_lines() -> None:
    found = _long_functions()
    new = {k: v for k, v in found.items() if k not in LONG_FUNCTIONS}
    assert not new, f"functions over {MAX_FUNCTION_LINES} code lines: {new}"
    mended = sorted(set(LONG_FUNCTIONS) - set(found))
    assert not mended, f"no longer over, remove from LONG_FUNCTIONS: {mended}"
