"""Checks of :func:`~pdmkit.models.pneumatic.estimate_parameters`' inputs, and the windows.

The free parameters, their bounds and optimised space, the recording's signals and
where the fitted windows lie (at rest just before each switch of the valve command,
until the piston has settled at the other end) become a :class:`_Problem`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from pdmkit.errors import DataError, ModelError, did_you_mean
from pdmkit.models.ode import ResponseData
from pdmkit.models.pneumatic._estimate_problem import _Problem
from pdmkit.models.pneumatic._integrate import _switch_times, simulate_piston
from pdmkit.models.pneumatic._twin import PneumaticParams

#: sensors whose readings the estimator can predict differentiably
FITTABLE_SIGNALS = (
    "LeverPosition",
    "LeverVelocity",
    "AccelerometerMoving_axisZ",
    "FlowExtrusion",
    "FlowContraction",
    "AirPressure",
)

#: parameters that only shape sensor readings the estimator does not fit
_SENSOR_ONLY = frozenset(
    {
        "frame_frequency",
        "frame_damping_ratio",
        "frame_mass",
        "strain_area",
        "mic_frequency",
        "mic_decay",
        "mic_gain",
        "mic_far_gain",
        "mic_ambient_gain",
        "mic_hiss_gain",
        "proximity_distance",
        "temp_gas_time_constant",
        "temp_wall_gain",
        "temp_sensor_time_constant",
    }
)
#: parameters that move the valve switching instants: a fixed-step simulation is
#: piecewise constant in them (no gradient)
_TIMING = frozenset({"cycle_period", "cycle_duty", "cycle_start", "valve_delay"})

_COARSE_DT = 5e-4  # stage-1 step: rest states identical to 2e-4, flows within ~1.5 %
_PRE_SWITCH = 0.005  # s of rest kept before each switch
_SETTLE_TOL = 2e-4  # m: the piston has arrived when within this of its rest position
_MARGIN = 0.1  # s kept after the slowest arrival (chamber filling, damper creep)


# ---------------------------------------------------------------------------- inputs
def _check_free(free, known: PneumaticParams) -> list[str]:
    if isinstance(free, str):
        free = (free,)
    names = [f.name for f in dataclasses.fields(PneumaticParams)]
    out: list[str] = []
    for k in free:
        if not isinstance(k, str) or k not in names:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} is not a PneumaticParams "
                f"field{did_you_mean(k, names)} Choose from the fields of "
                "PneumaticParams (see PneumaticParams.describe())."
            )
        if k in _SENSOR_ONLY:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} only shapes sensor readings "
                f"that cannot be fitted here; the fittable signals are "
                f"{', '.join(FITTABLE_SIGNALS)}. Leave {k!r} in `known`."
            )
        if k in _TIMING:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} moves the valve switching "
                "instants, which a fixed-step simulation cannot differentiate; set it in "
                "`known` (read it off the recorded valve command)."
            )
        if k in out:
            raise ModelError(
                f"estimate_parameters: free parameter {k!r} is listed twice in `free`."
            )
        out.append(k)
    if not out:
        raise ModelError("estimate_parameters: `free` is empty; name at least one field.")
    return out


def _check_bounds(names: list[str], known: PneumaticParams, bounds) -> tuple:
    fields = {f.name: f for f in dataclasses.fields(PneumaticParams)}
    bounds = dict(bounds or {})
    for k in bounds:
        if k not in names:
            raise ModelError(
                f"estimate_parameters: bounds given for {k!r}, which is not in `free` "
                f"({', '.join(names)}); free it or drop its bounds."
            )
    log, lo, hi, th_lo, th_hi = [], [], [], [], []
    for k in names:
        meta = fields[k].metadata
        value = float(getattr(known, k))
        f_lo = meta["lo"] if meta["lo"] is not None else -math.inf
        f_hi = meta["hi"] if meta["hi"] is not None else math.inf
        if k in bounds:
            try:
                b_lo, b_hi = (float(b) for b in bounds[k])
            except (TypeError, ValueError) as exc:
                raise ModelError(
                    f"estimate_parameters: bounds[{k!r}] must be a pair (low, high); got "
                    f"{bounds[k]!r}."
                ) from exc
            if not b_lo < b_hi:
                raise ModelError(
                    f"estimate_parameters: bounds[{k!r}] = ({b_lo:g}, {b_hi:g}) must have "
                    "low < high."
                )
            if b_lo < f_lo or b_hi > f_hi or (meta["lo_open"] and b_lo <= f_lo):
                raise ModelError(
                    f"estimate_parameters: bounds[{k!r}] = ({b_lo:g}, {b_hi:g}) leave the "
                    f"allowed range [{f_lo:g}, {f_hi:g}] {meta['unit']} of {k}."
                )
        else:
            if value == 0.0 or not math.isfinite(f_lo):
                raise ModelError(
                    f"estimate_parameters: give bounds for {k!r} (known value {value:g}, "
                    f"range [{f_lo:g}, {f_hi:g}] {meta['unit']}): its range is open and "
                    "the known value gives no scale, e.g. bounds={"
                    f"{k!r}: (low, high)}}."
                )
            b_lo = max(f_lo, abs(value) / 100.0) if f_lo >= 0 else value - abs(value)
            b_hi = min(f_hi, abs(value) * 100.0) if f_lo >= 0 else value + abs(value)
        positive = b_lo > 0
        th_lo.append(b_lo)
        th_hi.append(b_hi)
        log.append(positive)
        lo.append(math.log(b_lo) if positive else b_lo)
        hi.append(math.log(b_hi) if positive else b_hi)
    return (
        np.array(log, dtype=bool),
        np.array(lo),
        np.array(hi),
        np.array(th_lo),
        np.array(th_hi),
    )


def _recording_pool(recording, member: int) -> tuple[object, dict, str]:
    """``(fs as given, {signal: samples of the member}, where)`` of a recording."""
    if isinstance(recording, ResponseData):
        n = recording.n_members
        if not -n <= member < n:
            raise DataError(
                f"estimate_parameters: member {member} out of range; the recording has "
                f"{n} members (0..{n - 1})."
            )
        if recording.time.size > 0 and abs(float(recording.time[0])) > 1e-12:
            raise DataError(
                "estimate_parameters: the recording must start at t = 0 of the valve "
                f"command schedule in `known`; its time starts at {recording.time[0]:g} s."
            )
        pool = {k: np.asarray(v)[member] for k, v in recording.outputs.items()}
        return recording.fs, pool, "recording.outputs"
    if isinstance(recording, Mapping):
        if "fs" not in recording:
            raise DataError(
                "estimate_parameters: the recording mapping has no 'fs' entry; add the "
                "sampling rate in Hz, e.g. {'fs': 1000.0, 'LeverPosition': x, ...}."
            )
        pool = {k: v for k, v in recording.items() if k != "fs"}
        return recording["fs"], pool, "the recording"
    raise DataError(
        "estimate_parameters: recording must be a mapping of signal name -> 1-D "
        "array with an 'fs' entry, or a PneumaticResponse; got "
        f"{type(recording).__name__}."
    )


def _checked_rate(fs: object) -> float:
    """The sampling rate as a positive finite float."""
    try:
        fs = float(fs)
    except (TypeError, ValueError) as exc:
        raise DataError(f"estimate_parameters: fs must be a number; got {fs!r}.") from exc
    if not (math.isfinite(fs) and fs > 0):
        raise DataError(f"estimate_parameters: fs must be positive and finite; got {fs}.")
    return fs


def _checked_signal(s: str, pool: dict, wanted: bool, where: str) -> np.ndarray | None:
    """Signal ``s`` as a finite 1-D float array, or ``None`` for an unusable extra one."""
    if s not in pool:
        if not wanted:
            return None
        raise DataError(
            f"estimate_parameters: signal {s!r} is missing from {where}"
            f"{did_you_mean(s, pool)} It has "
            f"{', '.join(map(str, pool)) or 'no signals'}. Record it or drop it from "
            "`signals`."
        )
    try:
        arr = np.asarray(pool[s], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise DataError(
            f"estimate_parameters: signal {s!r} must be numeric; got "
            f"{type(pool[s]).__name__}."
        ) from exc
    if arr.ndim != 1:
        raise DataError(
            f"estimate_parameters: signal {s!r} must be 1-D (one member's samples); "
            f"got shape {arr.shape}. Pass one member (`member=`) of a batch."
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        if not wanted:
            return None
        raise DataError(
            f"estimate_parameters: signal {s!r} has {int(bad.sum())} non-finite "
            f"samples (first at index {int(np.flatnonzero(bad)[0])}); fill or "
            "interpolate the gaps (dropouts) or drop the signal."
        )
    return arr


def _check_recording(recording, signals: list[str], member: int):
    """-> (fs, {signal: 1-D float array}, {other signal: array} for windowing)."""
    fs, pool, where = _recording_pool(recording, member)
    fs = _checked_rate(fs)
    data = {}
    n = None
    for s in [*signals, *(k for k in ("LeverPosition",) if k not in signals)]:
        arr = _checked_signal(s, pool, s in signals, where)
        if arr is None:
            continue
        if n is None:
            n = arr.size
        elif arr.size != n:
            raise DataError(
                f"estimate_parameters: signal {s!r} has {arr.size} samples, the others "
                f"{n}; all signals must share one time base at fs = {fs:g} Hz."
            )
        data[s] = arr
    return fs, data, n


def _noise_scale(x: np.ndarray) -> float:
    """Robust white-noise std from second differences, floored at 1e-3 of the range."""
    d2 = np.diff(x, 2)
    mad = float(np.median(np.abs(d2 - np.median(d2)))) * 1.4826 / math.sqrt(6.0)
    span = float(np.ptp(x))
    return max(mad, 1e-3 * span, 1e-12)


def _windows(
    known: PneumaticParams,
    fs: float,
    n: int,
    data: Mapping[str, np.ndarray],
    window,
    max_windows: int | None,
) -> tuple[np.ndarray, int]:
    """First samples of the windows and their common length (samples)."""
    switches = [t for t in _switch_times(known, n / fs) if t * fs < n - 2]
    if not switches:
        raise DataError(
            f"estimate_parameters: the recording ({n / fs:g} s) holds no switch of the "
            f"valve command of `known` (first at {known.cycle_start + known.valve_delay:g}"
            f" s, period {known.cycle_period:g} s); the windows start at those switches."
        )
    k_sw = np.array([math.floor(t * fs + 1e-6) for t in switches])
    ends = np.append(k_sw[1:], n)  # a window never crosses the next switch
    if max_windows is not None:
        if not isinstance(max_windows, int | np.integer) or max_windows < 1:
            raise ModelError(
                f"estimate_parameters: max_windows must be a positive integer or None; "
                f"got {max_windows!r}."
            )
        k_sw, ends = k_sw[: int(max_windows)], ends[: int(max_windows)]
    k0 = np.maximum(k_sw - round(_PRE_SWITCH * fs), 0)
    room = int(np.min(ends - k0))
    if isinstance(window, str):
        if window != "auto":
            raise ModelError(
                f"estimate_parameters: window must be 'auto' or a length in s; got "
                f"{window!r}."
            )
        if "LeverPosition" in data:
            x = data["LeverPosition"]
        else:
            r = simulate_piston(known, t_end=n / fs, fs=fs, sensors=False, progress=False)
            x = np.asarray(r.states["position"][0])
        need = 0
        for a, b, first in zip(k_sw, ends, k0, strict=True):
            seg = x[a:b]
            rest = float(np.median(seg[-max(1, seg.size // 5) :]))
            moving = np.flatnonzero(np.abs(seg - rest) > _SETTLE_TOL)
            arrive = (int(moving[-1]) + 1) if moving.size else 0
            need = max(need, int(a - first) + arrive)
        length = min(room, need + round(_MARGIN * fs))
    else:
        try:
            w = float(window)
        except (TypeError, ValueError) as exc:
            raise ModelError(
                f"estimate_parameters: window must be 'auto' or a length in s; got "
                f"{window!r}."
            ) from exc
        if not (math.isfinite(w) and w > 0):
            raise ModelError(f"estimate_parameters: window must be > 0 s; got {w}.")
        length = round(w * fs)
        if length > room:
            raise ModelError(
                f"estimate_parameters: window = {w:g} s is longer than the {room / fs:g} s "
                "between a window start and the next switch (or the end of the "
                "recording); shorten it."
            )
    if length < 3:
        raise ModelError(
            f"estimate_parameters: windows of {length} samples are too short to fit; "
            "use a longer window."
        )
    return k0, int(length)


def _setup_problem(
    recording,
    free,
    known,
    signals,
    bounds,
    window,
    max_windows,
    member,
    dt,
) -> tuple[_Problem, dict]:
    """Validate the inputs and build the fit (no optimisation yet)."""
    if known is None:
        known = PneumaticParams()
    if not isinstance(known, PneumaticParams):
        raise ModelError(
            f"estimate_parameters: known must be a PneumaticParams; got "
            f"{type(known).__name__}."
        )
    if known.n_members is not None or known.is_torch:
        raise ModelError(
            "estimate_parameters: known must hold one scalar value per parameter (numpy "
            f"floats); got a batch of {known.n_members} members or torch tensors. Use "
            "known.member(i)."
        )
    names = _check_free(free, known)
    if isinstance(signals, str):
        signals = (signals,)
    signals = list(signals)
    if not signals:
        raise ModelError("estimate_parameters: `signals` is empty; name a sensor to fit.")
    for s in signals:
        if s not in FITTABLE_SIGNALS:
            raise ModelError(
                f"estimate_parameters: cannot fit signal {s!r}"
                f"{did_you_mean(s, FITTABLE_SIGNALS)} Fittable signals: "
                f"{', '.join(FITTABLE_SIGNALS)}."
            )
    if len(set(signals)) != len(signals):
        raise ModelError(f"estimate_parameters: `signals` repeats a name: {signals}.")
    log, lo, hi, th_lo, th_hi = _check_bounds(names, known, bounds)
    fs, data, n = _check_recording(recording, signals, member)
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ModelError(f"estimate_parameters: dt must be a positive number; got {dt!r}.")
    sub = 1.0 / (fs * dt)
    n_sub = round(sub)
    if n_sub < 1 or abs(sub - n_sub) > 1e-6 * sub:
        raise ModelError(
            f"estimate_parameters: 1/fs = {1 / fs:g} s must be a whole number of steps "
            f"dt = {dt:g} s; choose dt = 1/(fs k), e.g. {1 / (fs * max(1, round(sub))):g}."
        )
    n_sub_c = max(1, min(n_sub, round(1.0 / (fs * _COARSE_DT))))
    k0, length = _windows(known, fs, n, data, window, max_windows)
    idx = k0[:, None] + np.arange(length)[None, :]
    meas = np.stack([data[s][idx] for s in signals])  # (S, W, L)
    sigma = np.array([_noise_scale(data[s]) for s in signals])
    prob = _Problem(
        known=known,
        names=names,
        log=log,
        lo=lo,
        hi=hi,
        th_lo=th_lo,
        th_hi=th_hi,
        signals=signals,
        fs=fs,
        k0=k0,
        length=length,
        meas=meas,
        sigma=sigma,
        h_fine=1.0 / (fs * n_sub),
        n_sub_fine=n_sub,
        n_sub_coarse=n_sub_c,
    )
    return prob, data
