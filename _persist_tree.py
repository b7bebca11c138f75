"""The object tree of a model file: objects as JSON beside arrays and tensors.

The encoder turns an estimator into a JSON tree beside numpy arrays (arrays.npz) and
torch tensors (tensors.pt); the decoder rebuilds it, instantiating only classes of the
allowed packages (object_registry, torch_registry). Nothing is unpickled or executed.
"""

from __future__ import annotations

import functools
import importlib
import io
import math
from typing import Any

import numpy as np

from pdmkit.errors import ModelError

__all__ = [
    "PDMKIT_CLASSES",
    "SKLEARN_HELPERS",
    "TORCH_CLASSES",
    "object_registry",
    "torch_registry",
]


#: torch.nn classes a ``kind: torch`` file may rebuild, and a bound on every integer
#: of their config (a layer count of 300 000 costs minutes even on the meta device).
TORCH_CLASSES = (
    "Linear",
    "Conv1d",
    "Conv2d",
    "LSTM",
    "GRU",
    "RNN",
    "LayerNorm",
    "Embedding",
)


#: The pdmkit classes a model file may rebuild, by exact ``module.qualname``.
PDMKIT_CLASSES = (
    "pdmkit.experiments._deploy.FaultClassifier",
    "pdmkit.features._ranking.FeatureRanking",
    "pdmkit.features._selection.SelectTopRanked",
    "pdmkit.models.diagnosis._health.HealthModel",
    "pdmkit.rul._base.Unit",
    "pdmkit.rul._boosting.BoostingRULModel",
    "pdmkit.rul._conformal.ConformalRUL",
    "pdmkit.rul._degradation.ExponentialDegradationModel",
    "pdmkit.rul._degradation.LinearDegradationModel",
    "pdmkit.rul._indicators.HealthIndicator",
    "pdmkit.rul._indicators.RegimeNormalizer",
    "pdmkit.rul._neural.NeuralRULModel",
    "pdmkit.rul._pipeline.RULPipeline",
    "pdmkit.rul._result.RULPrediction",
    "pdmkit.rul._similarity.HashSimilarityModel",
    "pdmkit.rul._similarity.PairwiseSimilarityModel",
    "pdmkit.rul._similarity.ResidualSimilarityModel",
    "pdmkit.rul._survival.CovariateSurvivalModel",
    "pdmkit.rul._survival.ReliabilitySurvivalModel",
    "pdmkit.rul._gamma.GammaProcessDegradationModel",
    "pdmkit.rul._wiener.WienerDegradationModel",
    "pdmkit.rul._wiener_noise.NoisyWienerDegradationModel",
)


#: Where a class lived when earlier releases saved it -> where it lives now: a model
#: file written before a module was split still loads (the old name, the same class).
MOVED_CLASSES = {
    "pdmkit.features._ranking.SelectTopRanked": (
        "pdmkit.features._selection.SelectTopRanked"
    ),
    "pdmkit.rul._wiener.GammaProcessDegradationModel": (
        "pdmkit.rul._gamma.GammaProcessDegradationModel"
    ),
}
#: scikit-learn's compiled helpers that fitted estimators hold (beside the estimators
#: themselves, which come from ``sklearn.utils.discovery.all_estimators``).
SKLEARN_HELPERS = (
    "sklearn.tree._tree.Tree",
    "sklearn.neighbors._kd_tree.KDTree",
    "sklearn.neighbors._ball_tree.BallTree",
)


#: Classes rebuilt by calling them with arguments from the file (the rest are made
#: with ``cls.__new__`` and given their state).
_CONSTRUCTED_WITH_ARGS = frozenset({"sklearn.tree._tree.Tree"})


# --------------------------------------------------------------------------- registry
def _qualname(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _resolve_exact(name: str) -> type:
    """The class defined as ``name``; pdmkit's own strings only, never a file's."""
    module_name, _, qualname = name.rpartition(".")
    obj: Any = importlib.import_module(module_name)
    for attr in qualname.split("."):
        obj = getattr(obj, attr)
    if not isinstance(obj, type) or _qualname(obj) != name:
        raise RuntimeError(f"the registry entry {name} is not a class defined there")
    return obj


@functools.cache
def object_registry() -> dict[str, type]:
    """The exact classes a model file may name, ``module.qualname`` -> class.

    pdmkit's estimators (:data:`PDMKIT_CLASSES`), every scikit-learn estimator
    (``sklearn.utils.discovery.all_estimators``), its tree / neighbour helpers and
    its distance metrics (those that hold no Python function). A name is looked up
    as a whole string: nothing in a file is imported, split or followed.

    Returns
    -------
    dict of str to type

    Examples
    --------
    >>> registry = object_registry()
    >>> "pdmkit.rul._pipeline.RULPipeline" in registry
    True
    >>> "subprocess.Popen" in registry, "builtins.eval" in registry
    (False, False)
    """
    from sklearn.metrics import _dist_metrics
    from sklearn.utils.discovery import all_estimators

    names = [*PDMKIT_CLASSES, *SKLEARN_HELPERS]
    registry = {name: _resolve_exact(name) for name in names}
    registry |= {old: registry[new] for old, new in MOVED_CLASSES.items()}
    for _, cls in all_estimators():
        registry[_qualname(cls)] = cls
    for cls in vars(_dist_metrics).values():
        if (
            isinstance(cls, type)
            and issubclass(cls, _dist_metrics.DistanceMetric)
            and "PyFunc" not in cls.__name__
            and cls.__module__ == _dist_metrics.__name__
        ):
            registry[_qualname(cls)] = cls
    return registry


@functools.cache
def torch_registry() -> dict[str, type]:
    """The torch modules a ``kind: torch`` model file may name (exact names).

    The plain layers of :data:`TORCH_CLASSES`; each is constructed on the ``meta``
    device first (a config that declares huge layers costs nothing) after every
    integer of its config is checked against :data:`MAX_TORCH_CONFIG_INT`.
    """
    import torch

    return {
        _qualname(getattr(torch.nn, name)): getattr(torch.nn, name)
        for name in TORCH_CLASSES
    }


def _registered(name: Any, registry: dict[str, type], where: str) -> type:
    if isinstance(name, str) and name in registry:
        return registry[name]
    raise ModelError(
        f"{where} names the class {str(name)[:120]!r}, which is not one a pdmkit model "
        "file may rebuild (see pdmkit._persist.object_registry); refused. Do not load "
        "this file"
    )


def _versions() -> dict[str, str]:
    import sklearn

    from pdmkit import __version__

    return {"pdmkit": __version__, "numpy": np.__version__, "sklearn": sklearn.__version__}


def _is_torch_module(obj: Any) -> bool:
    torch = _torch_or_none()
    return torch is not None and isinstance(obj, torch.nn.Module)


def _torch_or_none():
    import sys

    return sys.modules.get("torch")


def _has_setstate(cls: type) -> bool:
    return getattr(cls, "__setstate__", None) not in (
        None,
        getattr(object, "__setstate__", None),
    )


def _is_sklearn(obj: Any) -> bool:
    return type(obj).__module__.startswith("sklearn.")


# --------------------------------------------------------------------------- encoding
class _Encoder:
    """Turn an object tree into JSON nodes, numpy arrays and torch tensors."""

    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}
        self.tensors: dict[str, Any] = {}

    def _array(self, a: np.ndarray) -> str:
        key = f"a{len(self.arrays)}"
        self.arrays[key] = a
        return key

    def encode(self, value: Any, path: str) -> Any:
        import pandas as pd

        if value is None or isinstance(value, bool | str):
            return value
        if isinstance(value, int) and not isinstance(value, bool):
            return value if abs(value) < 2**53 else {"t": "int", "v": str(value)}
        if isinstance(value, float):
            return value if math.isfinite(value) else {"t": "float", "v": repr(value)}
        if isinstance(value, np.generic | np.ndarray):
            return self._numpy(value, path)
        if isinstance(value, list | tuple):
            items = [self.encode(v, f"{path}[{i}]") for i, v in enumerate(value)]
            return {"t": "tuple" if isinstance(value, tuple) else "list", "items": items}
        if isinstance(value, dict):
            return {
                "t": "dict",
                "items": [
                    [self.encode(k, f"{path} key"), self.encode(v, f"{path}[{k!r}]")]
                    for k, v in value.items()
                ],
            }
        if isinstance(value, pd.DataFrame | pd.Series):
            return self._frame(value, path)
        if isinstance(value, pd.Index):
            return {"t": "index", "v": self._frame(value.to_series(index=None), path)}
        torch = _torch_or_none()
        if torch is not None and isinstance(value, torch.Tensor):
            key = f"t{len(self.tensors)}"
            self.tensors[key] = value.detach().cpu().clone()
            return {"t": "tensor", "key": key}
        if torch is not None and isinstance(value, torch.nn.Module):
            raise ModelError(
                f"{path} is a torch module ({type(value).__name__}) inside an object "
                "that does not say how to rebuild it; give the class __getstate__ / "
                "__setstate__ that keep its state_dict (as NeuralRULModel does)"
            )
        frozen = self._scipy_frozen(value)
        if frozen is not None:
            return frozen
        return self._object(value, path)

    def _numpy(self, value: np.generic | np.ndarray, path: str) -> dict:
        """A numpy scalar or array: into arrays.npz, or element-wise if of objects."""
        if isinstance(value, np.generic):
            arr = np.asarray(value)
            if arr.dtype.kind not in "biufcUS":
                raise self._refuse(value, path)
            return {"t": "scalar", "key": self._array(arr.reshape(1))}
        if value.dtype.kind in "biufcUSmM" or (
            value.dtype.kind == "V" and not value.dtype.hasobject
        ):
            return {"t": "ndarray", "key": self._array(value)}
        if value.dtype == object:
            return {
                "t": "objarray",
                "shape": list(value.shape),
                "items": [
                    self.encode(v, f"{path}[{i}]") for i, v in enumerate(value.ravel())
                ],
            }
        raise self._refuse(value, path)

    def _frame(self, value: Any, path: str) -> dict:
        import pandas as pd

        is_series = isinstance(value, pd.Series)
        frame = value.to_frame(name="__series__") if is_series else value
        if not all(isinstance(c, str) for c in frame.columns):
            names = [self.encode(c, f"{path} column") for c in frame.columns]
            frame = frame.set_axis([f"c{i}" for i in range(frame.shape[1])], axis=1)
        else:
            names = None
        buffer = io.BytesIO()
        try:
            frame.to_parquet(buffer)
        except Exception as exc:  # pyarrow refuses mixed object columns
            raise ModelError(
                f"{path}: a table that cannot be stored safely ({exc})"
            ) from None
        node = {
            "t": "series" if is_series else "dataframe",
            "key": self._array(np.frombuffer(buffer.getvalue(), dtype=np.uint8)),
        }
        if is_series:
            node["name"] = self.encode(value.name, f"{path}.name")
        if names is not None:
            node["columns"] = names
        return node

    @staticmethod
    def _scipy_frozen(value: Any) -> dict | None:
        dist = getattr(value, "dist", None)
        if (
            type(value).__module__.startswith("scipy.stats")
            and hasattr(value, "args")
            and hasattr(value, "kwds")
            and dist is not None
        ):
            import scipy.stats

            name = getattr(dist, "name", None)
            if getattr(scipy.stats, str(name), None) is None:
                return None
            args = [float(a) for a in value.args]
            kwds = {k: float(v) for k, v in value.kwds.items()}
            return {"t": "scipy_frozen", "name": name, "args": args, "kwds": kwds}
        return None

    def _object(self, value: Any, path: str) -> dict:
        cls = type(value)
        name = _qualname(cls)
        if name not in object_registry():
            raise self._refuse(value, path)
        if isinstance(value, type) or (callable(value) and not hasattr(value, "__dict__")):
            raise self._refuse(value, path)
        args = None
        try:
            reduced = value.__reduce_ex__(4)
        except TypeError:
            reduced = None
        if (
            isinstance(reduced, tuple)
            and len(reduced) >= 2
            and reduced[0] is cls
            and name in _CONSTRUCTED_WITH_ARGS
        ):
            # extension types that need constructor arguments (sklearn's Tree)
            args = list(reduced[1])
            state = reduced[2] if len(reduced) > 2 else None
            node = {"t": "object", "class": name, "args": self.encode(args, path)}
            if state is not None:
                node["state"] = self.encode(state, path)
            return node
        getstate = getattr(cls, "__getstate__", None)
        if getstate is not None and getstate is not object.__getstate__:
            state = value.__getstate__()
        elif hasattr(value, "__dict__"):
            state = dict(value.__dict__)
        else:
            slots = [s for c in cls.__mro__ for s in getattr(c, "__slots__", ())]
            state = {s: getattr(value, s) for s in slots if hasattr(value, s)}
        if not isinstance(state, dict) and not _has_setstate(cls):
            raise self._refuse(value, path)
        return {"t": "object", "class": name, "state": self.encode(state, path)}

    @staticmethod
    def _refuse(value: Any, path: str) -> ModelError:
        return ModelError(
            f"cannot save {path}: a {_qualname(type(value))} is not a type a model file "
            "can hold safely (numbers, strings, numpy arrays, pandas tables, torch "
            "tensors, pdmkit's and scikit-learn's estimators: see object_registry())"
        )


def _check_parquet_sizes(blob: bytes, where: str) -> None:
    """Refuse a table whose Parquet footer declares more than the model ceiling.

    The ceiling counts rows x columns at 8 bytes, or the row groups' uncompressed bytes.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from pdmkit._config import max_bytes

    budget = max_bytes("model")
    try:
        meta = pq.ParquetFile(io.BytesIO(blob)).metadata
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise ModelError(f"{where}: a table inside is damaged ({exc})") from None
    groups = [meta.row_group(i) for i in range(meta.num_row_groups)]
    declared = max(
        8 * meta.num_rows * max(meta.num_columns, 1),
        sum(g.total_byte_size for g in groups),
    )
    if declared > budget:
        raise ModelError(
            f"{where}: a table inside declares {declared / 2**20:.0f} MiB decoded, over "
            f"the {budget / 2**20:.0f} MiB a model file may hold; refused"
        )


def _tree_args_ok(args: Any) -> bool:
    """``Tree(n_features, n_classes, n_outputs)`` with sizes that agree.

    Its C code trusts them.
    """
    if not (isinstance(args, list) and len(args) == 3):
        return False
    n_features, n_classes, n_outputs = args
    return (
        isinstance(n_features, int | np.integer)
        and isinstance(n_outputs, int | np.integer)
        and isinstance(n_classes, np.ndarray)
        and n_classes.dtype.kind in "iu"
        and n_classes.shape == (n_outputs,)
        and 0 < n_outputs
        and 0 <= n_features < 2**31
        and bool(np.all(n_classes >= 1))
    )


class _Decoder:
    """Rebuild an object tree from JSON nodes, checking every node it meets."""

    def __init__(self, arrays: dict[str, np.ndarray], tensors: dict[str, Any], where: str):
        self.arrays = arrays
        self.tensors = tensors
        self.where = where

    def _get(self, store: dict, key: Any, what: str) -> Any:
        if not isinstance(key, str) or key not in store:
            raise ModelError(f"{self.where}: state.json refers to a missing {what} {key!r}")
        return store[key]

    def decode(self, node: Any) -> Any:
        """The value a JSON node stands for; a node of no known type is refused."""
        if node is None or isinstance(node, bool | int | float | str):
            return node
        if not isinstance(node, dict) or "t" not in node:
            raise ModelError(f"{self.where}: state.json holds an unknown node {node!r:.80}")
        t = node["t"]
        # a type that is no string (a list, say) matches no case, as it never did
        case = _DECODE_CASES.get(t) if isinstance(t, str) else None
        if case is None:
            raise ModelError(f"{self.where}: state.json holds an unknown node type {t!r}")
        return case(self, node)

    def _int(self, node: dict) -> int:
        """An integer too large for JSON's doubles, stored as text."""
        return int(node["v"])

    def _float(self, node: dict) -> float:
        """A non-finite float (nan, inf), stored as text."""
        return float(node["v"])

    def _scalar(self, node: dict) -> Any:
        """A numpy scalar, the one element of an array in arrays.npz."""
        return self._get(self.arrays, node["key"], "array")[0]

    def _ndarray(self, node: dict) -> np.ndarray:
        """A numpy array from arrays.npz."""
        return self._get(self.arrays, node["key"], "array")

    def _objarray(self, node: dict) -> np.ndarray:
        """An object array, each element a node of its own."""
        items = [self.decode(v) for v in node["items"]]
        out = np.empty(len(items), dtype=object)
        out[:] = items
        return out.reshape(node["shape"])

    def _sequence(self, node: dict) -> list | tuple:
        """A list or a tuple of nodes."""
        items = [self.decode(v) for v in node["items"]]
        return tuple(items) if node["t"] == "tuple" else items

    def _dict(self, node: dict) -> dict:
        """A dict, its keys and values nodes."""
        return {self.decode(k): self.decode(v) for k, v in node["items"]}

    def _table(self, node: dict) -> Any:
        """A pandas DataFrame or Series from Parquet bytes, its size checked first."""
        import pandas as pd

        raw = self._get(self.arrays, node["key"], "table")
        if not isinstance(raw, np.ndarray) or raw.dtype != np.uint8 or raw.ndim != 1:
            raise ModelError(f"{self.where}: a table's bytes are damaged")
        _check_parquet_sizes(raw.tobytes(), self.where)
        frame = pd.read_parquet(io.BytesIO(raw.tobytes()))
        if "columns" in node:
            frame.columns = [self.decode(c) for c in node["columns"]]
        if node["t"] == "series":
            series = frame.iloc[:, 0]
            series.name = self.decode(node.get("name"))
            return series
        return frame

    def _index(self, node: dict) -> Any:
        """A pandas Index, stored as a Series."""
        import pandas as pd

        return pd.Index(self.decode(node["v"]))

    def _tensor(self, node: dict) -> Any:
        """A torch tensor from tensors.pt."""
        return self._get(self.tensors, node["key"], "tensor")

    def _scipy_frozen(self, node: dict) -> Any:
        """A frozen scipy.stats distribution, by name, with float arguments."""
        import scipy.stats

        dist = getattr(scipy.stats, str(node["name"]), None)
        if not isinstance(dist, scipy.stats.rv_continuous | scipy.stats.rv_discrete):
            raise ModelError(f"{self.where}: unknown scipy distribution {node['name']!r}")
        return dist(*node["args"], **node["kwds"])

    def _object(self, node: dict) -> Any:
        """An instance of a registered class (by constructor arguments or by state)."""
        if "args" in node:
            return self._constructed_object(node)
        return self._restored_object(node)

    def _constructed_object(self, node: dict) -> Any:
        """A class called with checked arguments (only scikit-learn's Tree)."""
        cls = _registered(node["class"], object_registry(), self.where)
        if node["class"] not in _CONSTRUCTED_WITH_ARGS:
            raise ModelError(
                f"{self.where}: state.json asks to call {node['class']} with "
                "arguments; only scikit-learn's Tree is rebuilt that way. Refused"
            )
        args = self.decode(node["args"])
        if not _tree_args_ok(args):
            raise ModelError(f"{self.where}: the arguments of {node['class']} are damaged")
        try:
            obj = cls(*args)
            if "state" in node:
                obj.__setstate__(self.decode(node["state"]))
        except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
            raise ModelError(
                f"{self.where}: cannot rebuild a {node['class']} ({exc})"
            ) from None
        return obj

    def _restored_object(self, node: dict) -> Any:
        """A class made with ``cls.__new__`` and given its decoded state."""
        cls = _registered(node["class"], object_registry(), self.where)
        state = self.decode(node["state"])
        if not isinstance(state, dict) and not _has_setstate(cls):
            raise ModelError(f"{self.where}: the state of {node['class']} is damaged")
        obj = cls.__new__(cls)
        if _has_setstate(cls):
            try:
                obj.__setstate__(state)
            except (TypeError, ValueError, KeyError, IndexError) as exc:
                raise ModelError(
                    f"{self.where}: cannot restore a {node['class']} ({exc})"
                ) from None
        elif hasattr(obj, "__dict__"):
            obj.__dict__.update(state)
        else:
            for k, v in state.items():
                object.__setattr__(obj, k, v)
        return obj


#: node type -> the _Decoder method that rebuilds it; a type not here is refused
_DECODE_CASES = {
    "int": _Decoder._int,
    "float": _Decoder._float,
    "scalar": _Decoder._scalar,
    "ndarray": _Decoder._ndarray,
    "objarray": _Decoder._objarray,
    "list": _Decoder._sequence,
    "tuple": _Decoder._sequence,
    "dict": _Decoder._dict,
    "dataframe": _Decoder._table,
    "series": _Decoder._table,
    "index": _Decoder._index,
    "tensor": _Decoder._tensor,
    "scipy_frozen": _Decoder._scipy_frozen,
    "object": _Decoder._object,
}
