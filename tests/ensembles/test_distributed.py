"""Dask backend: a real LocalCluster (2 workers x 1 thread) gives the in-process results."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import Ensemble, simulate_fault_ensemble
from pdmkit.ensembles._distributed import (
    dask_client,
    dask_map,
    discover_mismatch_batch,
    parquet_partitions,
    read_partition,
    simulate_sweep,
)
from pdmkit.errors import DataError
from pdmkit.features import extract_ensemble

distributed = pytest.importorskip("distributed")

pytestmark = [pytest.mark.distributed, pytest.mark.slow]


@pytest.fixture(scope="module")
def ensemble():
    rng = np.random.default_rng(7)
    t = np.arange(4096) / 2000.0
    tone = np.sin(2 * np.pi * rng.uniform(20, 300, size=(60, 1)) * t)
    return Ensemble(
        {
            "vib": tone + 0.3 * rng.normal(size=(60, 4096)),
            "p": rng.normal(size=(60, 1024)),
        },
        fs={"vib": 2000.0, "p": 500.0},
        conditions={"fault": np.array(["none", "ir", "or"])[np.arange(60) % 3]},
    )


def test_features_of_an_ensemble_equal_in_process(client, ensemble):
    local = extract_ensemble(ensemble, batch_size=16)
    remote = extract_ensemble(ensemble, batch_size=16, client=client)
    pd.testing.assert_frame_equal(remote, local, check_exact=True)
    # several tasks did the work: both workers took part
    assert len(local) == 60


def test_features_of_a_parquet_ensemble_read_by_the_workers(client, ensemble, tmp_path):
    path = ensemble.to_parquet(tmp_path / "ens", members_per_file=7)
    local = extract_ensemble(path, batch_size=16)
    for source in (path, path.as_uri()):  # local path and fsspec URL
        remote = extract_ensemble(source, batch_size=16, client=client)
        pd.testing.assert_frame_equal(remote, local, check_exact=True)
    # reading the Parquet batches gives the values of the in-memory ensemble
    pd.testing.assert_frame_equal(
        local, extract_ensemble(ensemble, batch_size=16), check_exact=True
    )


def test_a_scheduler_address_connects(client, ensemble):
    address = client.scheduler.address
    local = extract_ensemble(ensemble.select(slice(0, 10)), groups=("stats",))
    remote = extract_ensemble(
        ensemble.select(slice(0, 10)), groups=("stats",), batch_size=4, client=address
    )
    pd.testing.assert_frame_equal(remote, local, check_exact=True)
    assert client.status == "running"  # the user's client is left open


def test_partitions_cover_the_members_once(ensemble, tmp_path):
    path = ensemble.to_parquet(tmp_path / "ens", members_per_file=7)
    parts = parquet_partitions(path, batch_size=16)
    ids = [m for p in parts for m in read_partition(p).member_ids]
    assert ids == ensemble.member_ids.tolist()
    one = read_partition(parts[1], signals=["p"])
    np.testing.assert_array_equal(
        one.stack("p")[0], ensemble.select(slice(16, 32)).stack("p")[0]
    )


def test_a_bad_member_raises_its_data_error_from_the_worker(client, tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    good = Ensemble({"x": np.ones((4, 64))}, fs=100.0)
    path = good.to_parquet(tmp_path / "ens")
    # another tool wrote a NaN into member m00002
    file = path / "part-00000.parquet"
    table = pq.read_table(file)
    rows = table.column("x").to_pylist()
    rows[2][5] = float("nan")
    table = table.set_column(
        table.schema.get_field_index("x"), "x", pa.array(rows, pa.list_(pa.float64()))
    )
    pq.write_table(table, file)
    with pytest.raises(DataError, match="m00002"):
        extract_ensemble(path, batch_size=2, client=client)
    table, errors = extract_ensemble(
        path, batch_size=2, client=client, on_error="skip", return_errors=True
    )
    assert table.index.tolist() == ["m00000", "m00001", "m00003"]
    assert errors["member"].tolist() == ["m00002"]
    assert "non-finite" in errors["error"].iloc[0]


def test_simulation_sweep_equals_in_process(client):
    configs = [
        {
            "n_members": 3,
            "t_end": 0.3,
            "signals": ["LeverPosition", "AirPressure"],
            "seed": s,
        }
        for s in (0, 1, 2)
    ]
    local = simulate_sweep(configs)
    remote = simulate_sweep(configs, client=client)
    assert remote.member_ids.tolist() == local.member_ids.tolist()
    pd.testing.assert_frame_equal(remote.conditions, local.conditions)
    for s in local.signal_names:
        np.testing.assert_array_equal(remote.stack(s)[0], local.stack(s)[0])
    # each setting is the plain simulator's output
    single = simulate_fault_ensemble(**configs[1])
    np.testing.assert_array_equal(
        local.select([f"s1/{m}" for m in single.member_ids]).stack("AirPressure")[0],
        single.stack("AirPressure")[0],
    )


def test_mismatch_batch_equals_in_process(client):
    from pdmkit.models.mismatch._cases import generate_concealed_case

    jobs = []
    for effect, seed in (("overflow", 3), ("none", 4)):
        case = generate_concealed_case(effect, 0.2, seed=seed, n_samples=300)
        jobs.append(
            {
                "model": case.source,
                "data": case.data,
                "effects": ["overflow"],
                "pairs": False,
                "max_iter": 5,
                "screen_iter": 3,
            }
        )
    local = discover_mismatch_batch(jobs)
    remote = discover_mismatch_batch(jobs, client=client)
    for a, b in zip(local, remote, strict=True):
        a.pop("timings", None)
        b.pop("timings", None)
        assert a == b
    assert local[0]["verdict"]["effect"] == "overflow"


def test_dask_map_keeps_order(client):
    assert dask_map(np.sqrt, [16.0, 1.0, 9.0], client=client) == [4.0, 1.0, 3.0]


def test_bad_client_arguments(monkeypatch):
    monkeypatch.setattr("pdmkit.ensembles._distributed.CONNECT_TIMEOUT", "1s")
    with pytest.raises(ValueError, match="positive integer"), dask_client(True):
        pass
    with pytest.raises(ValueError, match="scheduler address"), dask_client(2.5):
        pass
    with pytest.raises(ConnectionError, match=r"tcp://127\.0\.0\.1:1"):
        with dask_client("tcp://127.0.0.1:1"):
            pass


def test_per_member_model_fits(client):
    import scipy.stats

    rng = np.random.default_rng(4)
    lifetimes = [scipy.stats.weibull_min.rvs(2.0, scale=100.0, size=40, random_state=rng)
                 for _ in range(6)]  # fmt: skip
    local = dask_map(scipy.stats.weibull_min.fit, lifetimes, floc=0.0)
    remote = dask_map(scipy.stats.weibull_min.fit, lifetimes, client=client, floc=0.0)
    assert remote == local  # the cluster runs the very same fits, in order
    assert len(remote) == len(lifetimes)


def test_a_resumed_run_on_the_cluster_equals_the_in_process_run(client, ensemble, tmp_path):
    from pdmkit.experiments._runs import extract_features_run

    path = ensemble.to_parquet(tmp_path / "ens", members_per_file=7)
    local, _ = extract_features_run(path, tmp_path / "local", batch_size=16)
    run = tmp_path / "dask"
    extract_features_run(path, run, batch_size=16, client=client)
    (run / "parts" / "part-00002" / "meta.json").unlink()  # as if killed mid-commit
    kept = (run / "parts" / "part-00000" / "meta.json").stat().st_mtime_ns
    remote, _ = extract_features_run(path, run, batch_size=16, client=client)
    pd.testing.assert_frame_equal(remote, local, check_exact=True)
    assert (run / "parts" / "part-00000" / "meta.json").stat().st_mtime_ns == kept
    pd.testing.assert_frame_equal(
        local, extract_ensemble(path, batch_size=16), check_exact=True
    )
