"""Simulated ensembles of the pneumatic piston twin (seed 001, sections 3.3, 8.1, 8.4).

Three generators, each returning an :class:`~pdmkit.ensembles.Ensemble` of 10 s
recordings of the fifteen sensors of seed table 3.1:

* :func:`simulate_fault_ensemble`: the rig's settings of table 3.2 (throttle valves,
  small and large dampers) set to faulty values, labelled with the seed's combined
  fault codes, over random operating points (load mass, supply pressure) and random
  variation of the parameters nobody labels (friction, valve coefficients, delay), so
  that classes overlap as measured ones do;
* :func:`simulate_seed_ensemble`: the seed's data set as the seed built it, fault
  codes (one setting each, recorded about 20 times) grouped into the seed's 20 labels
  (:func:`seed_labels`);
* :func:`simulate_sensor_fault_ensemble`: one sensor with noise, offset, drift or
  signal loss (seed 8.1.1);
* :func:`simulate_leak_runs`: run-to-failure units whose chamber air-leak coefficient
  grows along unit-specific random paths (seed 8.1-8.2, 8.4).
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
from pdmkit.errors import DataError, ModelError

__all__ = [
    "PNEUMATIC_FAULTS",
    "PNEUMATIC_SENSORS",
    "SEED_JITTER",
    "SEED_LABELS",
    "SEED_SINGLE_FAULTS",
    "SEED_SUPPLY_BAR",
    "fault_labels",
    "pneumatic_residuals",
    "seed_labels",
    "simulate_fault_ensemble",
    "simulate_leak_runs",
    "simulate_seed_ensemble",
    "simulate_seed_single_fault_ensemble",
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
    """The members ``sl`` of a SensorSpec whose fields are per-member arrays."""
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
        params = PneumaticParams(**{k: v[sl] for k, v in params_cols.items()})
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
    operating_points=None,
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


#: The seed's 20 labels (section 3.3 and 7.2.1), as pdmkit fault codes -> the seed's
#: own label strings. The text names the places ("Healthy, Throttle valve 1, Throttle
#: valve 2, Small damper bottom, Small damper upper, Large dampers, and combinations of
#: these faults") but not the combinations; the seed author's code does
#: (``utils/faultCode2Label.m`` and ``utils/faultCode2Label_combinedFaults.m`` of
#: github.com/xvoron/thesis, and the 20 ``ClassNames`` of its classifiers,
#: ``sb/sensor_flow/train_flow_KNN.m``): the four adjustable places alone, and the 15
#: pairs of six places, the supply pressure counted as a place ("pressure+valve1", ...).
#: The large dampers occur only in pairs; the supply pressure only in pairs.
SEED_LABELS: dict[str, str] = {
    "healthy": "health",
    "throttle_1": "valve1",
    "throttle_2": "valve2",
    "damper_bottom": "damp_small_bot",
    "damper_upper": "damp_small_up",
    "supply_pressure+throttle_1": "pressure+valve1",
    "supply_pressure+throttle_2": "pressure+valve2",
    "damper_bottom+supply_pressure": "pressure+damp_small_bot",
    "large_dampers+supply_pressure": "pressure+damps_large",
    "damper_upper+supply_pressure": "pressure+damp_small_up",
    "throttle_1+throttle_2": "valve1+valve2",
    "damper_bottom+throttle_1": "valve1+damp_small_bot",
    "large_dampers+throttle_1": "valve1+damps_large",
    "damper_upper+throttle_1": "valve1+damp_small_up",
    "damper_bottom+throttle_2": "valve2+damp_small_bot",
    "large_dampers+throttle_2": "valve2+damps_large",
    "damper_upper+throttle_2": "valve2+damp_small_up",
    "damper_bottom+large_dampers": "damp_small_bot+damps_large",
    "damper_bottom+damper_upper": "damp_small_bot+damp_small_up",
    "damper_upper+large_dampers": "damps_large+damp_small_up",
}

#: Supply pressure (bar gauge) of the seed ensemble: nominal, and the "pressure" fault
#: place of the seed's combined labels (the other value of table 3.2, "5, 6 bar"), as the
#: rig's reservoir transmitter reads them: 5.99 bar for the nominal codes and 5.49 for
#: the pressure-fault codes (means of the 15 one-code combined labels, 5.45-5.53 for
#: the five "pressure+..." ones; ``sb/sensor_pressure/PressureAllFeatures.mat`` of the
#: author's repository). (Before, pdmkit took table 3.2's 5 bar.)
SEED_SUPPLY_BAR = {"nominal": 6.0, "fault": 5.5}
_SEED_PLACES = (*sorted(PNEUMATIC_FAULTS), "supply_pressure")
_SEED_SINGLE = ("healthy", "throttle_1", "throttle_2", "damper_bottom", "damper_upper")


def seed_labels() -> list[str]:
    """The seed's 20 labels as pdmkit fault codes (seed sections 3.3 and 7.2.1).

    The seed grouped its almost 250 fault codes "according to where the fault occurs"
    into 20 labels: healthy, the four adjustable places alone (throttle valves 1 and 2,
    small bottom and upper dampers) and the 15 pairs of six places (those four, the
    large dampers and the supply pressure). The text lists the places; the pairs are
    the author's own label table (see :data:`SEED_LABELS`, which also maps each code
    to the seed's label string, e.g. ``"supply_pressure+throttle_1"`` ->
    ``"pressure+valve1"``).

    Returns
    -------
    list of str
        Healthy and the four single faults first, then the 15 pairs (parts sorted).

    Examples
    --------
    >>> from pdmkit.ensembles import seed_labels
    >>> labels = seed_labels()
    >>> len(labels), labels[:3]
    (20, ['healthy', 'throttle_1', 'throttle_2'])
    >>> sum("+" in code for code in labels)
    15
    """
    return list(SEED_LABELS)


#: Run-to-run spread (relative standard deviation) of the seal friction and the valve's
#: switching delay of a rig recorded again at the same setting. The seed does not report
#: it; its ~20 recordings of a fault code were taken back to back, over minutes, in which
#: seal friction and solenoid switching time drift by about 1-2 % as the rig warms up.
#: 2 % it is. The rig's recordings bound it from above, not below: on the twin, 2 %
#: spreads a code's FlowContraction RMS by 0.07 % (relative std over the 20 repeats),
#: the rig's spread by 0.19 % (median over its 15 one-code labels,
#: ``sb/sensor_flow/FlowsFeaturesAll.mat`` of the author's repository).
SEED_JITTER = 0.02

#: Run-to-run spread (relative standard deviation of the gauge pressure) of the
#: regulated supply, measured on the rig: its reservoir reading's 10 s mean spreads by
#: 0.0023 bar within a fault code (median over the 15 one-code labels of the author's
#: ``sb/sensor_pressure/PressureAllFeatures.mat``), of which the transmitter's own noise
#: makes 0.0016 bar (0.16 bar / sqrt(10000 samples)); the rest, 0.0017 bar at 6 bar, is
#: 0.03 %. (Before, the supply got the 2 % of SEED_JITTER: fifty times the rig's.)
SEED_SUPPLY_REPEATABILITY = 3e-4


#: Fault codes of healthy and of each single fault in the seed's data set (its 4840
#: recordings of 242 codes): the author's feature tables label 260, 1340, 1080, 980 and
#: 880 recordings healthy, valve1, valve2, damp_small_bot and damp_small_up, and 20 each
#: of the 15 combined labels (the ``Label`` column of ``sb/sensor_proximity/
#: ProximityAllFeatures.mat``, github.com/xvoron/thesis): 13, 67, 54, 49 and 44 codes of
#: 20 recordings. (Before, pdmkit shared them evenly: 46, 46, 45, 45, 45.)
SEED_SINGLE_CODES = {
    "healthy": 13,
    "throttle_1": 67,
    "throttle_2": 54,
    "damper_bottom": 49,
    "damper_upper": 44,
}

#: Of those codes, the ones recorded at the low supply (their reservoir reads 5.5 bar
#: as the pressure-fault codes' do: 20, 200, 140, 120 and 100 recordings of
#: ``PressureAllFeatures.mat`` under 5.75 bar): the seed labels them by their knob
#: fault alone, so a low supply is no sign of the "pressure" labels.
SEED_SINGLE_LOW_SUPPLY_CODES = {
    "healthy": 1,
    "throttle_1": 10,
    "throttle_2": 7,
    "damper_bottom": 6,
    "damper_upper": 5,
}


def _shares(total: int, weights) -> np.ndarray:
    """``total`` split in proportion to ``weights`` (largest remainders), each >= 1."""
    weights = np.asarray(weights, dtype=float)
    exact = max(total, len(weights)) * weights / weights.sum()
    out = np.floor(exact).astype(int)
    order = np.argsort(-(exact - out), kind="stable")
    out[order[: max(total, len(weights)) - out.sum()]] += 1
    while np.any(out < 1):  # the smallest shares take one from the largest
        out[np.argmax(out)] -= 1
        out[np.argmin(out)] += 1
    return out


#: The seed's recordings were made on one rig (sections 3.3, 7.2.1) whose knobs were set
#: to the marks of a fault code: the rig's healthy recordings of the residual set
#: (``mb/featuretables/residual_featuretable.mat``, 100 recordings at 6.25 kg, 6 bar)
#: spread their position residual's RMS by 0.1 mm (standard deviation; mean 3.5 mm),
#: which rules out a +-0.5 division spread of the knobs (1.7 mm on the twin) and a
#: +-20 % friction or valve delay from code to code (0.5-0.8 mm).
_ONE_RIG = (
    "friction_coulomb",
    "friction_viscous",
    "c_a_in",
    "c_a_out",
    "c_b_in",
    "c_b_out",
    "valve_delay",
)


def _one_rig(n: int) -> dict[str, np.ndarray]:
    """The parameters nobody labels at the nominal twin's values, for ``n`` members."""
    from pdmkit.models import PneumaticParams

    nominal = PneumaticParams()
    return {k: np.full(n, float(getattr(nominal, k))) for k in _ONE_RIG}


def _seed_design(
    n_members: int, repeats: int, variation: str, seed: int, jitter: float = SEED_JITTER
) -> pd.DataFrame:
    """Fault codes, their settings and the members that repeat them (no simulation)."""
    rng = np.random.default_rng(seed)
    labels = seed_labels()
    n_codes = max(len(labels), round(n_members / repeats))
    # the 15 combined labels were each one fault code in the seed's combined-fault
    # data set; the remaining codes go to healthy and the single faults as in the
    # seed's data set (SEED_SINGLE_CODES), at least one each
    per_single = _shares(n_codes - 15, [SEED_SINGLE_CODES[lab] for lab in _SEED_SINGLE])
    code_labels = [
        lab for lab, k in zip(_SEED_SINGLE, per_single, strict=True) for _ in range(k)
    ] + [lab for lab in labels if "+" in lab]
    code_labels = np.asarray(code_labels)
    n_codes = len(code_labels)
    # operating point per code: loads cycle within each label, the supply is the
    # nominal one unless the supply pressure is a fault place of the label
    load_index = np.zeros(n_codes, dtype=int)
    for lab in np.unique(code_labels):
        where = np.flatnonzero(code_labels == lab)
        load_index[where] = (rng.permutation(len(where)) + rng.integers(4)) % 4
    loads = np.asarray(_LOADS_KG)[load_index]
    low = np.array(["supply_pressure" in lab.split("+") for lab in code_labels])
    for lab in _SEED_SINGLE:  # single-fault codes recorded at the low supply
        where = np.flatnonzero(code_labels == lab)
        share = SEED_SINGLE_LOW_SUPPLY_CODES[lab] / SEED_SINGLE_CODES[lab]
        low[rng.permutation(where)[: round(share * len(where))]] = True
    supply = np.where(low, SEED_SUPPLY_BAR["fault"], SEED_SUPPLY_BAR["nominal"])
    knobs = _fault_settings(code_labels, rng, at_mark=variation == "rig")
    # members: codes repeated round-robin, so every label appears once n >= 20
    member_code = np.arange(n_members) % n_codes
    rng.shuffle(member_code)
    cols: dict[str, np.ndarray] = {k: v[member_code] for k, v in knobs.items()}
    cols["mass_load"] = loads[member_code]
    cols["p_supply"] = _P_AMBIENT + supply[member_code] * 1e5
    unlabelled = ("mass_load", "p_supply")
    if variation == "rig":
        cols.update(_one_rig(n_members))
    elif variation == "code":
        drawn = _operating_conditions(n_codes, rng)
        cols.update({k: v[member_code] for k, v in drawn.items() if k not in unlabelled})
    else:
        drawn = _operating_conditions(n_members, rng)
        cols.update({k: v for k, v in drawn.items() if k not in unlabelled})
    set_point = (cols["p_supply"] - _P_AMBIENT) / 1e5  # what the operator knows
    if jitter:
        # run to run: no two recordings of one setting are quite the same
        noise = np.random.default_rng([seed, 1]).standard_normal((4, n_members))
        spread = (1.0 + jitter * noise).clip(0.5, 1.5)
        for row, k in enumerate(("friction_coulomb", "friction_viscous", "valve_delay")):
            cols[k] = cols[k] * spread[row]
        gauge = (cols["p_supply"] - _P_AMBIENT) * (
            1.0 + SEED_SUPPLY_REPEATABILITY * noise[3]
        )
        cols["p_supply"] = _P_AMBIENT + gauge
    frame = pd.DataFrame(cols)
    frame.insert(0, "fault", code_labels[member_code])
    frame.insert(1, "seed_label", [SEED_LABELS[c] for c in frame["fault"]])
    frame.insert(2, "fault_code", [f"SC{c:04d}" for c in member_code])
    frame["supply_bar"] = set_point
    return frame


def simulate_seed_ensemble(
    n_members: int = 400,
    *,
    repeats: int = 20,
    variation: str = "rig",
    jitter: float = SEED_JITTER,
    signals: Sequence[str] | None = None,
    t_end: float = 10.0,
    fs: float = 1000.0,
    seed: int = 0,
    batch_size: int = 250,
    members=None,
    acquisition: str = "seed_rig",
    test_cycle: str = "twin",
) -> Ensemble:
    """Simulate the seed's data set: fault codes grouped into the seed's 20 labels.

    Built as the seed built its measured data set (sections 3.3 and 7.2.1): a fault
    code is one setting of the rig (table 3.2: throttle valves and small dampers on
    their 1..10 scale, large dampers, load 0/1.25/5/6.25 kg, supply 5/6 bar) recorded
    ``repeats`` times for 10 s at 1 kHz with the fifteen sensors of table 3.1 and their
    noise; the codes are grouped "according to where the fault occurs" into the 20
    labels of :func:`seed_labels`. The seed's 4840 recordings of "almost 250" codes
    are about 20 per code, hence ``repeats=20`` and ``n_members=4840`` for the full
    size (242 codes).

    * each of the 15 combined labels is one code (the seed's combined-fault data set
      has one code per pair); the other codes go to healthy and the four single
      faults in the proportions of the seed's data set (13, 67, 54, 49 and 44 codes at
      full size, ``SEED_SINGLE_CODES``);
    * a code's faulty knobs are drawn from the faulty ranges of
      :data:`PNEUMATIC_FAULTS`, its other knobs are at their marks (the middle of
      their healthy ranges; drawn from those ranges for the other variations); its load
      cycles through the four loads of table 3.2 within its label; its supply is
      6 bar, or 5.5 bar when the supply pressure is a fault place of its label or the
      code is one of the single-fault codes the seed recorded at the low supply
      (:data:`SEED_SUPPLY_BAR`, ``SEED_SINGLE_LOW_SUPPLY_CODES``);
    * the parameters nobody labels (friction, valve coefficients, valve delay) are
      the nominal twin's for every code when ``variation="rig"`` (one rig, as the
      seed's: its healthy recordings' residual spreads by 0.1 mm), drawn per code
      from the ranges of :func:`simulate_fault_ensemble` when ``variation="code"``,
      or per recording when ``variation="member"`` (every recording on a slightly
      different rig: harder);
    * every recording gets a run-to-run spread of relative size ``jitter`` of the
      Coulomb and viscous friction and the valve delay (:data:`SEED_JITTER`), and the
      rig's measured 0.03 % of the supply pressure above ambient
      (``SEED_SUPPLY_REPEATABILITY``): a rig recorded twice at one setting does not
      repeat itself exactly.

    Parameters
    ----------
    n_members : int, default 400
        Number of recordings; at least 20 (one code per label). 4840 is the seed's.
    repeats : int, default 20
        Recordings per fault code; the number of codes is
        ``max(20, round(n_members / repeats))``.
    variation : {"rig", "code", "member"}, default "rig"
        One rig with its knobs at their marks, or the unlabelled parameters (and
        the knobs within their healthy ranges) varying per fault code or per
        recording.
    jitter : float, default SEED_JITTER (0.02)
        Relative run-to-run spread of friction and valve delay; 0 repeats a code
        exactly (the supply too) but for sensor noise.
    signals : sequence of str, optional
        Sensor signals to record (default all fifteen of seed table 3.1).
    t_end, fs : float
        Recording length (s) and sampling rate (Hz): 10 s at 1 kHz as the seed's.
    seed : int
        Seed of the design (codes, settings) and of the sensor noise.
    batch_size : int
        Members simulated at once.
    members : slice or sequence of int, optional
        Simulate only these members of the design (same codes, settings and member
        ids as in the whole ensemble): to simulate the full size in parts. The noise
        is drawn per block of ``batch_size`` member numbers, so a part made of whole
        blocks (a slice whose start and stop are multiples of ``batch_size``) records
        exactly what the whole ensemble records.
    acquisition : {"seed_rig", "typical"}, default "seed_rig"
        The sensors' healthy imperfections
        (:func:`pdmkit.models.default_sensor_specs`): the seed rig's own acquisition as
        its recordings show it, or the twin's typical datasheet values.
    test_cycle : {"twin", "seed_rig"}, default "twin"
        The valve program: the twin's five 2 s cycles, or the seed rig's single cycle
        (:data:`SEED_TEST_CYCLE`: up from 1 s to 6 s).

    Returns
    -------
    Ensemble
        Conditions ``fault`` (pdmkit code), ``seed_label`` (the seed's string),
        ``fault_code``, ``load_kg``, ``supply_bar`` and the true settings
        ``throttle_1``, ``throttle_2``, ``damper_upper``, ``damper_bottom``,
        ``large_damper_damping``.

    Raises
    ------
    pdmkit.errors.DataError
        ``n_members`` below 20, ``repeats`` below 1, an unknown ``variation``.

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_seed_ensemble
    >>> ens = simulate_seed_ensemble(40, repeats=2, t_end=0.2, signals=["FlowContraction"])
    >>> ens.conditions["seed_label"].nunique(), ens.conditions["fault_code"].nunique()
    (20, 20)
    >>> sorted(set(ens.conditions["supply_bar"]))
    [5.5, 6.0]
    """
    if isinstance(n_members, bool) or not isinstance(n_members, int | np.integer):
        raise DataError(f"n_members must be an integer >= 20; got {n_members!r}")
    if n_members < len(SEED_LABELS):
        raise DataError(
            f"n_members must be >= {len(SEED_LABELS)} (one fault code per seed label); "
            f"got {n_members}"
        )
    if (
        isinstance(repeats, bool)
        or not isinstance(repeats, int | np.integer)
        or repeats < 1
    ):
        raise DataError(f"repeats must be a positive integer; got {repeats!r}")
    if variation not in ("rig", "code", "member"):
        raise DataError(f"variation must be 'rig', 'code' or 'member'; got {variation!r}")
    if (
        isinstance(jitter, bool)
        or not isinstance(jitter, int | float)
        or not (0.0 <= jitter <= 0.3)
    ):
        raise DataError(f"jitter must be a number in [0, 0.3]; got {jitter!r}")
    signals = _signal_list(signals)
    design = _seed_design(int(n_members), int(repeats), variation, seed, float(jitter))
    ids = np.array([f"seed{i:05d}" for i in range(int(n_members))])
    if members is not None:
        pick = np.arange(int(n_members))[members]
        design = design.iloc[pick].reset_index(drop=True)
        ids = ids[pick]
    # the noise seed of a block of batch_size member numbers depends on the block only
    labels = ("fault", "seed_label", "fault_code", "supply_bar")
    params = [c for c in design.columns if c not in labels]
    cols = {c: design[c].to_numpy(float) for c in params}
    cols.update(_test_cycle(test_cycle, len(design)))
    specs = _acquisition_specs(acquisition)
    data = _simulate_members(cols, ids, seed, t_end, fs, signals, batch_size, specs)
    conditions = pd.DataFrame(
        {
            "fault": design["fault"].to_numpy(),
            "seed_label": design["seed_label"].to_numpy(),
            "fault_code": design["fault_code"].to_numpy(),
            "load_kg": cols["mass_load"],
            "supply_bar": design["supply_bar"].to_numpy(float),  # the set point
            "throttle_1": cols["throttle_a"],
            "throttle_2": cols["throttle_b"],
            "damper_upper": cols["damper_upper"],
            "damper_bottom": cols["damper_bottom"],
            "large_damper_damping": cols["damper_large_damping"],
        }
    )
    return Ensemble(data, fs=fs, conditions=conditions, member_ids=list(ids))


def _acquisition_specs(acquisition: str):
    """The sensors' healthy specs of an acquisition (see default_sensor_specs)."""
    from pdmkit.models import default_sensor_specs

    try:
        return default_sensor_specs(acquisition)
    except ModelError as exc:
        raise DataError(str(exc).replace("default_sensor_specs: ", "")) from None


def _simulate_members(cols, ids, seed, t_end, fs, signals, batch_size, specs=None):
    """Simulate members in blocks of ``batch_size`` member numbers, one noise seed each.

    A part of the design made of whole blocks records what the whole design records.
    ``specs``: sensor specs (scalar fields) for every member, default the twin's.
    """
    numbers = np.array([int(i[-5:]) for i in ids])
    block = numbers // batch_size
    out: dict[str, list[np.ndarray]] = {}
    order = []
    for b in _progress(np.unique(block), desc="simulating seed ensemble"):
        rows = np.flatnonzero(block == b)
        order.append(rows)
        part = _simulate_batches(
            {k: v[rows] for k, v in cols.items()},
            len(rows),
            t_end=t_end,
            fs=fs,
            signals=signals,
            seed=[seed, int(b)],
            batch_size=len(rows),
            desc="",
            specs=specs,
        )
        for name in signals:
            out.setdefault(name, []).append(part[name])
    inverse = np.argsort(np.concatenate(order))
    return {name: np.concatenate(parts, axis=0)[inverse] for name, parts in out.items()}


#: Sensor faults of seed 8.1.1, as SensorSpec fields relative to the signal's spread.
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


def _leak_path(rng, max_cycles, leak_start, leak_failure, shape) -> np.ndarray:
    """One unit's ``C_al`` per cycle, from ``leak_start`` to the failing cycle.

    The failing cycle is the first whose value is at or above ``leak_failure``.

    ``log C_al`` drifts to the threshold in about ``target`` cycles (drawn uniformly in
    ``[0.4 max_cycles, max_cycles]``) with gamma-distributed steps of shape ``shape``:
    a monotone random walk.
    """
    log_start, log_fail = np.log(leak_start), np.log(leak_failure)
    target = int(rng.integers(int(0.4 * max_cycles), max_cycles + 1))
    steps = rng.gamma(shape, 1.0 / shape, size=4 * target) * (log_fail - log_start) / target
    path = log_start + np.concatenate([[0.0], np.cumsum(steps)])
    end = int(np.flatnonzero(path >= log_fail)[0])
    return np.exp(path[: end + 1])


def _seed_leak_path(rng, max_cycles: int) -> np.ndarray:
    """One unit's ``C_al`` per cycle on the seed author's schedule (``mb/rul.mlx``)."""
    n = int(max_cycles / 2 + rng.uniform() * max_cycles / 2)
    base = np.linspace(1e-5, (1.0 + rng.uniform()) * 1e-3, max(n, 3))
    c_leak = base**2 + rng.uniform() * base**3
    return c_leak * (1.0 + (1.0 + 7.0 * rng.uniform(size=len(c_leak))) * 0.01)


def simulate_leak_runs(
    n_units: int = 10,
    *,
    max_cycles: int = 60,
    leak_start: float = 1e-10,
    leak_failure: float = 1e-6,
    chamber: str = "b",
    t_end: float = 10.0,
    fs: float = 1000.0,
    signals: Sequence[str] | None = ("LeverPosition", "FlowExtrusion", "AirPressure"),
    seed: int = 0,
    batch_size: int = 500,
    walk_shape: float = 16.0,
    schedule: str = "walk",
    operating_point: tuple[float, float] | None = None,
    unit_variation: bool = True,
    leak_scale: float = 1.0,
) -> Ensemble:
    """Simulate air-leak run-to-failure units (seed sections 8.1-8.2 and 8.4).

    Each unit is a sequence of recordings ("cycles"). Its leak coefficient ``C_al``
    grows log-linearly from ``leak_start`` with a unit-specific rate and a random walk
    around it, and the unit fails at the first cycle whose ``C_al`` reaches
    ``leak_failure``. Units get random operating points and parameter variation like
    :func:`simulate_fault_ensemble`, held fixed over their life.

    The walk: each cycle adds a gamma-distributed step to ``log C_al`` (shape
    ``walk_shape``, mean ``(log leak_failure - log leak_start) / target`` for a
    unit-specific ``target`` life), so the path is monotone and a step's coefficient of
    variation is ``1 / sqrt(walk_shape)`` (0.25 by default). The walk alone makes the
    remaining life uncertain: with ``n`` cycles left its standard deviation is about
    ``sqrt(n / walk_shape)`` cycles, even for a predictor that knows the unit's rate.

    Why 16: the seed (section 8.4.1) gives each of its 25 runs its own "dynamics of
    coefficient C development" over (1e-10, 1e-6) and no cycle-to-cycle randomness,
    and its linear degradation model lands "about 10 %" from the true RUL. The default
    keeps a random walk (units with the same rate still fail at different cycles) but
    one smooth enough that a unit's own history can tell its rate, as in the seed's
    runs: with 20 cycles left the walk spreads the life by about 1.1 cycles. Shape 4
    (step CV 0.5) is the rough stress case: there even a predictor told each unit's
    rate keeps every last-half prediction within 10 % of the life for only 89 % of
    units, and one that must learn the rate for about 74 % (docs/rul.md).

    Parameters
    ----------
    n_units : int, default 10
    max_cycles : int, default 60
        Typical longest life: each unit's leak rate is drawn so that its expected
        life falls between 40 % and 100 % of this (the random walk spreads it).
    leak_start, leak_failure : float, m^2
        ``C_al`` of a new unit and the failure threshold.
    chamber : {"a", "b"}
        The leaking chamber (seed figure 8.8 shows chamber B).
    t_end, fs, signals, seed, batch_size
        As :func:`simulate_fault_ensemble`.
    walk_shape : float, default 16.0
        Shape of the gamma-distributed steps of ``log C_al``; larger is smoother
        (``inf`` is not allowed; 1e6 is practically a straight line; 4 is rough).
    schedule : {"walk", "seed"}, default "walk"
        ``"walk"``: the random walk above. ``"seed"``: the seed author's own schedule
        (``mb/rul.mlx`` of github.com/xvoron/thesis): ``L = linspace(1e-5, b 1e-3, n)``
        with ``b ~ U(1, 2)`` and ``n ~ U(max_cycles / 2, max_cycles)`` cycles (100..200
        in the seed: pass ``max_cycles=200``), ``C_al = L**2 + r L**3`` with
        ``r ~ U(0, 1)``, and each cycle's ``C_al`` raised by a random 1..8 %; it runs
        from 1e-10 to 1..4e-6 m^2 and the unit's last cycle is its last simulated one
        (the seed defines failure by an indicator threshold, not by ``C_al``);
        ``leak_start``, ``leak_failure`` and ``walk_shape`` are not used.
    operating_point : (load_kg, supply_bar), optional
        Every unit at this load and supply (bar gauge) instead of random ones (the
        seed simulated its runs at one operating point).
    unit_variation : bool, default True
        Draw each unit's unlabelled parameters (friction, valve coefficients, valve
        delay) and healthy knob settings at random, as :func:`simulate_fault_ensemble`
        does. False: every unit is the nominal healthy twin (the
        :class:`~pdmkit.models.PneumaticParams` defaults, knobs at the middle of their
        healthy range) and only its leak differs, as in the seed author's 26 runs, all
        simulated from one parameter file (``mb/rul.mlx``; its figure 8.9 shows every
        run starting at the same indicator value).
    leak_scale : float, default 1.0
        Factor applied to the leak coefficient path before simulating: a schedule
        written for another model's valve sizes (the seed's ``C_al`` is relative to its
        identified valve coefficients) is carried over to the twin's.

    Returns
    -------
    Ensemble
        Members ``"u03/c0012"``; conditions ``unit``, ``cycle`` (0, 1, ...), ``c_leak``
        (m^2, the coefficient simulated), ``c_leak_schedule`` (the schedule's value,
        ``c_leak / leak_scale``), ``rul`` (cycles left until failure; 0 at the failing
        cycle) and ``failed`` (True at the last cycle of each unit).

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_leak_runs
    >>> runs = simulate_leak_runs(2, max_cycles=6, t_end=0.5, signals=["AirPressure"])
    >>> runs.conditions.groupby("unit")["rul"].min().tolist()
    [0, 0]
    """
    if chamber not in ("a", "b"):
        raise ValueError(f"chamber must be 'a' or 'b'; got {chamber!r}")
    if not 0 < leak_start < leak_failure:
        raise ValueError(
            f"need 0 < leak_start < leak_failure; got {leak_start!r}, {leak_failure!r}"
        )
    if max_cycles < 3:
        raise ValueError(f"max_cycles must be >= 3; got {max_cycles!r}")
    if not (
        isinstance(walk_shape, int | float | np.integer | np.floating)
        and not isinstance(walk_shape, bool)
        and 0 < walk_shape < np.inf
    ):
        raise ValueError(
            f"walk_shape must be a positive finite number (16 by default); got "
            f"{walk_shape!r}"
        )
    if schedule not in ("walk", "seed"):
        raise DataError(f"schedule must be 'walk' or 'seed'; got {schedule!r}")
    if (
        isinstance(leak_scale, bool)
        or not isinstance(leak_scale, int | float | np.integer | np.floating)
        or not 0 < leak_scale < np.inf
    ):
        raise DataError(f"leak_scale must be a positive finite number; got {leak_scale!r}")
    signals = _signal_list(signals)
    rng = np.random.default_rng(seed)
    units, cycles, leaks = [], [], []
    for u in range(int(n_units)):
        if schedule == "seed":
            path = _seed_leak_path(rng, int(max_cycles))
        else:
            path = _leak_path(rng, max_cycles, leak_start, leak_failure, float(walk_shape))
        units += [u] * len(path)
        cycles += list(range(len(path)))
        leaks += list(path)
    n = len(units)
    units_arr = np.asarray(units)
    per_unit = _operating_conditions(int(n_units), rng)
    if operating_point is not None:
        load_kg, supply_bar = (float(v) for v in operating_point)
        per_unit["mass_load"] = np.full(int(n_units), load_kg)
        per_unit["p_supply"] = np.full(int(n_units), _P_AMBIENT + supply_bar * 1e5)
    knobs = _fault_settings(np.array(["healthy"] * int(n_units)), rng)
    if not unit_variation:  # the nominal healthy twin, only the leak differs
        from pdmkit.models import PneumaticParams

        nominal = PneumaticParams()
        for k in per_unit:
            if k not in ("mass_load", "p_supply"):
                per_unit[k] = np.full(int(n_units), float(getattr(nominal, k)))
        healthy = {
            s.parameter: float(np.mean(s.healthy)) for s in PNEUMATIC_FAULTS.values()
        }
        knobs = {k: np.full(int(n_units), healthy[k]) for k in knobs}
    cols = {k: v[units_arr] for k, v in per_unit.items()}
    cols.update(knobs)
    for k in (
        "throttle_a",
        "throttle_b",
        "damper_upper",
        "damper_bottom",
        "damper_large_damping",
    ):
        cols[k] = cols[k][units_arr]
    cols[f"c_leak_{chamber}"] = np.asarray(leaks) * float(leak_scale)
    data = _simulate_batches(
        cols,
        n,
        t_end=t_end,
        fs=fs,
        signals=signals,
        seed=seed,
        batch_size=batch_size,
        desc="simulating leak runs",
    )
    cycles_arr = np.asarray(cycles)
    last = pd.Series(cycles_arr).groupby(units_arr).transform("max").to_numpy()
    conditions = pd.DataFrame(
        {
            "unit": units_arr,
            "cycle": cycles_arr,
            "c_leak": cols[f"c_leak_{chamber}"],
            "c_leak_schedule": np.asarray(leaks),
            "rul": last - cycles_arr,
            "failed": cycles_arr == last,
            "load_kg": cols["mass_load"],
            "supply_bar": (cols["p_supply"] - _P_AMBIENT) / 1e5,
        }
    )
    ids = [f"u{u:02d}/c{c:04d}" for u, c in zip(units_arr, cycles_arr, strict=True)]
    return Ensemble(data, fs=fs, conditions=conditions, member_ids=ids)


def pneumatic_residuals(
    ensemble: Ensemble,
    signals: Sequence[str] = ("LeverPosition",),
    *,
    t_end: float | None = None,
    reference: str = "operating_point",
    nominal_point: tuple[float, float] = (0.0, 6.0),
    test_cycle: str = "twin",
) -> Ensemble:
    """Residuals of recordings against the nominal twin (seed section 8.3).

    With ``reference="operating_point"``, for every operating point in the ensemble
    (its ``load_kg`` and ``supply_bar`` conditions, which an operator knows) the healthy
    nominal model is simulated once, without sensor imperfections, and subtracted from
    each member's recording: ``e(t) = y(t) - y_nominal(t)``; this keeps load and supply
    out of the residual. ``reference="nominal"`` is the seed's way ("the simulation was
    performed only once and then used as the nominal reference behavior for all
    calculations of all residuals"): one healthy response at ``nominal_point`` for
    every member.

    Parameters
    ----------
    ensemble : Ensemble
        Recordings of the twin (or of the rig) with ``load_kg`` and ``supply_bar``
        conditions.
    signals : sequence of str
        Signals to form residuals of; the result names them ``<signal>_res``.
    t_end : float, optional
        Length of the nominal simulation (default: the recordings' length).
    reference : {"operating_point", "nominal"}, default "operating_point"
        One healthy reference per operating point, or one for all (the seed's).
    nominal_point : (float, float), default (0.0, 6.0)
        Load (kg) and supply (bar gauge) of the single reference.
    test_cycle : {"twin", "seed_rig"}, default "twin"
        The reference's valve program (the recordings'; see
        :func:`simulate_seed_ensemble`).

    Returns
    -------
    Ensemble
        Residual signals, same members and conditions.

    Examples
    --------
    >>> from pdmkit.ensembles import pneumatic_residuals, simulate_fault_ensemble
    >>> ens = simulate_fault_ensemble(6, t_end=0.5, signals=["LeverPosition"], seed=3)
    >>> res = pneumatic_residuals(ens)
    >>> res.signal_names
    ['LeverPosition_res']
    """
    from pdmkit.models import PneumaticParams, SensorSpec, simulate_piston

    missing = [c for c in ("load_kg", "supply_bar") if c not in ensemble.conditions]
    if missing:
        raise DataError(
            f"the ensemble has no condition column(s) {missing}: residuals need each "
            "member's load mass (kg) and supply pressure (bar gauge)"
        )
    arrays, fs = {}, {}
    for name in signals:
        if name not in ensemble.signal_names:
            raise DataError(
                f"signal {name!r} is not in the ensemble {ensemble.signal_names}"
            )
        x, has = ensemble.stack(name)
        if not has.all():
            raise DataError(
                f"members {list(ensemble.member_ids[~has][:5])} lack signal {name!r}"
            )
        arrays[name], fs[name] = x, ensemble.fs[name]
    if reference not in ("operating_point", "nominal"):
        raise DataError(
            f"reference must be 'operating_point' or 'nominal'; got {reference!r}"
        )
    conditions = ensemble.conditions
    if reference == "nominal":
        load, supply = (float(v) for v in nominal_point)
        points = pd.DataFrame({"load_kg": [load], "supply_bar": [supply]})
    else:
        points = conditions[["load_kg", "supply_bar"]].drop_duplicates()
        points = points.reset_index(drop=True)
    healthy = {s.parameter: float(np.mean(s.healthy)) for s in PNEUMATIC_FAULTS.values()}
    params = PneumaticParams(
        mass_load=points["load_kg"].to_numpy(float),
        p_supply=_P_AMBIENT + points["supply_bar"].to_numpy(float) * 1e5,
        **healthy,
        **_test_cycle(test_cycle, len(points)),
    )
    rate = {fs[name] for name in signals}
    if len(rate) != 1:
        raise DataError(f"signals {list(signals)} have different rates {sorted(rate)}")
    rate_hz = rate.pop()
    n_samples = arrays[signals[0]].shape[1]
    duration = t_end if t_end is not None else n_samples / rate_hz
    ideal = {name: SensorSpec() for name in signals}
    nominal = simulate_piston(
        params,
        t_end=duration,
        fs=rate_hz,
        sensors=list(signals),
        seed=0,
        sensor_specs=ideal,
    )
    if reference == "nominal":
        row = np.zeros(len(conditions), dtype=int)
    else:
        key = pd.MultiIndex.from_frame(points)
        row = key.get_indexer(
            pd.MultiIndex.from_frame(conditions[["load_kg", "supply_bar"]])
        )
    out = {}
    for name in signals:
        reference = np.asarray(nominal.outputs[name])[:, :n_samples]
        out[f"{name}_res"] = arrays[name] - reference[row]
    return Ensemble(
        out,
        fs={f"{n}_res": fs[n] for n in signals},
        conditions=conditions,
        member_ids=list(ensemble.member_ids),
    )


#: the healthy class and the four single faults of the seed's residual set (8.2.1, the
#: ``ClassNames`` of the author's ``train_model.m``)
SEED_SINGLE_FAULTS = (
    "healthy",
    "throttle_1",
    "throttle_2",
    "damper_bottom",
    "damper_upper",
)


#: The valve program of the seed rig's recordings: one up command from 1 s to 6 s of the
#: 10 s recording, then down (the author's ``sb/legacy/MeasurementScript.m``: sOffset =
#: 1 s, eTime = 5 s; the recorded command ``outValveWP`` of ``data11_1_*.mat`` switches
#: at 0.998 s and 5.999 s). The same DAQ task writes the command and samples the sensors
#: (``DaqMeasurement.m``), so every recording starts at the same phase of the cycle. The
#: twin's own program is five 2 s cycles from 0.1 s (``test_cycle="twin"``).
SEED_TEST_CYCLE = {"cycle_start": 1.0, "cycle_period": 10.0, "cycle_duty": 0.5}


def _test_cycle(test_cycle: str, n: int) -> dict[str, np.ndarray]:
    """Valve-program parameters of ``n`` members: the twin's (none) or the seed rig's."""
    if test_cycle == "twin":
        return {}
    if test_cycle != "seed_rig":
        raise DataError(f"test_cycle must be 'twin' or 'seed_rig'; got {test_cycle!r}")
    return {k: np.full(n, v) for k, v in SEED_TEST_CYCLE.items()}


#: Fault codes per class of the seed's residual set (see
#: :func:`simulate_seed_single_fault_ensemble`).
SEED_RESIDUAL_SET_CODES = {
    "healthy": 5,
    "throttle_1": 8,
    "throttle_2": 7,
    "damper_bottom": 8,
    "damper_upper": 5,
}


def simulate_seed_single_fault_ensemble(
    n_members: int = 660,
    *,
    repeats: int = 20,
    operating_point: tuple[float, float] = (6.25, 6.0),
    jitter: float | None = None,
    t_end: float = 10.0,
    seed: int = 0,
    variation: str = "rig",
    test_cycle: str = "twin",
):
    """The seed's smaller data set (8.2.1) on the twin: single faults at one point.

    The set of the seed's residual classification (8.3; the author's ``data11``: 660
    recordings). Built like :func:`simulate_seed_ensemble` (fault codes of
    ``repeats`` recordings, faulty knobs from :data:`~pdmkit.ensembles.PNEUMATIC_FAULTS`,
    one rig with its other knobs at their marks, run-to-run ``jitter``), but with only
    healthy and the four single faults (the ``ClassNames`` of the author's
    ``train_model.m``), in the proportions of the author's set (100, 160, 140, 160 and
    100 recordings of healthy, valve1, valve2, damp_small_bot, damp_small_up in
    ``mb/featuretables/residual_featuretable.mat``: 5, 8, 7, 8 and 5 codes of 20), and
    every recording at ``operating_point`` (load kg, supply bar gauge): only the
    ``LeverPosition`` signal. ``variation="code"`` draws the unlabelled parameters and
    the knobs that are not faulty per code instead (pdmkit's reading before);
    ``test_cycle="seed_rig"`` records the rig's valve program (:data:`SEED_TEST_CYCLE`)
    instead of the twin's.

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_seed_single_fault_ensemble
    >>> ens = simulate_seed_single_fault_ensemble(10, repeats=2, t_end=0.2)
    >>> len(ens), sorted(set(ens.conditions["fault"]))[:2]
    (10, ['damper_bottom', 'damper_upper'])
    """
    jitter = SEED_JITTER if jitter is None else float(jitter)
    n = int(n_members)
    if n < len(SEED_SINGLE_FAULTS):
        raise DataError(
            f"n_members must be >= {len(SEED_SINGLE_FAULTS)}; got {n_members!r}"
        )
    if variation not in ("rig", "code"):
        raise DataError(f"variation must be 'rig' or 'code'; got {variation!r}")
    rng = np.random.default_rng([seed, 83])
    n_codes = max(len(SEED_SINGLE_FAULTS), round(n / int(repeats)))
    per_class = _shares(n_codes, [SEED_RESIDUAL_SET_CODES[c] for c in SEED_SINGLE_FAULTS])
    code_labels = np.repeat(np.array(SEED_SINGLE_FAULTS), per_class)
    knobs = _fault_settings(code_labels, rng, at_mark=variation == "rig")
    member_code = np.arange(n) % n_codes
    rng.shuffle(member_code)
    cols = {k: v[member_code] for k, v in knobs.items()}
    if variation == "rig":
        cols.update(_one_rig(n))
    else:
        drawn = _operating_conditions(n_codes, rng)
        cols.update(
            {
                k: v[member_code]
                for k, v in drawn.items()
                if k not in ("mass_load", "p_supply")
            }
        )
    load_kg, supply_bar = (float(v) for v in operating_point)
    cols["mass_load"] = np.full(n, load_kg)
    gauge = np.full(n, supply_bar * 1e5)
    if jitter:
        noise = np.random.default_rng([seed, 84]).standard_normal((4, n))
        spread = (1.0 + jitter * noise).clip(0.5, 1.5)
        for row, k in enumerate(("friction_coulomb", "friction_viscous", "valve_delay")):
            cols[k] = cols[k] * spread[row]
        gauge = gauge * (1.0 + SEED_SUPPLY_REPEATABILITY * noise[3])
    cols["p_supply"] = _P_AMBIENT + gauge
    cols.update(_test_cycle(test_cycle, n))
    ids = np.array([f"seed{i:05d}" for i in range(n)])
    specs = _acquisition_specs("seed_rig")
    data = _simulate_members(cols, ids, seed, t_end, 1000.0, ["LeverPosition"], 250, specs)
    labels = code_labels[member_code]
    conditions = pd.DataFrame(
        {
            "fault": labels,
            "seed_label": [SEED_LABELS[c] for c in labels],
            "fault_code": [f"RC{c:04d}" for c in member_code],
            "load_kg": load_kg,
            "supply_bar": supply_bar,  # the set point
        }
    )
    return Ensemble(data, fs=1000.0, conditions=conditions, member_ids=list(ids))
