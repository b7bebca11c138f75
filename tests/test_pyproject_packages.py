"""pyproject.toml's package list matches the source tree, so installs ship it all, quietly.

The repository root is the ``pdmkit`` package (``package-dir``), so setuptools ships
only the packages listed in ``[tool.setuptools] packages``: a folder of modules missing
from the list is missing from ``pip install .``, and a folder of data files missing
from it makes setuptools print a "Package would be ignored" box on every install.
The optional dependencies are extras: the core list holds neither torch nor Dask.
"""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
SETUP = PYPROJECT["tool"]["setuptools"]
#: repository folders that are not part of the package
OUTSIDE = {"tests", "benchmarks", "docs", "examples", "build", "results", "dist"}


def _folder(package: str) -> Path:
    return ROOT.joinpath(*package.split(".")[1:])


def _source_folders() -> set[str]:
    """Every folder of the package that holds modules (an ``__init__.py``)."""
    out = set()
    for init in ROOT.rglob("__init__.py"):
        rel = init.parent.relative_to(ROOT)
        if rel.parts and (rel.parts[0] in OUTSIDE or rel.parts[0].startswith(".")):
            continue
        out.add(".".join(["pdmkit", *rel.parts]))
    return out


def test_the_root_is_the_package():
    assert SETUP["package-dir"] == {"pdmkit": "."}


def test_every_folder_of_modules_is_listed():
    missing = sorted(_source_folders() - set(SETUP["packages"]))
    assert not missing, f"add to [tool.setuptools] packages: {missing}"


def test_every_listed_package_exists_and_data_folders_hold_their_files():
    for package in SETUP["packages"]:
        assert _folder(package).is_dir(), package
    data = SETUP["package-data"]
    for package, patterns in data.items():
        assert package in SETUP["packages"], f"package-data of an unlisted {package}"
        for pattern in patterns:
            # a pattern reaching into a sub-folder is what makes setuptools warn
            assert "/" not in pattern, f"{package}: list the folder of {pattern!r}"
            assert list(_folder(package).glob(pattern)), (
                f"{package}: {pattern} matches nothing"
            )
    # what the code reads at run time ships with it
    shipped = {(p, pat) for p, pats in data.items() for pat in pats}
    assert ("pdmkit.experiments.data", "*.toml") in shipped
    assert ("pdmkit.models.ode.showcases", "*.py") in shipped
    assert {"*.html", "*.js", "*.css"} <= set(data["pdmkit.experiments.designer.static"])
    # every listed package without modules is a data folder with package-data
    for package in set(SETUP["packages"]) - _source_folders():
        assert package in data, f"{package} holds no modules and no package-data"


def test_torch_and_dask_are_extras():
    core = " ".join(PYPROJECT["project"]["dependencies"])
    extras = PYPROJECT["project"]["optional-dependencies"]
    assert "torch" not in core and "dask" not in core
    assert any(r.startswith("torch") for r in extras["neural"])
    assert any(r.startswith("dask[distributed]") for r in extras["dask"])
    assert extras["all"] == ["pdmkit[neural,dask,designer,db,fast]"]
    assert "numba" not in core and any(r.startswith("numba") for r in extras["fast"])
    assert "pdmkit[all]" in extras["dev"]  # make test runs the whole suite
