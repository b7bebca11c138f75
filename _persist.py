"""Save and load trained models without unpickling anything.

A model file is a zip archive (extension of your choice, e.g. ``.pdmkit``)::

    manifest.json      format, kind, class, package versions, SHA-256 of every member
    model.skops        kind "skops": a scikit-learn estimator / pipeline (skops.io)
    state.json         kind "object" / "torch": the object tree as JSON
    arrays.npz         its numpy arrays and tables (Parquet bytes), allow_pickle=False
    tensors.pt         its torch tensors (a flat dict), loaded with weights_only=True

Three kinds of object:

- scikit-learn estimators and pipelines go through :mod:`skops.io`; loading trusts only
  the types skops reports that live under ``sklearn.``, ``numpy.``, ``scipy.`` or
  ``pdmkit.`` (anything else is refused, never trusted blanket-wise). A pipeline skops
  cannot write (a pdmkit step holding pandas tables, e.g. ``SelectTopRanked``) is saved
  as an object tree like the pdmkit estimators below;
- torch modules: ``state_dict`` plus a JSON config (constructor arguments), rebuilt by
  the module's class, which must live under ``pdmkit.`` or ``torch.nn.``;
- pdmkit estimators (the RUL models, health indicators): parameters and fitted
  attributes as JSON + arrays + tensors, rebuilt only for classes under ``pdmkit.`` or
  ``sklearn.`` (nested scikit-learn objects, pandas tables, scipy distributions
  included). A NeuralRULModel keeps its networks as ``state_dict`` weights.

Loading verifies the checksums first: a changed byte, a missing or an extra member, a
pickled payload, or a class outside the allowed packages raises
:class:`pdmkit.errors.ModelError` naming the file and the problem. The checksums
detect damage and edits; the protection against malicious files is that nothing in
them is ever executed or unpickled.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import math
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from pdmkit._atomic import atomic_path
from pdmkit._checks import file_sha256, npy_declared
from pdmkit._optional import require
from pdmkit._persist_tree import (
    _Decoder,
    _Encoder,
    _is_sklearn,
    _is_torch_module,
    _qualname,
    _registered,
    _versions,
    object_registry,
    torch_registry,
)
from pdmkit.errors import DataNotFoundError, ModelError

__all__ = ["file_sha256", "load_model", "object_registry", "save_model"]

FORMAT = "pdmkit.model"
FORMAT_VERSION = 1
_MEMBERS = {"manifest.json", "model.skops", "state.json", "arrays.npz", "tensors.pt"}
#: Deepest JSON nesting a model file may have (real models stay under 60).
MAX_JSON_DEPTH = 200
#: Most lists and objects a model file's JSON may hold (each costs ~100 bytes parsed;
#: numbers in bulk go to arrays.npz, so real models hold a few thousand).
MAX_JSON_CONTAINERS = 1_000_000
#: Largest JSON members (bytes): real models' state.json hold structure, not numbers
_JSON_LIMITS = {"manifest.json": 1 << 20, "state.json": 16 << 20}
MAX_TORCH_CONFIG_INT = 1 << 16

#: Functions skops may reference inside a scikit-learn estimator (score functions).
SKOPS_FUNCTIONS = tuple(
    f"sklearn.feature_selection._univariate_selection.{name}"
    for name in ("f_classif", "f_regression", "chi2", "r_regression", "f_oneway")
) + tuple(
    f"sklearn.feature_selection._mutual_info.{name}"
    for name in ("mutual_info_classif", "mutual_info_regression")
)


# --------------------------------------------------------------------------- save
def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _torch_bytes(tensors: dict[str, Any]) -> bytes:
    import torch

    buffer = io.BytesIO()
    torch.save(tensors, buffer)
    return buffer.getvalue()


def save_model(obj: Any, path: str | os.PathLike, *, config: dict | None = None) -> Path:
    """Save a trained model to ``path`` without pickle.

    Parameters
    ----------
    obj : scikit-learn estimator, torch module or pdmkit estimator
        See the module description for what each kind keeps.
    path : str or path-like
        The model file (written atomically: an existing file is replaced only when
        the new one is complete).
    config : dict, optional
        For a torch module: its constructor arguments (JSON-able); default the
        module's ``get_config()`` when it has one.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    pdmkit.errors.ModelError
        The object holds something that cannot be stored safely (the message names
        the attribute path and its type), or a torch module without a config.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pdmkit.rul import ReliabilitySurvivalModel
    >>> model = ReliabilitySurvivalModel().fit_lifetimes([80.0, 95.0, 110.0, 130.0])
    >>> path = save_model(model, pathlib.Path(tempfile.mkdtemp()) / "life.pdmkit")
    >>> loaded = load_model(path)
    >>> loaded.params_ == model.params_, bool(loaded.dist_.mean() == model.dist_.mean())
    (True, True)
    """
    members: dict[str, bytes] = {}
    manifest: dict[str, Any] = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "class": _qualname(type(obj)),
        "versions": _versions(),
    }
    if _is_torch_module(obj):
        name = _qualname(type(obj))
        if name not in torch_registry():
            raise ModelError(
                f"cannot save a torch module of class {name}: only the modules of "
                "torch.nn are saved this way (see torch_registry()); give your own "
                "module's estimator __getstate__ / __setstate__ that keep its weights"
            )
        if config is None and hasattr(obj, "get_config"):
            config = obj.get_config()
        if config is None:
            raise ModelError(
                f"saving the torch module {name} needs config= (its constructor "
                "arguments as a dict), or a get_config() method on the class"
            )
        manifest["kind"] = "torch"
        members["state.json"] = json.dumps({"config": config}).encode()
        members["tensors.pt"] = _torch_bytes(
            {k: v.detach().cpu().clone() for k, v in obj.state_dict().items()}
        )
    elif _is_sklearn(obj) and (skops := _skops_bytes(obj)) is not None:
        manifest["kind"] = "skops"
        members["model.skops"] = skops
    else:
        if config is not None:
            raise ModelError("config= is only for torch modules")
        manifest["kind"] = "object"
        enc = _Encoder()
        root = enc._object(obj, type(obj).__name__)
        members["state.json"] = json.dumps(root, allow_nan=False).encode()
        members["arrays.npz"] = _npz_bytes(enc.arrays)
        if enc.tensors:
            members["tensors.pt"] = _torch_bytes(enc.tensors)
    manifest["sha256"] = {k: hashlib.sha256(v).hexdigest() for k, v in members.items()}
    path = Path(path)
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("manifest.json", json.dumps(manifest, indent=2))
            for name, data in members.items():
                zf.writestr(name, data)
    return path


def _skops_bytes(obj: Any) -> bytes | None:
    """``obj`` through skops.io, or None where skops cannot (e.g. pandas attributes)."""
    import skops.io as sio

    buffer = io.BytesIO()
    try:
        sio.dump(obj, buffer)
    except (TypeError, ValueError, NotImplementedError, AttributeError):
        return None  # saved as an object tree instead
    return buffer.getvalue()


# --------------------------------------------------------------------------- load
def _zip_entries(zf: zipfile.ZipFile, where: str, what: str, budget: int) -> list:
    """The entries of an untrusted archive, after checking their declared sizes.

    The sum of the declared (decompressed) sizes must stay under ``budget``; reading
    is then bounded too, because :mod:`zipfile` stops at the declared size and a
    member that decompresses to more fails its CRC check.
    """
    infos = zf.infolist()
    declared = sum(info.file_size for info in infos)
    if declared > budget:
        raise ModelError(
            f"{where}: {what} declares {declared / 2**20:.0f} MiB once decompressed, "
            f"over the {budget / 2**20:.0f} MiB a model file may hold; refused (a "
            "decompression bomb, or raise $PDMKIT_MAX_MODEL_BYTES for a real model "
            "this large)"
        )
    return infos


def _check_npy_headers(blob: bytes, where: str, what: str, budget: int) -> None:
    """Refuse ``.npy`` entries of an archive whose header declares more than they hold."""
    with zipfile.ZipFile(io.BytesIO(blob)) as zf:
        for info in _zip_entries(zf, where, what, budget):
            if not info.filename.endswith(".npy"):
                continue
            with zf.open(info) as handle:
                try:
                    shape, dtype, _ = npy_declared(handle)
                except (ValueError, SyntaxError, TypeError) as exc:
                    raise ModelError(
                        f"{where}: {what} member {info.filename} has a damaged array "
                        f"header ({exc})"
                    ) from None
            nbytes = math.prod(shape) * dtype.itemsize
            if nbytes > info.file_size:
                raise ModelError(
                    f"{where}: {what} member {info.filename} declares an array of "
                    f"{nbytes} bytes {shape} but holds {info.file_size}; refused"
                )


def _json_depth(text: str) -> int:
    """Deepest nesting of ``[``/``{`` in JSON text (strings skipped), without parsing."""
    import re

    bare = re.sub(r'"(?:[^"\\]|\\.)*"', "", text).encode()
    steps = np.frombuffer(bare, dtype=np.uint8)
    change = np.zeros(steps.size, dtype=np.int32)
    change[(steps == ord("[")) | (steps == ord("{"))] = 1
    change[(steps == ord("]")) | (steps == ord("}"))] = -1
    return int(np.cumsum(change, dtype=np.int32).max(initial=0))


def _parse_json(blob: bytes, where: str, member: str) -> Any:
    # brackets counted on the raw bytes first (those inside strings too: an upper
    # bound), so a file of millions of empty lists costs nothing
    containers = blob.count(b"[") + blob.count(b"{")
    if containers > MAX_JSON_CONTAINERS:
        raise ModelError(
            f"{where}: {member} holds {containers} lists and objects, over the "
            f"{MAX_JSON_CONTAINERS} a model file may have (arrays belong in "
            "arrays.npz); refused"
        )
    try:
        text = blob.decode()
    except UnicodeDecodeError as exc:
        raise ModelError(f"{where}: {member} is not UTF-8 text ({exc})") from None
    depth = _json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise ModelError(
            f"{where}: {member} nests {depth} levels deep, over the {MAX_JSON_DEPTH} a "
            "model file may have; refused"
        )
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise ModelError(f"{where}: {member} is not valid JSON ({exc})") from None


def _read_members(path: Path, expect_sha256: str | None) -> tuple[dict, dict[str, bytes]]:
    """The manifest and the other members of a model file, every checksum verified."""
    where = str(path)
    if not path.is_file():
        raise DataNotFoundError(f"{path} does not exist; expected a pdmkit model file")
    if expect_sha256 is not None:
        found = file_sha256(path)
        if found != expect_sha256.strip().lower():
            raise ModelError(
                f"{where} has SHA-256 {found}, not the expected {expect_sha256}: it is "
                "not the file that was saved. Do not load it"
            )
    data = _read_zip_members(path, where)
    if "manifest.json" not in data:
        raise ModelError(f"{where} lacks manifest.json; not a pdmkit model file")
    manifest = _parse_json(data.pop("manifest.json"), where, "manifest.json")
    _check_manifest(manifest, data, where)
    return manifest, data


def _read_zip_members(path: Path, where: str) -> dict[str, bytes]:
    """The members of the zip archive, by name, after its sizes and names are checked."""
    from pdmkit._config import max_bytes

    budget = max_bytes("model")
    try:
        with zipfile.ZipFile(path) as zf:
            names = zf.namelist()
            extra = [n for n in names if n not in _MEMBERS]
            if extra:
                raise ModelError(
                    f"{where} holds unexpected member(s) {extra[:5]}; a pdmkit model file "
                    f"holds only {sorted(_MEMBERS)}: the file was tampered with"
                )
            if len(set(names)) != len(names):
                raise ModelError(f"{where} holds duplicate members: tampered with")
            _zip_entries(zf, where, "the archive", budget)
            for name, limit in _JSON_LIMITS.items():
                if name in names and zf.getinfo(name).file_size > limit:
                    raise ModelError(
                        f"{where}: {name} declares {zf.getinfo(name).file_size} bytes, "
                        f"over the {limit} a model's JSON may have (arrays belong in "
                        "arrays.npz); refused"
                    )
            return {n: zf.read(n) for n in names}
    except (
        zipfile.BadZipFile,
        zipfile.LargeZipFile,
        OSError,
        EOFError,
        RuntimeError,  # an encrypted member
    ) as exc:
        raise ModelError(
            f"{where} is not a pdmkit model file (not a readable zip archive: {exc}); "
            "was it written by pdmkit.save_model, and copied whole?"
        ) from None
    except (ValueError, NotImplementedError, zlib.error) as exc:  # bad CRC, bad deflate
        raise ModelError(f"{where} is damaged ({exc}); save the model again") from None


def _check_manifest(manifest: Any, data: dict[str, bytes], where: str) -> None:
    """Refuse a manifest of another format or version, or checksums that differ."""
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ModelError(f"{where}: manifest.json is not a pdmkit model manifest")
    if not isinstance(manifest.get("format_version"), int) or (
        manifest["format_version"] > FORMAT_VERSION
    ):
        raise ModelError(
            f"{where} has format_version {manifest.get('format_version')!r}; this pdmkit "
            f"reads up to {FORMAT_VERSION}. Upgrade pdmkit."
        )
    sums = manifest.get("sha256")
    if not isinstance(sums, dict) or set(sums) != set(data):
        raise ModelError(
            f"{where}: the checksums in manifest.json do not list exactly the members "
            f"{sorted(data)}; the file was tampered with or damaged"
        )
    for name, blob in data.items():
        if hashlib.sha256(blob).hexdigest() != sums[name]:
            raise ModelError(
                f"{where}: checksum mismatch for {name} (its SHA-256 differs from the "
                "one in manifest.json); the file was changed after it was saved. "
                "Do not load it; save the model again"
            )


def _load_npz(blob: bytes, where: str) -> dict[str, np.ndarray]:
    from pdmkit._config import max_bytes

    try:
        _check_npy_headers(blob, where, "arrays.npz", max_bytes("model"))
        with np.load(io.BytesIO(blob), allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except ValueError as exc:
        if "pickle" in str(exc):
            raise ModelError(
                f"{where}: arrays.npz holds a pickled object array; pdmkit never "
                "unpickles model files"
            ) from None
        raise ModelError(f"{where}: arrays.npz is damaged ({exc})") from None
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ModelError(f"{where}: arrays.npz is damaged ({exc})") from None


def _load_tensors(blob: bytes, where: str) -> dict[str, Any]:
    import pickle

    torch = require("torch", what=f"the torch model in {where}")

    from pdmkit._config import max_bytes

    try:
        with zipfile.ZipFile(io.BytesIO(blob)) as inner:  # torch's own zip container
            _zip_entries(inner, where, "tensors.pt", max_bytes("model"))
    except zipfile.BadZipFile:
        pass  # not a zip: torch's legacy format, read (bounded by its size) below
    try:
        tensors = torch.load(io.BytesIO(blob), weights_only=True, map_location="cpu")
    except (pickle.UnpicklingError, RuntimeError, EOFError, ValueError) as exc:
        raise ModelError(
            f"{where}: tensors.pt holds more than tensors or is damaged; refused "
            f"(torch.load with weights_only=True: {str(exc).splitlines()[0]})"
        ) from None
    if not isinstance(tensors, dict) or not all(
        isinstance(v, torch.Tensor) for v in tensors.values()
    ):
        raise ModelError(f"{where}: tensors.pt must be a flat dict of tensors")
    return tensors


def load_model(path: str | os.PathLike, *, expect_sha256: str | None = None) -> Any:
    """Load a model saved by :func:`save_model`, after checking it.

    A model file is data: loading it never runs code from it (see
    ``docs/model_files.md`` for the format and the threat model). Classes are taken
    only from an exact registry (:func:`object_registry`), sizes are checked before
    anything is decompressed, and nesting is bounded.

    Parameters
    ----------
    path : str or path-like
    expect_sha256 : str, optional
        The SHA-256 of the file as you saved it (``pdmkit rul`` prints it and writes
        it to its JSON summary). The checksums inside the file only catch damage; a
        hash kept apart from the file proves it is the one you saved.

    Returns
    -------
    object
        The estimator, pipeline or module, ready to predict.

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The file does not exist.
    pdmkit.errors.ModelError
        Not a model file; a hash or checksum mismatch; unexpected members; a pickled
        payload; a class outside the registry; sizes over the ceiling
        (``$PDMKIT_MAX_MODEL_BYTES``); the message names the file and the problem.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "m.pdmkit"
    >>> _ = path.write_bytes(b"not a model")
    >>> load_model(path)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.ModelError: ... is not a pdmkit model file (not a readable zip ...
    """
    path = Path(path)
    where = str(path)
    manifest, data = _read_members(path, expect_sha256)
    kind = manifest.get("kind")
    expected = {
        "skops": {"model.skops"},
        "torch": {"state.json", "tensors.pt"},
        "object": {"state.json", "arrays.npz"},
    }
    if not isinstance(kind, str) or kind not in expected:
        raise ModelError(f"{where}: unknown model kind {kind!r} in manifest.json")
    missing = expected[kind] - set(data)
    if missing:
        raise ModelError(f"{where} lacks {sorted(missing)} for a model of kind {kind!r}")
    try:
        if kind == "skops":
            return _load_skops(data["model.skops"], where)
        state = _parse_json(data["state.json"], where, "state.json")
        tensors = _load_tensors(data["tensors.pt"], where) if "tensors.pt" in data else {}
        if kind == "torch":
            return _load_torch_module(manifest, state, tensors, where)
        arrays = _load_npz(data["arrays.npz"], where)
        if not (isinstance(state, dict) and state.get("t") == "object"):
            raise ModelError(f"{where}: state.json does not describe an object")
        if state.get("class") != manifest.get("class"):
            raise ModelError(
                f"{where}: state.json rebuilds {state.get('class')!r} but the manifest "
                f"says {manifest.get('class')!r}; the file was tampered with"
            )
        return _Decoder(arrays, tensors, where).decode(state)
    except ModelError:
        raise
    except (RecursionError, MemoryError) as exc:
        raise ModelError(f"{where}: refused ({type(exc).__name__})") from None
    except (
        KeyError,
        ValueError,
        TypeError,
        AttributeError,
        IndexError,
        OverflowError,
        UnicodeError,
    ) as exc:  # a node of the wrong shape: damaged or hand-made, never trusted
        text = str(exc).splitlines()[0][:200] if str(exc) else ""
        raise ModelError(
            f"{where}: the file is damaged or was not written by pdmkit.save_model "
            f"({type(exc).__name__}: {text})"
        ) from None


def _load_torch_module(manifest: dict, state: Any, tensors: dict, where: str) -> Any:
    torch = require("torch", what=f"the torch model in {where}")

    cls = _registered(manifest.get("class"), torch_registry(), where)
    config = state.get("config") if isinstance(state, dict) else None
    if not isinstance(config, dict) or not all(isinstance(k, str) for k in config):
        raise ModelError(f"{where}: state.json lacks the module's config")
    for key, value in config.items():
        limit = 64 if key == "num_layers" else MAX_TORCH_CONFIG_INT
        if not isinstance(value, bool | int | float | str | type(None)) or (
            isinstance(value, int) and abs(value) > limit
        ):
            raise ModelError(
                f"{where}: the module's config {key}={str(value)[:40]!r} is not a "
                f"number up to {limit}, a flag or a short text; refused"
            )
    try:
        with torch.device("meta"):  # shapes only: a huge declared layer costs nothing
            shapes = {k: tuple(v.shape) for k, v in cls(**config).state_dict().items()}
        if shapes != {k: tuple(v.shape) for k, v in tensors.items()}:
            raise ModelError(
                f"{where}: the weights in tensors.pt do not have the shapes that "
                f"{manifest['class']}(**config) declares; refused"
            )
        module = cls(**config)
        module.load_state_dict(tensors)
    except (TypeError, RuntimeError, ValueError, OverflowError) as exc:
        raise ModelError(
            f"{where}: cannot rebuild {manifest['class']} from its config and "
            f"weights ({str(exc).splitlines()[0]})"
        ) from None
    module.eval()
    return module


@functools.cache
def skops_trusted_types() -> frozenset[str]:
    """The exact type and function names a skops payload may ask for.

    scikit-learn's estimators and helpers from :func:`object_registry` and the
    univariate score functions (:data:`SKOPS_FUNCTIONS`); never a prefix.
    """
    return frozenset(object_registry()) | frozenset(SKOPS_FUNCTIONS)


def _load_skops(blob: bytes, where: str) -> Any:
    import skops.io as sio

    from pdmkit._config import max_bytes

    try:
        _check_npy_headers(blob, where, "model.skops", max_bytes("model"))
        untrusted = sio.get_untrusted_types(data=blob)
    except ModelError:
        raise
    except Exception as exc:  # skops raises many types on a damaged archive
        raise ModelError(f"{where}: the skops payload is damaged ({exc})") from None
    refused = [t for t in untrusted if t not in skops_trusted_types()]
    if refused:
        raise ModelError(
            f"{where} asks to rebuild the type(s) {refused[:5]}, which are not allowed: "
            "only scikit-learn's estimators and score functions are trusted (see "
            "pdmkit._persist.skops_trusted_types). Do not load this file"
        )
    try:
        return sio.load(io.BytesIO(blob), trusted=list(untrusted))
    except Exception as exc:
        raise ModelError(f"{where}: cannot load the skops payload ({exc})") from None
