"""Dataset loaders: synthetic stand-ins (always run) and the real shared datasets."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io
import scipy.signal

import pdmkit.ensembles as pe
from pdmkit.errors import DataError, DataNotFoundError

CWRU_FILES = {
    "normal": "1797_Normal.npz",
    "IR_007": "1797_IR_7_DE12.npz",
    "IR_021": "1797_IR_21_DE12.npz",
    "B_007": "1797_B_7_DE12.npz",
    "OR_007": "1797_OR@6_7_DE12.npz",
}


# ---------------------------------------------------------------- registry, missing data


def test_registry_lists_the_datasets() -> None:
    assert set(pe.DATASETS) == {
        "cwru",
        "cmapss-fd001",
        "cascaded-tanks",
        "silverbox",
        "emps",
        "nasa-battery",
    }
    assert all(isinstance(v, str) and v for v in pe.DATASETS.values())
    with pytest.raises(
        DataError, match=r"unknown dataset 'nope'.*cascaded-tanks.*silverbox"
    ):
        pe.load_dataset("nope")


@pytest.mark.parametrize(
    "loader",
    [pe.load_cwru, pe.load_cmapss, pe.load_cascaded_tanks, pe.load_silverbox, pe.load_emps],
)
def test_missing_data_says_where_it_looked(
    loader, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PDMKIT_DATA", str(tmp_path))
    with pytest.raises(DataNotFoundError) as info:
        loader()
    msg = str(info.value)
    assert str(tmp_path) in msg and "PDMKIT_DATA" in msg


def test_missing_file_in_a_present_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PDMKIT_DATA", str(tmp_path))
    (tmp_path / "cmapss_fd001").mkdir()
    (tmp_path / "cmapss_fd001" / "readme.txt").write_text("x")
    with pytest.raises(DataNotFoundError, match=r"no train_FD001\.txt.*readme\.txt"):
        pe.load_cmapss()


# ---------------------------------------------------------------- synthetic stand-ins


@pytest.fixture
def fake_cwru(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator):
    folder = tmp_path / "cwru_bearing"
    folder.mkdir()
    raw = {}
    for i, (fault, name) in enumerate(CWRU_FILES.items()):
        if fault == "normal":
            n = 4 * (3 * 256) + 37
            data = {k: rng.normal(size=(n, 1)) for k in ("DE", "FE")}
        else:
            n = 2 * 256 + 10 * i
            data = {k: rng.normal(size=(n, 1)) for k in ("DE", "FE", "BA")}
        np.savez(folder / name, **data)
        raw[fault] = data
    monkeypatch.setenv("PDMKIT_DATA", str(tmp_path))
    return raw


def test_cwru_logic_on_synthetic_records(fake_cwru: dict) -> None:
    ens = pe.load_cwru(frame_length=256)
    assert ens.fs == {"DE": 12000.0, "FE": 12000.0, "BA": 12000.0}
    counts = ens.conditions["fault"].value_counts().to_dict()
    n_normal = math.ceil(fake_cwru["normal"]["DE"].shape[0] / 4)
    assert counts == {
        "normal": n_normal // 256,
        "IR_007": 2,
        "IR_021": 2,
        "B_007": 2,
        "OR_007": 2,
    }
    normal = ens.select(ens.conditions["fault"].eq("normal").to_numpy())
    assert not normal.has_signal("BA").any()
    expected = scipy.signal.resample_poly(fake_cwru["normal"]["FE"].ravel(), 1, 4)
    np.testing.assert_allclose(normal.signal("FE")[2], expected[512:768], atol=1e-12)
    ir = ens.select(["IR_021/f0001"])
    np.testing.assert_array_equal(
        ir.signal("BA")[0], fake_cwru["IR_021"]["BA"].ravel()[256:512]
    )
    row = ir.conditions.iloc[0]
    assert (row["location"], row["fault_diameter_in"], row["rpm"]) == (
        "inner_race",
        0.021,
        1797,
    )
    assert row["record"] == "1797_IR_21_DE12"


def test_cwru_subsets_and_bad_arguments(fake_cwru: dict) -> None:
    ens = pe.load_cwru(frame_length=256, signals=["DE"], faults=["normal", "OR_007"])
    assert ens.signal_names == ["DE"]
    assert set(ens.conditions["fault"]) == {"normal", "OR_007"}
    with pytest.raises(DataError, match="faults must be among"):
        pe.load_cwru(faults=["IR_014"])
    with pytest.raises(DataError, match="signals must be"):
        pe.load_cwru(signals=["XX"])
    with pytest.raises(DataError, match="no base accelerometer"):
        pe.load_cwru(signals=["BA"])


def _write_cmapss(folder: Path, rng: np.random.Generator, *, header: bool) -> pd.DataFrame:
    rows = []
    for unit, life in ((1, 5), (2, 3)):
        for cycle in range(1, life + 1):
            rows.append([unit, cycle, *rng.normal(size=24).round(4)])
    text = "\n".join(" ".join(str(v) for v in r) + "  " for r in rows) + "\n"
    head = "unit_number time opt_set1 s1 s2 s3\n" if header else ""
    (folder / "train_FD003.txt").write_text(head + text)
    (folder / "test_FD003.txt").write_text(head + text)
    (folder / "RUL_FD003.txt").write_text(("RUL  \n" if header else "") + "7 \n9 \n")
    return pd.DataFrame(rows)


@pytest.mark.parametrize("header", [True, False], ids=["added-header", "pristine"])
def test_cmapss_parsing_with_and_without_a_header_line(
    header: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator
) -> None:
    folder = tmp_path / "cmapss_fd001"
    folder.mkdir()
    rows = _write_cmapss(folder, rng, header=header)
    monkeypatch.setenv("PDMKIT_DATA", str(tmp_path))
    train = pe.load_cmapss("FD003", "train")
    assert len(train) == 8 and train.columns[:2].tolist() == ["unit", "cycle"]
    assert train.columns[-2:].tolist() == ["sensor_21", "rul"]
    np.testing.assert_allclose(train.iloc[:, 2:26].to_numpy(), rows.iloc[:, 2:].to_numpy())
    assert train["rul"].tolist() == [4, 3, 2, 1, 0, 2, 1, 0]
    test = pe.load_cmapss("FD003", "test")
    assert test.groupby("unit")["rul_true_final"].first().tolist() == [7, 9]


def test_cmapss_damaged_file_names_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "cmapss_fd001"
    folder.mkdir()
    (folder / "train_FD001.txt").write_text("1 1 2 3\n1 2 2 x\n")
    monkeypatch.setenv("PDMKIT_DATA", str(tmp_path))
    with pytest.raises(DataError, match=r"train_FD001\.txt"):
        pe.load_cmapss()
    with pytest.raises(DataError, match="subset"):
        pe.load_cmapss("FD009")


# ---------------------------------------------------------------- real data


@pytest.fixture(scope="module")
def cwru_real():
    from pdmkit import data_dir

    if not data_dir("cwru_bearing").is_dir():
        return None
    return pe.load_cwru()


@pytest.mark.real_data
def test_real_cwru(require_data, cwru_real) -> None:
    folder = require_data("cwru_bearing")
    ens = cwru_real
    assert sorted(set(ens.conditions["fault"])) == [
        "B_007",
        "IR_007",
        "IR_021",
        "OR_007",
        "normal",
    ]
    assert ens.fs == {"DE": 12000.0, "FE": 12000.0, "BA": 12000.0}
    fault = ens.conditions["fault"]
    normal = fault.eq("normal").to_numpy()
    assert not ens.has_signal("BA")[normal].any() and ens.has_signal("BA")[~normal].all()
    for label, name in CWRU_FILES.items():
        raw = np.load(folder / name)["DE"].ravel()
        n = math.ceil(raw.size / 4) if label == "normal" else raw.size
        assert (fault == label).sum() == n // 2048, label
    # frames equal slices of the resampled / raw record, computed here directly
    de = np.load(folder / "1797_Normal.npz")["DE"].ravel()
    ref = scipy.signal.resample_poly(de, 1, 4)
    np.testing.assert_allclose(ens.select(["normal/f0003"]).signal("DE")[0], ref[6144:8192])
    ba = np.load(folder / "1797_OR@6_7_DE12.npz")["BA"].ravel()
    np.testing.assert_array_equal(
        ens.select(["OR_007/f0012"]).signal("BA")[0], ba[24576:26624]
    )
    data, _ = ens.stack("DE")
    assert data.shape == (len(ens), 2048)


@pytest.mark.real_data
def test_real_cmapss_fd001(require_data) -> None:
    folder = require_data("cmapss_fd001")
    train = pe.load_cmapss("FD001", "train")
    assert train["unit"].nunique() == 100 and len(train) == 20631
    lives = train.groupby("unit")["cycle"].max()
    assert lives.min() == 128 and lives.max() == 362
    assert (train.groupby("unit")["rul"].min() == 0).all()
    test = pe.load_cmapss("FD001", "test")
    assert len(test) == 13096
    rul = test.groupby("unit")["rul_true_final"].first()
    assert len(rul) == 100
    np.testing.assert_array_equal(
        rul.to_numpy(), np.loadtxt(folder / "RUL_FD001.txt", skiprows=1)
    )
    raw = np.loadtxt(folder / "train_FD001.txt", skiprows=1)
    np.testing.assert_array_equal(train.iloc[:, :26].to_numpy(), raw)
    fd3 = pe.load_cmapss("FD003", "test")  # pristine file: no line skipped
    assert len(fd3) == np.loadtxt(folder / "test_FD003.txt").shape[0]
    pd.testing.assert_frame_equal(pe.load_dataset("cmapss-fd001"), train)


@pytest.mark.real_data
def test_real_cascaded_tanks(require_data) -> None:
    folder = require_data("cascaded_tanks")
    tanks = pe.load_cascaded_tanks()
    for key in ("uEst", "yEst", "uVal", "yVal"):
        assert tanks[key].shape == (1024,)
    assert tanks["Ts"] == 4.0 and tanks["fs"] == 0.25
    csv = pd.read_csv(folder / "dataBenchmark.csv")
    np.testing.assert_allclose(tanks["yVal"], csv["yVal"], atol=1e-4)


@pytest.mark.real_data
def test_real_silverbox(require_data) -> None:
    folder = require_data("silverbox")
    sb = pe.load_silverbox()
    assert sb["V1"].shape == sb["V2"].shape == (131072,)
    assert sb["fs"] == pytest.approx(610.35, abs=0.01)
    mat = scipy.io.loadmat(folder / "SNLS80mV.mat")
    np.testing.assert_array_equal(sb["V2"], mat["V2"].ravel())
    schroeder = pe.load_silverbox("Schroeder80mV")
    assert len(schroeder["V1"][schroeder["schroeder_period"]]) == 1024


@pytest.mark.real_data
def test_real_emps(require_data) -> None:
    require_data("emps")
    emps = pe.load_emps()
    assert emps["qm"].shape == (24841,) and emps["fs"] == 1000.0
    np.testing.assert_allclose(emps["force"], emps["gtau"] * emps["vir"])
    np.testing.assert_allclose(np.diff(emps["t"]), 1e-3, atol=1e-7)
    val = pe.load_emps("validation")
    assert set(np.unique(val["pulses_N"])) <= {0.0, 5.0}
