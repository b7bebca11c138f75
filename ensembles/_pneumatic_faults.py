"""The pneumatic piston's rig faults and its fault ensembles (Voronin's thesis, 3.3, 8.1.1).

The settings of the rig that the seed's faults change (:data:`PNEUMATIC_FAULTS`, seed
table 3.2), its combined fault codes (:func:`fault_labels`), the twin simulated in
batches over random operating points (:func:`simulate_fault_ensemble`) and one sensor
with the sensor faults of seed 8.1.1 (:func:`simulate_sensor_fault_ensemble`); the
seed's own data sets are in :mod:`pdmkit.ensembles._pneumatic`.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from pdmkit._progress import progress as _progress
from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.errors import DataError

__all__ = [
    "PNEUMATIC_FAULTS",
    "PNEUMATIC_SENSORS",
    "fault_labels",
    "simulate_fault_ensemble",
    "simulate_sensor_fault_ensemble",
]


#: The eight sensor types of the seed's table 3.1 / 9.1 and the signals each owns.
PNEUMATIC_SENSORS: dict[str, tuple[str, ...]] = {
    "Acc": ("AccelerometerMoving_axisZ", "AccelerometerStatic_axisZ"),
    "Encoder": ("LeverPosition", "LeverVelocity"),
    "Flow": ("FlowExtrusion", "FlowContraction"),
    "Mics": ("MIC_uBumper", "MIC_bBumper", "MIC_Ambient"),
    "Pressure": ("AirPressure",),
    "Proximity": ("ProximitySensor_upper", "ProximitySensor_bottom"),
    "Strain": ("StrainGauge",),
    "Temperature": ("TempCylinder", "TempAmbient"),
}


@dataclass(frozen=True)
class _Setting:
    """A rig setting: its healthy range and the range a fault puts it in."""

    parameter: str
    healthy: tuple[float, float]
    faulty: tuple[tuple[float, float], ...]
    sentence: str


#: Fault code -> the setting it changes (seed section 3.3 and table 3.2). Settings are
#: drawn uniformly from the healthy range, or from one of the faulty ranges.
#:
#: Healthy is the rig as the technician sets it for the job (seed 3.3: "optimally set"):
#: the hand-set knobs at their nominal mark 5 of the 1..10 scale, within the half
#: division a person repeats such a setting to, and the static large dampers within
#: +-15 % of their nominal damping (part-to-part and temperature spread of an
#: elastomer). A fault is a knob left at least two divisions off its mark: a throttle
#: closed to 1.5..3 (33..64 % of the nominal exhaust flow area: the throttles are
#: meter-out one-way valves, see PneumaticParams), a small damper turned to 1..2.5
#: (40 % of the nominal damping and less) or 8.5..10 (3.7 times and more); worn large
#: dampers have lost 70..95 % of their damping.
PNEUMATIC_FAULTS: dict[str, _Setting] = {
    "throttle_1": _Setting(
        "throttle_a",
        (4.5, 5.5),
        ((1.5, 3.0),),
        "throttle valve 1 (line A) closed two to three divisions too far",
    ),
    "throttle_2": _Setting(
        "throttle_b",
        (4.5, 5.5),
        ((1.5, 3.0),),
        "throttle valve 2 (line B) closed two to three divisions too far",
    ),
    "damper_bottom": _Setting(
        "damper_bottom",
        (4.5, 5.5),
        ((1.0, 2.5), (8.5, 10.0)),
        "small bottom damper set far too soft or too hard",
    ),
    "damper_upper": _Setting(
        "damper_upper",
        (4.5, 5.5),
        ((1.0, 2.5), (8.5, 10.0)),
        "small upper damper set far too soft or too hard",
    ),
    "large_dampers": _Setting(
        "damper_large_damping",
        (340.0, 460.0),
        ((20.0, 120.0),),
        "static large dampers worn (70-95 % of their damping lost)",
    ),
}

_LOADS_KG = (0.0, 1.25, 5.0, 6.25)  # table 3.2
_SUPPLIES_BAR = (5.0, 6.0)  # table 3.2, gauge
_P_AMBIENT = 101325.0


def fault_labels(max_faults: int = 1) -> list[str]:
    """The combined fault codes: ``healthy``, single faults, and combinations.

    Parameters
    ----------
    max_faults : int, default 1
        Largest number of simultaneous faults in a code (the seed combines them).

    Returns
    -------
    list of str
        Codes such as ``"throttle_1"`` or ``"damper_upper+throttle_1"`` (parts sorted).

    Examples
    --------
    >>> fault_labels(1)  # doctest: +NORMALIZE_WHITESPACE
    ['healthy', 'damper_bottom', 'damper_upper', 'large_dampers',
     'throttle_1', 'throttle_2']
    >>> len(fault_labels(2))
    16
    """
    if not isinstance(max_faults, int) or not 1 <= max_faults <= len(PNEUMATIC_FAULTS):
        raise ValueError(
            f"max_faults must be 1..{len(PNEUMATIC_FAULTS)}; got {max_faults!r}"
        )
    names = sorted(PNEUMATIC_FAULTS)
    codes = ["healthy"]
    for r in range(1, max_faults + 1):
        codes += ["+".join(c) for c in itertools.combinations(names, r)]
    return codes


def _check_labels(labels: Sequence[str]) -> list[str]:
    out = []
    for code in labels:
        parts = [] if code == "healthy" else code.split("+")
        unknown = [p for p in parts if p not in PNEUMATIC_FAULTS]
        if unknown or not code:
            raise DataError(
                f"unknown fault code {code!r}: parts {unknown} are not among "
                f"{['healthy', *sorted(PNEUMATIC_FAULTS)]}; combine faults with '+'"
            )
        out.append(code)
    return out


def _operating_conditions(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Operating point and unlabelled parameter variation, one value per member."""
    loads = rng.choice(_LOADS_KG, size=n)
    supplies = rng.choice(_SUPPLIES_BAR, size=n)
    return {
        "mass_load": loads,
        "p_supply": _P_AMBIENT + supplies * 1e5,
        # nobody labels these: they make members of one class differ
        "friction_coulomb": 10.0 * rng.uniform(0.8, 1.2, n),
        "friction_viscous": 20.0 * rng.uniform(0.8, 1.2, n),
        "c_a_in": 5e-6 * rng.uniform(0.92, 1.08, n),
        "c_a_out": 5e-6 * rng.uniform(0.92, 1.08, n),
        "c_b_in": 5e-6 * rng.uniform(0.92, 1.08, n),
        "c_b_out": 5e-6 * rng.uniform(0.92, 1.08, n),
        "valve_delay": 0.010 * rng.uniform(0.8, 1.2, n),
    }


def _operating_points(points, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Load mass and supply pressure of ``n`` members spread evenly over ``points``."""
    frame = pd.DataFrame(points)
    missing = [c for c in ("load_kg", "supply_bar") if c not in frame.columns]
    if missing or frame.empty:
        raise DataError(
            f"operating_points needs columns 'load_kg' and 'supply_bar' and at least one "
            f"row; got columns {list(frame.columns)} with {len(frame)} rows"
        )
    load = frame["load_kg"].to_numpy(dtype=float)
    supply = frame["supply_bar"].to_numpy(dtype=float)
    if np.any(~np.isfinite(load) | (load < 0)) or np.any(~np.isfinite(supply)):
        raise DataError(
            "operating_points: load_kg must be finite and >= 0 kg and supply_bar finite "
            f"(bar gauge); got loads {load.tolist()} and supplies {supply.tolist()}"
        )
    which = np.arange(n) % len(frame)
    rng.shuffle(which)
    return {"mass_load": load[which], "p_supply": _P_AMBIENT + supply[which] * 1e5}


def _fault_settings(
    labels: np.ndarray, rng: np.random.Generator, at_mark: bool = False
) -> dict[str, np.ndarray]:
    """Settings per label, drawn from the faulty or the healthy ranges.

    ``at_mark``: the settings that are not faulty at the middle of their healthy range
    (the mark a knob is set to) instead of drawn from it.
    """
    n = len(labels)
    values = {}
    for code, setting in PNEUMATIC_FAULTS.items():
        v = rng.uniform(*setting.healthy, size=n)
        if at_mark:
            v = np.full(n, 0.5 * (setting.healthy[0] + setting.healthy[1]))
        faulty = np.array([code in str(lab).split("+") for lab in labels])
        if faulty.any():
            ranges = np.array(setting.faulty)
            pick = rng.integers(0, len(ranges), size=n)
            lo, hi = ranges[pick, 0], ranges[pick, 1]
            v = np.where(faulty, rng.uniform(0.0, 1.0, n) * (hi - lo) + lo, v)
        values[setting.parameter] = v
    return values


def _slice_spec(spec, sl: slice):
    """The members ``sl`` (a slice or indices) of a SensorSpec with per-member fields."""
    fields = {k: (v[sl] if np.ndim(v) else v) for k, v in dataclasses.asdict(spec).items()}
    return type(spec)(**fields)


def _simulate_batches(
    params_cols, n, *, t_end, fs, signals, seed, batch_size, desc, specs=None
):
    """Simulate ``n`` members in batches; return {signal: (n, n_samples)}."""
    from pdmkit.models import PneumaticParams, simulate_piston

    seeds = np.random.SeedSequence(seed).spawn((n + batch_size - 1) // batch_size)
    out: dict[str, list[np.ndarray]] = {}
    starts = range(0, n, batch_size)
    for start, child in _progress(
        zip(starts, seeds, strict=True), desc=desc, total=len(seeds)
    ):
        sl = slice(start, min(start + batch_size, n))
        cols = {k: (v[sl] if np.ndim(v) else v) for k, v in params_cols.items()}
        params = PneumaticParams(**cols)
        batch_specs = None
        if specs is not None:
            batch_specs = {name: _slice_spec(spec, sl) for name, spec in specs.items()}
        response = simulate_piston(
            params,
            t_end=t_end,
            fs=fs,
            sensors=list(signals),
            seed=child,
            sensor_specs=batch_specs,
        )
        for name in signals:
            out.setdefault(name, []).append(np.asarray(response.outputs[name]))
    return {name: np.concatenate(parts, axis=0) for name, parts in out.items()}


def _signal_list(signals: Sequence[str] | None) -> list[str]:
    from pdmkit.models import SENSOR_NAMES

    if signals is None:
        return list(SENSOR_NAMES)
    unknown = [s for s in signals if s not in SENSOR_NAMES]
    if unknown:
        raise DataError(
            f"unknown sensor signal(s) {unknown}; the twin has {list(SENSOR_NAMES)}"
        )
    return list(signals)


def simulate_fault_ensemble(
    n_members: int = 600,
    *,
    labels: Sequence[str] | None = None,
    max_faults: int = 1,
    t_end: float = 10.0,
    fs: float = 1000.0,
    signals: Sequence[str] | None = None,
    seed: int = 0,
    batch_size: int = 500,
    operating_points: pd.DataFrame | dict | None = None,
) -> Ensemble:
    """Simulate labelled fault recordings of the pneumatic piston.

    Members are spread evenly over the fault codes. Each member draws its settings
    from the healthy or faulty range of :data:`PNEUMATIC_FAULTS`, a load mass from
    {0, 1.25, 5, 6.25} kg and a supply pressure from {5, 6} bar (table 3.2), and
    random friction (±20 %), valve coefficients (±8 %) and valve delay (±20 %): the
    unlabelled variation that makes members of one class differ.

    Parameters
    ----------
    n_members : int, default 600
        Number of recordings.
    labels : sequence of str, optional
        Fault codes to simulate (default :func:`fault_labels` ``(max_faults)``).
    max_faults : int, default 1
        Largest number of combined faults when ``labels`` is not given.
    t_end, fs : float
        Recording length (s) and sampling rate (Hz); the seed's recordings are 10 s at
        1 kHz.
    signals : sequence of str, optional
        Sensor signals to record (default all fifteen of seed table 3.1).
    seed : int
        Seed of every random choice and of the sensor noise.
    batch_size : int
        Members simulated at once.
    operating_points : DataFrame or dict, optional
        Columns ``load_kg`` and ``supply_bar`` (bar gauge): spread the members evenly
        over these operating points instead of drawing them at random, e.g. to simulate
        a healthy reference at the operating points of a measured ensemble.

    Returns
    -------
    Ensemble
        Condition columns ``fault`` (the code), ``load_kg``, ``supply_bar`` and the
        true settings ``throttle_1``, ``throttle_2``, ``damper_upper``,
        ``damper_bottom``, ``large_damper_damping``.

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_fault_ensemble
    >>> ens = simulate_fault_ensemble(12, t_end=0.5, signals=["LeverPosition"], seed=1)
    >>> len(ens), ens.fs["LeverPosition"], ens.conditions["fault"].nunique()
    (12, 1000.0, 6)
    >>> ref = simulate_fault_ensemble(
    ...     4, labels=["healthy"], t_end=0.5, signals=["LeverPosition"],
    ...     operating_points={"load_kg": [0.0, 5.0], "supply_bar": [6.0, 6.0]})
    >>> sorted(ref.conditions["load_kg"].tolist()), set(ref.conditions["supply_bar"])
    ([0.0, 0.0, 5.0, 5.0], {6.0})
    """
    if not isinstance(n_members, int | np.integer) or n_members < 1:
        raise ValueError(f"n_members must be a positive integer; got {n_members!r}")
    codes = _check_labels(labels) if labels is not None else fault_labels(max_faults)
    signals = _signal_list(signals)
    rng = np.random.default_rng(seed)
    member_labels = np.array([codes[i % len(codes)] for i in range(int(n_members))])
    rng.shuffle(member_labels)
    cols = _operating_conditions(int(n_members), rng)
    if operating_points is not None:
        cols.update(_operating_points(operating_points, int(n_members), rng))
    cols.update(_fault_settings(member_labels, rng))
    data = _simulate_batches(
        cols,
        int(n_members),
        t_end=t_end,
        fs=fs,
        signals=signals,
        seed=seed,
        batch_size=batch_size,
        desc="simulating fault ensemble",
    )
    conditions = pd.DataFrame(
        {
            "fault": member_labels,
            "load_kg": cols["mass_load"],
            "supply_bar": (cols["p_supply"] - _P_AMBIENT) / 1e5,
            "throttle_1": cols["throttle_a"],
            "throttle_2": cols["throttle_b"],
            "damper_upper": cols["damper_upper"],
            "damper_bottom": cols["damper_bottom"],
            "large_damper_damping": cols["damper_large_damping"],
        }
    )
    ids = [f"sim{i:05d}" for i in range(int(n_members))]
    return Ensemble(data, fs=fs, conditions=conditions, member_ids=ids)


_SENSOR_FAULTS = ("healthy", "noise", "offset", "drift", "loss")


def simulate_sensor_fault_ensemble(
    n_members: int = 200,
    *,
    sensor: str = "FlowExtrusion",
    t_end: float = 10.0,
    fs: float = 1000.0,
    seed: int = 0,
    batch_size: int = 500,
    faults: Sequence[str] | None = None,
) -> Ensemble:
    """Simulate one sensor healthy and with the sensor faults of seed section 8.1.1.

    Classes (condition ``sensor_fault``): ``healthy``, ``noise`` (white noise of 5-15 %
    of the signal's typical range), ``offset`` (a bias of 5-15 % of the range),
    ``drift`` (a bias growing to 10-30 % of the range over the recording) and ``loss``
    (60-100 % of the samples lost, read as 0 like a dead analogue channel). The machine
    itself is healthy, at random operating points.

    Parameters
    ----------
    n_members : int, default 200
    sensor : str, default "FlowExtrusion"
        The sensor signal to corrupt (seed figure 8.1 uses the flow sensor).
    t_end, fs, seed, batch_size
        As :func:`simulate_fault_ensemble`.
    faults : sequence of str, optional
        The classes to simulate, among ``healthy, noise, offset, drift, loss`` (default
        all five; the seed's section 8.1.1 has ``healthy, noise, offset``).

    Returns
    -------
    Ensemble
        One signal, ``sensor``; conditions ``sensor_fault``, ``load_kg``, ``supply_bar``.

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_sensor_fault_ensemble
    >>> ens = simulate_sensor_fault_ensemble(10, t_end=0.5, seed=2)
    >>> sorted(ens.conditions["sensor_fault"].unique())
    ['drift', 'healthy', 'loss', 'noise', 'offset']
    """
    from pdmkit.models import SensorSpec

    signals = _signal_list([sensor])
    classes = _SENSOR_FAULTS if faults is None else tuple(faults)
    unknown = [f for f in classes if f not in _SENSOR_FAULTS]
    if unknown or not classes:
        raise DataError(
            f"faults must be a non-empty subset of {list(_SENSOR_FAULTS)}; got "
            f"{list(classes)}"
        )
    rng = np.random.default_rng(seed)
    n = int(n_members)
    faults = np.array([classes[i % len(classes)] for i in range(n)])
    rng.shuffle(faults)
    cols = _operating_conditions(n, rng)
    cols.update(_fault_settings(np.array(["healthy"] * n), rng))
    # the typical range of the clean signal sets the size of the faults
    clean = _simulate_batches(
        {k: v[:1] for k, v in cols.items()},
        1,
        t_end=t_end,
        fs=fs,
        signals=signals,
        seed=seed,
        batch_size=1,
        desc="",
    )[sensor]
    span = float(np.percentile(clean, 99) - np.percentile(clean, 1)) or 1.0
    size = rng.uniform(0.05, 0.15, n) * span
    spec = SensorSpec(
        noise_std=np.where(faults == "noise", size, 0.0),
        offset=np.where(faults == "offset", size, 0.0),
        drift=np.where(faults == "drift", 2.0 * size / t_end, 0.0),
        dropout=np.where(faults == "loss", rng.uniform(0.6, 1.0, n), 0.0),
    )
    data = _simulate_batches(
        cols,
        n,
        t_end=t_end,
        fs=fs,
        signals=signals,
        seed=seed + 1,
        batch_size=batch_size,
        desc="simulating sensor faults",
        specs={sensor: spec},
    )
    conditions = pd.DataFrame(
        {
            "sensor_fault": faults,
            "load_kg": cols["mass_load"],
            "supply_bar": (cols["p_supply"] - _P_AMBIENT) / 1e5,
        }
    )
    return Ensemble(
        data, fs=fs, conditions=conditions, member_ids=[f"sf{i:05d}" for i in range(n)]
    )
