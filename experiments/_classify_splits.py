"""How :func:`pdmkit.experiments.classify` splits members: held-out part and CV folds.

Frames cut from one recording, repeats of one setting, cycles of one unit are one
*group*: they share the machine, the sensor mounting and the day, so a classifier
that sees some of them in training recognises the others without having learnt the
fault. Every split here keeps a group on one side (Smith & Randall, MSSP 2015;
Hendriks et al., MSSP 2022, on the CWRU benchmark), except ``split="random"``, which is
only done when asked and says what it measures.

Kinds (the ``kind`` of :attr:`SplitPlan.info`):

``group``
    Whole groups held out, class by class (``test_size`` of each class's groups, at
    least one and never all). A class recorded in a single group cannot be held out
    whole: its group's members are split in time instead (the earliest
    ``1 - test_size`` train, the latest test, ``gap`` members dropped between them),
    and the notes name those classes (``blocks``).
``random``
    Members drawn at random, stratified by class (what a random split of frames
    measures is said beside it).
``time``
    The earliest members train, the latest test (:func:`time_split`).
``where`` / ``table``
    The test members chosen by the user: a query on the table, or another table
    (a transfer test: another fault size, load, session or machine).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pandas as pd
from sklearn.model_selection import StratifiedGroupKFold, StratifiedKFold, train_test_split

from pdmkit._checks import time_as_seconds
from pdmkit.errors import DataError
from pdmkit.experiments._classify_result import _plain, _show, _sorted_plain

__all__ = ["SPLITS", "SplitPlan", "plan_split"]

#: ``split=`` values of :func:`classify`; ``"auto"`` is ``"group"`` when the members
#: have groups (``group=`` or a ``source_member`` column of framed recordings), else
#: ``"stratified"`` (each member its own recording); ``"stratified"`` is a random
#: split of members, stratified by class, as ``"random"``.
SPLITS = ("auto", "group", "random", "stratified", "time")

#: the condition column :meth:`Ensemble.frames` gives each frame: its recording
FRAME_SOURCE = "source_member"
#: the frame's position in its recording (orders a single recording's frames in time)
FRAME_INDEX = "frame"

RANDOM_WARNING = (
    "random split of members that share a {by} (frames of one recording on both "
    "sides): this measures how well the classifier recognises recordings it has "
    "already seen, not new ones; use the grouped split for a result"
)


@dataclasses.dataclass
class SplitPlan:
    """The held-out split and the groups the training part is cross-validated by.

    Attributes
    ----------
    train_pos, test_pos : numpy.ndarray
        Row positions of the training and test members.
    cv_groups : numpy.ndarray or None
        Group of each training member for grouped folds (None: plain stratified).
    info : dict
        What the JSON's ``split`` holds: ``kind``, ``by`` (the group column) and the
        counts; ``measures`` says in words what the held-out accuracy measures.
    """

    train_pos: np.ndarray
    test_pos: np.ndarray
    cv_groups: np.ndarray | None
    info: dict


def group_column(table: pd.DataFrame, group: str | None) -> str | None:
    """The column holding each member's group: ``group``, or a framed ensemble's source."""
    if group is not None:
        if group not in table.columns:
            conditions = [str(c) for c in table.columns if "/" not in str(c)]
            raise DataError(
                f"group column {group!r} is not in the feature table; condition "
                f"columns found: {conditions}"
            )
        if table[group].isna().any():
            bad = table.index[table[group].isna()]
            raise DataError(f"group column {group!r} is missing for members {_show(bad)}")
        return group
    return FRAME_SOURCE if FRAME_SOURCE in table.columns else None


def resolve_kind(split: str, by: str | None) -> str:
    """The split actually made for ``split=`` when the groups are ``by``."""
    if split not in SPLITS:
        raise DataError(f"split must be one of {list(SPLITS)}; got {split!r}")
    if split == "auto":
        return "group" if by is not None else "random"
    if split == "stratified":
        return "random"
    if split == "group" and by is None:
        raise DataError(
            "split='group' needs groups: pass group= (--group COL), the column naming "
            "each member's recording, session or unit"
        )
    return split


def _rank_in_time(table: pd.DataFrame, rows: np.ndarray) -> np.ndarray:
    """``rows`` in time order: by frame number when framed, else as given."""
    if FRAME_INDEX in table.columns:
        key = pd.to_numeric(table[FRAME_INDEX].iloc[rows], errors="coerce").to_numpy()
        if np.isfinite(key).all():
            return rows[np.argsort(key, kind="stable")]
    return rows


def _time_blocks(
    table: pd.DataFrame, rows: np.ndarray, test_size: float, gap: int
) -> tuple[np.ndarray, np.ndarray]:
    """One recording split in time: earliest rows train, latest test, ``gap`` dropped."""
    ranked = _rank_in_time(table, rows)
    n = len(ranked)
    n_test = max(1, math.ceil(test_size * (n - gap)))
    n_train = n - n_test - gap
    if n_train < 1:
        raise DataError(
            f"a class recorded once has {n} members: too few to split in time with "
            f"test_size={test_size} and a gap of {gap}; add another recording"
        )
    return ranked[:n_train], ranked[n - n_test :]


def _group_split(table, y, groups, test_size, gap, rng, notes):
    """Held-out groups class by class; a class with one group split in time."""
    train, test, blocks = [], [], []
    per_group = pd.DataFrame({"y": y.to_numpy(), "g": groups}).groupby("g")["y"].nunique()
    mixed = per_group.index[per_group > 1]
    if len(mixed):
        return _mixed_group_split(y, groups, test_size, rng, notes)
    for cls in _sorted_plain(y.unique()):
        rows = np.flatnonzero(y.to_numpy() == cls)
        names = list(pd.unique(groups[rows]))
        if len(names) == 1:
            a, b = _time_blocks(table, rows, test_size, gap)
            train.append(a)
            test.append(b)
            blocks.append(_plain(cls))
            continue
        n_test = min(max(1, round(test_size * len(names))), len(names) - 1)
        held = set(rng.choice(np.array(names, dtype=object), n_test, replace=False))
        mask = np.isin(groups[rows], list(held))
        train.append(rows[~mask])
        test.append(rows[mask])
    if blocks:
        notes.append(
            f"class(es) {_show(blocks)} have a single recording, so no honest split "
            f"holds a recording out: its earliest {1 - test_size:.0%} train and its "
            f"latest {test_size:.0%} test, {gap} member(s) dropped between them; record "
            "that class again (another day, another mounting) for a real test"
        )
    return np.concatenate(train), np.concatenate(test), blocks


def _mixed_group_split(y, groups, test_size, rng, notes):
    """Groups holding several classes (sessions, loads): whole groups held out."""
    n_splits = max(2, round(1 / test_size))
    seed = int(rng.integers(2**31 - 1))
    folds = StratifiedGroupKFold(n_splits=n_splits, shuffle=True, random_state=seed)
    try:
        train, test = next(folds.split(np.zeros(len(y)), y.to_numpy(), groups))
    except ValueError as exc:
        raise DataError(
            f"cannot hold out whole groups with test_size={test_size}: {exc}"
        ) from None
    unseen = _sorted_plain(set(y.iloc[test]) - set(y.iloc[train]))
    if unseen:
        notes.append(
            f"class(es) {_show(unseen)} occur only in the held-out groups: the "
            "classifier never saw them"
        )
    return train, test, []


def _cv_groups(table, y, groups, train, blocks, folds: int) -> np.ndarray:
    """Groups of the training members for grouped CV.

    A class whose training members come from one recording is cut into ``folds``
    contiguous time blocks, each its own group (neighbouring blocks touch: the
    notes of :func:`classify` say the folds of such classes are time blocks).
    """
    g = np.asarray(groups[train], dtype=object).copy()
    yt = y.to_numpy()[train]
    for cls in _sorted_plain(set(yt)):
        rows = np.flatnonzero(yt == cls)
        if len(set(g[rows])) > 1 and _plain(cls) not in blocks:
            continue
        ranked = _rank_in_time(table.iloc[train], rows)
        for k, chunk in enumerate(np.array_split(ranked, max(folds, 2))):
            g[chunk] = f"{g[chunk[0]] if len(chunk) else ''}#block{k}"
    return g


def plan_split(
    table: pd.DataFrame,
    y: pd.Series,
    y_all: np.ndarray,
    *,
    split: str,
    group: str | None,
    order: str | None,
    test_size: float,
    gap: int,
    test_where: str | None,
    cv: int | None,
    test_mask: np.ndarray | None = None,
    random_state: int | None,
    notes: list[str],
) -> SplitPlan:
    """The held-out split :func:`classify` makes, and the training part's CV groups."""
    by = group_column(table, group)
    groups = None if by is None else table[by].astype(str).to_numpy(dtype=object)
    rng = np.random.default_rng(random_state)
    blocks: list = []
    if test_mask is not None:
        kind = "table"
        train, test = np.flatnonzero(~test_mask), np.flatnonzero(test_mask)
    elif test_where is not None:
        kind = "where"
        train, test = _where_split(table, test_where)
    else:
        kind = resolve_kind(split, by)
        _check_test_size(y, test_size, kind)
        if kind == "time":
            train, test = time_split(table, y, order, test_size, notes)
        elif kind == "group":
            train, test, blocks = _group_split(table, y, groups, test_size, gap, rng, notes)
        else:
            train, test = train_test_split(
                np.arange(len(y)),
                test_size=test_size,
                stratify=y_all,
                random_state=random_state,
            )
            if by is not None:
                notes.insert(0, RANDOM_WARNING.format(by=f"{by!r}"))
    info: dict[str, Any] = {"kind": kind, "by": by if kind != "time" else order}
    if groups is not None and kind != "time":
        info["groups_train"] = len(set(groups[train]))
        info["groups_test"] = len(set(groups[test]))
        info["groups_on_both_sides"] = len(set(groups[train]) & set(groups[test]))
    if blocks:
        info["time_blocks"] = blocks
        info["gap"] = int(gap)
    if test_where is not None:
        info["where"] = test_where
    info["measures"] = _measures(kind, by, blocks)
    cv_groups = None
    if groups is not None and kind in ("group", "where", "table"):
        cv_groups = _cv_groups(table, y, groups, train, blocks, cv or 2)
    return SplitPlan(np.asarray(train), np.asarray(test), cv_groups, info)


def _where_split(table: pd.DataFrame, expr: str) -> tuple[np.ndarray, np.ndarray]:
    """Rows a pandas query selects test; the others train."""
    try:
        mask = table.eval(expr, engine="python")
    except Exception as exc:
        conditions = [str(c) for c in table.columns if "/" not in str(c)]
        raise DataError(
            f"test_where {expr!r} cannot be evaluated on the feature table "
            f"({type(exc).__name__}: {exc}); condition columns: {conditions}"
        ) from None
    mask = np.asarray(mask)
    if mask.dtype != bool or mask.shape != (len(table),):
        raise DataError(
            f"test_where {expr!r} must give one true/false per member; got "
            f"{mask.dtype} of shape {mask.shape}"
        )
    if mask.all() or not mask.any():
        raise DataError(
            f"test_where {expr!r} selects {int(mask.sum())} of {len(table)} members; "
            "it must leave members on both sides"
        )
    return np.flatnonzero(~mask), np.flatnonzero(mask)


def _measures(kind: str, by: str | None, blocks: list) -> str:
    if kind == "group":
        text = f"recordings never seen in training (whole {by!r} groups held out)"
        if blocks:
            text += f"; for {_show(blocks)} (one recording each) a later time block"
        return text
    if kind == "random":
        if by is not None:
            return (
                f"frames of recordings also seen in training (random split; {by!r} ignored)"
            )
        return "members drawn at random (each member its own recording)"
    if kind == "time":
        return "later members after training on the earlier ones"
    if kind == "where":
        return "the members the test expression selects, never seen in training"
    return "another table's members, never seen in training"


def cv_folds(
    X: np.ndarray,
    y: np.ndarray,
    n_splits: int,
    random_state: int | None,
    groups: np.ndarray | None,
):
    """``(train, test)`` folds of the training part: grouped when ``groups``."""
    if groups is None:
        folds = StratifiedKFold(n_splits=n_splits, shuffle=True, random_state=random_state)
        return list(folds.split(X, y))
    n_groups = len(set(groups))
    n_splits = min(n_splits, n_groups)
    if n_splits < 2:
        return []
    folds = StratifiedGroupKFold(n_splits=n_splits, shuffle=True, random_state=random_state)
    return [(a, b) for a, b in folds.split(X, y, groups) if len(np.unique(y[a])) > 1]


# ------------------------------------------------------------------------ time split
def _order_key(table: pd.DataFrame, order: str | None) -> tuple[np.ndarray, Any]:
    """Sort key of the members in time (numbers, or seconds for timestamps).

    Returned with a function that shows one member's time for messages.
    """
    if order is None:
        return np.arange(len(table), dtype=float), lambda i: f"member {table.index[i]!r}"
    if order not in table.columns:
        conditions = [str(c) for c in table.columns if "/" not in str(c)]
        raise DataError(
            f"order column {order!r} is not in the feature table; condition columns "
            f"found: {conditions}. Pass order= the column that orders members in time"
        )
    column = table[order]
    key, unread = time_as_seconds(column)
    if unread is not None:
        raise DataError(
            f"order column {order!r} holds {str(unread)!r}, neither a number nor a "
            "timestamp; a time split orders members by numbers or timestamps"
        )
    if not np.isfinite(key).all():
        bad = table.index[~np.isfinite(key)]
        raise DataError(
            f"order column {order!r} is missing for members {_show(bad)}; every member "
            "needs its time for a time split"
        )
    return key, lambda i: f"{order}={_plain(column.iloc[i])!r}"


def time_split(
    table: pd.DataFrame,
    y: pd.Series,
    order: str | None,
    test_size: float,
    notes: list[str],
) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the earlier (training) and later (test) members."""
    key, shown = _order_key(table, order)
    ranked = np.argsort(key, kind="stable")
    n = len(ranked)
    n_test = math.ceil(test_size * n)
    train_pos, test_pos = ranked[: n - n_test], ranked[n - n_test :]
    if len(train_pos) == 0:
        raise DataError(
            f"{n} members split in time with test_size={test_size} leave no training "
            "member; lower test_size"
        )
    by = f"by {order!r}" if order is not None else "in the order given"
    notes.append(
        f"time split {by}: trained on the {len(train_pos)} earliest members (up to "
        f"{shown(train_pos[-1])}), tested on the {len(test_pos)} latest (from "
        f"{shown(test_pos[0])})"
    )
    if key[train_pos[-1]] == key[test_pos[0]]:
        notes.append(
            f"members on both sides of the split share the time {shown(test_pos[0])}"
        )
    seen = set(y.iloc[train_pos])
    if len(seen) < 2:
        raise DataError(
            f"the {len(train_pos)} earliest members ({by}) hold only class "
            f"{_show(seen)}; a classifier needs two classes to learn from. Lower "
            "test_size (--test-size) or use the stratified split"
        )
    unseen = _sorted_plain(set(y.iloc[test_pos]) - seen)
    if unseen:
        notes.append(
            f"class(es) {_show(unseen)} appear only among the later (test) members: "
            "the classifier never saw them and cannot predict them"
        )
    return train_pos, test_pos


def _check_test_size(y: pd.Series, test_size: float, kind: str) -> None:
    """``test_size`` is a fraction, and a random split leaves every class both parts."""
    if not isinstance(test_size, float | np.floating) or not 0.0 < test_size < 1.0:
        raise ValueError(f"test_size must be a float in (0, 1); got {test_size!r}")
    n = len(y)
    n_classes = y.nunique()
    n_test = math.ceil(test_size * n)
    n_train = n - n_test
    if kind == "random" and (n_test < n_classes or n_train < n_classes):
        raise DataError(
            f"{n} members split with test_size={test_size} give {n_train} training and "
            f"{n_test} test members, but each part needs at least one member of each of "
            f"the {n_classes} classes; change test_size or add members"
        )
