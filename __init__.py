"""pdmkit: a predictive-maintenance workbench.

Layers, lowest first (an import may only point down):

``pdmkit.models``
    Dynamic models: physics simulators, system identification, residual generators.
``pdmkit.ensembles``
    Recordings and their condition variables: readers, Parquet stores, dataset loaders.
``pdmkit.features``
    Condition indicators (statistical, spectral, model-based) and their ranking.
``pdmkit.rul``
    Remaining-useful-life models and prognostic metrics.
``pdmkit.experiments``
    Workflows people run (classify faults, compare sensors, demo), the CLI and reports.

Trained pipelines and RUL models are saved and loaded without unpickling anything by
:func:`save_model` and :func:`load_model`.

Examples
--------
>>> import numpy as np
>>> import pdmkit.features as pf
>>> x = np.sin(2 * np.pi * 50 * np.arange(4096) / 4096.0)
>>> round(float(pf.extract(x, fs=4096.0, groups=("stats",))["stats/RMS"].iloc[0]), 4)
0.7071
"""

from importlib import import_module as _import_module

from pdmkit import errors
from pdmkit._config import data_dir
from pdmkit._persist import load_model, save_model

__version__ = "0.1.0"
__all__ = ["__version__", "data_dir", "errors", "load_model", "save_model"]

#: The layers, importable as attributes (``pdmkit.features``) on first use: importing
#: ``pdmkit`` alone stays light (no torch, scikit-learn or matplotlib).
_SUBPACKAGES = ("models", "ensembles", "features", "rul", "experiments")


def __getattr__(name: str):
    """``pdmkit.<layer>`` imports that layer on first access.

    Examples
    --------
    >>> import pdmkit
    >>> pdmkit.features.extract.__name__
    'extract'
    """
    if name in _SUBPACKAGES:
        return _import_module(f"pdmkit.{name}")
    raise AttributeError(f"module 'pdmkit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_SUBPACKAGES})
