"""Member files at their own rates, resampled to one and cut into frames (issue 30).

References the reader did not make: the frequency of a sine found by an FFT,
``scipy.signal.resample_poly`` called directly, and the frame count
``floor((N - L) / H) + 1`` of a recording of N samples.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.signal import resample_poly

from pdmkit.ensembles import read_members
from pdmkit.errors import DataError


def _sine(fs: float, n: int, hz: float) -> np.ndarray:
    return np.sin(2 * np.pi * hz * np.arange(n) / fs)


def _peak_hz(x: np.ndarray, fs: float) -> float:
    spectrum = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    return float(np.fft.rfftfreq(x.size, 1 / fs)[np.argmax(spectrum)])


@pytest.fixture
def two_rates(tmp_path: Path) -> tuple[Path, Path, Path]:
    """A 48 kHz recording (1 kHz sine), a 12 kHz one (700 Hz), neither stating its rate;
    a labels table giving both rates."""
    fast, slow = tmp_path / "run_fast.npz", tmp_path / "run_slow.npz"
    np.savez(fast, vib=_sine(48_000.0, 48_000, 1000.0))
    np.savez(slow, vib=_sine(12_000.0, 15_000, 700.0))
    labels = tmp_path / "labels.csv"
    pd.DataFrame(
        {"file": [fast.name, slow.name], "label": ["ok", "worn"], "fs": [48000, 12000]}
    ).to_csv(labels, index=False)
    return fast, slow, labels


def test_files_at_two_rates_are_an_error_naming_both(two_rates):
    fast, slow, labels = two_rates
    with pytest.raises(DataError) as info:
        read_members([fast, slow], labels=labels)
    message = str(info.value)
    assert "\n" not in message
    assert "run_fast.npz" in message and "48000 Hz" in message
    assert "run_slow.npz" in message and "12000 Hz" in message
    assert "--resample HZ" in message


def test_one_wrong_rate_in_skip_mode_is_left_out_with_the_hint(two_rates, tmp_path):
    fast, slow, labels = two_rates
    other = tmp_path / "run_slow2.npz"
    np.savez(other, vib=_sine(12_000.0, 15_000, 500.0))
    table = pd.read_csv(labels)
    table.loc[2] = [other.name, "worn", 12000]
    table.to_csv(labels, index=False)
    ens, errors = read_members(
        [fast, slow, other], labels=labels, on_error="skip", return_errors=True
    )
    assert ens.member_ids.tolist() == ["run_slow", "run_slow2"]
    assert ens.fs == {"vib": 12000.0}
    assert errors["member"].tolist() == ["run_fast"]
    assert "sampled at 48000 Hz; expected 12000 Hz" in errors["error"].iloc[0]
    assert "--resample HZ" in errors["error"].iloc[0]


def test_resampled_members_keep_their_content(two_rates):
    fast, slow, labels = two_rates
    ens = read_members([fast, slow], labels=labels, resample=12_000.0)
    assert ens.fs == {"vib": 12000.0}
    x_fast, x_slow = ens.signal("vib")
    # 48 kHz -> 12 kHz: a quarter of the samples, the sine still at 1000 Hz
    assert x_fast.size == 12_000
    assert _peak_hz(x_fast, 12_000.0) == pytest.approx(1000.0, abs=1.0)
    reference = resample_poly(np.load(fast)["vib"], 1, 4)
    np.testing.assert_allclose(x_fast, reference, rtol=0, atol=1e-12)
    # the 12 kHz file is read as it is
    np.testing.assert_array_equal(x_slow, np.load(slow)["vib"])
    assert _peak_hz(x_slow, 12_000.0) == pytest.approx(700.0, abs=1.0)
    cond = ens.conditions
    assert cond["fs_original"].tolist() == [48000.0, 12000.0]
    assert cond["label"].tolist() == ["ok", "worn"]
    assert "fs" not in cond.columns  # the rate, not a condition: ens.fs states it


def test_a_rate_stated_by_the_file_is_not_overridden(tmp_path):
    path = tmp_path / "a.npz"
    np.savez(path, vib=np.zeros(100), fs=48000.0)
    labels = tmp_path / "l.csv"
    pd.DataFrame({"file": ["a"], "fs": [12000]}).to_csv(labels, index=False)
    with pytest.raises(DataError) as info:
        read_members(path, labels=labels)
    message = str(info.value)
    assert message.startswith("a.npz ")
    assert "48000 Hz" in message and "12000 Hz" in message
    # the same rate twice is no conflict
    pd.DataFrame({"file": ["a"], "fs": ["48 kHz"]}).to_csv(labels, index=False)
    assert read_members(path, labels=labels).fs == {"vib": 48000.0}


def test_the_rate_from_a_named_group_of_the_file_name(tmp_path):
    np.savez(tmp_path / "IR_48k.npz", vib=_sine(48_000.0, 4800, 2000.0))
    np.savez(tmp_path / "OR_12k.npz", vib=_sine(12_000.0, 1200, 2000.0))
    ens = read_members(
        tmp_path,
        label_from_name=r"^(?P<label>[A-Z]+)_(?P<fs>\d+k)",
        resample=12_000.0,
    )
    assert ens.conditions["label"].tolist() == ["IR", "OR"]
    assert ens.conditions["fs_original"].tolist() == [48000.0, 12000.0]
    assert [x.size for x in ens.signal("vib")] == [1200, 1200]
    assert "fs" not in ens.conditions.columns


def test_a_bad_rate_condition_and_a_missing_rate_name_the_file(tmp_path):
    np.savez(tmp_path / "a.npz", vib=np.zeros(100))
    labels = tmp_path / "l.csv"
    pd.DataFrame({"file": ["a"], "fs": ["fast"]}).to_csv(labels, index=False)
    with pytest.raises(DataError, match=r"a\.npz: condition 'fs' .* is 'fast'"):
        read_members(tmp_path / "a.npz", labels=labels)
    with pytest.raises(DataError, match=r"a\.npz states no sampling rate.*--fs"):
        read_members(tmp_path / "a.npz", resample=1000.0)
    # a blank fs cell states nothing: fs= gives the rate
    pd.DataFrame({"file": ["a"], "fs": [np.nan], "k": [1]}).to_csv(labels, index=False)
    ens = read_members(tmp_path / "a.npz", labels=labels, fs=500.0, resample=250.0)
    assert ens.signal("vib")[0].size == 50 and ens.conditions["fs_original"].tolist() == [
        500.0
    ]


@pytest.mark.parametrize(("length", "hop"), [(256, None), (256, 100), (300, 512)])
def test_frame_counts_and_source_member(tmp_path, length, hop):
    sizes = {"a": 1000, "b": 2048, "c": 300}
    for name, n in sizes.items():
        np.savez(tmp_path / f"{name}.npz", vib=np.arange(float(n)))
    ens = read_members(tmp_path, fs=1000.0, frame=length, hop=hop)
    step = hop or length
    expected = {m: (n - length) // step + 1 for m, n in sizes.items()}
    cond = ens.conditions
    assert cond.groupby("source_member").size().to_dict() == expected
    assert len(ens) == sum(expected.values())
    for member_id, x, source, k in zip(
        ens.member_ids, ens.signal("vib"), cond["source_member"], cond["frame"], strict=True
    ):
        assert member_id == f"{source}/f{k:04d}"
        np.testing.assert_array_equal(x, np.arange(k * step, k * step + length))


def test_seconds_and_samples_give_the_same_frames(tmp_path):
    np.savez(tmp_path / "a.npz", vib=np.random.default_rng(0).normal(size=5000))
    by_samples = read_members(tmp_path, fs=2000.0, frame=200, hop=50)
    by_seconds = read_members(tmp_path, fs=2000.0, frame="0.1s", hop="25ms")
    also = read_members(tmp_path, fs=2000.0, frame="200", hop="50")
    for other in (by_seconds, also):
        assert other.member_ids.tolist() == by_samples.member_ids.tolist()
        np.testing.assert_array_equal(other.stack("vib")[0], by_samples.stack("vib")[0])
    # seconds are rounded to the nearest sample: 0.10004 s at 2 kHz is 200.08 samples
    assert (
        read_members(tmp_path, fs=2000.0, frame="0.10004s").stack("vib")[0].shape[1] == 200
    )


def test_seconds_are_converted_at_the_rate_after_resampling(two_rates):
    fast, slow, labels = two_rates
    ens = read_members([fast, slow], labels=labels, resample=12_000.0, frame="0.25s")
    # 3000 samples at 12 kHz: 12000 // 3000 = 4 frames, 15000 // 3000 = 5
    assert ens.stack("vib")[0].shape == (9, 3000)
    assert ens.conditions.groupby("source_member").size().tolist() == [4, 5]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"frame": 0}, r"frame \(--frame\) must be positive; got 0"),
        ({"frame": "0"}, r"frame \(--frame\) must be positive; got '0'"),
        ({"frame": "-5"}, r"frame \(--frame\) must be a number of samples .* got '-5'"),
        ({"frame": 2048.0}, r"frame \(--frame\) must be a number of samples"),
        ({"frame": "0.1 parsec"}, r"duration \(0\.1s, 100ms\); got '0\.1 parsec'"),
        ({"frame": "12.5"}, r"'12\.5' is no whole number of samples"),
        ({"hop": 512}, r"hop \(--hop\) 512 needs frame \(--frame LENGTH\)"),
        ({"frame": 64, "hop": "0ms"}, r"hop \(--hop\) must be positive"),
        ({"frame": "0.1ms"}, r"frame \(--frame\) 0\.0001 s is 0\.1 samples at 1000 Hz"),
        ({"resample": 0}, r"resample \(--resample\) must be a positive"),
    ],
)
def test_bad_frame_options_are_one_line_errors(tmp_path, kwargs, message):
    np.savez(tmp_path / "a.npz", vib=np.zeros(1000))
    with pytest.raises(DataError, match=message) as info:
        read_members(tmp_path, fs=1000.0, **kwargs)
    assert "\n" not in str(info.value)


def test_a_file_shorter_than_a_frame_is_named_with_its_length(tmp_path):
    np.savez(tmp_path / "long.npz", vib=np.zeros(4096))
    np.savez(tmp_path / "short.npz", vib=np.zeros(1000))
    with pytest.raises(DataError) as info:
        read_members(tmp_path, fs=1000.0, frame=2048)
    assert str(info.value) == (
        "short.npz has 1000 samples (1 s at 1000 Hz), fewer than one frame of 2048 "
        "samples (2.048 s); choose a shorter frame (--frame) or leave the file out"
    )
    ens, errors = read_members(
        tmp_path, fs=1000.0, frame=2048, on_error="skip", return_errors=True
    )
    assert ens.conditions["source_member"].tolist() == ["long", "long"]
    assert errors["member"].tolist() == ["short"]
