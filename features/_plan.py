"""Feature tables of ensembles: :func:`extract_ensemble`, and the plan behind it.

An ensemble's table is computed in units of work (batches of members, or the
partitions of an on-disk ensemble): :func:`plan_extraction` checks the request and cuts
the ensemble, :func:`extract_task` computes one unit, :meth:`ExtractionPlan.combine`
joins them. :func:`extract_ensemble` runs the plan in this process or on Dask; the
resumable runs of :mod:`pdmkit.experiments` run the same plan one committed partition
at a time.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._progress import progress as _progress_bar
from pdmkit.ensembles import (
    Ensemble,
    Partition,
    dask_map,
    parquet_partitions,
    read_partition,
)
from pdmkit.errors import DataError
from pdmkit.features._common import MemberDataError
from pdmkit.features._extract import check_batch_size, extract
from pdmkit.features._groups import check_group_options, check_groups

__all__ = [
    "ERROR_COLUMNS",
    "ExtractionPlan",
    "extract_ensemble",
    "extract_task",
    "plan_extraction",
]

#: The columns of the errors table (members left out with ``on_error="skip"``).
ERROR_COLUMNS = ("member", "signal", "source", "error")


@dataclass(frozen=True)
class ExtractionPlan:
    """How an ensemble's feature table is computed: units of work, and their union.

    :func:`plan_extraction` checks the request and cuts the ensemble into items (batches
    of members, or the partitions of an on-disk ensemble); :func:`extract_task` computes
    one item (in this process, on a Dask worker, or as one partition of a resumable
    run); :meth:`combine` joins the items' results into the table. This is what
    :func:`extract_ensemble` does, open for other drivers (resumable runs, clusters).

    Attributes
    ----------
    items : list or iterable
        Batches (:class:`pdmkit.ensembles.Ensemble`) or
        :class:`pdmkit.ensembles.Partition` objects.
    total : int or None
        How many items (None for a plain iterable of batches).
    signals : list of str or None
        Signals to use (None: every signal of each batch).
    groups : tuple of str
        Indicator groups (checked).
    options : dict
        Group options (checked).
    shaft_column : str or None
        The condition column holding each member's shaft speed (``shaft_hz="rpm_col"``).
    on_error : {"raise", "skip"}
        What a bad member does.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.features import extract_task, plan_extraction
    >>> ens = Ensemble({"x": np.random.default_rng(0).normal(size=(6, 256))}, fs=100.0)
    >>> plan = plan_extraction(ens, groups=("stats",), batch_size=4)
    >>> plan.total, plan.resumable
    (2, True)
    >>> results = [extract_task(item, **plan.task_options()) for item in plan.items]
    >>> plan.combine(results).shape
    (6, 11)
    """

    items: Iterable
    total: int | None
    signals: list[str] | None
    groups: tuple[str, ...]
    options: dict
    shaft_column: str | None
    on_error: str

    @property
    def resumable(self) -> bool:
        """True when the items can be enumerated again (not a one-pass iterable)."""
        return isinstance(self.items, list)

    def task_options(self) -> dict:
        """The keyword arguments of :func:`extract_task` for this plan."""
        return {
            "signals": self.signals,
            "groups": self.groups,
            "options": self.options,
            "shaft_column": self.shaft_column,
            "on_error": self.on_error,
        }

    def combine(self, results: Iterable, return_errors: bool = False):
        """Join the :func:`extract_task` results (in item order) into the table.

        Returns the feature table, or ``(table, errors)`` with ``return_errors``
        (see :func:`extract_ensemble`).
        """
        return _combine(results, return_errors)


def plan_extraction(
    ensemble: Ensemble,
    *,
    signals: Sequence[str] | None = None,
    groups: Sequence[str] = ("stats", "spectral"),
    batch_size: int = 512,
    on_error: str = "raise",
    where: str = "plan_extraction()",
    **options,
) -> ExtractionPlan:
    """Check a feature-table request and cut the ensemble into units of work.

    Parameters
    ----------
    ensemble, signals, groups, batch_size, on_error, **options
        As for :func:`extract_ensemble`.
    where : str
        The function the request was made to, for the messages.

    Returns
    -------
    ExtractionPlan

    Raises
    ------
    pdmkit.errors.DataError
        An unknown group, an option of a group not asked for, a bad ``batch_size`` or
        ``on_error``, an empty ensemble.
    TypeError
        An unknown option, or an ``ensemble`` of the wrong type.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.features import plan_extraction
    >>> ens = Ensemble({"x": np.zeros((10, 256))}, fs=100.0)
    >>> plan = plan_extraction(ens, groups=("stats", "ar"), batch_size=4, ar_order=4)
    >>> plan.total, plan.groups, plan.options
    (3, ('stats', 'ar'), {'ar_order': 4})
    """
    group_list = check_groups(groups)
    check_group_options(group_list, options, where=where)
    batch_size = check_batch_size(batch_size)
    if on_error not in ("raise", "skip"):
        raise DataError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    if signals is not None:
        signals = [signals] if isinstance(signals, str) else list(signals)
    shaft = options.get("shaft_hz")
    total = None
    if isinstance(ensemble, str | os.PathLike):
        items: Iterable = list(parquet_partitions(ensemble, batch_size=batch_size))
        total = len(items)
    elif _is_ensemble(ensemble):
        n = len(ensemble)
        if n == 0:
            raise DataError("the ensemble has 0 members; nothing to extract")
        total = math.ceil(n / batch_size)
        items = [ensemble] if n <= batch_size else list(ensemble.batches(batch_size))
    elif isinstance(ensemble, Iterable):
        items = _checked_batches(ensemble)
    else:
        raise TypeError(
            "ensemble must be a pdmkit.ensembles.Ensemble, a path to a Parquet ensemble "
            f"or an iterable of Ensemble batches, got {type(ensemble).__name__}"
        )
    return ExtractionPlan(
        items,
        total,
        signals,
        group_list,
        dict(options),
        shaft if isinstance(shaft, str) else None,
        on_error,
    )


def _checked_batches(batches: Iterable) -> Iterator:
    for batch in batches:
        if not (_is_ensemble(batch) or hasattr(batch, "manifest")):
            raise TypeError(
                f"the batches must be pdmkit.ensembles.Ensemble objects, got "
                f"{type(batch).__name__}"
            )
        yield batch


def _is_ensemble(obj) -> bool:
    return all(hasattr(obj, a) for a in ("stack", "signal_names", "member_ids", "fs"))


def _describe_ids(ids: Sequence) -> str:
    ids = list(ids)
    shown = ", ".join(repr(i) for i in ids[:8])
    return shown + (f" and {len(ids) - 8} more" if len(ids) > 8 else "")


def _wrap_error(err: DataError, signal: str, present: pd.Index) -> DataError:
    rows = getattr(err, "rows", None)
    if rows:
        ids = [present[r] for r in rows]
        word = "member" if len(ids) == 1 else "members"
        problem = getattr(err, "problem", str(err))
        msg = f"signal {signal!r}, {word} {_describe_ids(ids)}: {problem}"
        new = MemberDataError(msg, rows=rows, problem=problem)
    else:
        msg = f"signal {signal!r} (members {_describe_ids(present)}): {err}"
        new = MemberDataError(msg, rows=(), problem=str(err))
    new.signal = signal
    new.member_ids = [present[r] for r in rows] if rows else list(present)
    return new


def _error_row(member, signal, source, message) -> dict:
    return {"member": str(member), "signal": signal, "source": source, "error": message}


def _present_same_length(batch, name, ids, skip, errors):
    """``batch.stack(name)``; with ``skip``, members of an odd length are set aside."""
    try:
        return batch.stack(name)
    except DataError:
        if not skip:
            raise
    xs = batch.signal(name)
    lengths = np.array([-1 if x is None else len(x) for x in xs])
    values, counts = np.unique(lengths[lengths >= 0], return_counts=True)
    common = values[counts == counts.max()].max()  # the most common; ties: longest
    mask = lengths == common
    for i in np.flatnonzero((lengths >= 0) & ~mask):
        errors.append(
            _error_row(
                ids[i],
                name,
                None,
                f"signal {name!r} of member {ids[i]!r} has {lengths[i]} samples; the "
                f"other members of its batch have {common}; member skipped (cut the "
                "members to one length with frames())",
            )
        )
    return np.stack([xs[i] for i in np.flatnonzero(mask)]), mask


def _named_inputs(batch, options, ids, skip, errors):
    """Model-group inputs given as a signal name (``frf_input="Force"``), per member.

    Returns ``({option: array (members, samples)}, has_all_inputs mask)``; members
    lacking an input signal are errors (skipped with ``skip``).
    """
    named = {
        k: v for k, v in options.items() if k.endswith("_input") and isinstance(v, str)
    }
    has_all = np.ones(len(ids), dtype=bool)
    inputs = {}
    for key, signal in named.items():
        if signal not in batch.signal_names:
            raise DataError(
                f"{key}={signal!r} names no signal of the ensemble; its signals are "
                f"{list(batch.signal_names)}"
            )
        values, mask = _present_same_length(batch, signal, ids, skip, errors)
        mask = np.asarray(mask, dtype=bool)
        missing = ids[~mask]
        if len(missing) and not skip:
            raise DataError(
                f"{key}={signal!r}: members {list(missing[:5])} lack that input signal "
                "(pass on_error='skip' to leave them out)"
            )
        for member in missing:
            errors.append(
                _error_row(
                    member,
                    signal,
                    None,
                    f"member {member!r} lacks the input signal "
                    f"{signal!r} of {key}; member skipped",
                )
            )
        full = np.full((len(ids), values.shape[1]), np.nan)
        full[mask] = values
        inputs[key] = full
        has_all &= mask
    return inputs, has_all


def _worker_threads() -> int | None:
    """Threads of the Dask worker running this task (None outside a worker)."""
    import sys

    if "distributed" not in sys.modules:
        return None
    try:
        from distributed import get_worker

        return int(get_worker().state.nthreads)
    except (ImportError, ValueError, AttributeError):
        return None


def _batch_table(
    batch, signals, groups, options, shaft_column, on_error="raise", errors=None
) -> pd.DataFrame:
    skip = on_error == "skip"
    errors = [] if errors is None else errors
    ids = pd.Index(batch.member_ids)
    conditions = batch.conditions
    conditions = (
        pd.DataFrame(index=ids) if conditions is None else conditions.reindex(ids).copy()
    )
    available = list(batch.signal_names)
    names = available if signals is None else list(signals)
    unknown = [s for s in names if s not in available]
    if unknown:
        raise DataError(
            f"signal(s) {unknown} are not in the ensemble; its signals are {available}"
        )
    parts = [conditions]
    n_errors = len(errors)
    inputs, has_inputs = _named_inputs(batch, options, ids, skip, errors)
    for name in names:
        array, mask = _present_same_length(batch, name, ids, skip, errors)
        mask = np.asarray(mask, dtype=bool)
        if inputs:  # model groups: keep the members that have their input signals too
            array = array[has_inputs[mask]]
            mask = mask & has_inputs
        if skip and signals is not None:  # a signal asked for by name must be there
            for i in np.flatnonzero(~batch.has_signal(name)):
                errors.append(
                    _error_row(
                        ids[i],
                        name,
                        None,
                        f"member {ids[i]!r} lacks signal {name!r}; member skipped",
                    )
                )
        present = ids[mask]
        if len(present) == 0:
            continue
        if shaft_column is not None and shaft_column not in conditions.columns:
            raise DataError(
                f"shaft_hz={shaft_column!r} names no condition column; the conditions "
                f"are {list(conditions.columns)}"
            )
        per_member = dict(inputs)
        if shaft_column is not None:
            per_member["shaft_hz"] = conditions[shaft_column].to_numpy(dtype=float)
        feats, present = _signal_features(
            batch.fs[name],
            array,
            present,
            ids,
            name,
            groups,
            options,
            per_member,
            skip,
            errors,
        )
        if feats is None:
            continue
        feats.index = present
        feats.columns = [f"{name}/{c}" for c in feats.columns]
        parts.append(feats)
    table = pd.concat(parts, axis=1).reindex(ids)
    if len(errors) > n_errors:
        failed = {e["member"] for e in errors[n_errors:]}
        table = table[~table.index.isin(failed)]
    return table


def _signal_features(
    fs, array, present, ids, name, groups, options, per_member, skip, errors
):
    """The feature rows of one signal of a batch: ``(table or None, members kept)``.

    ``per_member`` holds option values with one row per member of the batch (``ids``
    order); a member whose data the extractor refuses is dropped and its error recorded
    (``skip``), or the error raised naming the member.
    """
    while len(present):
        rows_of = ids.get_indexer(present)
        opts = {**options, **{k: v[rows_of] for k, v in per_member.items()}}
        try:
            # in a Dask worker, use its threads, not every core of the machine
            return extract(array, fs, groups, workers=_worker_threads(), **opts), present
        except DataError as err:
            wrapped = _wrap_error(err, name, present)
            if not skip:
                raise wrapped from err
            rows = getattr(err, "rows", None) or list(range(len(present)))
            problem = getattr(wrapped, "problem", str(err))
            for r in rows:
                message = f"signal {name!r} of member {present[r]!r}: {problem}"
                errors.append(
                    _error_row(present[r], name, None, f"{message}; member skipped")
                )
            keep = np.ones(len(present), dtype=bool)
            keep[rows] = False
            array, present = array[keep], present[keep]
    return None, present


def extract_task(
    item: Partition | Ensemble,
    *,
    signals: Sequence[str] | None,
    groups: Sequence[str],
    options: dict,
    shaft_column: str | None,
    on_error: str,
) -> tuple[pd.DataFrame | None, list[dict], list[str]]:
    """One unit of work of an :class:`ExtractionPlan`: a batch or a Parquet partition.

    A module-level function of keyword arguments (:meth:`ExtractionPlan.task_options`),
    so that Dask can send it to workers.

    Returns
    -------
    table : pandas.DataFrame or None
        The item's feature rows (None: nothing to compute).
    errors : list of dict
        Members left out (rows of the errors table, :data:`ERROR_COLUMNS`).
    signals : list of str
        The signals the item's table holds, in column order.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.features import extract_task, plan_extraction
    >>> ens = Ensemble({"x": np.ones((3, 128))}, fs=100.0)
    >>> plan = plan_extraction(ens, groups=("stats",))
    >>> table, errors, signals = extract_task(plan.items[0], **plan.task_options())
    >>> table["x/stats/RMS"].tolist(), errors, signals
    ([1.0, 1.0, 1.0], [], ['x'])
    """
    errors: list = []
    source = None
    if isinstance(item, Partition):
        source = f"{item.root} (members {item.start}:{item.stop})"
        wanted = signals
        if signals is not None:  # model groups' input signals are read too
            named = [v for k, v in options.items() if k.endswith("_input")]
            wanted = list(
                dict.fromkeys([*signals, *(v for v in named if isinstance(v, str))])
            )
        try:
            batch = read_partition(
                item, signals=wanted, errors=errors if on_error == "skip" else None
            )
        except DataError as exc:
            if on_error != "skip":
                raise
            # an unreadable part file: its members' ids are unknown, name positions
            message = f"{exc}; member skipped"
            rows = [
                _error_row(f"#{i}", None, source, message)
                for i in range(item.start, item.stop)
            ]
            return None, rows, []
    else:
        batch = item
    if len(batch) == 0:
        return None, errors, []
    start = len(errors)
    table = _batch_table(batch, signals, groups, options, shaft_column, on_error, errors)
    for e in errors[start:]:
        e["source"] = e["source"] or source
    names = list(signals) if signals is not None else list(batch.signal_names)
    return table, errors, names


def extract_ensemble(
    ensemble: Ensemble,
    *,
    signals: Sequence[str] | None = None,
    groups: Sequence[str] = ("stats", "spectral"),
    batch_size: int = 512,
    progress: bool | None = None,
    client: Any = None,
    on_error: str = "raise",
    return_errors: bool = False,
    **options,
) -> pd.DataFrame | tuple[pd.DataFrame, pd.DataFrame]:
    """Feature table of an ensemble: :func:`extract` per signal, members by id.

    Members stream through in batches of ``batch_size``, so an on-disk ensemble is
    never loaded whole: memory stays bounded by one batch plus the (small) feature rows.
    With ``client`` the batches run as tasks on a Dask cluster (an on-disk ensemble is
    then read by the workers, partition by partition); the table is the same.

    Parameters
    ----------
    ensemble : Ensemble, path, URL, or iterable of Ensemble
        A :class:`pdmkit.ensembles.Ensemble`; a path or fsspec URL (``s3://...``,
        ``file://...``) of an on-disk Parquet ensemble, read ``batch_size`` members at a
        time (the batches of :func:`pdmkit.ensembles.iter_parquet`); or an iterable of
        Ensemble batches.
    signals : sequence of str, optional
        Signals to use; default all of ``ensemble.signal_names``.
    groups : sequence of str, default ("stats", "spectral")
        Indicator groups (see :func:`extract`).
    batch_size : int, default 512
        Members per batch (per Dask task).
    progress : bool, optional
        Show a progress bar (in-process runs); default only when stderr is a terminal.
    client : dask.distributed.Client, str, int, optional
        Run on Dask: a client, a scheduler address (``"tcp://host:8786"``) or a number
        of local worker processes to start; default in-process. See
        :func:`pdmkit.ensembles.dask_client`.
    on_error : {"raise", "skip"}, default "raise"
        ``"skip"``: a member with bad data (NaN/inf samples, a length that differs
        from its batch, a signal named in ``signals`` that it lacks, a signal too short
        for the indicators) is left out of the table and described in the errors table;
        the other members go on. ``"raise"``: the first bad member raises.
    return_errors : bool, default False
        Also return the errors table (columns ``member``, ``signal``, ``source``,
        ``error``; empty when nothing went wrong).
    **options
        Group options, as for :func:`extract`. ``<group>_input`` of a model group
        (``frf``, ``hw``, ``fractional``) may name a signal of the ensemble: each
        member's own recording of it is the input. ``shaft_hz`` may also name a condition
        column holding each member's shaft speed in Hz.

    Returns
    -------
    pandas.DataFrame, or (DataFrame, DataFrame) with ``return_errors``
        Indexed by member id: the condition columns, then ``<signal>/<group>/<Feature>``
        columns (e.g. ``DE/stats/Kurtosis``); NaN where a member lacks a signal.

    Raises
    ------
    pdmkit.errors.DataError
        Bad signal data, naming the signal and the member ids (``on_error="raise"``);
        unknown signal names.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble
    >>> from pdmkit.features import extract_ensemble
    >>> rng = np.random.default_rng(0)
    >>> ens = Ensemble({"vib": rng.normal(size=(4, 2048))}, fs=1000.0,
    ...                conditions={"fault": ["none", "none", "ir", "ir"]})
    >>> table = extract_ensemble(ens, groups=("stats",))
    >>> table.shape
    (4, 12)
    >>> list(table.columns[:3])
    ['fault', 'vib/stats/Mean', 'vib/stats/Std']
    >>> short = Ensemble({"vib": [rng.normal(size=2048), rng.normal(size=100)]}, fs=1e3)
    >>> table, errors = extract_ensemble(short, on_error="skip", return_errors=True)
    >>> table.index.tolist(), errors["member"].tolist()
    (['m00000'], ['m00001'])
    """
    plan = plan_extraction(
        ensemble,
        signals=signals,
        groups=groups,
        batch_size=batch_size,
        on_error=on_error,
        where="extract_ensemble()",
        **options,
    )
    if client is None:
        items = _progress_bar(
            plan.items, desc="features", total=plan.total, enable=progress
        )
        results = (extract_task(item, **plan.task_options()) for item in items)
    else:
        results = dask_map(
            extract_task, list(plan.items), client=client, **plan.task_options()
        )
    return plan.combine(results, return_errors)


def _combine(results, return_errors: bool = False):
    """The feature table (and errors) from the :func:`extract_task` results, in order."""
    tables, errors = [], []
    order: list[str] = []
    for table, errs, names in results:
        errors.extend(errs)
        if table is None:
            continue
        for s in names:
            if s not in order:
                order.append(s)
        tables.append(table)
    error_table = pd.DataFrame(errors, columns=list(ERROR_COLUMNS))
    if not tables or not sum(len(t) for t in tables):
        if len(error_table):
            raise DataError(
                f"every member was skipped for bad data ({len(error_table)} problem(s)), "
                f"e.g. {error_table['error'].iloc[0]}"
            )
        raise DataError("the ensemble has 0 members; nothing to extract")
    table = pd.concat(tables, axis=0) if len(tables) > 1 else tables[0]

    # batches lacking a signal put its columns late: order by signal, conditions first
    def key(column) -> int:
        head = str(column).split("/", 1)[0]
        return 1 + order.index(head) if "/" in str(column) and head in order else 0

    columns = sorted(table.columns, key=key)
    table = table[columns]
    duplicated = table.index[table.index.duplicated()].unique()
    if len(duplicated):
        raise DataError(
            f"member ids {_describe_ids(duplicated)} occur in more than one batch; "
            "member ids must be unique"
        )
    if len(error_table) and not return_errors:
        import warnings

        warnings.warn(
            f"{error_table['member'].nunique()} member(s) skipped for bad data, e.g. "
            f"{error_table['error'].iloc[0]}; pass return_errors=True to get the table",
            UserWarning,
            stacklevel=3,
        )
    return (table, error_table) if return_errors else table
