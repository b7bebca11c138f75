"""`pdmkit features --workers/--scheduler/--fresh`: the same table as the in-process run."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import Ensemble
from pdmkit.experiments._cli import main


@pytest.fixture
def ensemble_dir(tmp_path):
    rng = np.random.default_rng(11)
    ens = Ensemble(
        {"vib": rng.normal(size=(40, 4096)), "p": rng.normal(size=(40, 512))},
        fs={"vib": 4000.0, "p": 100.0},
        conditions={"fault": np.array(["ok", "ir"])[np.arange(40) % 2]},
    )
    return ens.to_parquet(tmp_path / "ens", members_per_file=9)


@pytest.mark.slow
@pytest.mark.distributed
def test_workers_write_the_same_features_parquet(ensemble_dir, tmp_path):
    base = ["features", "--ensemble", str(ensemble_dir), "--batch-size", "8"]
    assert main([*base, "--out", str(tmp_path / "local")]) == 0
    assert main([*base, "--workers", "2", "--out", str(tmp_path / "dask")]) == 0
    local = (tmp_path / "local" / "features.parquet").read_bytes()
    assert (tmp_path / "dask" / "features.parquet").read_bytes() == local
    # an fsspec URL of the same ensemble gives the same table
    url = ensemble_dir.as_uri()
    assert main(["features", "--ensemble", url, "--batch-size", "8", "--out",
                 str(tmp_path / "url")]) == 0  # fmt: skip
    assert (tmp_path / "url" / "features.parquet").read_bytes() == local


@pytest.mark.slow
@pytest.mark.distributed
@pytest.mark.real_data
def test_cwru_with_two_workers_equals_in_process(require_data, tmp_path):
    require_data("cwru_bearing")
    assert main(["features", "--dataset", "cwru", "--out", str(tmp_path / "a")]) == 0
    args = ["features", "--dataset", "cwru", "--workers", "2", "--out", str(tmp_path / "b")]
    assert main(args) == 0
    a = pd.read_parquet(tmp_path / "a" / "features.parquet")
    b = pd.read_parquet(tmp_path / "b" / "features.parquet")
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert len(a) == 265  # every frame of the five records


def test_unreachable_scheduler_is_a_clear_error(
    ensemble_dir, tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr("pdmkit.ensembles._distributed.CONNECT_TIMEOUT", "1s")
    status = main(
        ["features", "--ensemble", str(ensemble_dir), "--scheduler", "tcp://127.0.0.1:1",
         "--out", str(tmp_path / "o")]
    )  # fmt: skip
    assert status == 2
    assert "cannot reach the Dask scheduler at 'tcp://127.0.0.1:1'" in (
        capsys.readouterr().err
    )


def test_changed_settings_after_a_saved_run_start_over(ensemble_dir, tmp_path):
    out = tmp_path / "o"
    base = ["features", "--ensemble", str(ensemble_dir), "--out", str(out)]
    assert main([*base, "--groups", "stats"]) == 0
    assert json.loads((out / "run" / "manifest.json").read_text())["state"] == "saved"
    # the store's results are in OUT already: other settings start over, and say so
    with pytest.warns(UserWarning, match="discarded the 1 partitions"):
        assert main([*base, "--groups", "stats", "spectral"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert any(
        "discarded the" in w and "config differs (groups:" in w for w in summary["warnings"]
    )
    assert any("spectral" in c for c in pd.read_parquet(out / "features.parquet"))


def test_changed_settings_after_an_interrupted_run_need_fresh(
    ensemble_dir, tmp_path, capsys
):
    out = tmp_path / "o"
    base = ["features", "--ensemble", str(ensemble_dir), "--out", str(out)]
    assert main([*base, "--groups", "stats"]) == 0
    first = pd.read_parquet(out / "features.parquet")
    # what a run killed halfway leaves: committed partitions of a run still "running"
    manifest = out / "run" / "manifest.json"
    manifest.write_text(
        json.dumps({**json.loads(manifest.read_text()), "state": "running"})
    )
    assert main([*base, "--groups", "stats", "spectral"]) == 2
    err = capsys.readouterr().err
    assert "interrupted" in err and "config differs (groups:" in err and "--fresh" in err
    # the refused run left the earlier result untouched
    pd.testing.assert_frame_equal(pd.read_parquet(out / "features.parquet"), first)
    assert main([*base, "--groups", "stats", "spectral", "--fresh"]) == 0
    assert any("spectral" in c for c in pd.read_parquet(out / "features.parquet"))


def test_workers_must_be_positive(ensemble_dir, tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["features", "--ensemble", str(ensemble_dir), "--workers", "0"])
    assert "expected a positive integer, got 0" in capsys.readouterr().err
