"""Resumable runs: per-partition results committed atomically under a run directory.

Layout of a run directory::

    run/
      manifest.json         kind, config, package versions, input fingerprints
      parts/
        part-00000/         one committed partition (written whole or not at all)
          features.parquet
          errors.parquet
          meta.json
        ...

A run that is killed and started again skips the partitions already in ``parts/`` and
gives the same final result. Results computed differently never mix: a changed
configuration, input or package version starts over when the directory holds no
committed partition, or (``replace_stale=True``, as ``pdmkit features`` does) when its
run failed or its results were saved elsewhere; otherwise (a run interrupted halfway,
or any finished run in the Python API) it is refused, and ``fresh=True`` (``--fresh``)
starts over. The manifest's ``state`` tells which: ``running``, ``failed``,
``complete``, ``saved``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit import __version__
from pdmkit._atomic import atomic_dir, atomic_path, remove_stale_temporaries
from pdmkit._progress import progress as bar
from pdmkit.ensembles import dask_client, dask_stream
from pdmkit.errors import DataError

__all__ = [
    "RunDirectory",
    "extract_features_run",
    "fingerprint_ensemble",
    "fingerprint_path",
    "mark_run",
    "package_versions",
    "predict_members",
]

FORMAT = "pdmkit.run"
FORMAT_VERSION = 1


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages that decide numerical results.

    Examples
    --------
    >>> sorted(package_versions())[:3]
    ['numpy', 'pandas', 'pdmkit']
    """
    import scipy

    versions = {
        "pdmkit": __version__,
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
    }
    try:
        import pyarrow

        versions["pyarrow"] = pyarrow.__version__
    except ImportError:  # pragma: no cover - pyarrow is a dependency
        pass
    return versions


def fingerprint_path(path: str | os.PathLike) -> str:
    r"""A fingerprint of a file or directory tree: names, sizes and modification times.

    Cheap for large datasets (no content is read): rewriting a file changes its
    fingerprint; merely reading it does not. An fsspec URL is fingerprinted by its
    listing (names, sizes, and modification times where the store gives them).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "a.csv").write_text("x\n1\n")
    >>> before = fingerprint_path(d)
    >>> _ = (d / "a.csv").write_text("x\n12\n")
    >>> before == fingerprint_path(d)
    False
    """
    h = hashlib.sha256()
    if isinstance(path, str) and "://" in path:
        import fsspec

        fs, root = fsspec.core.url_to_fs(path)
        for info in sorted(fs.find(root, detail=True).values(), key=lambda i: i["name"]):
            stamp = info.get("mtime") or info.get("LastModified") or info.get("updated")
            h.update(f"{info['name']}\0{info.get('size')}\0{stamp}\n".encode())
        return h.hexdigest()
    path = Path(path)
    if not path.exists():
        raise DataError(f"{path} does not exist; cannot fingerprint the run's input")
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    for f in files:
        st = f.stat()
        rel = f.name if f == path else f.relative_to(path).as_posix()
        h.update(f"{rel}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def fingerprint_ensemble(ensemble: Any) -> str:
    """A content hash of an in-memory ensemble: ids, conditions, rates and samples.

    Examples
    --------
    >>> from pdmkit.ensembles import Ensemble
    >>> a = Ensemble({"x": np.zeros((2, 8))}, fs=1.0)
    >>> b = Ensemble({"x": np.ones((2, 8))}, fs=1.0)
    >>> fingerprint_ensemble(a) == fingerprint_ensemble(b)
    False
    """
    h = hashlib.blake2b(digest_size=32)
    h.update(json.dumps(list(map(str, ensemble.member_ids))).encode())
    h.update(pd.util.hash_pandas_object(ensemble.conditions, index=True).values.tobytes())
    h.update(json.dumps(ensemble.fs, sort_keys=True).encode())
    for name in ensemble.signal_names:
        h.update(name.encode())
        for x in ensemble.signal(name):
            h.update(b"\x00" if x is None else np.ascontiguousarray(x).data)
    return h.hexdigest()


def _canonical(value: Any) -> Any:
    """JSON-able form of a config value (tuples as lists, objects by repr)."""
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(value.items(), key=str)}
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    if isinstance(value, np.ndarray):
        return _canonical(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return repr(value)


class RunDirectory:
    """A run directory: manifest plus atomically committed partition results.

    Parameters
    ----------
    path : str or path-like
        The run directory (created when missing).
    kind : str
        What the run computes (e.g. ``"features"``).
    config : mapping
        Every setting that changes the result (JSON-able; tuples become lists).
    inputs : mapping of str to str
        Input name -> fingerprint (see :func:`fingerprint_path`).
    fresh : bool, default False
        Discard any results already in the directory and start over.
    replace_stale : bool, default False
        Also start over, with a warning, when the directory holds a run made with
        other settings that failed or whose results were saved elsewhere (state
        ``failed`` or ``saved``). A run with no committed partition is always replaced.

    Raises
    ------
    pdmkit.errors.DataError
        The directory holds committed partitions of a run of another kind,
        configuration, input or package versions (the message says what differs and
        suggests ``--fresh``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> run = RunDirectory(path, kind="demo", config={"k": 1}, inputs={"x": "abc"})
    >>> run.commit("part-00000", {"out": pd.DataFrame({"v": [1.0]})}, meta={"n": 1})
    >>> run.done("part-00000"), run.done("part-00001")
    (True, False)
    >>> RunDirectory(path, kind="demo", config={"k": 2}, inputs={"x": "abc"})
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: ... config differs (k: 1 -> 2); ... --fresh ...
    """

    def __init__(
        self,
        path: str | os.PathLike,
        *,
        kind: str,
        config: Mapping[str, Any],
        inputs: Mapping[str, str],
        fresh: bool = False,
        replace_stale: bool = False,
    ) -> None:
        self.path = Path(path)
        self.parts = self.path / "parts"
        for where in (self.path, self.parts):
            if where.is_symlink():  # pdmkit writes (and deletes) only inside --out
                raise DataError(
                    f"{where} is a symbolic link; pdmkit keeps its run store inside "
                    "the output folder and will not follow it. Remove the link or "
                    "choose another --out"
                )
        self.replace_stale = replace_stale
        self.state = "running"
        self.manifest = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "kind": kind,
            "config": _canonical(dict(config)),
            "inputs": _canonical(dict(inputs)),
            "versions": package_versions(),
        }
        file = self.path / "manifest.json"
        if fresh and self.path.exists():
            self._clear()
        if file.is_file():
            self._check(file)
        else:
            if self.path.exists() and any(
                p.name not in ("parts",) and not p.name.startswith(".")
                for p in self.path.iterdir()
            ):
                entries = sorted(p.name for p in self.path.iterdir())
                raise DataError(
                    f"{self.path} exists and is not a pdmkit run directory (it holds "
                    f"{entries[:8]}, no manifest.json); choose another folder or pass "
                    "--fresh to replace it"
                )
            self.path.mkdir(parents=True, exist_ok=True)
            self.set_state("running")
        self.parts.mkdir(exist_ok=True)
        # commits cut short by a kill (not those of a live process)
        remove_stale_temporaries(self.path)
        remove_stale_temporaries(self.parts, legacy_names=["*"])

    def set_state(self, state: str, **info: Any) -> None:
        """Record the run's state in its manifest, with ``info``.

        The state is ``running``, ``failed``, ``complete`` or ``saved``; ``info`` is e.g.
        the output run that saved it.
        """
        self.state = state
        data = {**self.manifest, "state": state, **_canonical(info)}
        with atomic_path(self.path / "manifest.json") as tmp:
            tmp.write_text(json.dumps(data, indent=2) + "\n")

    def committed(self) -> list[str]:
        """The keys of the committed partitions."""
        return sorted(p.parent.name for p in self.parts.glob("*/meta.json"))

    def _clear(self) -> None:
        manifest = self.path / "manifest.json"
        if not self.path.is_dir() or not (manifest.is_file() or self.parts.is_dir()):
            if self.path.exists() and any(self.path.iterdir()):
                raise DataError(
                    f"--fresh would delete {self.path}, which is not a pdmkit run "
                    "directory; choose another folder"
                )
            return
        self._discard_parts()
        manifest.unlink(missing_ok=True)

    def _discard_parts(self) -> None:
        """Delete the partitions pdmkit committed (their ``*.parquet`` and ``meta.json``).

        Nothing else: a file someone put there stays, as does any link (never followed).
        """
        if not self.parts.is_dir() or self.parts.is_symlink():
            return
        for part in self.parts.iterdir():
            if part.is_symlink() or not part.is_dir():
                continue
            for file in part.iterdir():
                if (
                    file.is_file()
                    and not file.is_symlink()
                    and (file.name == "meta.json" or file.suffix == ".parquet")
                ):
                    file.unlink()
            with contextlib.suppress(OSError):
                part.rmdir()  # only when nothing foreign is left in it

    def _check(self, file: Path) -> None:
        try:
            old = json.loads(file.read_text())
        except (ValueError, OSError) as exc:
            raise DataError(
                f"{file} is damaged ({exc}); start over with --fresh (fresh=True)"
            ) from None
        if old.get("format") != FORMAT:
            raise DataError(f"{file} is not a pdmkit run manifest; choose another folder")
        diffs = []
        for section in ("kind", "config", "inputs", "versions"):
            a, b = old.get(section), self.manifest[section]
            if a == b:
                continue
            if isinstance(a, dict) and isinstance(b, dict):
                keys = sorted(set(a) | set(b))
                changed = [
                    f"{k}: {_short(a.get(k))} -> {_short(b.get(k))}"
                    for k in keys
                    if a.get(k) != b.get(k)
                ]
                diffs.append(f"{section} differs ({'; '.join(changed)})")
            else:
                diffs.append(f"{section} differs ({_short(a)} -> {_short(b)})")
        state = str(old.get("state", "unknown"))
        if diffs:
            done = self.committed()
            if done and not (self.replace_stale and state in ("failed", "saved")):
                what = {"running": "interrupted", "unknown": "earlier"}.get(state, state)
                raise DataError(
                    f"the {what} run in {self.path} ({len(done)} committed partitions) "
                    "was made with other settings: "
                    + ", ".join(diffs)
                    + "; its results cannot be mixed with this run's. Resume it with "
                    "its settings, start over with --fresh (fresh=True), or write to "
                    "another folder"
                )
            if done:
                warnings.warn(
                    f"{self.path}: discarded the {len(done)} partitions of an earlier "
                    f"{state} run made with other settings ({', '.join(diffs)})",
                    UserWarning,
                    stacklevel=3,
                )
            self._discard_parts()
            self.set_state("running")
        elif state in ("complete", "saved"):
            self.state = state
        else:
            self.set_state("running")

    def done(self, key: str) -> bool:
        """Whether partition ``key`` is committed."""
        return (self.parts / key / "meta.json").is_file()

    def commit(
        self, key: str, frames: Mapping[str, pd.DataFrame], meta: Mapping[str, Any]
    ) -> None:
        """Write one partition's tables (Parquet) and metadata (JSON), all or nothing."""
        with atomic_dir(self.parts / key) as tmp:
            for name, frame in frames.items():
                frame.to_parquet(tmp / f"{name}.parquet")
            (tmp / "meta.json").write_text(json.dumps(_canonical(dict(meta))) + "\n")

    def load(self, key: str) -> tuple[dict[str, pd.DataFrame], dict[str, Any]]:
        """Read one committed partition back: (tables, metadata)."""
        folder = self.parts / key
        frames = {p.stem: pd.read_parquet(p) for p in sorted(folder.glob("*.parquet"))}
        return frames, json.loads((folder / "meta.json").read_text())

    def run(
        self,
        func: Callable[..., Any],
        items: Iterable[Any],
        keys: Sequence[str],
        to_frames: Callable[[Any], tuple[dict[str, pd.DataFrame], dict[str, Any]]],
        *,
        client: Any = None,
        progress: bool | None = None,
        **kwargs: Any,
    ) -> list[tuple[dict[str, pd.DataFrame], dict[str, Any]]]:
        """Compute the partitions not yet committed, commit each as it finishes.

        ``func(item, **kwargs)`` computes one partition; ``to_frames`` turns its result
        into (tables, metadata). With a Dask ``client`` the partitions run as tasks and
        are committed by this process as they complete. Returns every partition, read
        back from the directory, in the order of ``keys``.
        """
        items = list(items)
        if len(items) != len(keys):
            raise ValueError(f"{len(keys)} keys for {len(items)} partitions")
        todo = [(k, it) for k, it in zip(keys, items, strict=True) if not self.done(k)]
        if todo and client is None:
            for key, item in bar(todo, desc="partitions", total=len(todo), enable=progress):
                self.commit(key, *to_frames(func(item, **kwargs)))
        elif todo:
            with dask_client(client) as c:
                tasks = dask_stream(c, func, [item for _, item in todo], **kwargs)
                for i, result in tasks:
                    self.commit(todo[i][0], *to_frames(result))
        return [self.load(k) for k in keys]


def mark_run(path: str | os.PathLike, state: str, output_run: str | None = None) -> None:
    """Set the ``state`` of the run directory ``path`` (no-op when it has no manifest).

    ``pdmkit features`` marks its store ``saved`` (with the id of the output run) once
    the table is committed to ``--out``: a later run with other settings may then
    replace it without ``--fresh``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> _ = RunDirectory(path, kind="demo", config={}, inputs={})
    >>> mark_run(path, "saved", output_run="r1")
    >>> json.loads((path / "manifest.json").read_text())["state"]
    'saved'
    """
    file = Path(path) / "manifest.json"
    if not file.is_file():
        return
    data = json.loads(file.read_text())
    data["state"] = state
    if output_run is not None:
        data["output_run"] = output_run
    with atomic_path(file) as tmp:
        tmp.write_text(json.dumps(data, indent=2) + "\n")


def _short(value: Any, limit: int = 60) -> str:
    text = json.dumps(value) if not isinstance(value, str) else value
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _feature_frames(result) -> tuple[dict[str, pd.DataFrame], dict[str, Any]]:
    from pdmkit.features import ERROR_COLUMNS

    table, errors, names = result
    frames = {"errors": pd.DataFrame(errors, columns=list(ERROR_COLUMNS))}
    if table is not None:
        frames["features"] = table
    return frames, {"signals": list(names), "n_members": 0 if table is None else len(table)}


def extract_features_run(
    ensemble: Any,
    run_dir: str | os.PathLike,
    *,
    signals: Sequence[str] | None = None,
    groups: Sequence[str] = ("stats", "spectral"),
    batch_size: int = 512,
    on_error: str = "raise",
    fresh: bool = False,
    client: Any = None,
    inputs: Mapping[str, str] | None = None,
    progress: bool | None = None,
    replace_stale: bool = False,
    **options: Any,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`pdmkit.features.extract_ensemble` as a resumable run.

    Every batch of ``batch_size`` members is one partition, committed to ``run_dir``
    as soon as it is done; started again after a crash (or a kill), the run computes
    only the partitions missing and returns the same table.

    Parameters
    ----------
    ensemble : Ensemble, path or URL
        As for :func:`~pdmkit.features.extract_ensemble` (no plain iterables: a run
        must be able to enumerate its partitions again).
    run_dir : str or path-like
        The run directory.
    signals, groups, batch_size, on_error, **options
        As for :func:`~pdmkit.features.extract_ensemble`.
    fresh : bool, default False
        Discard the results in ``run_dir`` and start over.
    client : dask.distributed.Client, str, int, optional
        Run the partitions on Dask (see :func:`pdmkit.ensembles.dask_client`).
    inputs : mapping, optional
        Fingerprints of the input (default: computed from the ensemble or its files).
    progress : bool, optional
        Progress bar over partitions (in-process).
    replace_stale : bool, default False
        Start over (with a warning) when ``run_dir`` holds a failed or saved run made
        with other settings (see :class:`RunDirectory`); a directory without committed
        partitions is always replaced.

    Returns
    -------
    features : pandas.DataFrame
    errors : pandas.DataFrame
        Members left out with ``on_error="skip"`` (columns member, signal, source,
        error).

    Raises
    ------
    pdmkit.errors.DataError
        ``run_dir`` holds committed partitions of a run with another configuration,
        input or package versions (the message suggests ``fresh=True`` / ``--fresh``),
        or bad data with ``on_error="raise"``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pdmkit.ensembles import Ensemble
    >>> ens = Ensemble({"x": np.random.default_rng(0).normal(size=(6, 256))}, fs=100.0)
    >>> run = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> table, errors = extract_features_run(ens, run, groups=("stats",), batch_size=4)
    >>> table.shape, len(errors), sorted(p.name for p in (run / "parts").iterdir())
    ((6, 11), 0, ['part-00000', 'part-00001'])
    """
    from pdmkit.features import extract_task, plan_extraction

    plan = plan_extraction(
        ensemble,
        signals=signals,
        groups=groups,
        batch_size=batch_size,
        on_error=on_error,
        where="extract_features_run()",
        **options,
    )
    if not plan.resumable:
        raise TypeError(
            "a resumable run takes an Ensemble or the path/URL of a Parquet ensemble, "
            f"got {type(ensemble).__name__}"
        )
    if inputs is None:
        inputs = {
            "ensemble": fingerprint_path(ensemble)
            if isinstance(ensemble, str | os.PathLike)
            else fingerprint_ensemble(ensemble)
        }
    config = {
        "signals": plan.signals,
        "groups": list(plan.groups),
        "batch_size": batch_size,
        "on_error": on_error,
        "options": options,
    }
    run = RunDirectory(
        run_dir,
        kind="features",
        config=config,
        inputs=inputs,
        fresh=fresh,
        replace_stale=replace_stale,
    )
    keys = [f"part-{i:05d}" for i in range(len(plan.items))]
    try:
        parts = run.run(
            extract_task,
            plan.items,
            keys,
            _feature_frames,
            client=client,
            progress=progress,
            **plan.task_options(),
        )
        results = []
        for frames, meta in parts:
            errors = frames["errors"].to_dict(orient="records")
            results.append((frames.get("features"), errors, meta["signals"]))
        combined = plan.combine(results, return_errors=True)
    except Exception:  # e.g. every member skipped: a failed run, not a finished one
        run.set_state("failed")
        raise
    if run.state != "saved":
        run.set_state("complete")
    return combined


def predict_members(
    model: Any,
    table: pd.DataFrame,
    *,
    label: str | None = None,
    features: Sequence[str] | None = None,
    on_error: str = "skip",
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Predict every member of a feature table, reporting the members that cannot be.

    A member whose indicators hold NaN or inf, or whose ``label`` value the model never
    saw in training (not in ``model.classes_``), is left out and described in the
    errors table; the others are predicted. With ``on_error="raise"`` the first such
    member raises instead.

    Parameters
    ----------
    model : fitted classifier
        With ``predict`` (and ``classes_`` to check labels).
    table : pandas.DataFrame
        Feature table, one row per member.
    label : str, optional
        Condition column with the true class (kept beside the prediction).
    features : sequence of str, optional
        Indicator columns (default: the model's ``feature_names_in_``, else every
        column with a ``/`` in its name).
    on_error : {"skip", "raise"}, default "skip"

    Returns
    -------
    predictions : pandas.DataFrame
        Indexed by member: ``predicted`` (and ``label``).
    errors : pandas.DataFrame
        Columns member, signal, source, error.

    Raises
    ------
    pdmkit.errors.DataError
        Feature columns the model needs are missing, the label column is missing, or
        (``on_error="raise"``) a bad member.

    Examples
    --------
    >>> from sklearn.neighbors import KNeighborsClassifier
    >>> train = pd.DataFrame({"v/stats/RMS": [0.0, 0.1, 1.0, 1.1],
    ...                       "fault": ["ok", "ok", "ir", "ir"]})
    >>> model = KNeighborsClassifier(1).fit(train[["v/stats/RMS"]], train["fault"])
    >>> new = pd.DataFrame({"v/stats/RMS": [0.05, 1.05], "fault": ["ok", "or"]},
    ...                    index=["m1", "m2"])
    >>> pred, errors = predict_members(model, new, label="fault")
    >>> pred["predicted"].to_dict(), errors["member"].tolist()
    ({'m1': 'ok'}, ['m2'])
    """
    if on_error not in ("raise", "skip"):
        raise ValueError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    if features is None:
        names = getattr(model, "feature_names_in_", None)
        features = (
            list(names) if names is not None else [c for c in table.columns if "/" in c]
        )
    features = list(features)
    missing = [c for c in features if c not in table.columns]
    if missing:
        raise DataError(
            f"the feature table lacks {len(missing)} indicator(s) the model was trained "
            f"on, e.g. {missing[:5]}; extract them with the same groups and options"
        )
    if label is not None and label not in table.columns:
        raise DataError(
            f"label column {label!r} is not in the feature table; its condition "
            f"columns are {[c for c in table.columns if '/' not in str(c)]}"
        )
    errors: list[dict] = []
    values = table[features].to_numpy(dtype=float)
    finite = np.isfinite(values)
    ok = finite.all(axis=1)
    for i in np.flatnonzero(~ok):
        col = features[int(np.argmax(~finite[i]))]
        errors.append(
            {
                "member": str(table.index[i]),
                "signal": col.split("/")[0] if "/" in col else None,
                "source": None,
                "error": f"member {table.index[i]!r}: indicator {col!r} is "
                f"{values[i, int(np.argmax(~finite[i]))]} (NaN/inf); not predicted",
            }
        )
    classes = getattr(model, "classes_", None)
    if label is not None and classes is not None:
        known = {str(c) for c in classes}
        for i in np.flatnonzero(ok):
            value = table[label].iloc[i]
            if str(value) not in known:
                ok[i] = False
                errors.append(
                    {
                        "member": str(table.index[i]),
                        "signal": None,
                        "source": None,
                        "error": f"member {table.index[i]!r}: label {label}={value!r} "
                        f"was not seen in training (the model knows "
                        f"{sorted(known)}); not predicted",
                    }
                )
    if errors and on_error == "raise":
        raise DataError(errors[0]["error"].replace("; not predicted", ""))
    out = pd.DataFrame(index=table.index[ok])
    if ok.any():
        out["predicted"] = model.predict(table.loc[ok, features])
    else:
        out["predicted"] = pd.Series(dtype=object)
    if label is not None:
        out["label"] = table.loc[ok, label].to_numpy()
    errs = pd.DataFrame(errors, columns=["member", "signal", "source", "error"])
    return out, errs
