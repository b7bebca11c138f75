"""The design card's layout: top-level folders import as ``pdmkit.<name>``."""

from __future__ import annotations

import importlib
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import pdmkit

ROOT = Path(__file__).resolve().parents[1]
SUBPACKAGES = ["models", "ensembles", "features", "rul", "experiments"]


@pytest.mark.parametrize("name", SUBPACKAGES)
def test_subpackage_imports_under_pdmkit(name: str) -> None:
    module = importlib.import_module(f"pdmkit.{name}")
    assert Path(module.__file__).resolve() == ROOT / name / "__init__.py"
    assert isinstance(module.__all__, list | tuple)


def test_bare_folder_names_are_not_importable() -> None:
    # `import models` must not silently pick up pdmkit's folder in users' code.
    code = (
        "import importlib.util, sys; "
        "sys.exit(importlib.util.find_spec('features') is not None)"
    )
    assert subprocess.run([sys.executable, "-c", code], cwd="/").returncode == 0


def test_errors_subclass_builtins() -> None:
    e = pdmkit.errors
    assert issubclass(e.DataError, ValueError)
    assert issubclass(e.ModelError, ValueError)
    assert issubclass(e.NotFittedError, AttributeError)
    assert issubclass(e.ConvergenceWarning, RuntimeWarning)


@pytest.mark.slow
def test_wheel_holds_the_same_modules_as_the_checkout(tmp_path: Path) -> None:
    """`pip install .` must ship the same pdmkit.* modules an editable install sees."""
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        pytest.skip(f"could not build a wheel here: {proc.stderr[-300:]}")
    wheel = next(tmp_path.glob("pdmkit-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    for sub in SUBPACKAGES:
        for source in (ROOT / sub).glob("*.py"):
            assert f"pdmkit/{sub}/{source.name}" in names
    assert "pdmkit/__init__.py" in names and "pdmkit/errors.py" in names
    assert not any(n.startswith(("pdmkit/tests/", "tests/")) for n in names)
