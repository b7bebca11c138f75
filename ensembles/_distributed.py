"""Scale-out on Dask distributed: the same work, partition by partition, on a cluster.

pdmkit runs in-process by default (vectorised numpy, members streamed in batches). When
the user passes a cluster, the same functions run as Dask tasks instead:

- ``client`` is a :class:`dask.distributed.Client` the user made (left open), a
  scheduler address such as ``"tcp://10.0.0.5:8786"`` (connected and closed again), or
  an integer ``N``: a :class:`dask.distributed.LocalCluster` of ``N`` worker processes
  with one thread each is started and shut down again.
- ``None`` (default) runs in-process; the result is the same either way.

A Parquet ensemble (see :meth:`Ensemble.to_parquet`) is read partition by partition
(one task per part file) from local disk or any fsspec URL (``file://``, ``s3://``,
``gcs://``, ...), so the driver never holds the signals.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pdmkit._checks import check_int
from pdmkit._optional import require
from pdmkit.ensembles._ensemble import Ensemble, _table_to_ensemble
from pdmkit.ensembles._limits import check_declared_sizes
from pdmkit.ensembles._parquet import (
    FORMAT,
    MANIFEST,
    _lists_to_arrays,
    _pick,
    read_manifest,
    url_filesystem,
)
from pdmkit.ensembles._pneumatic_faults import simulate_fault_ensemble
from pdmkit.ensembles._signals import MEMBER
from pdmkit.errors import DataError, DataNotFoundError

__all__ = [
    "LOST_TASK_ATTEMPTS",
    "Partition",
    "WorkerLostError",
    "dask_client",
    "dask_map",
    "dask_stream",
    "discover_mismatch_batch",
    "parquet_partitions",
    "read_partition",
    "simulate_sweep",
]


#: How long to try to reach a scheduler address before giving up.
CONNECT_TIMEOUT = "10s"


def _is_client(obj: Any) -> bool:
    return all(hasattr(obj, a) for a in ("submit", "gather", "scheduler_info"))


def _check_workers(workers: Any) -> int:
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(
            f"client=N (local Dask workers) must be a positive integer; got {workers!r}"
        )
    return workers


@contextlib.contextmanager
def dask_client(client: Any = None) -> Iterator[Any]:
    """Resolve ``client`` to a Dask client for the duration of a ``with`` block.

    Parameters
    ----------
    client : dask.distributed.Client, str, int or None
        A client (yielded as is, never closed); a scheduler address (``"tcp://..."``:
        connected, closed on exit); a number ``N`` of local worker processes (a
        ``LocalCluster`` with one thread per worker is started, shut down on exit); or
        None: yields None, meaning "run in-process".

    Yields
    ------
    dask.distributed.Client or None

    Raises
    ------
    ConnectionError
        The scheduler address cannot be reached (the message names it).
    ValueError
        ``client`` is none of the above.

    Examples
    --------
    >>> with dask_client(None) as c:
    ...     print(c)
    None
    >>> with dask_client(0) as c:  # doctest: +ELLIPSIS
    ...     pass
    Traceback (most recent call last):
    ...
    ValueError: client=N (local Dask workers) must be a positive integer; got 0
    """
    if client is None:
        yield None
        return
    if _is_client(client):
        yield client
        return
    if isinstance(client, str):
        address = client
        Client = require("distributed", what="a Dask scheduler address").Client

        try:
            c = Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise ConnectionError(
                f"cannot reach the Dask scheduler at {address!r} ({exc}); start one with "
                "`dask scheduler` (and `dask worker ADDRESS`), or pass workers=N to start "
                "a local cluster"
            ) from None
        try:
            yield c
        finally:
            c.close()
        return
    if isinstance(client, int):  # bool is refused by _check_workers
        n = _check_workers(client)
        dist = require("distributed", what="a local Dask cluster (workers=N)")
        Client, LocalCluster = dist.Client, dist.LocalCluster

        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        try:
            c = Client(cluster, set_as_default=False)
            try:
                yield c
            finally:
                c.close()
        finally:
            cluster.close()
        return
    raise ValueError(
        "client must be a dask.distributed.Client, a scheduler address such as "
        f"'tcp://host:8786', a number of local workers, or None; got {client!r}"
    )


def _in_flight_limit(c: Any) -> int:
    try:
        threads = sum(w.get("nthreads", 1) for w in c.scheduler_info()["workers"].values())
    except Exception:  # pragma: no cover - a scheduler without the info
        threads = 2
    return max(2, 2 * threads)


#: How many times :func:`dask_stream` sends one task to the cluster when the worker
#: running it, or holding its input, dies (the scheduler itself also re-runs a task up
#: to ``distributed.scheduler.allowed-failures`` times, default 3, before giving up on
#: it with ``KilledWorker``). A task that kills every worker it runs on (a member that
#: runs the worker out of memory, a crash in native code) ends as a
#: :class:`WorkerLostError` after this many workers died with it.
LOST_TASK_ATTEMPTS = 3

#: Pauses (seconds) between attempts to send a task's input to the workers while a
#: worker that just died is still listed by the scheduler.
SCATTER_RETRY_DELAYS = (0.1, 0.3, 1.0, 2.0, 4.0)


class WorkerLostError(ConnectionError):
    """A Dask task was lost with its worker too often: it probably kills its workers.

    A :class:`ConnectionError` (the workers' connections closed under it), so the
    ``pdmkit`` command reports it in one line with exit status 2.
    """


def _describe(i: int, item: Any) -> str:
    """A short name of work item ``i`` for messages (partition, batch of members)."""
    if isinstance(item, Partition):
        return f"partition {item.index} of {item.root} (members {item.start}:{item.stop})"
    ids = getattr(item, "member_ids", None)
    if ids is not None and len(ids):
        first, last = str(ids[0]), str(ids[-1])
        span = first if len(ids) == 1 else f"{first}..{last}"
        return f"batch {i} ({len(ids)} member(s), {span})"
    return f"task {i}"


#: The advice that ends a WorkerLostError message.
_LOST_HINT = (
    "it probably makes the worker run out of memory or crash: use a smaller batch "
    "size, give the workers more memory, or check its members in-process"
)

#: Dask's reasons for cancelling a task whose input was lost with its worker.
_PLAIN_LOSSES = ("already forgotten", "lost dependencies", "unknown")


class _QuietLostTasks(logging.Filter):
    """Drop the scheduler's errors about :func:`dask_stream`'s lost tasks and inputs.

    Tasks and inputs lost with a worker ("... lose scattered data, which can't be
    recovered", "Couldn't gather keys") are computed again. Only a scheduler in this process
    (a ``LocalCluster``) logs here.
    """

    MESSAGES = ("scattered data", "Couldn't gather keys")

    def __init__(self) -> None:
        super().__init__()
        self.keys: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        text = str(record.msg)
        if not self.keys or not any(m in text for m in self.MESSAGES):
            return True
        message = record.getMessage()
        return not any(k in message for k in self.keys)


def _scatter(c: Any, item: Any) -> Any:
    """``item`` sent to a worker: a future, or the item itself when it is a scalar."""
    if isinstance(item, int | float | str | bytes | type(None)):
        return item
    delays = iter(SCATTER_RETRY_DELAYS)
    while True:
        try:
            # a list of one: scatter would split a dict or list into futures per entry
            [future] = c.scatter([item], hash=False)
            return future
        except TimeoutError as exc:  # (an OSError) the scheduler waited for a worker
            raise WorkerLostError(
                f"no Dask worker is running to take a task's input ({exc}); start "
                "workers for the scheduler, or run in-process"
            ) from None
        except OSError:  # CommClosedError: the worker chosen has just died
            delay = next(delays, None)
            if delay is None:
                raise
            time.sleep(delay)


def dask_stream(
    c: Any, func: Callable[..., Any], items: Iterable[Any], **kwargs: Any
) -> Iterator[tuple[int, Any]]:
    """Run ``func(item, **kwargs)`` as tasks on client ``c``; yield ``(i, result)``.

    Results come in the order the tasks finish. At most about two tasks per worker
    thread are in flight, and each item is sent to the cluster only when its task is
    submitted, so neither this process nor the workers hold all items at once.

    A task lost with a worker that died (killed, out of memory, its machine gone) is
    sent again, with its item, to the workers left (a ``RuntimeWarning`` says so): the
    results are those of a run where no worker died. An item whose task was lost
    :data:`LOST_TASK_ATTEMPTS` times, or that the scheduler gave up on
    (``KilledWorker``), raises :class:`WorkerLostError`. An exception raised by
    ``func`` is raised here at once, with its own type; it is not retried.

    Examples
    --------
    >>> from distributed import Client, LocalCluster  # doctest: +SKIP
    >>> with Client(LocalCluster(n_workers=1, processes=False)) as c:  # doctest: +SKIP
    ...     sorted(dask_stream(c, abs, [-1, -2]))
    [(0, 1), (1, 2)]
    """
    from concurrent.futures import CancelledError

    from distributed import KilledWorker, as_completed

    limit = _in_flight_limit(c)
    iterator = iter(enumerate(items))
    pending = as_completed([], loop=c.loop)
    # future -> (position, item, attempt): the item stays here until its result is in,
    # so that a task lost with its worker (and the scattered input with it) can be
    # sent again; at most ``limit`` items are held
    index: dict[Any, tuple[int, Any, int]] = {}
    quiet = _QuietLostTasks()
    keys: dict[Any, tuple[str, ...]] = {}  # future -> its key and its input's

    def submit(i: int, item: Any, attempt: int) -> None:
        data = _scatter(c, item)
        future = c.submit(func, data, pure=False, **kwargs)
        keys[future] = (str(future.key),) + ((str(data.key),) if data is not item else ())
        quiet.keys.update(keys[future])
        index[future] = (i, item, attempt)
        pending.add(future)

    def done(future: Any) -> None:
        future.release()
        quiet.keys.difference_update(keys.pop(future, ()))

    def submit_next() -> bool:
        try:
            i, item = next(iterator)
        except StopIteration:
            return False
        submit(i, item, 1)
        return True

    def lost(future: Any, i: int, item: Any, attempt: int, reason: str) -> None:
        done(future)
        what = _describe(i, item)
        if attempt >= LOST_TASK_ATTEMPTS:
            said = "" if reason in _PLAIN_LOSSES else f" (Dask: {reason})"
            raise WorkerLostError(
                f"{what} was lost {attempt} times with a Dask worker that died{said}; "
                f"{_LOST_HINT}"
            )
        warnings.warn(
            f"a Dask worker died; {what} is computed again "
            f"(attempt {attempt + 1} of {LOST_TASK_ATTEMPTS})",
            RuntimeWarning,
            stacklevel=3,
        )
        submit(i, item, attempt + 1)

    scheduler_log = logging.getLogger("distributed.scheduler")
    scheduler_log.addFilter(quiet)
    try:
        for _ in range(limit):
            if not submit_next():
                break
        for future in pending:
            i, item, attempt = index.pop(future)
            if future.status == "error":
                exc = future.exception()
                if isinstance(exc, KilledWorker):  # the scheduler's retries are spent
                    done(future)
                    raise WorkerLostError(
                        f"{_describe(i, item)} killed every Dask worker that ran it "
                        f"({exc.allowed_failures + 1} died running it); {_LOST_HINT}"
                    ) from None
            try:
                result = future.result()  # raises the task's exception with its type
            except CancelledError as exc:  # its worker died with the task's input
                lost(future, i, item, attempt, getattr(exc, "reason", None) or "unknown")
                continue
            done(future)
            yield i, result
            submit_next()
    finally:
        scheduler_log.removeFilter(quiet)
        for future in index:
            future.cancel()


def dask_map(
    func: Callable[..., Any],
    items: Iterable[Any],
    *,
    client: Any = None,
    **kwargs: Any,
) -> list[Any]:
    """``[func(item, **kwargs) for item in items]``, on a Dask cluster when given one.

    One task per item; results come back in the order of ``items``. An exception in a
    task is raised here with its own type and message (the other tasks are cancelled).
    Use it for batches of per-member model fits or mismatch analyses: ``func`` must be
    importable by the workers (a function of a module, not a lambda of ``__main__``
    when the workers are separate processes) and return picklable results.

    Parameters
    ----------
    func : callable
    items : iterable
    client : dask.distributed.Client, str, int or None
        See :func:`dask_client`; None runs in-process.
    **kwargs
        Passed to every call.

    Returns
    -------
    list

    Examples
    --------
    >>> import math
    >>> dask_map(math.sqrt, [1.0, 4.0, 9.0])
    [1.0, 2.0, 3.0]
    """
    with dask_client(client) as c:
        if c is None:
            return [func(item, **kwargs) for item in items]
        results: dict[int, Any] = dict(dask_stream(c, func, items, **kwargs))
        return [results[i] for i in range(len(results))]


# --------------------------------------------------------------------------- Parquet
def _is_url(path: Any) -> bool:
    return isinstance(path, str) and "://" in path


@dataclass(frozen=True)
class Partition:
    """A run of consecutive members of an on-disk ensemble: the unit of work of a task.

    Attributes
    ----------
    root : str
        The ensemble directory (local path or fsspec URL).
    index : int
        Position among the partitions.
    start, stop : int
        Members ``start:stop`` of the ensemble (in the order they were written).
    files : tuple of (str, int, int)
        ``(file name, first member of the file, member count)`` of every part file;
        a partition reads only the row groups of the files it overlaps.
    manifest : dict
        The ensemble's signals, sampling rates and condition columns.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> path = Ensemble({"x": np.ones((5, 3))}, fs=1.0).to_parquet(
    ...     pathlib.Path(tempfile.mkdtemp()) / "ens", members_per_file=2)
    >>> [(p.start, p.stop) for p in parquet_partitions(path)]
    [(0, 2), (2, 4), (4, 5)]
    >>> [(p.start, p.stop) for p in parquet_partitions(path, batch_size=3)]
    [(0, 3), (3, 5)]
    """

    root: str
    index: int
    start: int
    stop: int
    files: tuple[tuple[str, int, int], ...]
    manifest: Mapping[str, Any]

    def __len__(self) -> int:
        return self.stop - self.start


def _read_url_manifest(url: str) -> dict[str, Any]:

    fs, root = url_filesystem(url)
    file = f"{root.rstrip('/')}/{MANIFEST}"
    try:
        with fs.open(file, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise DataNotFoundError(
            f"{url} is not a pdmkit ensemble: it has no {MANIFEST} (expected a directory "
            "written by Ensemble.to_parquet)"
        ) from None
    try:
        manifest = json.loads(raw.decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise DataError(f"{url}/{MANIFEST} is not valid JSON ({exc})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise DataError(f"{url}/{MANIFEST} is not a pdmkit ensemble manifest")
    missing = [k for k in ("signals", "fs", "conditions", "files") if k not in manifest]
    if missing:
        raise DataError(f"{url}/{MANIFEST} lacks the entries {missing}; it is damaged")
    return manifest


def parquet_partitions(
    path: str | os.PathLike, batch_size: int | None = None
) -> list[Partition]:
    """Split an on-disk ensemble, local or at an fsspec URL, into partitions.

    Parameters
    ----------
    path : str or path-like
        A directory written by :meth:`Ensemble.to_parquet`, or its URL
        (``file:///...``, ``s3://bucket/ens``; the fsspec backend must be installed).
    batch_size : int, optional
        Members per partition: the same consecutive batches as
        :func:`iter_parquet` ``(path, batch_size)`` yields. Default: one partition per
        part file.

    Returns
    -------
    list of Partition

    Raises
    ------
    pdmkit.errors.DataError
        Not a pdmkit ensemble (the message says what was found).

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> path = Ensemble({"x": np.ones((3, 2))}, fs=1.0).to_parquet(
    ...     pathlib.Path(tempfile.mkdtemp()) / "ens")
    >>> len(parquet_partitions(path)), len(parquet_partitions(path.as_uri(), 2))
    (1, 2)
    """
    if _is_url(path):
        root = str(path)
        manifest = _read_url_manifest(root)
    else:
        root = str(Path(path))
        manifest = read_manifest(root)
    files, start = [], 0
    for entry in manifest["files"]:
        n = int(entry["n_members"])
        files.append((str(entry["name"]), start, n))
        start += n
    total = start
    meta = {k: manifest[k] for k in ("signals", "fs", "conditions")}
    if batch_size is None:
        bounds = [(a, a + n) for _, a, n in files if n]
    else:
        size = check_int(batch_size, "batch_size")
        bounds = [(a, min(a + size, total)) for a in range(0, total, size)]
    return [Partition(root, i, a, b, tuple(files), meta) for i, (a, b) in enumerate(bounds)]


@contextlib.contextmanager
def _open(url: str) -> Iterator[Any]:
    if _is_url(url):
        import fsspec

        with fsspec.open(url, "rb") as f:
            yield f
    else:
        yield url


def _read_rows(url: str, columns: list[str], first: int, last: int) -> Any:
    """Rows ``first:last`` of one Parquet file, reading only the row groups needed."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    with _open(url) as source:
        reader = pq.ParquetFile(source, buffer_size=1 << 20, pre_buffer=False)
        # sizes declared before anything is decoded: a bomb costs only its own part
        check_declared_sizes(reader.metadata, url, columns=columns, per_row_group=True)
        groups, offset, skip = [], 0, None
        for g in range(reader.metadata.num_row_groups):
            n = reader.metadata.row_group(g).num_rows
            if offset + n > first and offset < last:
                groups.append(g)
                skip = offset if skip is None else skip
            offset += n
        if not groups:
            return None
        # decode batch by batch, keeping only rows first:last (bounded memory)
        kept, pos = [], skip
        size = max(1, min(last - first, 64))
        for batch in reader.iter_batches(
            batch_size=size, row_groups=groups, columns=columns, use_threads=False
        ):
            lo, hi = max(first - pos, 0), min(last - pos, batch.num_rows)
            if hi > lo:
                kept.append(batch.slice(lo, hi - lo))
            pos += batch.num_rows
            if pos >= last:
                break
        schema = reader.schema_arrow
        schema = pa.schema([schema.field(c) for c in columns])
    return pa.Table.from_batches(kept, schema=schema)


def _drop_nonfinite(table: Any, sigs: list[str], where: str, errors: list) -> Any:
    """Drop (and record in ``errors``) the rows whose signals hold NaN or inf."""
    import numpy as np

    keep = np.ones(table.num_rows, dtype=bool)
    ids = None
    for s in sigs:
        arrays, finite = _lists_to_arrays(table.column(s))
        if finite:
            continue
        ids = table.column(MEMBER).to_pylist() if ids is None else ids
        for i, x in enumerate(arrays):
            if x is None or np.isfinite(x).all():
                continue
            bad = ~np.isfinite(x)
            keep[i] = False
            errors.append(
                {
                    "member": str(ids[i]),
                    "signal": s,
                    "source": where,
                    "error": f"signal {s!r} of member {ids[i]!r} holds {int(bad.sum())} "
                    f"non-finite value(s) (first at sample {int(np.argmax(bad))}); "
                    "member skipped",
                }
            )
    return table if keep.all() else table.filter(keep)


def read_partition(
    part: Partition,
    signals: str | Sequence[str] | None = None,
    columns: Sequence[str] | None = None,
    *,
    errors: list | None = None,
) -> Ensemble:
    """Read the members of one partition (on the worker that runs the task).

    Parameters
    ----------
    part : Partition
        From :func:`parquet_partitions`.
    signals, columns : optional
        Signals and condition columns to read (default: all).
    errors : list, optional
        When given, members whose signals hold NaN or inf are left out and described
        here (dicts with ``member``, ``signal``, ``source``, ``error``) instead of
        failing the whole partition.

    Returns
    -------
    Ensemble

    Raises
    ------
    pdmkit.errors.DataError
        A part file cannot be read (the message names it), or an unknown signal/column.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> path = Ensemble({"x": np.arange(10.0).reshape(5, 2)}, fs=1.0).to_parquet(
    ...     pathlib.Path(tempfile.mkdtemp()) / "ens", members_per_file=2)
    >>> part = parquet_partitions(path, batch_size=3)[0]
    >>> read_partition(part).member_ids.tolist()
    ['m00000', 'm00001', 'm00002']
    """
    import pyarrow as pa

    manifest = dict(part.manifest)
    sigs = _pick(signals, manifest["signals"], "signal(s)", Path(part.root))
    cols = _pick(columns, manifest["conditions"], "condition column(s)", Path(part.root))
    tables, where = [], []
    for name, first, n in part.files:
        a, b = max(part.start, first), min(part.stop, first + n)
        if a >= b:
            continue
        url = f"{part.root.rstrip('/')}/{name}"
        try:
            table = _read_rows(url, [MEMBER, *cols, *sigs], a - first, b - first)
        except (pa.ArrowException, OSError) as exc:
            raise DataError(f"cannot read {url} ({exc}); the dataset is damaged") from None
        if table is None or table.num_rows != b - a:
            raise DataError(
                f"{url} holds fewer members than its manifest says ({n}); the dataset "
                "is damaged: write it again"
            )
        tables.append(table)
        where.append(url)
    if not tables:
        raise DataError(f"partition {part.index} of {part.root} holds no members")
    table = tables[0] if len(tables) == 1 else pa.concat_tables(tables)
    if errors is not None:
        table = _drop_nonfinite(table, sigs, " + ".join(where), errors)
    return _table_to_ensemble(table, manifest, sigs, cols, " + ".join(where))


# --------------------------------------------------------------------------- simulation
def _simulate_one(config: Mapping[str, Any], simulator: Callable[..., Ensemble]):
    return simulator(**config)


def simulate_sweep(
    configs: Sequence[Mapping[str, Any]],
    *,
    simulator: Callable[..., Ensemble] | None = None,
    keys: Sequence[str] | None = None,
    client: Any = None,
) -> Ensemble:
    """Simulate the twin at every setting of a sweep, one task per setting.

    Each setting is a dict of keyword arguments of ``simulator`` (default
    :func:`simulate_fault_ensemble`): seeds, operating points, labels, recording
    length. A setting always gives the same members, so the result is the same
    in-process and on any cluster.

    Parameters
    ----------
    configs : sequence of dict
        Keyword arguments of ``simulator``, one dict per task.
    simulator : callable, optional
        A function returning an :class:`Ensemble` (importable by the workers).
    keys : sequence of str, optional
        Prefix of each setting's member ids (default ``"s0"``, ``"s1"``, ...).
    client : dask.distributed.Client, str, int or None
        See :func:`dask_client`; None runs in-process.

    Returns
    -------
    Ensemble
        The members of all settings, ids ``"<key>/<id>"``.

    Examples
    --------
    >>> sweep = simulate_sweep(
    ...     [{"n_members": 2, "t_end": 0.2, "signals": ["LeverPosition"], "seed": s}
    ...      for s in (0, 1)])
    >>> sweep.member_ids.tolist()
    ['s0/sim00000', 's0/sim00001', 's1/sim00000', 's1/sim00001']
    """
    configs = [dict(c) for c in configs]
    if not configs:
        raise ValueError("simulate_sweep needs at least one setting in configs")
    if simulator is None:
        simulator = simulate_fault_ensemble
    if keys is None:
        keys = [f"s{i}" for i in range(len(configs))]
    elif len(keys) != len(configs):
        raise ValueError(f"simulate_sweep got {len(keys)} keys for {len(configs)} configs")
    parts = dask_map(_simulate_one, configs, client=client, simulator=simulator)
    return Ensemble.concat(parts, keys=list(keys))


# --------------------------------------------------------------------------- mismatch
def _mismatch_task(job: Mapping[str, Any]) -> dict[str, Any]:
    from pdmkit.models import discover_mismatch, load_model_file
    from pdmkit.models.ode import load_model_source

    job = dict(job)
    model = job.pop("model")
    if isinstance(model, Path) or (isinstance(model, str) and "def rhs" not in model):
        model = load_model_file(model)
    elif isinstance(model, str):
        model = load_model_source(model)
    data = job.pop("data")
    return discover_mismatch(model, data, **job).to_dict()


def discover_mismatch_batch(
    jobs: Sequence[Mapping[str, Any]], *, client: Any = None
) -> list[dict[str, Any]]:
    """Run :func:`pdmkit.models.discover_mismatch` on many recordings, one task each.

    Parameters
    ----------
    jobs : sequence of dict
        Each with ``model`` (the text of a model file, or its path: model objects of
        files do not travel between processes), ``data`` (a DataFrame) and any other
        keyword argument of :func:`~pdmkit.models.discover_mismatch` (``validation``,
        ``effects``, ...).
    client : dask.distributed.Client, str, int or None
        See :func:`dask_client`; None runs in-process.

    Returns
    -------
    list of dict
        ``MismatchResult.to_dict()`` of every job, in order.

    Examples
    --------
    >>> from pdmkit.models.mismatch._cases import generate_concealed_case
    >>> case = generate_concealed_case("overflow", 0.2, seed=3, n_samples=300)
    >>> [out] = discover_mismatch_batch(
    ...     [{"model": case.source, "data": case.data, "effects": ["overflow"],
    ...       "pairs": False, "max_iter": 5, "screen_iter": 3}])
    >>> out["verdict"]["effect"]
    'overflow'
    """
    jobs = [dict(j) for j in jobs]
    for i, job in enumerate(jobs):
        missing = [k for k in ("model", "data") if k not in job]
        if missing:
            raise ValueError(f"mismatch job {i} lacks {missing}; give model= and data=")
    return dask_map(_mismatch_task, jobs, client=client)
