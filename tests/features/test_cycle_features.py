"""Cycle indicators: stroke times, rates, bounces, events and the synchronous average.

Every expected value is a closed form of a synthetic stroke (a ramp, an exponential
approach, a decaying ring) or a plain reshape of whole cycles, never the function itself.
"""

from __future__ import annotations

import numpy as np
import pytest

from pdmkit.errors import DataError
from pdmkit.features import (
    CYCLE_LEVELS,
    cycle_average,
    cycle_feature_names,
    cycle_features,
    extract,
)

FS = 1000.0


def _strokes(n_samples, period, start, rise_at, speed, height, fs=FS):
    """Cylinder position: at rest at 0, from ``rise_at`` s into each cycle up at
    ``speed`` to ``height``, down again (same speed) half a period later."""
    t = np.arange(n_samples) / fs
    phase = (t - start) % period
    up = np.clip((phase - rise_at) * speed, 0.0, height)
    down = np.clip((phase - period / 2 - rise_at) * speed, 0.0, height)
    return np.where(t < start, 0.0, up - down)


def test_transition_times_and_rates_match_the_ramp():
    # members with their own speed; the cycle starts 0.1234 s in (not on a sample) and
    # lasts 1.0005 s (not a whole number of samples): times must stay sub-sample exact
    period, start, rise_at, height = 1.0005, 0.1234, 0.05, 0.16
    speeds = np.array([0.8, 1.0, 1.6])
    x = np.stack([_strokes(12_000, period, start, rise_at, v, height) for v in speeds])
    levels = (0.1, 0.5, 0.9)
    f = cycle_features(x, FS, period, start=start, levels=levels, n_windows=0)
    for level in levels:
        tag = f"{level * 100:g}"
        expected = rise_at + level * height / speeds  # closed form of the ramp
        np.testing.assert_allclose(f[f"S1_T{tag}"], expected, atol=1e-9)
        np.testing.assert_allclose(f[f"S2_T{tag}"], expected, atol=1e-9)
        np.testing.assert_allclose(f[f"S1_Rate{tag}"], speeds, rtol=1e-9)
        np.testing.assert_allclose(f[f"S2_Rate{tag}"], speeds, rtol=1e-9)  # towards End
    np.testing.assert_allclose(f["S1_Drop50_90"], 0.0, atol=1e-9)
    np.testing.assert_allclose(f["S1_PeakRate"], speeds, rtol=1e-9)
    np.testing.assert_allclose(f["S1_Start"], 0.0, atol=1e-12)
    np.testing.assert_allclose(f["S1_End"], height, rtol=1e-12)
    np.testing.assert_allclose(f["S2_End"], 0.0, atol=1e-12)


def test_falling_and_rising_strokes_give_the_same_times():
    x = _strokes(10_000, 2.0, 0.1, 0.02, 1.2, 0.16)
    up = cycle_features(x, FS, 2.0, start=0.1, n_windows=0)
    down = cycle_features(-x, FS, 2.0, start=0.1, n_windows=0)
    for name in cycle_feature_names(n_windows=0):
        if name.split("_")[1].startswith(("T", "Rate", "Drop", "Settle", "PeakTime")):
            assert down[name] == pytest.approx(up[name], abs=1e-12), name


def test_exponential_approach_settles_at_tau_ln50():
    # y = A (1 - exp(-t / tau)): 2 % of the step is left at t = tau * ln(50)
    tau, height = 0.02, 0.1
    t = np.arange(4000) / FS
    phase = t % 1.0
    x = np.where(phase < 0.5, height * (1 - np.exp(-phase / tau)), 0.0)
    f = cycle_features(x, FS, 1.0, levels=(0.5, 0.9), n_windows=0)
    # the last sample outside the band is the one before tau ln 50 (+ one sample)
    assert f["S1_Settle"] == pytest.approx(tau * np.log(50), abs=1.0 / FS)
    assert f["S1_T50"] == pytest.approx(tau * np.log(2), abs=1e-4)  # interpolated
    assert f["S1_Overshoot"] == pytest.approx(0.0, abs=1e-12)
    assert f["S1_Rebound"] == pytest.approx(0.0, abs=1e-12)


def test_overshoot_and_rebound_of_a_bouncing_stroke():
    # up to A + o at 0.1 s, back down to A - r at 0.12 s, up to A at 0.13 s, then rest
    a, o, r = 0.16, 0.004, 0.006
    knots_t = [0.0, 0.02, 0.10, 0.12, 0.13, 1.0]
    knots_x = [0.0, 0.0, a + o, a - r, a, a]
    phase = (np.arange(8000) / FS) % 2.0
    x = np.interp(phase, knots_t, knots_x) * (phase < 1.0)
    f = cycle_features(x, FS, 2.0, levels=(0.5, 0.99), n_windows=0)
    assert f["S1_Overshoot"] == pytest.approx(o, rel=1e-9)
    assert f["S1_Rebound"] == pytest.approx(o + r, rel=1e-9)
    # the bounce ends at 0.13 s: within 2 % of A from the first sample after it
    inside = np.abs(np.interp(np.arange(1000) / FS, knots_t, knots_x) - a) <= 0.02 * a
    last_out = np.flatnonzero(~inside)[-1]
    assert f["S1_Settle"] == pytest.approx((last_out + 1) / FS)


def test_event_indicators_of_a_decaying_ring():
    # an impact 0.3 s into each 1 s cycle: e = P exp(-(t - t0) / tau), zero before
    peak, t0, tau = 2.0, 0.3, 0.01
    since = np.arange(5000) % 1000 - round(t0 * FS)  # samples since the impact
    x = np.where(since >= 0, peak * np.exp(-since / (tau * FS)), 0.0)
    f = cycle_features(x, FS, 1.0, phases=(0.0,), n_windows=0)
    assert f["S1_Peak"] == pytest.approx(peak)
    assert f["S1_PeakTime"] == pytest.approx(t0, abs=0.5 / FS)
    assert f["S1_Decay"] == pytest.approx(tau * np.log(10), abs=1.0 / FS)
    # energy sum(e^2) / fs of the sampled ring: a geometric series (P^2 tau / 2 for
    # continuous time)
    ratio = np.exp(-2.0 / (tau * FS))
    assert f["S1_Energy"] == pytest.approx(peak**2 / FS / (1 - ratio), rel=1e-9)
    # nothing before the impact, the ring after it: RMS of P exp(-s/tau) over a window
    assert f["S1_EventRMS1"] == pytest.approx(0.0, abs=1e-12)
    assert f["S1_EventRMS2"] == pytest.approx(0.0, abs=1e-12)
    s = np.arange(2, 10) / FS  # window (0.002, 0.01) s after the peak
    expected = np.sqrt(np.mean((peak * np.exp(-s / tau)) ** 2))
    assert f["S1_EventRMS3"] == pytest.approx(expected, rel=1e-9)


def test_phase_windows_equal_a_reshape_of_whole_cycles():
    rng = np.random.default_rng(4)
    x = rng.normal(size=(3, 5000)) + np.sin(2 * np.pi * np.arange(5000) / 1000.0)
    f = cycle_features(x, FS, 1.0, n_windows=4)
    cycles = x.reshape(3, 5, 1000)  # five whole cycles of 1000 samples
    for k in range(4):
        w = cycles[:, :, 250 * k : 250 * (k + 1)]
        np.testing.assert_allclose(f[f"W{k + 1:02d}_Mean"], w.mean(axis=(1, 2)))
        np.testing.assert_allclose(f[f"W{k + 1:02d}_Std"], np.median(w.std(axis=2), axis=1))


def test_medians_over_strokes_ignore_one_disturbed_stroke():
    x = _strokes(10_000, 2.0, 0.0, 0.05, 1.0, 0.16)
    clean = cycle_features(x, FS, 2.0, n_windows=0)
    y = x.copy()
    y[2050:2100] += 0.01  # a knock during the second up stroke only
    disturbed = cycle_features(y, FS, 2.0, n_windows=0)
    assert disturbed["S1_T50"] == pytest.approx(clean["S1_T50"], abs=1e-12)
    assert disturbed["S1_Peak"] == pytest.approx(clean["S1_Peak"], abs=1e-12)


def test_cycle_average_recovers_a_periodic_waveform():
    # 7.3 Hz: 136.99 samples per cycle, so the average interpolates between samples
    f0, n = 7.3, 30_000
    t = np.arange(n) / FS
    clean = np.sin(2 * np.pi * f0 * t)
    noise = np.random.default_rng(1).normal(0.0, 1.0, n)
    csa = cycle_average(clean + noise, FS, 1 / f0, n_points=64)
    phases = np.arange(64) / 64
    truth = np.sin(2 * np.pi * phases)
    n_cycles = int((n - 1) * f0 / FS)
    # white noise averages down by 1 / sqrt(cycles); interpolation error is ~1e-3
    assert np.std(csa - truth) < 2.0 / np.sqrt(n_cycles)
    exact = cycle_average(clean, FS, 1 / f0, n_points=64)
    np.testing.assert_allclose(exact, truth, atol=2e-3)


def test_per_member_periods_and_chunks_change_nothing():
    x = np.stack(
        [
            _strokes(9000, 2.0, 0.1, 0.02, 1.0, 0.16),
            _strokes(9000, 1.5, 0.3, 0.02, 0.7, 0.16),
        ]
    )
    both = cycle_features(x, FS, [2.0, 1.5], start=[0.1, 0.3], n_windows=3)
    first = cycle_features(x[0], FS, 2.0, start=0.1, n_windows=3)
    second = cycle_features(x[1], FS, 1.5, start=0.3, n_windows=3)
    for name in both:
        assert both[name][0] == pytest.approx(first[name], abs=1e-12)
        assert both[name][1] == pytest.approx(second[name], abs=1e-12)
    table = extract(
        x,
        FS,
        groups=("cycle",),
        batch_size=1,
        cycle_period=[2.0, 1.5],
        cycle_start=[0.1, 0.3],
        cycle_windows=3,
    )
    assert table["cycle/S1_T50"].tolist() == pytest.approx(both["S1_T50"].tolist())


def test_extract_names_the_cycle_group_and_its_options():
    x = _strokes(4000, 2.0, 0.0, 0.05, 1.0, 0.16)
    table = extract(x, FS, groups=("stats", "cycle"), cycle_period=2.0)
    names = cycle_feature_names()
    assert [c for c in table.columns if c.startswith("cycle/")] == [
        f"cycle/{n}" for n in names
    ]
    assert len(names) == 2 * (2 + 3 * len(CYCLE_LEVELS) - 1 + 10 + 5) + 16
    assert np.isfinite(table.to_numpy()).all()
    with pytest.raises(ValueError, match="cycle_period"):
        extract(x, FS, groups=("cycle",))
    with pytest.raises(ValueError, match="phases"):
        extract(x, FS, groups=("cycle",), cycle_period=2.0, cycle_phases=(0.5, 0.2))
    with pytest.raises(ValueError, match="cycle_levels"):
        extract(x, FS, groups=("cycle",), cycle_period=2.0, cycle_levels=(0.9, 0.5))


def test_short_or_broken_recordings_are_named():
    with pytest.raises(DataError, match="no complete segment"):
        cycle_features(np.zeros(500), FS, 2.0)
    with pytest.raises(DataError, match="no complete cycle"):
        cycle_average(np.zeros(500), FS, 2.0)
    bad = np.zeros((2, 4000))
    bad[1, 7] = np.nan
    with pytest.raises(DataError, match="row 1"):
        cycle_features(bad, FS, 2.0)
    with pytest.raises(ValueError, match="period"):
        cycle_features(np.zeros(4000), FS, -1.0)


def test_speed_lost_in_the_twins_upper_damper_follows_the_damping_law():
    # a heavy piston (6.75 kg) barely slows in the small damper, so there dv/dx = -b/m
    # plus drive terms that do not depend on b: between two damper settings the speed
    # lost from 8 mm to 3.2 mm before the top differs by (b2 - b1) * 4.8 mm / m
    from pdmkit.models import PneumaticParams, simulate_piston

    settings = np.array([1.0, 3.0, 5.0, 7.0])
    p = PneumaticParams(mass_load=np.full(4, 6.25), damper_upper=settings)
    r = simulate_piston(p, t_end=2.5, sensors=["LeverPosition"], seed=0)
    f = cycle_features(
        np.asarray(r.outputs["LeverPosition"]), FS, p.cycle_period,
        start=p.cycle_start, levels=(0.95, 0.98), n_windows=0,
    )  # fmt: skip
    lost = f["S1_Rate95"] - f["S1_Rate98"]
    ratio = p.damper_small_max / p.damper_small_min
    b = p.damper_small_min * ratio ** ((settings - 1.0) / 9.0)
    mass = p.mass_piston + 6.25
    expected = (b[1:] - b[0]) * (0.05 - 0.02) * p.stroke / mass
    np.testing.assert_allclose(lost[1:] - lost[0], expected, rtol=0.2)
    assert np.all(np.diff(lost) > 0)


def test_a_speed_pulse_is_followed_to_its_peak_and_back():
    # a speed: from rest up to 1 m/s in 0.1 s, braked to 0 in 0.02 s (End = Start = 0,
    # so the target is the peak); rise and fall times are closed forms of the triangle
    rise_at, peak, up, down = 0.05, 1.0, 0.1, 0.02
    phase = (np.arange(8000) / FS) % 1.0
    v = np.interp(phase, [0, rise_at, rise_at + up, rise_at + up + down, 1.0],
                  [0, 0, peak, 0, 0])  # fmt: skip
    f = cycle_features(v, FS, 1.0, phases=(0.0,), levels=(0.5, 0.9), n_windows=0)
    assert f["S1_T50"] == pytest.approx(rise_at + 0.5 * up, abs=1e-9)
    assert f["S1_Rate90"] == pytest.approx(peak / up, rel=1e-9)
    assert f["S1_Fall50"] == pytest.approx(0.5 * down, abs=1e-9)
    assert f["S1_Fall90"] == pytest.approx(0.9 * down, abs=1e-9)
    assert f["S1_Overshoot"] == 0.0
    # settled once within 2 % of the peak of rest: 98 % of the way down
    assert f["S1_Settle"] == pytest.approx(rise_at + up + 0.98 * down, abs=1.0 / FS)
