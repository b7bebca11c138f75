"""Bad input: each bad member is reported by name, the other members' results are intact."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from pdmkit.ensembles import Ensemble
from pdmkit.ensembles._member_files import read_members
from pdmkit.errors import DataError
from pdmkit.experiments._cli import main
from pdmkit.experiments._runs import predict_members
from pdmkit.features import extract_ensemble

FS = 2000.0


def _signals(rng, n=2048):
    t = np.arange(n) / FS
    return {
        "vib": np.sin(2 * np.pi * rng.uniform(50, 200) * t) + 0.1 * rng.normal(size=n),
        "temp": 40 + rng.normal(size=n),
    }


def _write_csv(path, sig, fs=FS, fault="ok"):
    n = len(sig["vib"])
    frame = pd.DataFrame({"time": np.arange(n) / fs, **sig, "fault": fault})
    frame.to_csv(path, index=False)


@pytest.fixture
def members(tmp_path, rng):
    """Six good members (csv, .mat, .npz) and one of each bad kind."""
    good, bad = tmp_path / "good", tmp_path / "all"
    good.mkdir()
    bad.mkdir()
    for i in range(4):
        sig = _signals(rng)
        for folder in (good, bad):
            _write_csv(folder / f"g{i}.csv", sig, fault=["ok", "ir"][i % 2])
    sig = _signals(rng)
    for folder in (good, bad):
        savemat(folder / "g4.mat", {**sig, "fs": FS, "fault": "ir"})
        np.savez(folder / "g5.npz", **sig, fs=FS)
    # corrupt: a truncated Parquet file and a .mat that is not one
    pd.DataFrame(_signals(rng)).to_parquet(bad / "b_trunc.parquet")
    raw = (bad / "b_trunc.parquet").read_bytes()
    (bad / "b_trunc.parquet").write_bytes(raw[: len(raw) // 2])
    (bad / "b_notmat.mat").write_bytes(b"MATLAB? no, a text file")
    # non-finite samples
    sig = _signals(rng)
    sig["vib"][100:103] = np.nan
    _write_csv(bad / "b_nan.csv", sig)
    # missing signal
    sig = _signals(rng)
    del sig["temp"]
    _write_csv(bad / "b_notemp.csv", sig)
    # wrong sampling rate (recorded at 4 kHz)
    _write_csv(bad / "b_fs.csv", _signals(rng), fs=2 * FS)
    return good, bad


def test_each_bad_member_is_reported_and_the_rest_read(members):
    good, bad = members
    ens, errors = read_members(
        bad, signals=["vib", "temp"], on_error="skip", return_errors=True
    )
    clean = read_members(good, signals=["vib", "temp"])
    assert ens.member_ids.tolist() == clean.member_ids.tolist()
    for s in ("vib", "temp"):
        for a, b in zip(ens.signal(s), clean.signal(s), strict=True):
            np.testing.assert_array_equal(a, b)
    msgs = dict(zip(errors["member"], errors["error"], strict=True))
    assert set(msgs) == {"b_trunc", "b_notmat", "b_nan", "b_notemp", "b_fs"}
    assert "cannot read" in msgs["b_trunc"] and "b_trunc.parquet" in msgs["b_trunc"]
    assert "b_notmat.mat" in msgs["b_notmat"]
    assert (
        "'vib' of b_nan.csv holds 3 NaN/inf value(s) (first at sample 100)"
        in (msgs["b_nan"])
    )
    assert "b_notemp.csv lacks signal(s) ['temp']" in msgs["b_notemp"]
    assert "b_fs.csv is sampled at 4000 Hz; expected 2000 Hz" in msgs["b_fs"]
    assert all(m.endswith("member skipped") for m in msgs.values())


def test_strict_reading_raises_on_the_first_bad_file(members):
    _, bad = members
    with pytest.raises(DataError, match=r"b_fs\.csv is sampled at 4000 Hz"):
        read_members(sorted(bad.glob("b_fs.csv")) + sorted(bad.glob("g*")))


def test_cli_skips_reports_and_exits_3(members, tmp_path, capsys):
    good, bad = members
    out_bad, out_good = tmp_path / "out_bad", tmp_path / "out_good"
    args = ["features", "--signals", "vib", "temp", "--groups", "stats", "spectral"]
    assert main([*args, "--members", str(good), "--out", str(out_good)]) == 0
    status = main([*args, "--members", str(bad), "--out", str(out_bad)])
    err = capsys.readouterr().err
    assert status == 3
    assert "5 member(s) skipped for bad input" in err
    errors = pd.read_parquet(out_bad / "errors.parquet")
    assert sorted(errors["member"]) == ["b_fs", "b_nan", "b_notemp", "b_notmat", "b_trunc"]
    summary = json.loads((out_bad / "summary.json").read_text())
    assert summary["n_skipped"] == 5
    assert "Members left out" in (out_bad / "report.html").read_text()
    # the good members' indicators are exactly those of a run without the bad files
    pd.testing.assert_frame_equal(
        pd.read_parquet(out_bad / "features.parquet"),
        pd.read_parquet(out_good / "features.parquet"),
        check_exact=True,
    )


def test_cli_strict_stops_with_status_2_and_writes_no_table(members, tmp_path, capsys):
    _, bad = members
    out = tmp_path / "out"
    status = main(["features", "--members", str(bad), "--strict", "--out", str(out)])
    assert status == 2
    assert "error: " in capsys.readouterr().err
    assert not (out / "features.parquet").exists()


def test_extraction_skips_odd_members_of_an_ensemble(rng):
    xs = [rng.normal(size=2048) for _ in range(5)]
    xs[1] = xs[1][:1500]  # another length than its batch
    xs[3] = xs[3][:40]
    ens = Ensemble({"vib": xs[:1] + xs[1:]}, fs=FS)
    table, errors = extract_ensemble(ens, on_error="skip", return_errors=True)
    assert table.index.tolist() == ["m00000", "m00002", "m00004"]
    msgs = dict(zip(errors["member"], errors["error"], strict=True))
    assert "has 1500 samples; the other members of its batch have 2048" in msgs["m00001"]
    assert "has 40 samples" in msgs["m00003"]
    good = extract_ensemble(ens.select(["m00000", "m00002", "m00004"]))
    pd.testing.assert_frame_equal(table, good, check_exact=True)
    with pytest.raises(DataError, match="different lengths"):
        extract_ensemble(ens)
    with pytest.warns(UserWarning, match="2 member"):
        extract_ensemble(ens, on_error="skip")


def test_a_nan_member_in_a_parquet_ensemble_is_skipped(tmp_path, rng):
    import pyarrow as pa
    import pyarrow.parquet as pq

    ens = Ensemble({"vib": rng.normal(size=(6, 1024))}, fs=FS)
    path = ens.to_parquet(tmp_path / "ens", members_per_file=3)
    file = path / "part-00001.parquet"
    table = pq.read_table(file)
    rows = table.column("vib").to_pylist()
    rows[1][7] = float("inf")
    pq.write_table(table.set_column(0 + 1, "vib", pa.array(rows)), file)
    with pytest.raises(DataError, match="m00004"):
        extract_ensemble(path)
    out, errors = extract_ensemble(path, on_error="skip", return_errors=True, batch_size=4)
    assert errors["member"].tolist() == ["m00004"]
    assert "part-00001.parquet" in errors["source"].iloc[0]
    kept = ens.select(["m00000", "m00001", "m00002", "m00003", "m00005"])
    # other batch neighbours can move the last bit of BLAS-summed indicators
    pd.testing.assert_frame_equal(out, extract_ensemble(kept), rtol=1e-12)


def test_unseen_labels_at_predict_time(rng):
    from sklearn.neighbors import KNeighborsClassifier

    x = np.r_[rng.normal(0, 0.1, 20), rng.normal(3, 0.1, 20)]
    train = pd.DataFrame({"a/stats/RMS": x, "fault": ["ok"] * 20 + ["ir"] * 20})
    model = KNeighborsClassifier(3).fit(train[["a/stats/RMS"]], train["fault"])
    new = pd.DataFrame(
        {
            "a/stats/RMS": [0.0, 3.0, 2.9, np.nan],
            "fault": ["ok", "ir", "ball", "ok"],
        },
        index=["n0", "n1", "n2", "n3"],
    )
    pred, errors = predict_members(model, new, label="fault")
    assert pred["predicted"].to_dict() == {"n0": "ok", "n1": "ir"}
    msgs = dict(zip(errors["member"], errors["error"], strict=True))
    assert "label fault='ball' was not seen in training" in msgs["n2"]
    assert "['ir', 'ok']" in msgs["n2"]
    assert "'a/stats/RMS' is nan" in msgs["n3"]
    with pytest.raises(DataError, match="'ball' was not seen"):
        predict_members(model, new.iloc[:3], label="fault", on_error="raise")


def test_a_corrupt_part_file_loses_only_its_members(tmp_path, rng):
    ens = Ensemble({"vib": rng.normal(size=(9, 1024))}, fs=FS)
    path = ens.to_parquet(tmp_path / "ens", members_per_file=3)
    file = path / "part-00001.parquet"
    file.write_bytes(file.read_bytes()[:100])  # truncated by a failed copy
    with pytest.raises(DataError, match=r"cannot read .*part-00001\.parquet"):
        extract_ensemble(path, batch_size=3)
    out, errors = extract_ensemble(path, batch_size=3, on_error="skip", return_errors=True)
    assert errors["member"].tolist() == ["#3", "#4", "#5"]
    assert "part-00001.parquet" in errors["error"].iloc[0]
    kept = ens.select(["m00000", "m00001", "m00002", "m00006", "m00007", "m00008"])
    pd.testing.assert_frame_equal(
        out, extract_ensemble(kept, batch_size=3), check_exact=True
    )
