"""Loaders for the shared recorded datasets (``pdmkit.data_dir()``; see its README).

Each loader reads the files as their authors distribute them and fails with
:class:`pdmkit.errors.DataNotFoundError` (saying where it looked and what to put
there) when they are absent. The examples run only where the data are present.
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs, check_int
from pdmkit._config import data_dir
from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.ensembles._matlab_numpy import read_mat, read_npz
from pdmkit.ensembles._signals import _names_list, resample_poly_1d, resample_ratio
from pdmkit.ensembles._table_files import read_table
from pdmkit.errors import DataError, DataNotFoundError

__all__ = [
    "BATTERY_EOL_AH",
    "DATASETS",
    "load_cascaded_tanks",
    "load_cmapss",
    "load_cwru",
    "load_dataset",
    "load_emps",
    "load_nasa_battery",
    "load_silverbox",
]


def _folder(name: str, source: str) -> Path:
    try:
        return data_dir(name, must_exist=True)
    except DataNotFoundError as exc:
        raise DataNotFoundError(f"{exc} (the files come from {source})") from None


def _need(folder: Path, names: Sequence[str], source: str) -> Path:
    """The first of ``names`` that exists in ``folder``."""
    for name in names:
        if (folder / name).is_file():
            return folder / name
    present = sorted(p.name for p in folder.iterdir())
    raise DataNotFoundError(
        f"{folder} has no {' or '.join(names)} (it holds "
        f"{_names_list(present) or 'nothing'}); "
        f"put the file there (from {source}) or point $PDMKIT_DATA elsewhere"
    )


def _vector(data: dict[str, Any], key: str, file: Path) -> np.ndarray:
    if key not in data:
        raise DataError(
            f"{file} has no variable {key!r}; it holds {_names_list(sorted(data))}"
        )
    try:
        x = np.asarray(data[key], dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise DataError(f"variable {key!r} of {file} is not numeric") from None
    if not np.isfinite(x).all():
        raise DataError(
            f"variable {key!r} of {file} holds {int((~np.isfinite(x)).sum())} non-finite "
            "values"
        )
    return x


def _scalar(data: dict[str, Any], key: str, file: Path) -> float:
    x = _vector(data, key, file)
    if x.size != 1:
        raise DataError(f"variable {key!r} of {file} should be one number; got {x.size}")
    return float(x[0])


# --------------------------------------------------------------------------------------
# CWRU bearings
# --------------------------------------------------------------------------------------

_CWRU_SOURCE = "the CWRU Bearing Data Center, 0 hp / 1797 rpm records, converted to .npz"
# fault label, file, native rate (Hz), fault diameter (in), location
_CWRU_RECORDS = (
    ("normal", "1797_Normal.npz", 48000.0, 0.0, "none"),
    ("IR_007", "1797_IR_7_DE12.npz", 12000.0, 0.007, "inner_race"),
    ("IR_021", "1797_IR_21_DE12.npz", 12000.0, 0.021, "inner_race"),
    ("B_007", "1797_B_7_DE12.npz", 12000.0, 0.007, "ball"),
    ("OR_007", "1797_OR@6_7_DE12.npz", 12000.0, 0.007, "outer_race"),
)
_CWRU_SIGNALS = ("DE", "FE", "BA")


def load_cwru(
    frame_length: int = 2048,
    fs: float = 12000.0,
    signals: Sequence[str] = ("DE", "FE", "BA"),
    faults: Sequence[str] | None = None,
) -> Ensemble:
    """CWRU bearing vibration at 0 hp / 1797 rpm, cut into frames.

    Five records of folder ``cwru_bearing/``: normal (48 kHz, no base accelerometer),
    inner race 0.007" and 0.021", ball 0.007", outer race 0.007" at 6 o'clock (12 kHz,
    drive-end fault data). Every record is first brought to ``fs`` with
    ``scipy.signal.resample_poly`` (the normal one by 1/4 at the default 12 kHz), so a
    classifier cannot tell the classes apart by their rate, then cut into
    non-overlapping frames of ``frame_length`` samples (trailing samples dropped).

    Parameters
    ----------
    frame_length : int, default 2048
        Samples per frame (at ``fs``).
    fs : float, default 12000.0
        Common sampling rate in Hz.
    signals : sequence of str, default ("DE", "FE", "BA")
        Accelerometers: drive end, fan end, base. The normal record has no ``BA``:
        its frames hold None there.
    faults : sequence of str, optional
        Subset of ``"normal", "IR_007", "IR_021", "B_007", "OR_007"`` (default: all).

    Returns
    -------
    Ensemble
        One member per frame, id ``"<fault>/f<k:04d>"``; conditions ``fault``,
        ``fault_diameter_in``, ``location`` (``"none"``, ``"inner_race"``, ``"ball"``,
        ``"outer_race"``), ``rpm`` (1797), ``record`` (file stem), ``source_member``
        (the fault label) and ``frame``.

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The folder or a record file is missing.

    References
    ----------
    W. Smith, R. Randall, "Rolling element bearing diagnostics using the Case Western
    Reserve University data: a benchmark study", MSSP 64-65 (2015).

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> if data_dir("cwru_bearing").is_dir():
    ...     ens = load_cwru(frame_length=2048)
    ...     assert sorted(set(ens.conditions["fault"])) == [
    ...         "B_007", "IR_007", "IR_021", "OR_007", "normal"]
    ...     assert ens.fs == {"DE": 12000.0, "FE": 12000.0, "BA": 12000.0}
    """
    frame_length = check_int(frame_length, "frame_length")
    fs = check_fs(fs, "fs")
    signals = [signals] if isinstance(signals, str) else list(signals)
    unknown = [s for s in signals if s not in _CWRU_SIGNALS]
    if unknown or not signals or len(set(signals)) != len(signals):
        raise DataError(
            f"signals must be distinct names among {_CWRU_SIGNALS}; got {list(signals)}"
        )
    labels = [r[0] for r in _CWRU_RECORDS]
    chosen = labels if faults is None else ([faults] if isinstance(faults, str) else faults)
    bad = [f for f in chosen if f not in labels]
    if bad or not chosen:
        raise DataError(f"faults must be among {labels}; got {list(chosen)}")
    if "normal" in chosen and signals == ["BA"]:
        raise DataError(
            "the normal CWRU record has no base accelerometer BA; add 'DE' or 'FE' to "
            "signals, or leave 'normal' out of faults"
        )

    folder = _folder("cwru_bearing", _CWRU_SOURCE)
    arrays: dict[str, list[np.ndarray | None]] = {s: [] for s in signals}
    rows = []
    for label, name, native, diameter, location in _CWRU_RECORDS:
        if label not in chosen:
            continue
        file = _need(folder, [name], _CWRU_SOURCE)
        data = read_npz(file)
        up, down = resample_ratio(native, fs, f"CWRU record {file.name}")
        for s in signals:
            x = _vector(data, s, file) if s in data else None
            arrays[s].append(None if x is None else resample_poly_1d(x, up, down))
        rows.append(
            {
                "fault": label,
                "fault_diameter_in": diameter,
                "location": location,
                "rpm": 1797,
                "record": file.stem,
            }
        )
    ids = [r["fault"] for r in rows]
    records = Ensemble(arrays, fs, conditions=pd.DataFrame(rows), member_ids=ids)
    return records.frames(frame_length)


# --------------------------------------------------------------------------------------
# C-MAPSS turbofan
# --------------------------------------------------------------------------------------

_CMAPSS_SOURCE = "the NASA Prognostics Data Repository (C-MAPSS, Saxena et al. 2008)"
CMAPSS_COLUMNS = (
    "unit",
    "cycle",
    *(f"setting_{i}" for i in range(1, 4)),
    *(f"sensor_{i}" for i in range(1, 22)),
)


def _is_numeric_line(line: str) -> bool:
    tokens = line.split()
    if not tokens:
        return False
    try:
        [float(t) for t in tokens]
    except ValueError:
        return False
    return True


def _read_numbers(file: Path, n_columns: int) -> np.ndarray:
    """A whitespace-separated numeric text file; header lines at the top are skipped."""
    try:
        lines = file.read_text(encoding="latin-1").splitlines()
    except OSError as exc:
        raise DataError(f"cannot read {file} ({exc})") from None
    skip = 0
    while skip < len(lines) and not _is_numeric_line(lines[skip]):
        skip += 1
    if skip == len(lines):
        raise DataError(f"{file} holds no numeric rows")
    try:
        data = np.loadtxt(io.StringIO("\n".join(lines[skip:])), dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise DataError(
            f"{file} is damaged: {exc} (counting rows after {skip} header line(s))"
        ) from None
    if data.shape[1] != n_columns:
        raise DataError(f"{file} has {data.shape[1]} columns; expected {n_columns}")
    return data


def load_cmapss(subset: str = "FD001", part: str = "train") -> pd.DataFrame:
    """NASA C-MAPSS turbofan run-to-failure data as a long table.

    Reads ``cmapss_fd001/{train,test}_<subset>.txt`` (26 whitespace-separated columns:
    unit, cycle, three operational settings, 21 sensors). Lines at the top that do not
    parse as numbers are skipped: the copies of ``train/test/RUL_FD001`` here carry one
    added header line (whose names do not match the 26 columns), the FD003 files none.

    Parameters
    ----------
    subset : {"FD001", "FD002", "FD003", "FD004"}
        Which simulation campaign (the shared folder holds FD001 and the FD003 test part).
    part : {"train", "test"}
        ``"train"``: engines run to failure; ``"test"``: engines stopped before failure.

    Returns
    -------
    pandas.DataFrame
        One row per unit and cycle: ``unit``, ``cycle`` (int), ``setting_1..3``,
        ``sensor_1..21``; for ``"train"`` also ``rul`` = last cycle of the unit - cycle;
        for ``"test"`` also ``rul_true_final``, the true remaining life after the unit's
        last cycle (from ``RUL_<subset>.txt``, line i for unit i).

    References
    ----------
    A. Saxena, K. Goebel, D. Simon, N. Eklund, "Damage propagation modeling for aircraft
    engine run-to-failure simulation", PHM 2008.

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> if (data_dir("cmapss_fd001") / "train_FD001.txt").is_file():
    ...     train = load_cmapss("FD001", "train")
    ...     assert train["unit"].nunique() == 100 and len(train) == 20631
    ...     assert (train.groupby("unit")["rul"].min() == 0).all()
    """
    subset = str(subset).upper()
    if not re.fullmatch(r"FD00[1-4]", subset):
        raise DataError(f"subset must be one of FD001..FD004; got {subset!r}")
    if part not in ("train", "test"):
        raise DataError(f"part must be 'train' or 'test'; got {part!r}")
    folder = _folder("cmapss_fd001", _CMAPSS_SOURCE)
    file = _need(folder, [f"{part}_{subset}.txt"], _CMAPSS_SOURCE)
    data = _read_numbers(file, len(CMAPSS_COLUMNS))
    table = pd.DataFrame(data, columns=list(CMAPSS_COLUMNS))
    table[["unit", "cycle"]] = table[["unit", "cycle"]].astype(np.int64)
    units = np.unique(table["unit"].to_numpy())
    if part == "train":
        last = table.groupby("unit")["cycle"].transform("max")
        table["rul"] = (last - table["cycle"]).astype(np.int64)
    else:
        rul_file = _need(folder, [f"RUL_{subset}.txt"], _CMAPSS_SOURCE)
        rul = _read_numbers(rul_file, 1)[:, 0]
        if not np.array_equal(units, np.arange(1, len(units) + 1)) or len(rul) != len(
            units
        ):
            raise DataError(
                f"{rul_file} gives {len(rul)} true RULs for {len(units)} units in {file} "
                f"(units {units.min()}..{units.max()}); expected one line per unit 1..N"
            )
        table["rul_true_final"] = rul.astype(np.int64)[table["unit"].to_numpy() - 1]
    return table


# --------------------------------------------------------------------------------------
# nonlinear system-identification benchmarks
# --------------------------------------------------------------------------------------

_TANKS_SOURCE = "nonlinearbenchmark.org, Cascaded Tanks (Schoukens et al. 2016)"


def load_cascaded_tanks() -> dict[str, Any]:
    """The Cascaded Tanks benchmark (two stacked water tanks with overflow).

    Reads ``cascaded_tanks/dataBenchmark.mat`` (or ``dataBenchmark.csv`` when the
    ``.mat`` is absent; the CSV rounds to 5 significant digits).

    Returns
    -------
    dict
        ``uEst, yEst`` (estimation) and ``uVal, yVal`` (validation): 1-D float64, 1024
        samples each, u = pump voltage (V), y = lower-tank level sensor (V);
        ``Ts`` = 4.0 s and ``fs`` = 0.25 Hz.

    References
    ----------
    M. Schoukens, P. Mattsson, T. Wigren, J.-P. Noël, "Cascaded tanks benchmark combining
    soft and hard nonlinearities", Workshop on Nonlinear System Identification
    Benchmarks, 2016.

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> if data_dir("cascaded_tanks").is_dir():
    ...     tanks = load_cascaded_tanks()
    ...     assert tanks["uEst"].shape == (1024,) and tanks["Ts"] == 4.0
    """
    folder = _folder("cascaded_tanks", _TANKS_SOURCE)
    file = _need(folder, ["dataBenchmark.mat", "dataBenchmark.csv"], _TANKS_SOURCE)
    if file.suffix == ".mat":
        data = read_mat(file)
    else:
        table = read_table(file)
        data = {c: table[c].dropna().to_numpy() for c in table.columns}
    out: dict[str, Any] = {
        k: _vector(data, k, file) for k in ("uEst", "yEst", "uVal", "yVal")
    }
    if len({len(v) for v in out.values()}) != 1:
        raise DataError(f"{file}: uEst, yEst, uVal, yVal have different lengths")
    out["Ts"] = _scalar(data, "Ts", file)
    out["fs"] = 1.0 / out["Ts"]
    return out


_SILVERBOX_SOURCE = "nonlinearbenchmark.org, Silverbox (Wigren & Schoukens 2013)"
SILVERBOX_FS = 1e7 / 2**14
"""Silverbox sampling rate, 10 MHz / 2**14 = 610.3515625 Hz (Wigren & Schoukens 2013)."""


def load_silverbox(record: str = "SNLS80mV") -> dict[str, Any]:
    """The Silverbox benchmark (electronic mass-spring-damper with cubic stiffness).

    The shared folder ``silverbox/`` holds two records, each as ``.mat`` and ``.csv``:
    ``SNLS80mV`` (the benchmark record of the technical note: a filtered Gaussian
    "arrow" followed by ten odd random-phase multisines) and ``Schroeder80mV`` (extra
    data, not in the technical note, with one Schroeder-phase multisine). Both carry
    ``V1`` (input), ``V2`` (output), 131072 samples, and overload flags ``Ovld1``,
    ``Ovld2`` (the README of the data folder mentions only V1, V2; the ``.mat`` files
    store row vectors, the CSVs have a trailing empty column and the Schroeder CSV the
    flags in its first row only). The ``.mat`` is read when present, else the CSV.

    Parameters
    ----------
    record : {"SNLS80mV", "Schroeder80mV"}

    Returns
    -------
    dict
        ``V1`` input voltage and ``V2`` output voltage (1-D float64, V, raw: offsets
        not removed), ``fs`` = 610.3515625 Hz, ``Ts`` = 1/fs, ``record``,
        ``overload`` (True if a channel overloaded, None when the file has no flags);
        for ``Schroeder80mV`` also ``schroeder_period``, the slice of one 1024-sample
        Schroeder period named in the folder's README.txt (MATLAB 10585:11608).

    References
    ----------
    T. Wigren, J. Schoukens, "Three free data sets for development and benchmarking in
    nonlinear system identification", ECC 2013.

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> if data_dir("silverbox").is_dir():
    ...     sb = load_silverbox()
    ...     assert sb["V1"].shape == sb["V2"].shape == (131072,)
    ...     assert abs(sb["fs"] - 610.35) < 0.01
    """
    records = ("SNLS80mV", "Schroeder80mV")
    if record not in records:
        raise DataError(f"record must be one of {records}; got {record!r}")
    folder = _folder("silverbox", _SILVERBOX_SOURCE)
    file = _need(folder, [f"{record}.mat", f"{record}.csv"], _SILVERBOX_SOURCE)
    if file.suffix == ".mat":
        data = read_mat(file)
    else:
        table = read_table(file)
        data = {c: table[c].dropna().to_numpy() for c in table.columns}
    out: dict[str, Any] = {"V1": _vector(data, "V1", file), "V2": _vector(data, "V2", file)}
    if out["V1"].shape != out["V2"].shape:
        raise DataError(f"{file}: V1 and V2 have different lengths")
    flags = [_scalar(data, k, file) for k in ("Ovld1", "Ovld2") if k in data]
    out.update(
        fs=SILVERBOX_FS,
        Ts=1.0 / SILVERBOX_FS,
        record=record,
        overload=bool(any(flags)) if flags else None,
    )
    if record == "Schroeder80mV":
        out["schroeder_period"] = slice(10584, 10584 + 1024)
    return out


_EMPS_SOURCE = "nonlinearbenchmark.org, EMPS (Janot, Gautier, Brunot 2019)"


def load_emps(part: str = "estimation") -> dict[str, Any]:
    """The EMPS benchmark (electro-mechanical positioning system, closed loop, friction).

    Parameters
    ----------
    part : {"estimation", "validation"}
        ``DATA_EMPS.mat`` or ``DATA_EMPS_PULSES.mat`` (with force pulses) in ``emps/``.

    Returns
    -------
    dict
        ``t`` (s), ``qm`` motor position (m), ``qg`` reference position (m), ``vir``
        control voltage (V), ``force`` = ``gtau * vir`` (N), the gains ``kp``, ``kv``,
        ``gtau`` (float), ``fs`` in Hz (from the time vector: 1000.0), ``Ts`` = 1/fs,
        ``part``; for ``"validation"`` also ``pulses_N``, the applied force pulses (N).

    References
    ----------
    A. Janot, M. Gautier, M. Brunot, "Data set and reference models of EMPS",
    Workshop on Nonlinear System Identification Benchmarks, 2019.

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> if data_dir("emps").is_dir():
    ...     emps = load_emps()
    ...     assert emps["qm"].shape == (24841,) and emps["fs"] == 1000.0
    """
    files = {"estimation": "DATA_EMPS.mat", "validation": "DATA_EMPS_PULSES.mat"}
    if part not in files:
        raise DataError(f"part must be 'estimation' or 'validation'; got {part!r}")
    folder = _folder("emps", _EMPS_SOURCE)
    file = _need(folder, [files[part]], _EMPS_SOURCE)
    data = read_mat(file)
    out: dict[str, Any] = {k: _vector(data, k, file) for k in ("t", "qm", "qg", "vir")}
    if len({len(v) for v in out.values()}) != 1:
        raise DataError(f"{file}: t, qm, qg, vir have different lengths")
    for k in ("kp", "kv", "gtau"):
        out[k] = _scalar(data, k, file)
    out["force"] = out["gtau"] * out["vir"]
    t = out["t"]
    span = t[-1] - t[0]
    if len(t) < 2 or not span > 0:
        raise DataError(f"{file}: the time vector t does not increase")
    # rate from the whole span (per-step jitter is ~1e-8 s); round off float noise
    out["fs"] = float(np.round((len(t) - 1) / span, 6))
    out["Ts"] = 1.0 / out["fs"]
    out["part"] = part
    if "pulses_N" in data:
        out["pulses_N"] = _vector(data, "pulses_N", file)
    return out


# --------------------------------------------------------------------------------------
# NASA Li-ion battery ageing
# --------------------------------------------------------------------------------------

_BATTERY_SOURCE = (
    "the NASA Prognostics Data Repository (Li-ion battery, Saha & Goebel 2007)"
)
BATTERY_CELLS = ("B0005", "B0006", "B0007", "B0018")
#: End-of-life capacity (Ah) of the NASA cells: 30 % fade of the 2 Ah rating, where the
#: experiments were meant to stop.
BATTERY_EOL_AH = 1.4


def load_nasa_battery(
    cells: Sequence[str] | None = None, *, eol_capacity: float | None = BATTERY_EOL_AH
) -> pd.DataFrame:
    """NASA Li-ion battery ageing (cells B0005, B0006, B0007, B0018) as a long table.

    Reads ``nasa_battery/<cell>_cycle_summary.csv``: one row per discharge of the
    cell's charge / discharge ageing cycles at 24 °C (2 A constant-current discharges).
    With ``eol_capacity`` a cell's life ends at its first discharge whose capacity is
    below it (``failed`` True there, later rows dropped); a cell that never gets there
    is right-censored (``failed`` False on all its rows: B0007 at 1.4 Ah, whose lowest
    capacity is 1.4004 Ah).

    Parameters
    ----------
    cells : sequence of str, optional
        Cells to read (default all four).
    eol_capacity : float or None, default 1.4
        End-of-life capacity in Ah; None keeps every discharge and no ``failed``.

    Returns
    -------
    pandas.DataFrame
        ``unit`` (cell name), ``cycle`` (discharge number, from 1), ``capacity`` (Ah),
        ``soh`` (% of the first capacity), ``voltage`` (V, mean of the discharge),
        ``temperature`` (°C), ``discharge_time`` (s) and, with ``eol_capacity``,
        ``failed``.

    References
    ----------
    B. Saha, K. Goebel, "Battery data set", NASA Prognostics Data Repository, 2007.

    Examples
    --------
    >>> from pdmkit import data_dir
    >>> if (data_dir("nasa_battery") / "B0005_cycle_summary.csv").is_file():
    ...     cells = load_nasa_battery()
    ...     ends = cells.groupby("unit")["cycle"].max().to_dict()
    ...     assert ends == {"B0005": 125, "B0006": 109, "B0007": 168, "B0018": 97}
    """
    names = list(BATTERY_CELLS if cells is None else cells)
    unknown = [c for c in names if c not in BATTERY_CELLS]
    if unknown or not names:
        raise DataError(f"cells must be some of {list(BATTERY_CELLS)}; got {names!r}")
    folder = _folder("nasa_battery", _BATTERY_SOURCE)
    parts = []
    for cell in names:
        file = _need(folder, [f"{cell}_cycle_summary.csv"], _BATTERY_SOURCE)
        raw = read_table(file)
        need = ["discharge", "capacity", "soh", "voltage", "temperature", "time"]
        missing = [c for c in need if c not in raw.columns]
        if missing:
            raise DataError(
                f"{file} lacks column(s) {missing}; expected {need} (a NASA battery "
                "cycle summary)"
            )
        table = pd.DataFrame(
            {
                "unit": cell,
                "cycle": raw["discharge"].astype(np.int64),
                "capacity": raw["capacity"].astype(float),
                "soh": raw["soh"].astype(float),
                "voltage": raw["voltage"].astype(float),
                "temperature": raw["temperature"].astype(float),
                "discharge_time": raw["time"].astype(float),
            }
        ).sort_values("cycle", ignore_index=True)
        if eol_capacity is not None:
            below = np.flatnonzero(table["capacity"].to_numpy() < float(eol_capacity))
            if below.size:
                table = table.iloc[: below[0] + 1].copy()
            table["failed"] = False
            if below.size:
                table.loc[table.index[-1], "failed"] = True
        parts.append(table)
    return pd.concat(parts, ignore_index=True)


# --------------------------------------------------------------------------------------
# registry
# --------------------------------------------------------------------------------------

_REGISTRY: dict[str, tuple[Callable[..., Any], dict[str, Any], str]] = {
    "cwru": (
        load_cwru,
        {},
        "CWRU bearings 0 hp/1797 rpm: normal, IR 0.007/0.021, ball, OR; DE/FE/BA frames "
        "of 2048 at 12 kHz (Ensemble)",
    ),
    "cmapss-fd001": (
        load_cmapss,
        {"subset": "FD001", "part": "train"},
        "NASA C-MAPSS FD001 turbofan run-to-failure, train part: 100 units, long table "
        "with rul (DataFrame)",
    ),
    "cascaded-tanks": (
        load_cascaded_tanks,
        {},
        "Cascaded Tanks with overflow: uEst/yEst/uVal/yVal, 1024 samples, Ts 4 s (dict)",
    ),
    "silverbox": (
        load_silverbox,
        {},
        "Silverbox Duffing oscillator circuit: V1 in, V2 out, 131072 samples at "
        "610.35 Hz (dict)",
    ),
    "nasa-battery": (
        load_nasa_battery,
        {},
        "NASA Li-ion cells B0005/6/7/18: capacity per discharge until 1.4 Ah (B0007 "
        "censored), long table (DataFrame)",
    ),
    "emps": (
        load_emps,
        {},
        "EMPS positioning system with friction: t, qm, qg, vir, force at 1 kHz (dict)",
    ),
}

DATASETS: dict[str, str] = {name: entry[2] for name, entry in _REGISTRY.items()}
"""Names accepted by :func:`load_dataset`, with a one-line description each."""


def load_dataset(name: str, **kwargs: Any) -> Any:
    """Load a shared dataset by name (see ``DATASETS`` for the names).

    Parameters
    ----------
    name : str
        ``"cwru"``, ``"cmapss-fd001"`` (train part, long table), ``"cascaded-tanks"``,
        ``"silverbox"``, ``"emps"`` or ``"nasa-battery"`` (long table).
    **kwargs
        Passed on to the loader (e.g. ``frame_length=1024`` for ``"cwru"``,
        ``part="test"`` for ``"cmapss-fd001"``).

    Returns
    -------
    Ensemble, pandas.DataFrame or dict
        Whatever the loader returns.

    Examples
    --------
    >>> sorted(DATASETS)
    ['cascaded-tanks', 'cmapss-fd001', 'cwru', 'emps', 'nasa-battery', 'silverbox']
    >>> load_dataset("hydraulic")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: unknown dataset 'hydraulic'; known: cascaded-tanks, ...
    """
    try:
        loader, defaults, _ = _REGISTRY[name]
    except (KeyError, TypeError):
        raise DataError(
            f"unknown dataset {name!r}; known: {', '.join(sorted(_REGISTRY))}"
        ) from None
    return loader(**{**defaults, **kwargs})
