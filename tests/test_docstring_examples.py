"""Run every docstring example in the package (numpydoc ``Examples`` sections).

The examples are imported as the installed ``pdmkit`` modules (not as files), so they
exercise exactly what a user imports.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import matplotlib
import numpy as np
import pytest

import pdmkit

matplotlib.use("Agg")


def _modules() -> list[str]:
    names = ["pdmkit"]
    for info in pkgutil.walk_packages(pdmkit.__path__, prefix="pdmkit."):
        # tests/ and benchmarks/ sit under the repository root but are not in the
        # package; __main__ runs the CLI when imported.
        if info.name.split(".")[1] in {"tests", "benchmarks", "docs", "__main__"}:
            continue
        names.append(info.name)
    return sorted(names)


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    np.random.seed(0)  # noqa: NPY002  (examples may use the legacy global generator)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False
    )
    for test in finder.find(module, name):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} docstring example(s) failed in {name}"


def test_every_public_function_has_an_example() -> None:
    """Everything a subpackage lists in ``__all__`` shows how it is used."""
    missing = []
    public_modules = [
        n for n in _modules() if not any(p.startswith("_") for p in n.split("."))
    ]
    for name in public_modules:
        module = importlib.import_module(name)
        for public in getattr(module, "__all__", []):
            obj = getattr(module, public)
            if isinstance(obj, type) and issubclass(obj, BaseException):
                continue  # exceptions are documented by the message they carry
            if callable(obj) and getattr(obj, "__module__", "").startswith("pdmkit"):
                if ">>>" not in (obj.__doc__ or ""):
                    missing.append(f"{name}.{public}")
    assert not missing, (
        f"public callables without a runnable example: {sorted(set(missing))}"
    )
