"""Public namespaces list public names only (issue 32).

``dir()`` of pdmkit and of each subpackage shows what its ``__all__`` lists, its
subpackages and public modules: no ``importlib``, ``annotations`` or helper imports.
The source thesis's study lives in its own module, not among the general workflows.
"""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import pdmkit

PACKAGES = sorted(
    ["pdmkit"]
    + [m.name for m in pkgutil.walk_packages(pdmkit.__path__, "pdmkit.") if m.ispkg]
)
#: public modules that are not packages
MODULES = ["pdmkit.errors", "pdmkit.experiments.thesis"]

THESIS = {
    "RIG_TABLE_SENSOR_ACCURACY",
    "SEED_NUMBERS",
    "SEED_SENSOR_ACCURACY",
    "SEED_SENSOR_RECIPES",
    "SeedResult",
    "SeedSensorRecipe",
    "run_seed_study",
    "seed_air_leak_rul",
    "seed_comparison",
    "seed_feature_table",
    "seed_flow_bagged_trees",
    "seed_flow_knn",
    "seed_flow_pca_bagged_trees",
    "seed_indicators",
    "seed_rank",
    "seed_residual_classification",
    "seed_sensor_faults",
    "seed_sensor_table",
}


def test_the_walk_finds_the_subpackages():
    assert {"pdmkit.features", "pdmkit.models.ode", "pdmkit.experiments.designer"} <= set(
        PACKAGES
    )


@pytest.mark.parametrize("name", PACKAGES + MODULES)
def test_dir_shows_only_public_names(name):
    module = importlib.import_module(name)
    public = set(module.__all__)
    children = {m.name for m in pkgutil.iter_modules(getattr(module, "__path__", []))}
    stray = sorted(
        n for n in dir(module) if not n.startswith("_") and n not in public | children
    )
    assert not stray, f"{name} shows names outside its __all__: {stray}"
    assert len(dir(module)) == len(set(dir(module))), f"{name}: dir() repeats names"


@pytest.mark.parametrize("name", PACKAGES + MODULES)
def test_every_listed_name_resolves(name):
    module = importlib.import_module(name)
    missing = [n for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ lists names it lacks: {missing}"
    assert len(module.__all__) == len(set(module.__all__))


def test_the_thesis_study_has_its_own_module():
    import pdmkit.experiments as experiments
    import pdmkit.experiments.thesis as thesis

    assert set(thesis.__all__) == THESIS
    assert not THESIS & set(experiments.__all__)
    assert not [n for n in experiments.__all__ if n.lower().startswith("seed")]
    with pytest.raises(AttributeError):
        experiments.seed_flow_knn  # noqa: B018
    # the very objects the study's modules define
    from pdmkit.experiments._seed_recipes import seed_flow_knn

    assert thesis.seed_flow_knn is seed_flow_knn
