"""Sensor models of the demonstration device (seed table 3.1, sections 4.6 and 8.1.1).

Each sensor turns noise-free model quantities (SI) into the reading the real sensor
reports, in its unit, then a :class:`SensorSpec` adds what can go wrong with a sensor:
gain error, offset, drift, noise, quantisation and dropout (seed 8.1.1: "noise" and
"offset" sensor faults, drift and complete signal loss), and for the two proximity
switches the repeatability of their switching point.

Two sets of healthy imperfections (:func:`default_sensor_specs`): ``"typical"``, the
twin's long-standing assumed datasheet values, and ``"seed_rig"``, the seed rig's own
acquisition as its recordings show it (:data:`SEED_RIG_ACQUISITION`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import signal as sps

from pdmkit._checks import replace_fields
from pdmkit.errors import ModelError, did_you_mean
from pdmkit.models.pneumatic._params import piston_areas

__all__ = ["SENSOR_NAMES", "SENSOR_UNITS", "SensorSpec", "default_sensor_specs"]

#: The seed rig's acquisition of its analogue channels, measured in the author's
#: recordings (github.com/xvoron/thesis, ``models/models_datastore/data11_1_1..3.mat``:
#: three healthy 10 s recordings of fault code 1100001 at 6.25 kg, 6 bar):
#: signal -> (resolution, standard deviation at rest), in the signal's unit. The
#: resolution is the spacing of the recorded values; the rest spread is that of the
#: last second (piston at rest at the bottom, reservoir refilled), the mean of the
#: three recordings. The channels on the rig's NI 9221 module (12 bit over its
#: +-62.5 V nominal range: 30.5 mV per count, ``sb/legacy/MeasurementScript.m``) read
#: one count times each transmitter's scale (``sb/legacy/Conversion_*.m``): the
#: reservoir pressure transmitter 6.25 bar/V -> 0.1907 bar (recorded: 0.19066), the
#: flow sensors 5 l/min/V -> 0.1525 l/min (0.15253), the accelerometers 3.0 g/V
#: (333 mV/g) -> 0.0916 g (0.09162), the strain gauge's load cell 200 N/V -> 6.1 N
#: (6.101). The standard deviation at rest is about one count: the module's input
#: noise over the transmitters' 0.4-2 V and 0-10 V signals.
SEED_RIG_ACQUISITION: dict[str, tuple[float, float]] = {
    "AirPressure": (0.19066, 0.168),
    "FlowExtrusion": (0.15253, 0.129),
    "FlowContraction": (0.15253, 0.125),
    # recorded in g and N; here in m/s^2 (g = 9.81 as Conversion_Acc.m) and in Pa at
    # the default strain_area of 1e-4 m^2
    "AccelerometerMoving_axisZ": (0.091621 * 9.81, 0.0809 * 9.81),
    "AccelerometerStatic_axisZ": (0.091619 * 9.81, 0.0794 * 9.81),
    "StrainGauge": (6.101e4, 5.544e4),
}

#: The rig's load cell's zero, N: its readings less the twin's rod force
#: (:func:`rod_force`, the seed rig's machine at the recordings' 6.25 kg, 6 bar and
#: valve program), averaged over the three healthy recordings ``data11_1_1..3.mat``
#: (-58.0 N; 23 N RMS left, most of it where the rig's piston starts 0.2 s later). The
#: cell was zeroed with the lever hanging on it: at rest at the top it reads 86 N, not
#: the lever's 128 N weight.
SEED_RIG_STRAIN_TARE = -58.0

#: Repeat accuracy of the switching point of the rig's proximity switches, m (Festo
#: SMT-8M-A-PS-24V-E-0,3-M8D, part 574334: "Repetition accuracy 0.2 mm"; its datasheet
#: is ``doc/sensors/574334datasheet.pdf`` of the author's repository).
SMT_8M_REPEATABILITY = 2e-4

#: Reference atmosphere for standard flow (ISO 8778 / ISO 6358 "ANR"): 20 degC, 100 kPa.
P_STD = 1.0e5
T_STD = 293.15

SENSOR_UNITS: dict[str, str] = {
    "LeverPosition": "m",
    "LeverVelocity": "m/s",
    "AccelerometerMoving_axisZ": "m/s^2",
    "AccelerometerStatic_axisZ": "m/s^2",
    "FlowExtrusion": "l/min",
    "FlowContraction": "l/min",
    "AirPressure": "bar",
    "MIC_uBumper": "V",
    "MIC_bBumper": "V",
    "MIC_Ambient": "V",
    "TempCylinder": "degC",
    "TempAmbient": "degC",
    "StrainGauge": "Pa",
    "ProximitySensor_upper": "-",
    "ProximitySensor_bottom": "-",
}
SENSOR_NAMES: tuple[str, ...] = tuple(SENSOR_UNITS)

_DESCRIPTION = {
    "LeverPosition": "encoder displacement (piston position, 0 = bottom)",
    "LeverVelocity": "encoder velocity",
    "AccelerometerMoving_axisZ": "accelerometer on the moving part (mean over a sample)",
    "AccelerometerStatic_axisZ": "accelerometer on the static frame (frame mode response)",
    "FlowExtrusion": "standard flow into chamber A",
    "FlowContraction": "standard flow out of chamber A",
    "AirPressure": "reservoir pressure, gauge",
    "MIC_uBumper": "microphone at the upper bumper",
    "MIC_bBumper": "microphone at the bottom bumper",
    "MIC_Ambient": "ambient microphone",
    "TempCylinder": "cylinder barrel temperature (slow sensor)",
    "TempAmbient": "ambient temperature",
    "StrainGauge": "stress in the piston rod's load cell (rod force / strain_area)",
    "ProximitySensor_upper": "1 within proximity_distance of the top end",
    "ProximitySensor_bottom": "1 within proximity_distance of the bottom end",
}


@dataclass(frozen=True)
class SensorSpec:
    """Imperfections of one sensor, in the sensor's output unit.

    Applied in this order to the ideal reading ``x`` at times ``t``::

        y = (1 + gain_error) * x + offset + drift * t + noise_std * N(0, 1)
        y = quantization * round(y / quantization)          (if quantization > 0)
        y[lost] = dropout_fill   with P(lost) = dropout     (each sample independently)

    ``switch_repeatability`` is for the proximity switches only (they threshold the
    position, m, see the module notes): the spread of the switching point.

    Every field is a float or an array of shape ``(n_members,)`` so that each member
    of a simulated ensemble can carry its own sensor fault.

    Parameters
    ----------
    noise_std : float
        Standard deviation of white measurement noise. >= 0.
    offset : float
        Constant bias.
    drift : float
        Bias growing linearly with time, per second.
    gain_error : float
        Relative sensitivity error (0.05 = reads 5 % high). > -1.
    dropout : float
        Probability in [0, 1] that a sample is lost; 1 = complete signal loss.
    dropout_fill : float
        Value recorded for lost samples (0, as a dead analogue channel reads; NaN allowed).
    quantization : float
        Resolution (LSB); 0 = none.
    switch_repeatability : float
        Proximity switches only: repeat accuracy of the switching point in m (the
        full width of its spread, as datasheets state it, e.g. 0.2 mm for the rig's
        Festo SMT-8M-A, part 574334). Each approach of the piston switches at a point
        drawn uniformly within +-half of it around the nominal point and releases at
        the same point (no hysteresis stated); 0 = the exact point every time.
        Ignored by the analogue sensors.

    Examples
    --------
    >>> import numpy as np
    >>> from pdmkit.models import SensorSpec
    >>> spec = SensorSpec(offset=0.5, quantization=0.25)
    >>> spec.apply(np.array([[0.0, 0.1, 1.0]]), fs=1000.0).tolist()
    [[0.5, 0.5, 1.5]]
    """

    noise_std: Any = 0.0
    offset: Any = 0.0
    drift: Any = 0.0
    gain_error: Any = 0.0
    dropout: Any = 0.0
    dropout_fill: Any = 0.0
    quantization: Any = 0.0
    switch_repeatability: Any = 0.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = np.asarray(getattr(self, f.name), dtype=np.float64)
            if v.ndim > 1:
                raise ModelError(
                    f"SensorSpec.{f.name} must be a number or shape (n_members,); got "
                    f"shape {v.shape}."
                )
            if f.name != "dropout_fill" and not np.all(np.isfinite(v)):
                raise ModelError(f"SensorSpec.{f.name} must be finite; got {v!r}.")
            val = float(v) if v.ndim == 0 else v
            object.__setattr__(self, f.name, val)
        checks = [
            ("noise_std", lambda v: v >= 0, ">= 0"),
            ("quantization", lambda v: v >= 0, ">= 0"),
            ("switch_repeatability", lambda v: v >= 0, ">= 0"),
            ("dropout", lambda v: (v >= 0) & (v <= 1), "in [0, 1]"),
            ("gain_error", lambda v: v > -1, "> -1"),
        ]
        for name, ok, text in checks:
            v = np.asarray(getattr(self, name))
            if not np.all(ok(v)):
                raise ModelError(
                    f"SensorSpec.{name} must be {text}; got {getattr(self, name)!r}."
                )

    def replace(self, **changes: Any) -> SensorSpec:
        """A copy with some fields changed; unknown names raise ModelError.

        Examples
        --------
        >>> from pdmkit.models import SensorSpec
        >>> SensorSpec().replace(offset=2.0).offset
        2.0
        """
        return replace_fields(self, changes, "field")

    def apply(self, x, fs: float, rng: np.random.Generator | int | None = None, t0=0.0):
        """Apply the imperfections to ideal readings ``x`` of shape (n_members, n_samples).

        Parameters
        ----------
        x : array_like
            Ideal readings in the sensor's unit; 1-D is one member.
        fs : float
            Sampling rate in Hz (for the drift).
        rng : numpy Generator or int, optional
            Random source for noise and dropout.
        t0 : float
            Time of the first sample in s.

        Returns
        -------
        numpy.ndarray
            Readings, shape of ``x`` (2-D for 2-D input).

        Examples
        --------
        >>> import numpy as np
        >>> from pdmkit.models import SensorSpec
        >>> y = SensorSpec(noise_std=0.1).apply(np.zeros((1, 20000)), fs=1e3, rng=0)
        >>> round(float(y.std()), 2)
        0.1
        """
        x = np.asarray(x, dtype=np.float64)
        one_d = x.ndim == 1
        x2 = x[None, :] if one_d else x
        if x2.ndim != 2:
            raise ModelError(
                f"SensorSpec.apply: x must be (n_members, n_samples); got shape {x.shape}."
            )
        n, n_samples = x2.shape
        rng = np.random.default_rng(rng)

        def col(name):
            v = getattr(self, name)
            if np.ndim(v) == 1:
                if len(v) != n:
                    raise ModelError(
                        f"SensorSpec.{name} has {len(v)} member values but the signal has "
                        f"{n} members."
                    )
                return np.asarray(v)[:, None]
            return v

        y = x2 * (1.0 + col("gain_error")) + col("offset")
        if np.any(np.asarray(self.drift) != 0):
            t = t0 + np.arange(n_samples) / float(fs)
            y = y + col("drift") * t[None, :]
        if np.any(np.asarray(self.noise_std) > 0):
            y = y + col("noise_std") * rng.standard_normal((n, n_samples), dtype=np.float32)
        q = col("quantization")
        if np.any(np.asarray(q) > 0):
            qq = np.broadcast_to(q, y.shape)
            safe = np.where(qq > 0, qq, 1.0)
            y = np.where(qq > 0, np.round(y / safe) * safe, y)
        if np.any(np.asarray(self.dropout) > 0):
            lost = rng.random((n, n_samples)) < col("dropout")
            y = np.where(lost, np.broadcast_to(col("dropout_fill"), y.shape), y)
        return y[0] if one_d else y


def default_sensor_specs(acquisition: str = "typical") -> dict[str, SensorSpec]:
    """Healthy sensor imperfections of the fifteen sensors of seed table 3.1.

    ``"typical"``: noise levels and resolutions typical of datasheets for such sensors
    (assumed), except the encoder resolution of about 7 um that the seed states
    (section 4.6). ``"seed_rig"``: the same, with the channels of
    :data:`SEED_RIG_ACQUISITION` as the seed rig's recordings show them (white noise
    and the recorded resolution; the noise is the rest spread less the resolution's
    own ``q / sqrt(12)``), the load cell's zero (:data:`SEED_RIG_STRAIN_TARE`), and the
    proximity switches' switching point repeating to the 0.2 mm of the rig's switches
    (Festo SMT-8M-A-PS-24V-E-0,3-M8D, part 574334, the datasheet in the author's
    repository: "Repetition accuracy 0.2 mm").

    Parameters
    ----------
    acquisition : {"typical", "seed_rig"}, default "typical"
        Which set.

    Returns
    -------
    dict of str to SensorSpec
        Keyed by the datastore signal names of table 3.1 (see :data:`SENSOR_UNITS`).

    Raises
    ------
    pdmkit.errors.ModelError
        An unknown ``acquisition``.

    Examples
    --------
    >>> from pdmkit.models import default_sensor_specs
    >>> specs = default_sensor_specs()
    >>> len(specs), specs["LeverPosition"].quantization
    (15, 7e-06)
    >>> rig = default_sensor_specs("seed_rig")
    >>> rig["AirPressure"].quantization, rig["ProximitySensor_upper"].switch_repeatability
    (0.19066, 0.0002)
    """
    S = SensorSpec
    specs = {
        "LeverPosition": S(quantization=7e-6),
        "LeverVelocity": S(noise_std=2e-3),
        "AccelerometerMoving_axisZ": S(noise_std=0.1),
        "AccelerometerStatic_axisZ": S(noise_std=0.05),
        "FlowExtrusion": S(noise_std=0.5, quantization=0.1),
        "FlowContraction": S(noise_std=0.5, quantization=0.1),
        "AirPressure": S(noise_std=2e-3, quantization=1e-3),
        "MIC_uBumper": S(noise_std=5e-3),
        "MIC_bBumper": S(noise_std=5e-3),
        "MIC_Ambient": S(noise_std=2e-2),
        "TempCylinder": S(noise_std=0.05, quantization=0.1),
        "TempAmbient": S(noise_std=0.05, quantization=0.1),
        "StrainGauge": S(noise_std=2e3),
        "ProximitySensor_upper": S(),
        "ProximitySensor_bottom": S(),
    }
    if acquisition == "typical":
        return specs
    if acquisition != "seed_rig":
        raise ModelError(
            f"default_sensor_specs: acquisition must be 'typical' or 'seed_rig'; got "
            f"{acquisition!r}."
        )
    for name, (resolution, rest_std) in SEED_RIG_ACQUISITION.items():
        noise = math.sqrt(max(rest_std**2 - resolution**2 / 12.0, 0.0))
        specs[name] = S(noise_std=round(noise, 6), quantization=round(resolution, 6))
    # the load cell's zero, in Pa at the default strain_area of 1e-4 m^2
    specs["StrainGauge"] = specs["StrainGauge"].replace(offset=SEED_RIG_STRAIN_TARE / 1e-4)
    for name in ("ProximitySensor_upper", "ProximitySensor_bottom"):
        specs[name] = S(switch_repeatability=SMT_8M_REPEATABILITY)
    return specs


def resolve_specs(sensor_specs: Mapping[str, SensorSpec] | None) -> dict[str, SensorSpec]:
    """Defaults updated by the user's specs; unknown sensor names raise ModelError."""
    specs = default_sensor_specs()
    for name, spec in (sensor_specs or {}).items():
        if name not in specs:
            raise ModelError(
                f"sensor_specs: unknown sensor {name!r}{did_you_mean(name, specs)} "
                f"Sensors: {', '.join(specs)}."
            )
        if not isinstance(spec, SensorSpec):
            raise ModelError(
                f"sensor_specs[{name!r}] must be a SensorSpec; got {type(spec).__name__}."
            )
        specs[name] = spec
    return specs


def _col(value, rows=slice(None)):
    """A parameter as a column for (members, samples) arrays: (k, 1) or a float."""
    v = np.asarray(value, dtype=np.float64)
    return v[rows][:, None] if v.ndim == 1 else float(v)


def _spec_rows(spec: SensorSpec, rows: slice) -> SensorSpec:
    changes = {
        f.name: getattr(spec, f.name)[rows]
        for f in dataclasses.fields(spec)
        if np.ndim(getattr(spec, f.name)) == 1
    }
    return dataclasses.replace(spec, **changes) if changes else spec


def _frame_acceleration(force, fs, f_n, zeta):
    """The frame mode's acceleration (times its mass) driven by ``force`` (ZOH, axis -1)."""
    w = 2.0 * math.pi * f_n
    den = [1.0, 2.0 * zeta * w, w * w]
    num = [1.0, 0.0, 0.0]
    b, a, _ = sps.cont2discrete((num, den), 1.0 / fs, method="zoh")
    return sps.lfilter(np.ravel(b), a, force, axis=-1)


def _impact_resonator(x, fs, f_r, decay):
    """Decaying resonance excited by x; an impulse of 1 peaks near 1."""
    r = math.exp(-1.0 / (fs * decay))
    th = 2.0 * math.pi * f_r / fs
    return sps.lfilter([math.sin(th)], [1.0, -2.0 * r * math.cos(th), r * r], x, axis=-1)


def _first_order_lag(x, fs, tau, x0):
    if tau <= 0:
        return x
    a = math.exp(-1.0 / (fs * tau))
    zi = (a * x0)[:, None] if np.ndim(x0) else np.full((x.shape[0], 1), a * x0)
    y, _ = sps.lfilter([1.0 - a], [1.0, -a], x, axis=-1, zi=zi)
    return y


def rod_force(raw: Mapping[str, np.ndarray], p, rows=slice(None)) -> np.ndarray:
    """Force the piston rod passes to the lever, N (positive pushing it up).

    The rig's load cell (Burster 8524, 2 kN, ``doc/notes/pneustand_components.md`` of
    the seed author's repository) sits in the rod, between the cylinder and the lever:
    it reads the pressure force on the piston, ``(p_A - p_0) S_A - (p_B - p_0) S_B``,
    less what the cylinder's own upper end takes (``force_top``: its upper stop and
    dampers); the bottom stop and its dampers act on the lever, beyond the cell. The
    piston's own inertia and seal friction are neglected. The rig's recordings show
    exactly this split (``models/models_datastore/data11_1_1..3.mat``, 6.25 kg, 6 bar):
    at rest at the bottom the cell reads the chamber-B pressure force pulling the lever
    onto its stop, at rest at the top only the lever's weight, 298 N apart.
    """
    s_a, s_b = piston_areas(_col(p.bore, rows), _col(p.rod_diameter, rows))
    p0 = _col(p.p_ambient, rows)
    pressure = (raw["pressure_a"] - p0) * s_a - (raw["pressure_b"] - p0) * s_b
    return pressure - raw["force_top"]


def ideal_readings(
    raw: Mapping[str, np.ndarray], p, fs: float, names, rng, rows=slice(None)
) -> dict:
    """Noise-free readings in sensor units from the model's sampled quantities.

    ``raw`` holds numpy arrays (n_members, n_samples): position, velocity,
    pressure_supply, mass_flow_a, acceleration, force_top, force_bottom,
    mass_flow_exhaust, temperature_a, temperature_b.
    """
    x = raw["position"]
    out: dict[str, np.ndarray] = {}
    want = set(names)
    mass = _col(p.mass_piston, rows) + _col(p.mass_load, rows)
    if "LeverPosition" in want:
        out["LeverPosition"] = x
    if "LeverVelocity" in want:
        out["LeverVelocity"] = raw["velocity"]
    if "AccelerometerMoving_axisZ" in want:
        out["AccelerometerMoving_axisZ"] = raw["acceleration"]
    if "AccelerometerStatic_axisZ" in want:
        # force on the mount = (M + M_L)(a + g): the frame carries the moving mass
        f_mount = mass * (raw["acceleration"] + _col(p.gravity, rows))
        acc = _frame_acceleration(
            f_mount - f_mount[:, :1], fs, p.frame_frequency, p.frame_damping_ratio
        )
        out["AccelerometerStatic_axisZ"] = acc / p.frame_mass
    if "StrainGauge" in want:
        out["StrainGauge"] = rod_force(raw, p, rows) / p.strain_area
    rho_std = P_STD / (287.1 * T_STD)
    to_lpm = 60000.0 / rho_std
    if "FlowExtrusion" in want:
        out["FlowExtrusion"] = np.maximum(raw["mass_flow_a"], 0.0) * to_lpm
    if "FlowContraction" in want:
        out["FlowContraction"] = np.maximum(-raw["mass_flow_a"], 0.0) * to_lpm
    if "AirPressure" in want:
        out["AirPressure"] = (raw["pressure_supply"] - _col(p.p_ambient, rows)) / 1e5
    mics = [m for m in ("MIC_uBumper", "MIC_bBumper", "MIC_Ambient") if m in want]
    if mics:

        def sound(force):
            d = np.diff(force, axis=-1, prepend=force[:, :1])
            return _impact_resonator(d, fs, p.mic_frequency, p.mic_decay)

        s_top = sound(raw["force_top"])
        s_bot = sound(raw["force_bottom"])
        gain = _col(p.mic_gain, rows)
        far = _col(p.mic_far_gain, rows)
        hiss_amp = _col(p.mic_hiss_gain, rows) * np.abs(raw["mass_flow_exhaust"])
        mix = {
            "MIC_uBumper": gain * (s_top + far * s_bot),
            "MIC_bBumper": gain * (s_bot + far * s_top),
            "MIC_Ambient": gain * _col(p.mic_ambient_gain, rows) * (s_top + s_bot),
        }
        for m in mics:
            out[m] = mix[m] + hiss_amp * rng.standard_normal(x.shape, dtype=np.float32)
    t_amb = _col(p.t_ambient, rows)
    if "TempCylinder" in want:
        # the barrel follows the mean gas temperature weakly (temp_wall_gain); the
        # sensor lags the barrel, starting from steady operation (the recording mean)
        gas = 0.5 * (raw["temperature_a"] + raw["temperature_b"])
        wall = t_amb + _col(p.temp_wall_gain, rows) * (gas - t_amb)
        lag = _first_order_lag(
            wall, fs, float(p.temp_sensor_time_constant), wall.mean(axis=-1)
        )
        out["TempCylinder"] = lag - 273.15
    if "TempAmbient" in want:
        out["TempAmbient"] = np.broadcast_to(t_amb - 273.15, x.shape).copy()
    return out


def _switch(x, point, spec: SensorSpec, rng: np.random.Generator) -> np.ndarray:
    """0/1 output of a switch that is on while ``x >= point`` (members x samples).

    With ``spec.switch_repeatability`` > 0 every approach switches at its own point,
    drawn uniformly within +-half the repeatability around ``point``, and releases at
    that point; the next approach, once the piston has left that zone, draws again.
    """
    point = np.broadcast_to(np.asarray(point, dtype=np.float64), (x.shape[0], 1))
    spread = np.broadcast_to(
        np.asarray(spec.switch_repeatability, dtype=np.float64).reshape(-1, 1),
        (x.shape[0], 1),
    )
    on = x >= point
    if not np.any(spread > 0):
        return on.astype(np.float64)
    out = np.zeros(x.shape)
    for i in np.flatnonzero(spread[:, 0] > 0):
        xi, k, n = x[i], 0, x.shape[1]
        while k < n:
            here = point[i, 0] + spread[i, 0] * (rng.random() - 0.5)
            # off until the piston reaches this approach's point, then on until it
            # falls back below it
            rise = np.flatnonzero(xi[k:] >= here)
            if rise.size == 0:
                break
            start = k + int(rise[0])
            fall = np.flatnonzero(xi[start:] < here)
            k = start + int(fall[0]) if fall.size else n
            out[i, start:k] = 1.0
            # the next approach starts once the piston has left the switching zone
            away = np.flatnonzero(xi[k:] < point[i, 0] - 0.5 * spread[i, 0])
            k = k + int(away[0]) if away.size else n
    out[spread[:, 0] <= 0] = on[spread[:, 0] <= 0]
    return out


def _seed_sequence(seed) -> np.random.SeedSequence:
    """The seed (int / None / SeedSequence / Generator) as a SeedSequence."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, np.random.Generator):
        return np.random.SeedSequence(int(seed.integers(2**63)))
    try:
        return np.random.SeedSequence(seed)
    except TypeError as exc:
        raise ModelError(
            f"seed must be an int, None, a numpy SeedSequence or Generator; got {seed!r}."
        ) from exc


def sensor_outputs(
    raw, p, fs, specs: Mapping[str, SensorSpec], names, seed, chunk: int = 64
) -> dict:
    """Readings with imperfections, one independent random stream per sensor.

    Members are processed in chunks (smaller temporaries, much faster for big batches).
    """
    names = list(names)
    n, n_samples = raw["position"].shape
    seeds = _seed_sequence(seed).spawn(len(SENSOR_NAMES) + 1)
    stream = {
        name: np.random.default_rng(s)
        for name, s in zip(SENSOR_NAMES, seeds[1:], strict=True)
    }
    physics_rng = np.random.default_rng(seeds[0])
    out = {name: np.empty((n, n_samples)) for name in names}
    for start in range(0, n, chunk):
        rows = slice(start, min(start + chunk, n))
        part = {k: v[rows] for k, v in raw.items()}
        ideal = ideal_readings(part, p, fs, names, physics_rng, rows)
        stroke = _col(p.stroke, rows)
        dist = _col(p.proximity_distance, rows)
        for name in names:
            spec = _spec_rows(specs[name], rows)
            if name.startswith("ProximitySensor"):
                # the spec acts on the sensed position (m); the switch thresholds it
                sensed = spec.replace(
                    dropout=0.0, quantization=0.0, switch_repeatability=0.0
                ).apply(part["position"], fs, stream[name])
                if name.endswith("upper"):
                    on = _switch(sensed, stroke - dist, spec, stream[name])
                else:  # on below the point: the same switch on the mirrored position
                    on = _switch(-sensed, -dist, spec, stream[name])
                if np.any(np.asarray(spec.dropout) > 0):
                    on = SensorSpec(
                        dropout=spec.dropout, dropout_fill=spec.dropout_fill
                    ).apply(on, fs, stream[name])
                out[name][rows] = on
            else:
                out[name][rows] = spec.apply(ideal[name], fs, stream[name])
    return out
