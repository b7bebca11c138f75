"""The on-disk ensemble: round trip, streaming, atomic writes, damaged datasets."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import pdmkit.ensembles._parquet as store
from pdmkit.ensembles import Ensemble, iter_parquet
from pdmkit.errors import DataError, DataNotFoundError


def assert_same(a: Ensemble, b: Ensemble) -> None:
    assert a.member_ids.tolist() == b.member_ids.tolist()
    assert a.signal_names == b.signal_names
    assert a.fs == b.fs
    for s in a.signal_names:
        for x, y in zip(a.signal(s), b.signal(s), strict=True):
            if x is None:
                assert y is None
            else:
                assert y.dtype == np.float64
                np.testing.assert_array_equal(x, y)
    pd.testing.assert_frame_equal(a.conditions, b.conditions)


@pytest.fixture
def ens(rng: np.random.Generator) -> Ensemble:
    n = 7
    lengths = rng.integers(5, 60, size=n)
    return Ensemble(
        {
            "DE": [rng.normal(size=k) for k in lengths],
            "BA": [None if i % 3 == 0 else rng.normal(size=4) for i in range(n)],
        },
        fs={"DE": 12000.0, "BA": 610.3515625},
        conditions=pd.DataFrame(
            {
                "fault": pd.Categorical(["normal", "IR", "IR", "B", "normal", "OR", "B"]),
                "diameter": rng.uniform(size=n),
                "unit": np.arange(n, dtype=np.int64),
                "healthy": [True, False, False, False, True, False, False],
                "record": [f"rec_{i}" for i in range(n)],
                "when": pd.date_range("2024-01-01", periods=n, freq="h"),
            }
        ),
        member_ids=[f"IR_007/f{i:04d}" for i in range(n)],
    )


def test_round_trip_equals_the_original(ens: Ensemble, tmp_path: Path) -> None:
    path = ens.to_parquet(tmp_path / "ds", members_per_file=3)
    assert path == tmp_path / "ds"
    names = sorted(p.name for p in path.iterdir())
    assert names == [
        "_pdmkit_ensemble.json",
        "part-00000.parquet",
        "part-00001.parquet",
        "part-00002.parquet",
    ]
    manifest = json.loads((path / "_pdmkit_ensemble.json").read_text())
    assert manifest["n_members"] == 7
    assert manifest["signals"] == ["DE", "BA"]
    assert manifest["fs"] == {"DE": 12000.0, "BA": 610.3515625}
    assert [f["n_members"] for f in manifest["files"]] == [3, 3, 1]
    assert_same(ens, Ensemble.from_parquet(path))


def test_files_are_plain_parquet_with_one_row_per_member(
    ens: Ensemble, tmp_path: Path
) -> None:
    path = ens.to_parquet(tmp_path / "ds", members_per_file=4)
    table = pq.read_table(path / "part-00000.parquet")
    assert table.num_rows == 4
    de_type = table.schema.field("DE").type
    assert pa.types.is_list(de_type) and de_type.value_type == pa.float64()
    assert table.column("member").to_pylist() == ens.member_ids[:4].tolist()
    assert table.column("BA").to_pylist()[0] is None
    np.testing.assert_array_equal(table.column("DE").to_pylist()[1], ens.signal("DE")[1])


def test_read_a_subset_of_signals_and_columns(ens: Ensemble, tmp_path: Path) -> None:
    path = ens.to_parquet(tmp_path / "ds")
    sub = Ensemble.from_parquet(path, signals=["BA"], columns=["fault"])
    assert sub.signal_names == ["BA"] and sub.fs == {"BA": 610.3515625}
    assert sub.conditions.columns.tolist() == ["fault"]
    with pytest.raises(DataError, match=r"no signal.*'XX'.*'DE', 'BA'"):
        Ensemble.from_parquet(path, signals=["XX"])
    with pytest.raises(DataError, match="condition column"):
        Ensemble.from_parquet(path, columns=["nope"])


@pytest.mark.parametrize("batch_size", [1, 2, 3, 5, 100])
def test_streaming_batches_concatenate_to_the_whole(
    ens: Ensemble, tmp_path: Path, batch_size: int
) -> None:
    path = ens.to_parquet(tmp_path / "ds", members_per_file=3)
    batches = list(iter_parquet(path, batch_size=batch_size))
    sizes = [len(b) for b in batches]
    assert all(s == batch_size for s in sizes[:-1]) and 0 < sizes[-1] <= batch_size
    assert_same(ens, Ensemble.concat(batches))


def test_streaming_reads_only_the_requested_signal(ens: Ensemble, tmp_path: Path) -> None:
    path = ens.to_parquet(tmp_path / "ds", members_per_file=2)
    batches = list(iter_parquet(path, batch_size=4, signals="DE", columns=[]))
    whole = Ensemble.concat(batches)
    assert whole.signal_names == ["DE"] and whole.conditions.shape[1] == 0
    for x, y in zip(whole.signal("DE"), ens.signal("DE"), strict=True):
        np.testing.assert_array_equal(x, y)


def test_large_members_are_split_into_row_groups(
    monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator, tmp_path: Path
) -> None:
    monkeypatch.setattr(store, "_GROUP_VALUES", 100)
    ens = Ensemble({"x": rng.normal(size=(10, 40))}, fs=1.0)
    path = ens.to_parquet(tmp_path / "ds", members_per_file=10)
    # 100 samples per row group at most: two members of 40 each
    assert pq.ParquetFile(path / "part-00000.parquet").num_row_groups == 5
    assert_same(ens, Ensemble.concat(iter_parquet(path, batch_size=4)))


def test_empty_ensemble_round_trip(tmp_path: Path) -> None:
    ens = Ensemble({"x": np.zeros((2, 3))}, fs=5.0, conditions={"k": [1, 2]}).select([])
    back = Ensemble.from_parquet(ens.to_parquet(tmp_path / "ds"))
    assert len(back) == 0 and back.signal_names == ["x"] and back.fs == {"x": 5.0}
    assert back.conditions["k"].dtype == np.int64


def test_failed_write_keeps_the_previous_dataset_and_leaves_no_temp_dirs(
    ens: Ensemble, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "ds"
    old = ens.select(slice(0, 2))
    old.to_parquet(target)
    before = sorted(p.name for p in target.iterdir())

    real = store._write_part
    calls = []

    def failing(*args, **kwargs):
        calls.append(args[0])
        if len(calls) == 2:
            raise OSError("disk full")
        return real(*args, **kwargs)

    monkeypatch.setattr(store, "_write_part", failing)
    with pytest.raises(OSError, match="disk full"):
        ens.to_parquet(target, members_per_file=2)
    assert len(calls) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]  # no temp dirs left
    assert sorted(p.name for p in target.iterdir()) == before
    assert_same(old, Ensemble.from_parquet(target))


def test_overwrite_replaces_an_existing_dataset(ens: Ensemble, tmp_path: Path) -> None:
    target = tmp_path / "ds"
    ens.to_parquet(target, members_per_file=2)
    small = ens.select([0])
    small.to_parquet(target)
    assert sorted(p.name for p in target.iterdir()) == [
        "_pdmkit_ensemble.json",
        "part-00000.parquet",
    ]
    assert_same(small, Ensemble.from_parquet(target))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_refuses_to_replace_something_that_is_not_an_ensemble(
    ens: Ensemble, tmp_path: Path
) -> None:
    precious = tmp_path / "thesis"
    precious.mkdir()
    (precious / "chapter1.tex").write_text("years of work")
    with pytest.raises(DataError, match=r"not a pdmkit ensemble.*chapter1.tex"):
        ens.to_parquet(precious)
    assert (precious / "chapter1.tex").read_text() == "years of work"
    file = tmp_path / "notes.txt"
    file.write_text("x")
    with pytest.raises(DataError, match="is a file"):
        ens.to_parquet(file)


def test_reading_something_that_is_not_an_ensemble(tmp_path: Path) -> None:
    with pytest.raises(DataNotFoundError, match="does not exist"):
        Ensemble.from_parquet(tmp_path / "missing")
    with pytest.raises(DataError, match="directory is empty"):
        Ensemble.from_parquet(tmp_path)
    (tmp_path / "data.csv").write_text("a\n1\n")
    with pytest.raises(DataError, match=r"not a pdmkit ensemble: it holds 'data.csv'"):
        list(iter_parquet(tmp_path))
    with pytest.raises(DataError, match="it is a file"):
        Ensemble.from_parquet(tmp_path / "data.csv")
    (tmp_path / "_pdmkit_ensemble.json").write_text("{not json")
    with pytest.raises(DataError, match="not valid JSON"):
        Ensemble.from_parquet(tmp_path)
    (tmp_path / "_pdmkit_ensemble.json").write_text('{"format": "other"}')
    with pytest.raises(DataError, match="not a pdmkit ensemble manifest"):
        Ensemble.from_parquet(tmp_path)


def test_damaged_parts_are_reported(ens: Ensemble, tmp_path: Path) -> None:
    path = ens.to_parquet(tmp_path / "ds", members_per_file=3)
    (path / "part-00002.parquet").unlink()
    with pytest.raises(DataError, match=r"incomplete.*part-00002.parquet"):
        Ensemble.from_parquet(path)
    path = ens.to_parquet(tmp_path / "ds2", members_per_file=3)
    (path / "part-00001.parquet").write_bytes(np.random.default_rng(0).bytes(300))
    with pytest.raises(DataError, match=r"part-00001.parquet"):
        Ensemble.from_parquet(path)
    with pytest.raises(DataError, match=r"part-00001.parquet"):
        list(iter_parquet(path))


def test_condition_columns_that_parquet_cannot_store_are_named(tmp_path: Path) -> None:
    ens = Ensemble({"x": np.zeros((2, 3))}, fs=1.0, conditions={"mixed": [1, "a"]})
    with pytest.raises(DataError, match="'mixed'"):
        ens.to_parquet(tmp_path / "ds")
    assert not any(tmp_path.iterdir())
