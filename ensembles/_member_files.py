"""Member files (one recording per file) as an :class:`Ensemble`: :func:`read_members`.

Each file is read by the reader of its format (:func:`read_table`, :func:`read_mat`,
:func:`read_npz`), its sampling rate taken from the file, its time column or an ``fs``
condition, its conditions from its name or a table; a bad file is reported, the others
read on. The members are then brought to one rate (``resample=``) and cut into frames
(``frame=``), see ``_member_labels.py``.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs
from pdmkit._config import max_bytes
from pdmkit._progress import progress as _progress_bar
from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.ensembles._limits import _too_big
from pdmkit.ensembles._matlab_numpy import _read_mat, read_npz
from pdmkit.ensembles._member_labels import (
    _FRAME_WORDS,
    _at_one_rate,
    _condition_rate,
    _frame_specs,
    _in_samples,
    _long_enough,
    _NameConditions,
    _resampled,
    clock_column,
)
from pdmkit.ensembles._member_matlab import nothing_to_read, unpack_mat
from pdmkit.ensembles._member_rates import (
    _time_rate,
    member_rate,
    resampled_multi,
    signal_rates,
    split_rate,
)
from pdmkit.ensembles._table_files import (
    _COMPRESSED,
    _CSV,
    _PARQUET,
    _read_table,
)
from pdmkit.errors import DataError, DataNotFoundError, DataWarning, did_you_mean

__all__ = ["read_members"]


def _member_like(path: Path) -> bool:
    """True when ``path`` is named like a member file (``x.csv``, ``x.mat``, ...)."""
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] in _COMPRESSED:
        suffixes.pop()
    return bool(suffixes) and suffixes[-1] in (*_CSV, *_PARQUET, ".mat", ".npz")


#: Names of a sampling-rate scalar in a .mat / .npz member file.
_FS_NAMES = ("fs", "Fs", "FS", "sampling_rate", "sample_rate")
#: Names of a time column in a CSV / Parquet member file.
_TIME_NAMES = ("time", "t", "Time", "TIME")
_MEMBER_ERRORS = ("member", "signal", "source", "error")
#: Most signals one member file may hold (``$PDMKIT_MAX_SIGNALS``): every signal costs
#: a full set of indicators, so a 35 KB CSV of 2000 three-sample columns cost a minute
#: and a gigabyte before this bound.
MAX_SIGNALS = 1024


def _member_arrays(
    path: Path, notes: list, time: str | None = None
) -> tuple[dict, float | None, dict]:
    """(signals, sampling rate or None, condition values) of one member file.

    What was read other than as written (a boolean signal, a variable skipped) is
    appended to ``notes`` as ``("variable" or "column", its name, what was done)``.
    ``time`` names the time column (or variable); default one of :data:`_TIME_NAMES`.
    """
    signals, fs, conditions = _member_contents(path, notes, time)
    limit = int(os.environ.get("PDMKIT_MAX_SIGNALS", MAX_SIGNALS))
    if len(signals) > limit:
        raise DataError(
            f"{path}: {len(signals)} signal columns, more than the {limit} a member may "
            "hold; is it a table of members or features rather than one recording? "
            "(raise $PDMKIT_MAX_SIGNALS if it really is one)"
        )
    return signals, fs, conditions


#: What a member's variable that is not read is, and why (for the DataWarning).
_NOT_READ = (
    "not a signal (a numeric vector) or a condition (a scalar); skipped. Save what it "
    "holds as numeric variables to read it"
)
#: What a true/false signal became.
_CLOCK_FIELD = (
    "looks like a clock field (whole numbers, constant in the file); kept as a condition "
    "(the recording's time stamp), not a signal"
)
_CLOCK_COUNTER = (
    "looks like a clock or a sample counter (whole numbers counting up); not read as a "
    "signal"
)
_READ_AS_01 = (
    "holds true/false values; read as a signal of 0.0 and 1.0. Save it as numbers if "
    "that is what it means (or as one scalar if it is a condition)"
)


def _unread_variable(value: Any, arr: np.ndarray | None) -> str | None:
    """Why a .mat / .npz variable is neither a signal nor a condition (None: it is one)."""
    if isinstance(value, dict):
        return f"is a MATLAB struct (fields {sorted(value)[:5]}), {_NOT_READ}"
    if arr is None:
        return f"is a {type(value).__name__} object, {_NOT_READ}"
    kind = arr.dtype.kind
    if kind == "O":
        return f"is a MATLAB cell or struct array (shape {arr.shape}), {_NOT_READ}"
    if kind == "V":
        return f"is a structured (record) array {arr.dtype}, {_NOT_READ}"
    if arr.size == 0:
        return f"is empty ({arr.dtype} of shape {arr.shape}), {_NOT_READ}"
    if arr.size == 1 and kind in "USiufb":
        return None  # a condition
    if kind in "iufb" and arr.ndim >= 1:
        return None  # a signal
    return f"holds {arr.dtype} values of shape {arr.shape}, {_NOT_READ}"


def _no_time_column(path: Path, time: str, names: list, what: str) -> DataError:
    return DataError(
        f"{path}: no time {what} {time!r} (time= / --time); it has {names[:12]}"
        f"{did_you_mean(time, names)}. Name its time {what}, or leave time out and "
        "pass fs= (--fs)"
    )


def _member_contents(
    path: Path, notes: list, time: str | None = None
) -> tuple[dict, float | None, dict]:
    """(signals, sampling rate or None, condition values) of one file, by its format."""
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return _variables_contents(path, read_npz(path), notes, time)
    if suffix == ".mat":
        data, listing = _read_mat(path)
        variables, rates, conds = unpack_mat(path, data, notes)
        signals, fs, conditions = _variables_contents(path, variables, notes, time)
        if not signals and listing:
            raise nothing_to_read(path, listing)
        return signals, member_rate(signals, fs, rates), {**conds, **conditions}
    return _table_contents(path, notes, time)


def _time_variable_rate(path: Path, data: dict, time: str) -> float | None:
    """The sampling rate of the time variable ``time``, taken out of ``data``."""
    if time not in data:
        raise _no_time_column(path, time, [str(k) for k in data], "variable")
    stamps = np.asarray(data.pop(time))
    if stamps.dtype.kind not in "iuf" or stamps.size < 2:
        raise DataError(
            f"{path}: time variable {time!r} holds {stamps.dtype} of shape "
            f"{stamps.shape}; expected a vector of times in seconds"
        )
    return _time_rate(
        path, pd.Series(stamps.reshape(-1), name=time), lambda k: f"sample {k}"
    )


def _rate_variable(path: Path, key: str, value: Any, arr: np.ndarray | None) -> float:
    """The sampling rate an ``fs`` variable holds: one positive finite number."""
    rate = (
        float(arr.reshape(-1)[0])
        if arr is not None and arr.size == 1 and arr.dtype.kind in "iuf"
        else None
    )
    if rate is None or not math.isfinite(rate) or rate <= 0:
        found = (
            f"{arr.dtype} of shape {arr.shape}" if arr is not None else type(value).__name__
        )
        raise DataError(
            f"{path}: variable {key!r} should be the sampling rate (one "
            f"positive number, Hz); it holds {found}"
            + (f" = {rate:g}" if rate is not None else "")
        )
    return rate


def _signal_variable(path: Path, key: str, arr: np.ndarray, limit: int) -> np.ndarray:
    """A numeric vector variable as float64 samples, after its shape and size checks."""
    if arr.ndim > 1 and sorted(arr.shape)[-2] != 1:
        raise DataError(
            f"{path}: variable {key!r} has shape {arr.shape}; a member "
            "file holds 1-D signals (or n x 1 columns)"
        )
    if arr.size * 8 > limit:  # as float64, before the copy is made
        raise _too_big(
            f"{path}: signal {key!r} ({arr.size} samples as float64)",
            arr.size * 8,
            limit,
            "takes",
        )
    return arr.reshape(-1).astype(np.float64)


def _variables_contents(
    path: Path, data: dict, notes: list, time: str | None
) -> tuple[dict, float | None, dict]:
    """(signals, rate, conditions) of the variables of a ``.mat`` / ``.npz`` file."""
    signals, fs, conditions = {}, None, {}
    limit = max_bytes("member")
    if time is not None:
        fs = _time_variable_rate(path, data, time)
    for key, value in data.items():
        numeric = isinstance(value, np.ndarray | np.generic | bool | int | float | str)
        arr = np.asarray(value) if numeric or isinstance(value, complex) else None
        if arr is not None and arr.dtype.kind == "c":
            raise DataError(
                f"{path}: variable {key!r} holds complex values ({arr.dtype} of shape "
                f"{arr.shape}); pdmkit reads real signals. Store the real and "
                f"imaginary parts as two signals (e.g. {key}_re and {key}_im)"
            )
        if key in _FS_NAMES:
            fs = _rate_variable(path, key, value, arr)
            continue
        why = _unread_variable(value, arr)
        if why is not None:
            notes.append(("variable", key, why))
        elif arr.size == 1:
            conditions[key] = arr.reshape(-1)[0].item()
        else:
            signal = _signal_variable(path, key, arr, limit)
            if arr.dtype.kind == "b":
                notes.append(("variable", key, _READ_AS_01))
            signals[key] = signal
    return signals, fs, conditions


def _table_contents(
    path: Path, notes: list, time: str | None
) -> tuple[dict, float | None, dict]:
    """(signals, rate, conditions) of the columns of a CSV / Parquet member file."""
    table, where = _read_table(path, {})
    fs = None
    if time is not None and time not in table.columns:
        raise _no_time_column(path, time, [str(c) for c in table.columns], "column")
    if time is None:
        time = next((c for c in _TIME_NAMES if c in table.columns), None)
    if time is not None:
        fs = _time_rate(path, table.pop(time), where)
    signals, conditions = {}, {}
    for c in table.columns:
        column = table[c]
        if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
            values = column.to_numpy(dtype=np.float64)
            clock = clock_column(str(c), values)
            if clock == "constant":
                conditions[str(c)] = float(values[0])
                notes.append(("column", str(c), _CLOCK_FIELD))
            elif clock == "counter":
                notes.append(("column", str(c), _CLOCK_COUNTER))
            else:
                signals[str(c)] = values
        elif column.nunique(dropna=False) == 1:
            conditions[str(c)] = column.iloc[0]
        elif pd.api.types.is_bool_dtype(column):
            notes.append(("column", str(c), _READ_AS_01))
            signals[str(c)] = column.to_numpy(dtype=np.float64)
        else:
            raise DataError(
                f"{path}: column {c!r} holds text that changes from row to row; a member "
                "file holds numeric signal columns, a time column and constant labels"
            )
    return signals, fs, conditions


def _without_clashes(kept: list, fail) -> list:
    """Skip the members where a name is a signal while most members hold it as a label.

    Or the reverse (a label where most members hold a signal): one odd file must not stop
    the others being read.
    """
    from collections import Counter

    as_signal = Counter(s for _, _, a, _ in kept for s in a)
    as_label = Counter(c for _, _, _, cd in kept for c in cd)
    clash = {n for n in as_label if n in as_signal}
    if not clash:
        return kept
    out = []
    for member, path, arrays, conds in kept:
        odd = next(
            (
                n
                for n in sorted(clash)
                if (n in conds and as_signal[n] >= as_label[n])
                or (n in arrays and as_label[n] > as_signal[n])
            ),
            None,
        )
        if odd is None:
            out.append((member, path, arrays, conds))
            continue
        here, there = ("a label", "a signal") if odd in conds else ("a signal", "a label")
        others = as_signal[odd] if odd in conds else as_label[odd]
        fail(
            member,
            odd,
            path,
            f"{path.name}: {odd!r} is {here} here but {there} in {others} other "
            "member file(s)",
        )
    return out


def read_members(
    files: Any,
    *,
    fs: float | None = None,
    signals: Any = None,
    time: str | None = None,
    label_from_name: Any = None,
    labels: Any = None,
    resample: float | None = None,
    frame: int | str | None = None,
    hop: int | str | None = None,
    on_error: str = "raise",
    return_errors: bool = False,
    progress: bool | None = None,
) -> Ensemble | tuple[Ensemble, pd.DataFrame]:
    r"""Build an ensemble from member files: one recording per file.

    A member file is a CSV / Parquet table (numeric columns are signals, a ``time``
    column gives the sampling rate, constant text columns are condition variables such
    as the label), or a ``.mat`` / ``.npz`` file (numeric vectors are signals, a scalar
    ``fs`` gives the sampling rate, other scalars are conditions). The member id is the
    file name without its extension.

    A ``.mat`` file may be v4 to v7.3 (HDF5) and hold what MATLAB users save: a
    struct's fields are read as variables; a timetable's variables are signals at the
    rate of its row times; a one-row table (MATLAB's ensemble member: a table of
    timetables and scalars) gives a signal per timetable, named after the table
    variable, and a condition per scalar or one-row table. Signals may differ in rate
    (a rig's 1 kHz sensors beside 40 kHz microphones): each keeps its own (``fs`` of
    the ensemble), and every member must have each signal at one rate (else that
    member fails, unless ``resample`` brings every signal to one rate); the member's
    rate, which ``fs``, ``frame`` and ``hop`` refer to, is its first signal's. A file
    without a signal pdmkit reads is an error that lists what it holds.

    Member files are untrusted input, read by :func:`read_table`, :func:`read_mat` and
    :func:`read_npz` with their checks (sizes declared before reading against
    ``max_bytes("member")``, header-less CSV files, columns mixing numbers and text),
    plus:

    - a time column must increase uniformly: a missing, repeated or decreasing time
      stamp, or a step that differs from the median step by more than 1 % of it (or by
      more than one unit of the last decimal the stamps are written with, when that is
      larger: stamps rounded to microseconds stay uniform at 25.6 kHz), is an error
      naming the file and the line. The rate is the number of steps over the span;
    - a signal must fit the ceiling as float64 samples;
    - a complex variable of a ``.mat`` / ``.npz`` file is an error naming it (store the
      real and imaginary parts as two signals); a true/false vector (or CSV column) is
      read as a signal of 0.0 and 1.0, and a variable that is neither a numeric vector
      nor a scalar (a MATLAB struct or cell array, text, an empty or structured array)
      is skipped: a :class:`pdmkit.errors.DataWarning` names each, once for all the
      files that hold it;
    - in a folder (or a glob pattern's matches), a sub-folder named like a member file
      (``x.csv/``) is that member's error; other sub-folders are not read, and a
      DataWarning names them.

    Each member's sampling rate is the one its file states (time column, ``fs``
    variable), else its ``fs`` condition (a column ``fs`` of ``labels`` or a named group
    ``(?P<fs>...)`` of ``label_from_name``, in Hz: ``48000``, ``48k``, ``48 kHz``),
    else ``fs``. An ``fs`` condition overrides nothing the file states: a different
    rate is an error naming the file and both. It is taken as the rate, not kept as a
    condition (the ensemble states the rate, as it does a file's ``fs`` variable).

    Files at different rates are never read at one rate. Without ``resample``, every
    member must have ``fs`` (when given) or the most common rate: otherwise a DataError
    names the files and their rates. With ``resample``, every member is resampled to
    that rate (``scipy.signal.resample_poly`` by ``up / down``, the ratio of the rates
    as a fraction of integers of at most 10000; its anti-aliasing filter is scipy's
    default, a Kaiser-windowed FIR low-pass, beta 5, cut off at the lower of the two
    Nyquist frequencies, so content above ``resample / 2`` is removed); a member of
    ``n`` samples gets ``ceil(n * up / down)``, and the condition ``fs_original`` keeps
    the rate it was recorded at.

    With ``frame``, each member is then cut into frames (:meth:`Ensemble.frames`):
    ``frame`` samples long, ``hop`` apart (default ``frame``: no overlap), ``floor((n -
    frame) / hop) + 1`` frames from a member of ``n`` samples, trailing samples
    dropped. Lengths are samples (``2048``, ``"2048"``) or durations (``"0.1s"``,
    ``"100ms"``), turned into samples at the members' (common) rate and rounded to the
    nearest sample. A frame's id is ``"<member>/f<k:04d>"``; its conditions are its
    member's plus ``source_member`` (the member id: frames of one recording belong
    together, e.g. on one side of a train/test split) and ``frame`` (``k``).

    With ``on_error="skip"`` a file that cannot be read or fails a check, a member
    lacking a signal named in ``signals``, a signal with NaN or inf samples, a sampling
    rate that differs from ``fs`` (default: the most common rate of the files) when
    there is no ``resample``, or a member shorter than one frame leaves that member out
    and adds a row to the errors table (with the reason); the other members are read as
    if the bad file were not there.

    Parameters
    ----------
    files : path, glob pattern or sequence of them
        Member files; a directory stands for all the files in it.
    fs : float, optional
        Sampling rate in Hz of the files that state none (no time column, ``fs``
        variable or ``fs`` condition); without ``resample`` also the rate every member
        must have. Required when no file states its own.
    signals : sequence of str, optional
        Signals every member must have (default: all found; a member lacking one gets
        None there).
    time : str, optional
        The time column of CSV / Parquet members (or time variable of ``.mat`` /
        ``.npz`` members, in seconds) when it is not named ``time``, ``t``, ``Time``
        or ``TIME``; a member without it is an error naming the file.
    label_from_name : str or re.Pattern, optional
        A regular expression searched in each member's file name: its one group
        becomes the condition ``label``, or its named groups (``(?P<fault>...)``)
        conditions of their names, so a label need not be repeated on every row of a
        member file. A file whose name does not match is an error naming it.
    labels : path or DataFrame, optional
        A table (CSV / Parquet, read by :func:`read_table`) with a column ``file``
        (or ``member``, ``name``, ``filename``, ``path``) naming each member file
        (``a.csv``) or member id (``a``), and condition columns beside it (a column
        ``fs``: each file's sampling rate). A member file the table does not list is
        an error naming it; rows naming no file read give a DataWarning. A condition
        given twice with different values (in the file, by its name, in the table) is
        an error.
    resample : float, optional
        Resample every member to this rate in Hz (see above).
    frame : int or str, optional
        Cut every member into frames of this length: samples, or ``"0.1s"`` /
        ``"100ms"``.
    hop : int or str, optional
        The distance between frame starts (samples or a duration); needs ``frame``.
    on_error : {"raise", "skip"}, default "raise"
    return_errors : bool, default False
        Also return the errors table (columns ``member``, ``signal``, ``source``,
        ``error``).
    progress : bool, optional
        A progress bar over the files; default only when stderr is a terminal.

    Returns
    -------
    Ensemble, or (Ensemble, DataFrame) with ``return_errors``

    Raises
    ------
    pdmkit.errors.DataError
        With ``on_error="raise"``: the first bad file (the message names it and says
        what was expected and found), or files at different rates without ``resample``
        (all named, with their rates). Always: no file matched, no member was left, a
        bad ``frame`` / ``hop`` / ``resample``.

    Warns
    -----
    pdmkit.errors.DataWarning
        A variable or column read as 0/1 or skipped, or a sub-folder not read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> t = np.arange(100) / 50.0
    >>> pd.DataFrame({"time": t, "vib": np.sin(t), "fault": "ir"}).to_csv(
    ...     d / "a.csv", index=False)
    >>> pd.DataFrame({"time": t / 2, "vib": np.cos(t), "fault": "ok"}).to_csv(
    ...     d / "b.csv", index=False)
    >>> _ = (d / "c.csv").write_bytes(b"\x00\x01garbage")
    >>> ens, errors = read_members(d, fs=50.0, on_error="skip", return_errors=True)
    >>> ens.member_ids.tolist(), ens.conditions["fault"].tolist()
    (['a'], ['ir'])
    >>> errors["member"].tolist()
    ['b', 'c']
    >>> print(errors["error"].iloc[0])
    b.csv is sampled at 100 Hz; expected 50 Hz (fs as given); pass resample= (--resample
    HZ) to read it; member skipped

    Files at two rates are an error naming them, unless resampled to one; here in
    frames of 0.5 s (25 samples at 50 Hz) every 0.2 s: a has 100 samples at 50 Hz
    (8 frames), b 100 at 100 Hz (50 at 50 Hz: 3 frames):

    >>> read_members([d / "a.csv", d / "b.csv"])
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: member files at different sampling rates: b.csv is ...
    >>> ens = read_members([d / "a.csv", d / "b.csv"], resample=50.0, frame="0.5s",
    ...                    hop="200ms")
    >>> len(ens), ens.fs["vib"], ens.stack("vib")[0].shape
    (11, 50.0, (11, 25))
    >>> ens.conditions.loc["b/f0002", ["source_member", "frame", "fs_original"]].to_dict()
    {'source_member': 'b', 'frame': 2, 'fs_original': 100.0}

    The label from the file names, and a time column named otherwise:

    >>> e = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("run1_IR.csv", "run2_OR.csv"):
    ...     pd.DataFrame({"sec": t, "vib": np.sin(t)}).to_csv(e / name, index=False)
    >>> ens = read_members(e, time="sec", label_from_name=r"_([A-Z]+)[.]csv")
    >>> ens.conditions["label"].tolist(), ens.fs["vib"]
    (['IR', 'OR'], 50.0)
    """
    if on_error not in ("raise", "skip"):
        raise ValueError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    target = None if resample is None else check_fs(resample, "resample (--resample)")
    lengths = _frame_specs(frame, hop)
    patterns = [files] if isinstance(files, str | os.PathLike) else list(files)
    paths = _member_paths(patterns)
    wanted = (
        None
        if signals is None
        else [signals]
        if isinstance(signals, str)
        else list(signals)
    )
    log = _MemberErrors(on_error)
    read: list[tuple[str, Path, dict, float | None, dict]] = []
    noted: dict[tuple[str, str, str], list[Path]] = {}
    multi: dict[Path, dict] = {}  # signals at another rate than their member's
    named = _NameConditions(label_from_name, labels)
    for path in _progress_bar(paths, desc="reading members", enable=progress):
        member = _read_member(path, time, wanted, named, noted, log.fail, multi)
        if member is not None:
            read.append(member)
    named.warn_unused()
    for (what, name, done), where in noted.items():
        warnings.warn(
            f"{_files_named(where)}: {what} {name!r} {done}", DataWarning, stacklevel=2
        )
    if target is None:
        kept, rate = _at_one_rate(read, fs, log.on_error, log.fail)
    else:
        single = [r for r in read if r[1] not in multi]
        kept = _resampled(single, fs, target, wanted, log.fail) + resampled_multi(
            [r for r in read if r[1] in multi], multi, target, wanted, log.fail
        )
        order = {p: i for i, p in enumerate(paths)}
        kept.sort(key=lambda row: order.get(row[1], -1))
        rate, multi = target, {}
    kept = _without_clashes(kept, log.fail)
    kept, rates = signal_rates(kept, rate, multi, wanted, log.fail)
    if lengths is not None and kept:  # none kept: the error says why, below
        length, step = (
            _in_samples(s, rate, w) for s, w in zip(lengths, _FRAME_WORDS, strict=True)
        )
        kept = _long_enough(kept, length, rate, wanted, log.fail)
    ens = _members_ensemble([(m, a, c) for m, _, a, c in kept], wanted, rates, paths, log)
    if lengths is not None:
        ens = ens.frames(length, hop=step)
    return (ens, log.table(paths)) if return_errors else ens


def _member_paths(patterns: list) -> list[Path]:
    """The files that paths, folders and glob patterns name, in order.

    A sub-folder not named like a member file is not read (a DataWarning names it).
    """
    import glob

    paths: list[Path] = []
    folders: list[Path] = []  # sub-folders not named like a member file: not read
    for p in patterns:
        p = Path(p)
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if not q.name[0] == ".")
        elif any(ch in str(p) for ch in "*?["):
            found = sorted(Path(q) for q in glob.glob(str(p)))
        else:
            paths.append(p)  # a folder named here is the member's error
            continue
        for q in found:
            if q.is_file() or _member_like(q):  # a folder 'x.csv' is the member's error
                paths.append(q)
            elif q.is_dir():
                folders.append(q)
    if folders:
        shown = ", ".join(str(q) for q in folders[:3])
        more = f" and {len(folders) - 3} more" if len(folders) > 3 else ""
        warnings.warn(
            f"{len(folders)} sub-folder(s) not read as members: {shown}{more}; a member "
            "is one file, and only the files directly in a folder are read. Name the "
            f"files inside a sub-folder to read them too (e.g. {folders[0] / '*'})",
            DataWarning,
            stacklevel=3,  # read_members' caller
        )
    if not paths:
        raise DataNotFoundError(f"no member files match {[str(p) for p in patterns]}")
    return paths


class _MemberErrors:
    """The members left out and why (``on_error="skip"``), or the first one raised."""

    def __init__(self, on_error: str) -> None:
        self.on_error = on_error
        self.errors: list[dict] = []

    def fail(self, member: str, signal: Any, path: Path, message: str) -> None:
        """Raise ``message`` as a DataError, or note the member as skipped."""
        if self.on_error == "raise":
            raise DataError(message)
        self.errors.append(
            {
                "member": member,
                "signal": signal,
                "source": str(path),
                "error": f"{message}; member skipped",
            }
        )

    def table(self, paths: list[Path]) -> pd.DataFrame:
        """The errors table, in the order of the files."""
        order = {str(p): i for i, p in enumerate(paths)}
        self.errors.sort(key=lambda e: order.get(e["source"], -1))
        return pd.DataFrame(self.errors, columns=list(_MEMBER_ERRORS))


def _read_member(
    path: Path,
    time: str | None,
    wanted: list | None,
    named: _NameConditions,
    noted: dict,
    fail: Callable,
    multi: dict,
) -> tuple[str, Path, dict, float | None, dict] | None:
    """``(member, path, signals, rate, conditions)`` of one file, or None if it failed.

    What was read other than as written is added to ``noted`` (note -> files); the
    signals at another rate than the member's (first signal's) to ``multi[path]``.
    """
    member = path.name.split(".")[0]
    notes: list[tuple[str, str, str]] = []
    try:
        extra = named.conditions(path)
        arrays, rate, conds = _member_arrays(path, notes, time)
        rate, odd = split_rate(rate, arrays, wanted)
        conds = named.merge(path, conds, extra)
        rate = _condition_rate(path, conds, rate)  # an fs condition: the rate
    except DataError as exc:
        fail(member, None, path, str(exc))
        return None
    for note in notes:
        noted.setdefault(note, []).append(path)
    if not arrays:
        fail(member, None, path, f"{path.name} holds no numeric signal")
        return None
    missing = [s for s in wanted or () if s not in arrays]
    if missing:
        fail(
            member,
            missing[0],
            path,
            f"{path.name} lacks signal(s) {missing}; it has {sorted(arrays)}",
        )
        return None
    bad = [s for s, x in arrays.items() if not np.isfinite(x).all()]
    if bad:
        x = arrays[bad[0]]
        fail(
            member,
            bad[0],
            path,
            f"signal {bad[0]!r} of {path.name} holds {int((~np.isfinite(x)).sum())} "
            f"NaN/inf value(s) (first at sample {int(np.argmax(~np.isfinite(x)))})",
        )
        return None
    if odd:
        multi[path] = odd
    return member, path, arrays, rate, conds


def _files_named(where: list[Path]) -> str:
    """The one file, or how many and the first three names."""
    if len(where) == 1:
        return str(where[0])
    return f"{len(where)} member files ({', '.join(p.name for p in where[:3])}" + (
        ", ...)" if len(where) > 3 else ")"
    )


def _members_ensemble(
    kept: list, wanted: list | None, fs: dict, paths: list, log: _MemberErrors
) -> Ensemble:
    """The ensemble of the ``(member, signals, conditions)`` read; none is an error.

    ``fs`` holds each signal's rate.
    """
    if not kept:
        first = f"; e.g. {log.errors[0]['error']}" if log.errors else ""
        raise DataError(f"no member could be read from {len(paths)} file(s){first}")
    names = wanted or list(dict.fromkeys(s for _, a, _ in kept for s in a))
    ids = [m for m, _, _ in kept]
    if len(set(ids)) != len(ids):
        dup = sorted({m for m in ids if ids.count(m) > 1})
        raise DataError(f"member files share the names {dup[:5]}; rename them")
    return Ensemble(
        {s: [a.get(s) for _, a, _ in kept] for s in names},
        fs={s: fs[s] for s in names},
        conditions=pd.DataFrame([c for _, _, c in kept]) if kept else None,
        member_ids=ids,
    )
