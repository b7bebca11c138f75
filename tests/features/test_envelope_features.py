"""Bearing defect frequencies (published CWRU numbers) and envelope analysis."""

from __future__ import annotations

import numpy as np
import pytest

import pdmkit.features as pf

SHAFT = 1797 / 60.0

# CWRU Bearing Data Center, "Bearing information": defect frequencies as multiples of
# the running speed. Drive end SKF 6205-2RS JEM: inner 5.4152, outer 3.5848, cage
# 0.39828, rolling element 4.7135; fan end SKF 6203-2RS JEM: 4.9469, 3.0530, 0.3817,
# 3.9874. CWRU's "rolling element" column is twice the ball spin frequency.
CWRU_MULTIPLES = {
    "drive": (
        pf.CWRU_DRIVE_END,
        {"BPFI": 5.4152, "BPFO": 3.5848, "FTF": 0.39828, "BSFx2": 4.7135},
    ),
    "fan": (
        pf.CWRU_FAN_END,
        {"BPFI": 4.9469, "BPFO": 3.0530, "FTF": 0.3817, "BSFx2": 3.9874},
    ),
}


def test_cwru_drive_end_at_1797_rpm():
    # published: inner race 162.2 Hz, outer race 107.4 Hz, ball 141.1 Hz (2 x BSF)
    f = pf.CWRU_DRIVE_END.frequencies(SHAFT)
    assert f["BPFI"] == pytest.approx(162.2, abs=0.1)
    assert f["BPFO"] == pytest.approx(107.4, abs=0.1)
    assert f["BSFx2"] == pytest.approx(141.1, abs=0.1)
    assert f["BSF"] == pytest.approx(141.1 / 2, abs=0.05)


@pytest.mark.parametrize("end", sorted(CWRU_MULTIPLES))
def test_cwru_multiples_of_running_speed(end):
    bearing, multiples = CWRU_MULTIPLES[end]
    f = bearing.frequencies(1.0)
    for key, value in multiples.items():
        assert f[key] == pytest.approx(value, rel=5e-4), key


def test_geometry_is_stored_in_metres():
    assert pf.CWRU_DRIVE_END.ball_diameter == pytest.approx(0.3126 * 0.0254)
    assert pf.CWRU_DRIVE_END.pitch_diameter == pytest.approx(1.537 * 0.0254)


def test_contact_angle_and_identities():
    f0 = pf.bearing_frequencies(25.0, 12, 10.0, 50.0)
    f15 = pf.bearing_frequencies(25.0, 12, 10.0, 50.0, contact_angle_deg=15)
    # BPFO + BPFI = n * shaft for any angle; FTF = BPFO / n
    for f in (f0, f15):
        assert f["BPFO"] + f["BPFI"] == pytest.approx(12 * 25.0)
        assert f["FTF"] == pytest.approx(f["BPFO"] / 12)
    assert f15["BPFO"] > f0["BPFO"]


def test_bad_geometry_is_rejected():
    with pytest.raises(ValueError, match="swap"):
        pf.BearingGeometry(n_balls=9, ball_diameter=0.04, pitch_diameter=0.01)
    with pytest.raises(ValueError, match="n_balls"):
        pf.BearingGeometry(n_balls=0, ball_diameter=0.01, pitch_diameter=0.04)
    with pytest.raises(ValueError, match="shaft_hz"):
        pf.bearing_frequencies(-1.0, 9, 1.0, 4.0)


def test_envelope_spectrum_of_an_am_carrier():
    fs = 8192.0
    t = np.arange(8192) / fs
    x = (1.0 + 0.3 * np.cos(2 * np.pi * 64 * t)) * np.sin(2 * np.pi * 1500 * t)
    env = pf.envelope_spectrum(x, fs, band=(1000, 2000))
    assert env.frequencies[np.argmax(env.amplitude)] == 64.0
    assert env.amplitude[env.frequencies == 64.0][0] == pytest.approx(0.3, rel=0.02)
    assert env.to_pandas().shape == (len(env.frequencies), 1)


def _faulty_bearing(rng, fault: str, n_members: int, fs: float, n: int) -> np.ndarray:
    """Impacts at the defect rate ringing a 3.5 kHz resonance, plus noise.

    An inner-race defect turns with the shaft, so its impacts are amplitude-modulated
    at the shaft speed as it passes in and out of the load zone.
    """
    f = pf.CWRU_DRIVE_END.frequencies(SHAFT)[fault]
    t = np.arange(n) / fs
    rows = []
    for _ in range(n_members):
        phase = rng.uniform(0, 1 / f)
        since = (t + phase) % (1.0 / f)
        ring = np.exp(-1500 * since) * np.sin(2 * np.pi * 3500 * since)
        if fault == "BPFI":
            ring *= 1.0 + 0.8 * np.cos(2 * np.pi * SHAFT * t)
        rows.append(ring + 0.3 * rng.normal(size=n) + np.sin(2 * np.pi * SHAFT * t))
    return np.array(rows)


@pytest.mark.parametrize("fault", ["BPFI", "BPFO"])
def test_envelope_features_point_at_the_defect(rng, fault):
    fs = 12_000.0
    x = _faulty_bearing(rng, fault, 4, fs, 24_000)
    e = pf.envelope_features(x, fs, pf.CWRU_DRIVE_END, SHAFT, band=(2500, 4500))
    firsts = {k: e[k] for k in ("BPFO_1", "BPFI_1", "BSFx2_1", "FTF_1")}
    for key, values in firsts.items():
        if key != f"{fault}_1":
            assert (firsts[f"{fault}_1"] > 3 * values).all(), key
    assert (e[f"{fault}_2"] > e["BSFx2_2"]).all()


def test_envelope_features_match_the_envelope_spectrum(rng):
    fs = 12_000.0
    x = _faulty_bearing(rng, "BPFO", 2, fs, 12_000)
    e = pf.envelope_features(x, fs, pf.CWRU_DRIVE_END, SHAFT, tolerance=0.01)
    env = pf.envelope_spectrum(x, fs)
    bpfo = pf.CWRU_DRIVE_END.frequencies(SHAFT)["BPFO"]
    for h in (1, 2, 3):
        half = max(0.01 * h * bpfo, fs / x.shape[1])
        sel = np.abs(env.frequencies - h * bpfo) <= half
        np.testing.assert_allclose(e[f"BPFO_{h}"], env.amplitude[:, sel].max(axis=1))


def test_per_member_shaft_speed(rng):
    fs = 12_000.0
    x = _faulty_bearing(rng, "BPFO", 2, fs, 12_000)
    same = pf.envelope_features(x, fs, pf.CWRU_DRIVE_END, SHAFT)
    per_member = pf.envelope_features(x, fs, pf.CWRU_DRIVE_END, [SHAFT, SHAFT])
    for key in same:
        np.testing.assert_allclose(per_member[key], same[key])
    with pytest.raises(ValueError, match="shaft_hz has 3 values"):
        pf.envelope_features(x, fs, pf.CWRU_DRIVE_END, [SHAFT] * 3)


def test_harmonics_above_nyquist_are_nan():
    e = pf.envelope_features(
        np.random.default_rng(0).normal(size=1000), 400.0, pf.CWRU_DRIVE_END, SHAFT
    )
    assert np.isnan(e["BPFI_2"]) and np.isfinite(e["BPFI_1"])


@pytest.mark.real_data
@pytest.mark.parametrize(
    ("file", "fault"), [("1797_IR_7_DE12.npz", "BPFI"), ("1797_OR@6_7_DE12.npz", "BPFO")]
)
def test_cwru_recordings_show_their_defect(require_data, file, fault):
    """Smith & Randall (MSSP 2015) class IR 0.007 and OR@6 0.007 at 0 hp as clearly
    diagnosable by envelope analysis: the defect line dominates the envelope spectrum."""
    folder = require_data("cwru_bearing")
    x = np.load(folder / file)["DE"].ravel()
    frames = x[: 10 * 12_000].reshape(10, 12_000)  # ten 1 s frames at 12 kHz
    e = pf.envelope_features(frames, 12_000.0, pf.CWRU_DRIVE_END, SHAFT)
    firsts = {k: np.median(e[k]) for k in ("BPFO_1", "BPFI_1", "BSFx2_1", "FTF_1")}
    assert max(firsts, key=firsts.get) == f"{fault}_1"
