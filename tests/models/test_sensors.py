"""Sensor models (seed table 3.1) and sensor imperfections (seed 8.1.1).

Statistics are checked against scipy.stats intervals; unit conversions against the
definitions (ISO 8778 standard air, gauge pressure, Celsius).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats

from pdmkit.errors import ModelError
from pdmkit.models import (
    SENSOR_NAMES,
    SENSOR_UNITS,
    PneumaticParams,
    SensorSpec,
    default_sensor_specs,
    simulate_piston,
)

FS = 1000.0


# ------------------------------------------------------------------ SensorSpec
def test_offset_gain_and_drift_are_exact_without_noise() -> None:
    x = np.linspace(-2.0, 3.0, 5000)[None, :]
    t = np.arange(x.shape[1]) / FS
    y = SensorSpec(offset=0.7, gain_error=-0.04, drift=0.01).apply(x, fs=FS)
    np.testing.assert_allclose(y, 0.96 * x + 0.7 + 0.01 * t, rtol=0, atol=1e-12)


def test_noise_has_the_requested_standard_deviation() -> None:
    n = 50_000
    y = SensorSpec(noise_std=0.3).apply(np.zeros(n), fs=FS, rng=1)
    # 99.9 % chi-square interval for the sample variance
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], n - 1) / (n - 1)
    assert lo < (y.std(ddof=1) / 0.3) ** 2 < hi
    assert abs(y.mean()) < 4 * 0.3 / np.sqrt(n)
    assert stats.normaltest(y).pvalue > 1e-3


def test_quantisation_rounds_to_the_resolution() -> None:
    q = 0.05
    x = np.linspace(0.0, 10.0, 40_001)
    y = SensorSpec(quantization=q).apply(x, fs=FS)
    assert np.allclose(y / q, np.round(y / q), atol=1e-9)
    err = y - x
    assert np.abs(err).max() <= q / 2 + 1e-12
    # rounding error of a slow ramp is uniform on [-q/2, q/2]
    assert stats.kstest(err, stats.uniform(loc=-q / 2, scale=q).cdf).pvalue > 1e-3


def test_dropout_loses_the_requested_fraction() -> None:
    n, p = 100_000, 0.03
    y = SensorSpec(dropout=p, dropout_fill=-99.0).apply(np.ones(n), fs=FS, rng=2)
    lost = int(np.sum(y == -99.0))
    assert stats.binomtest(lost, n, p).pvalue > 1e-3
    assert np.all(y[y != -99.0] == 1.0)
    dead = SensorSpec(dropout=1.0, dropout_fill=np.nan).apply(np.ones(10), fs=FS)
    assert np.all(np.isnan(dead))  # complete signal loss


def test_member_arrays_give_each_member_its_own_fault() -> None:
    x = np.zeros((3, 100))
    y = SensorSpec(offset=np.array([0.0, 1.0, -2.0])).apply(x, fs=FS)
    assert y[:, 0].tolist() == [0.0, 1.0, -2.0]
    with pytest.raises(ModelError, match="2 member values"):
        SensorSpec(offset=np.array([0.0, 1.0])).apply(x, fs=FS)


def test_spec_validation() -> None:
    with pytest.raises(ModelError, match="dropout"):
        SensorSpec(dropout=1.5)
    with pytest.raises(ModelError, match="noise_std"):
        SensorSpec(noise_std=-1.0)
    with pytest.raises(ModelError, match="did you mean 'offset'"):
        SensorSpec().replace(ofset=1.0)


# ------------------------------------------------------------------ sensors in a simulation
@pytest.fixture(scope="module")
def clean():
    """Two cycles, every sensor noise-free (only the physics of the sensors)."""
    specs = {name: SensorSpec() for name in SENSOR_NAMES}
    p = PneumaticParams(mic_hiss_gain=0.0)
    return simulate_piston(p, t_end=4.0, sensor_specs=specs, seed=0)


def test_all_fifteen_sensors_of_table_3_1(clean) -> None:
    assert set(clean.outputs) == set(SENSOR_NAMES) and len(SENSOR_NAMES) == 15
    for name, y in clean.outputs.items():
        assert y.shape == (1, 4000) and np.all(np.isfinite(y)), name
    assert SENSOR_UNITS["FlowExtrusion"] == "l/min" and SENSOR_UNITS["AirPressure"] == "bar"


def test_unit_conversions(clean) -> None:
    p = clean.params
    out, st, sig = clean.outputs, clean.states, clean.signals
    np.testing.assert_allclose(out["LeverPosition"], st["position"])
    # standard litres per minute at 20 degC, 100 kPa (ISO 8778)
    rho_n = 1.0e5 / (287.1 * 293.15)
    lpm = sig["mass_flow_a"] / rho_n * 60_000
    np.testing.assert_allclose(out["FlowExtrusion"], np.maximum(lpm, 0), atol=1e-9)
    np.testing.assert_allclose(out["FlowContraction"], np.maximum(-lpm, 0), atol=1e-9)
    np.testing.assert_allclose(out["AirPressure"], (st["pressure_supply"] - 101325) / 1e5)
    np.testing.assert_allclose(out["TempAmbient"], p.t_ambient - 273.15)
    x = st["position"]
    np.testing.assert_array_equal(
        out["ProximitySensor_upper"], (x >= p.stroke - p.proximity_distance).astype(float)
    )
    np.testing.assert_array_equal(
        out["ProximitySensor_bottom"], (x <= p.proximity_distance).astype(float)
    )


def test_flow_sensor_volume_matches_the_chamber_fill(clean) -> None:
    # energy balance of the adiabatic chamber (seed 4.20): kappa R T m_in
    # = d(pV) + (kappa - 1) p dV, so the metered air follows from the chamber states
    p = clean.params
    t = clean.time
    up = (t > 0.1) & (t <= 1.1)
    litres = clean.outputs["FlowExtrusion"][0, up].sum() / FS / 60  # standard litres
    s_a = np.pi / 4 * p.bore**2
    x, v = clean.states["position"][0], clean.states["velocity"][0]
    pa = clean.states["pressure_a"][0]
    vol = s_a * x + p.v_dead_a
    i0, i1 = np.flatnonzero(up)[[0, -1]]
    work = np.trapezoid((pa * s_a * v)[i0 - 1 : i1 + 1], dx=1 / FS)
    mass = (pa[i1] * vol[i1] - pa[i0 - 1] * vol[i0 - 1] + 0.4 * work) / (
        1.4 * 287.1 * 293.15
    )
    assert litres == pytest.approx(mass / (1.0e5 / (287.1 * 293.15)) * 1e3, rel=0.02)


def test_strain_gauge_reads_the_rod_force(clean) -> None:
    """The load cell in the rod: the pressure force less the cylinder's top end's."""
    p = clean.params
    t, x = clean.time, clean.states["position"][0]
    strain = clean.outputs["StrainGauge"][0] * p.strain_area  # N
    s_a = np.pi / 4 * p.bore**2
    s_b = s_a - np.pi / 4 * p.rod_diameter**2
    gauge_b = clean.states["pressure_b"][0] - p.p_ambient
    # at rest on the bottom stop (an external one): chamber B pulls the lever down
    bottom = (t > 1.9) & (t < 2.1)
    assert np.ptp(x[bottom]) < 1e-5
    rest = strain[bottom].mean()
    assert rest == pytest.approx(-(gauge_b[bottom] * s_b).mean(), rel=1e-3)
    assert rest == pytest.approx(-(p.p_supply - p.p_ambient) * s_b, rel=0.02)
    # at rest at the top the cylinder's own end takes the pressure: the rod carries the
    # lever's weight (friction holds at most friction_coulomb of it)
    top = (t > 1.0) & (t < 1.1)
    assert np.ptp(x[top]) < 1e-5 and x[top].mean() > 0.9 * p.stroke
    weight = (p.mass_piston + p.mass_load) * p.gravity
    assert abs(strain[top].mean() - weight) <= p.friction_coulomb + 1e-6


def test_static_accelerometer_rings_at_the_frame_mode(clean) -> None:
    p = clean.params
    acc = clean.outputs["AccelerometerStatic_axisZ"][0]
    f, pxx = signal.welch(acc, fs=FS, nperseg=1024)
    assert f[np.argmax(pxx)] == pytest.approx(p.frame_frequency, abs=3.0)
    rest = (clean.time > 1.9) & (clean.time < 2.1)
    assert np.abs(acc[rest]).max() < 0.01 * np.abs(acc).max()  # quiet between impacts


def test_microphones_hear_impacts_at_their_bumper(clean) -> None:
    p = clean.params
    t = clean.time
    upper = clean.outputs["MIC_uBumper"][0]
    bottom = clean.outputs["MIC_bBumper"][0]
    # the microphone is the bumper resonance driven by the change of the contact forces
    # (the far bumper at mic_far_gain): the ratio of the spectra is the resonance,
    # which peaks at mic_frequency whatever the spectrum of the impacts is
    excite = np.diff(clean.signals["force_top"][0], prepend=0.0) + p.mic_far_gain * (
        np.diff(clean.signals["force_bottom"][0], prepend=0.0)
    )
    f, pxx = signal.welch(upper, fs=FS, nperseg=1024)
    _, pee = signal.welch(excite, fs=FS, nperseg=1024)
    band = (f > 50) & (f < 480)
    gain = pxx[band] / pee[band]
    half_bandwidth = 1 / (2 * np.pi * p.mic_decay)  # of the decaying resonance, Hz
    assert f[band][np.argmax(gain)] == pytest.approx(p.mic_frequency, abs=half_bandwidth)
    # and the recording's own spectrum peaks within the resonance band
    assert f[np.argmax(pxx)] == pytest.approx(p.mic_frequency, abs=2 * half_bandwidth)
    top_hit = (t > 0.25) & (t < 0.6)  # arrival at the top
    bottom_hit = (t > 1.25) & (t < 1.6)  # arrival at the bottom
    assert np.abs(upper[top_hit]).max() > 3 * np.abs(bottom[top_hit]).max()
    assert np.abs(bottom[bottom_hit]).max() > 3 * np.abs(upper[bottom_hit]).max()
    quiet = (t > 0.9) & (t < 1.1)
    assert np.abs(upper[quiet]).max() < 1e-3


def test_cylinder_temperature_is_slow_and_near_ambient(clean) -> None:
    temp = clean.outputs["TempCylinder"][0]
    assert abs(temp.mean() - 20.0) < 5.0
    assert np.abs(np.diff(temp)).max() < 0.05  # K per ms: a slow first-order sensor


def test_sensor_faults_reach_the_outputs() -> None:
    faults = {
        "FlowExtrusion": SensorSpec(offset=5.0),
        "AirPressure": SensorSpec(dropout=1.0),
        "LeverVelocity": SensorSpec(noise_std=0.05),
    }
    names = [*faults, "LeverPosition"]
    base = simulate_piston(
        t_end=0.5, sensors=names, seed=4, sensor_specs={k: SensorSpec() for k in names}
    )
    faulty = simulate_piston(t_end=0.5, sensors=names, seed=4, sensor_specs=faults)
    diff = faulty.outputs["FlowExtrusion"] - base.outputs["FlowExtrusion"]
    np.testing.assert_allclose(diff, 5.0)
    assert np.all(faulty.outputs["AirPressure"] == 0.0)
    noise = faulty.outputs["LeverVelocity"] - base.outputs["LeverVelocity"]
    assert noise.std() == pytest.approx(0.05, rel=0.1)
    assert set(faulty.outputs) == set(names)
    with pytest.raises(ModelError, match="unknown sensor 'Flow'"):
        simulate_piston(t_end=0.1, sensor_specs={"Flow": SensorSpec()})


def test_default_noise_is_reproducible_by_seed() -> None:
    a = simulate_piston(t_end=0.2, seed=7).outputs["MIC_Ambient"]
    b = simulate_piston(t_end=0.2, seed=7).outputs["MIC_Ambient"]
    c = simulate_piston(t_end=0.2, seed=8).outputs["MIC_Ambient"]
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert default_sensor_specs()["LeverPosition"].quantization == 7e-6  # seed 4.6


def test_seed_accepts_seed_sequences_and_generators() -> None:
    ss = np.random.SeedSequence(5)
    a = simulate_piston(t_end=0.05, sensors=["MIC_Ambient"], seed=ss).outputs["MIC_Ambient"]
    b = simulate_piston(t_end=0.05, sensors=["MIC_Ambient"], seed=np.random.SeedSequence(5))
    assert np.array_equal(a, b.outputs["MIC_Ambient"])
    simulate_piston(t_end=0.05, sensors=["MIC_Ambient"], seed=np.random.default_rng(1))
    with pytest.raises(ModelError, match="seed must be"):
        simulate_piston(t_end=0.05, sensors=["MIC_Ambient"], seed="abc")


# ------------------------------------------------------------ the seed rig's acquisition
def test_seed_rig_resolution_is_one_count_of_its_12_bit_module() -> None:
    # NI 9221: 12 bit over its +-62.5 V nominal range; the transmitters' scales of the
    # author's Conversion_*.m: pressure 6.25 bar/V, flow 50 l/min / 10 V, acc 1/0.333 g/V
    count = 125.0 / 4096
    rig = default_sensor_specs("seed_rig")
    assert rig["AirPressure"].quantization == pytest.approx(6.25 * count, rel=1e-3)
    assert rig["FlowContraction"].quantization == pytest.approx(5.0 * count, rel=1e-3)
    acc = rig["AccelerometerMoving_axisZ"].quantization / 9.81
    assert acc == pytest.approx(count / 0.333, rel=1e-3)
    # the typical set is unchanged (the twin's other users keep it)
    assert default_sensor_specs()["AirPressure"].quantization == 1e-3
    with pytest.raises(ModelError, match="acquisition"):
        default_sensor_specs("rig")


def test_seed_rig_pressure_reading_at_rest_is_the_recorded_one() -> None:
    # a steady 6 bar through the rig's acquisition: values on a grid of one count, a
    # spread of 0.168 bar (the author's recordings, last second at rest)
    spec = default_sensor_specs("seed_rig")["AirPressure"]
    y = spec.apply(np.full((4, 10_000), 6.05), fs=FS, rng=0)
    steps = np.diff(np.unique(np.round(y, 6)))
    np.testing.assert_allclose(steps, 0.19066, rtol=1e-6)
    assert y.std(axis=1) == pytest.approx(np.full(4, 0.168), rel=0.03)


def test_switch_repeatability_spreads_the_switching_point_uniformly() -> None:
    # a slow ramp up and down through the upper switch's point, 400 approaches: each
    # switches once on and once off, at points uniform within +-0.1 mm (std 0.2/sqrt(12))
    from pdmkit.models.pneumatic._sensors import _switch

    up = np.linspace(0.150, 0.160, 5001)  # 2 um a sample
    ramp = np.concatenate([up, up[::-1]])
    x = np.tile(np.tile(ramp, 4), (100, 1))
    spec = SensorSpec(switch_repeatability=2e-4)
    on = _switch(x, 0.155, spec, np.random.default_rng(0))
    edges = np.diff(on, axis=1)
    assert (edges == 1).sum() == (edges == -1).sum() == 400  # no chatter
    rows, cols = np.nonzero(edges == 1)
    points = x[rows, cols + 1]
    assert np.abs(points - 0.155).max() <= 1.0e-4 + 2e-6
    assert points.std() == pytest.approx(2e-4 / np.sqrt(12), rel=0.15)
    assert stats.kstest((points - 0.155) / 2e-4 + 0.5, "uniform").pvalue > 0.001
    exact = _switch(x, 0.155, SensorSpec(), np.random.default_rng(0))
    np.testing.assert_array_equal(exact, (x >= 0.155).astype(float))
    with pytest.raises(ModelError, match="switch_repeatability"):
        SensorSpec(switch_repeatability=-1.0)
