"""Feature tables from arrays (extract) and ensembles (extract_ensemble)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.signal
import scipy.stats

import pdmkit.features as pf
from pdmkit.ensembles import Ensemble
from pdmkit.errors import DataError

FS = 1000.0


@pytest.fixture
def signals(rng):
    t = np.arange(3000) / FS
    freqs = np.array([30.0, 55.0, 120.0, 310.0, 70.0, 90.0])[:, None]
    return np.sin(2 * np.pi * freqs * t) + 0.2 * rng.normal(size=(6, t.size))


# --------------------------------------------------------------------------- extract
def test_columns_and_values(signals):
    table = pf.extract(signals, FS, groups=("stats", "spectral"), bands=[(0, 100)])
    assert table.shape[0] == 6
    assert list(table.index) == list(range(6))
    assert table.columns[0] == "stats/Mean"
    assert {"stats/Kurtosis", "spectral/PeakFreq1", "spectral/BandPower_0_100Hz"} <= set(
        table.columns
    )
    assert all(c.startswith(("stats/", "spectral/")) for c in table.columns)
    np.testing.assert_allclose(
        table["stats/Kurtosis"], scipy.stats.kurtosis(signals, axis=1, fisher=False)
    )
    for i, x in enumerate(signals):
        f, p = scipy.signal.welch(x, FS, window="hann", nperseg=1024, noverlap=512)
        assert table["spectral/PeakFreq1"][i] == f[np.argmax(p)]


def test_chunking_does_not_change_the_result(signals):
    groups = ("stats", "harmonic", "spectral", "envelope")
    opts = {"bearing": pf.CWRU_DRIVE_END, "shaft_hz": np.linspace(20, 30, 6)}
    whole = pf.extract(signals, FS, groups, batch_size=100, **opts)
    pieces = pf.extract(signals, FS, groups, batch_size=4, **opts)
    pd.testing.assert_frame_equal(whole, pieces)
    one = pf.extract(signals[3], FS, groups, bearing=pf.CWRU_DRIVE_END, shaft_hz=26.0)
    assert one.shape == (1, whole.shape[1])
    np.testing.assert_allclose(
        one.iloc[0].to_numpy(), whole.iloc[3].to_numpy(), rtol=1e-7, equal_nan=True
    )


def test_group_functions_agree_with_extract(signals):
    table = pf.extract(signals, FS, groups=("stats", "harmonic", "spectral"), n_peaks=3)
    s = pf.stats(signals)
    h = pf.harmonic(signals, FS)
    sp = pf.spectral(signals, FS, n_peaks=3)
    for prefix, values in (("stats", s), ("harmonic", h), ("spectral", sp)):
        for key, v in values.items():
            np.testing.assert_allclose(table[f"{prefix}/{key}"], v, equal_nan=True)


def test_samples_on_axis_0_and_float32(signals):
    a = pf.extract(signals, FS, groups=("stats",))
    b = pf.extract(signals.T.copy(), FS, groups=("stats",), axis=0)
    c = pf.extract(signals.astype(np.float32), FS, groups=("stats",))
    pd.testing.assert_frame_equal(a, b)
    np.testing.assert_allclose(c.to_numpy(), a.to_numpy(), rtol=1e-5, atol=1e-6)


def test_nan_members_are_named(signals):
    signals = signals.copy()
    signals[4, 100] = np.nan
    signals[1, 7] = -np.inf
    with pytest.raises(DataError, match=r"signals: member rows 1, 4: NaN or inf") as err:
        pf.extract(signals, FS, batch_size=2)
    assert "row 1: 0 NaN and 1 inf, first at sample 7" in str(err.value)


def test_short_signal_error_says_how_to_fix():
    with pytest.raises(DataError, match=r"100 samples.*nperseg=512.*pass nperseg<=100"):
        pf.extract(np.ones((3, 100)), FS, nperseg=512)


@pytest.mark.parametrize(
    ("signals", "match"),
    [
        (np.empty((0, 100)), "0 members"),
        (np.empty((3, 0)), "empty"),
        (np.ones((2, 3, 4)), "1-D .* or 2-D"),
        (np.array([["a", "b"]]), "real numbers"),
    ],
)
def test_bad_shapes(signals, match):
    with pytest.raises(DataError, match=match):
        pf.extract(signals, FS)


def test_unknown_group_lists_the_known_ones(signals):
    with pytest.raises(ValueError, match=r"unknown feature group\(s\) \['stat'\].*'stats'"):
        pf.extract(signals, FS, groups=("stat",))


def test_unknown_option_lists_the_allowed_ones(signals):
    with pytest.raises(
        TypeError, match=r"'nperseq' \(did you mean 'nperseg'\?\).*spectral: nperseg"
    ):
        pf.extract(signals, FS, nperseq=256)


def test_option_of_a_group_not_asked_for(signals):
    with pytest.raises(
        ValueError, match=r"\['bands'\] belong to group\(s\) \['spectral'\]"
    ):
        pf.extract(signals, FS, groups=("stats",), bands=[(0, 10)])


def test_envelope_group_needs_geometry_and_speed(signals):
    with pytest.raises(ValueError, match="missing bearing and shaft_hz"):
        pf.extract(signals, FS, groups=("envelope",))


# --------------------------------------------------------------------------- ensembles
@pytest.fixture
def ensemble(rng):
    n = 7
    vib = rng.normal(size=(n, 2048))
    vib[4:] += np.sin(2 * np.pi * 50 * np.arange(2048) / 2000.0)
    temp = [rng.normal(20, 1, 256) if i % 3 else None for i in range(n)]
    return Ensemble(
        {"vib": vib, "temp": temp},
        fs={"vib": 2000.0, "temp": 10.0},
        conditions={"fault": ["ok"] * 4 + ["ir"] * 3, "load": np.arange(n)},
        member_ids=[f"run{i}" for i in range(n)],
    )


def test_ensemble_table_layout(ensemble):
    table = pf.extract_ensemble(ensemble, groups=("stats",), batch_size=3, progress=False)
    assert list(table.index) == list(ensemble.member_ids)
    assert list(table.columns[:2]) == ["fault", "load"]
    assert "vib/stats/Kurtosis" in table.columns and "temp/stats/RMS" in table.columns
    assert table.columns.get_loc("vib/stats/Mean") < table.columns.get_loc(
        "temp/stats/Mean"
    )
    pd.testing.assert_series_equal(
        table["fault"], ensemble.conditions["fault"], check_names=False
    )
    # members lacking a signal: NaN; the others: the values extract gives
    has_temp = ensemble.has_signal("temp")
    assert table.loc[~has_temp, "temp/stats/RMS"].isna().all()
    data, mask = ensemble.stack("temp")
    expected = pf.extract(data, 10.0, groups=("stats",))
    np.testing.assert_allclose(
        table.loc[mask, "temp/stats/RMS"].to_numpy(), expected["stats/RMS"].to_numpy()
    )


def test_batches_do_not_change_the_result(ensemble):
    a = pf.extract_ensemble(ensemble, groups=("stats", "spectral"), batch_size=2, n_peaks=2)
    b = pf.extract_ensemble(
        ensemble, groups=("stats", "spectral"), batch_size=100, n_peaks=2
    )
    pd.testing.assert_frame_equal(a, b)


def test_first_batch_without_a_signal_keeps_the_column_order(ensemble):
    # members run0 and run3 lack "temp"; a batch of [run0] has no temp columns at all
    table = pf.extract_ensemble(
        ensemble.select(["run0", "run1"]), batch_size=1, groups=("stats",)
    )
    assert [c.split("/")[0] for c in table.columns if "/" in c][-1] == "temp"
    assert table.loc["run0", "temp/stats/Mean"] != table.loc["run0", "temp/stats/Mean"]


def test_signal_selection_and_unknown_signal(ensemble):
    table = pf.extract_ensemble(ensemble, signals=["vib"], groups=("stats",))
    assert not any(c.startswith("temp/") for c in table.columns)
    with pytest.raises(DataError, match=r"\['pressure'\] are not in the ensemble.*'vib'"):
        pf.extract_ensemble(ensemble, signals=["pressure"])


def test_parquet_path_and_batch_iterator(ensemble, tmp_path):
    expected = pf.extract_ensemble(ensemble, groups=("stats",))
    path = ensemble.to_parquet(tmp_path / "ens", members_per_file=3)
    from_disk = pf.extract_ensemble(path, groups=("stats",), batch_size=2)
    pd.testing.assert_frame_equal(from_disk, expected, check_dtype=False)
    from_iter = pf.extract_ensemble(ensemble.batches(3), groups=("stats",))
    pd.testing.assert_frame_equal(from_iter, expected)


def test_error_names_the_member_and_the_signal(ensemble):
    # "temp" members have 256 samples: a 512-sample Welch segment cannot fit
    with pytest.raises(
        DataError, match=r"signal 'temp' \(members 'run1', 'run2'.*256 samples"
    ):
        pf.extract_ensemble(ensemble, groups=("spectral",), nperseg=512, batch_size=3)


def test_nan_member_is_named_by_id():
    """Ensemble itself refuses NaN; a duck-typed batch source may still deliver one."""

    class Batch:
        def __init__(self):
            self.signal_names = ["x"]
            self.fs = {"x": 100.0}
            self.member_ids = pd.Index(["a", "b", "c"], name="member")
            self.conditions = pd.DataFrame({"label": [0, 1, 1]}, index=self.member_ids)

        def __len__(self):
            return 3

        def stack(self, name):
            data = np.ones((2, 50))
            data[1, 3] = np.nan
            return data, np.array([True, False, True])

    with pytest.raises(DataError, match=r"signal 'x', member 'c': NaN or inf"):
        pf.extract_ensemble([Batch()], groups=("stats",))


def test_shaft_speed_from_a_condition_column(rng):
    fs = 4000.0
    x = rng.normal(size=(3, 4000))
    ens = Ensemble({"de": x}, fs=fs, conditions={"shaft_hz": [20.0, 25.0, 30.0]})
    table = pf.extract_ensemble(
        ens, groups=("envelope",), bearing=pf.CWRU_DRIVE_END, shaft_hz="shaft_hz"
    )
    direct = pf.extract(
        x, fs, ("envelope",), bearing=pf.CWRU_DRIVE_END, shaft_hz=[20.0, 25.0, 30.0]
    )
    np.testing.assert_allclose(table["de/envelope/BPFO_1"], direct["envelope/BPFO_1"])


def test_ensemble_options_are_checked_before_reading(ensemble):
    with pytest.raises(TypeError, match="unknown keyword"):
        pf.extract_ensemble("/no/such/path", nperseq=3)
    with pytest.raises(TypeError, match="Ensemble"):
        pf.extract_ensemble(42)


def test_ragged_members_are_explained():
    with pytest.raises(DataError, match="members of different lengths"):
        pf.extract([np.ones(10), np.ones(12)], FS)


def test_progress_bar_and_workers(ensemble, capsys):
    quiet = pf.extract_ensemble(ensemble, groups=("stats",), batch_size=2, progress=False)
    shown = pf.extract_ensemble(ensemble, groups=("stats",), batch_size=2, progress=True)
    pd.testing.assert_frame_equal(quiet, shown)
    assert "features" in capsys.readouterr().err
    x = np.random.default_rng(1).normal(size=(9, 500))
    serial = pf.extract(x, FS, batch_size=2, workers=1)
    threaded = pf.extract(x, FS, batch_size=2, workers=3)
    pd.testing.assert_frame_equal(serial, threaded)
    with pytest.raises(ValueError, match="workers must be a positive number"):
        pf.extract(x, FS, workers=0)
