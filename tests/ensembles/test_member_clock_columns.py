"""Clock columns of raw recordings are time stamps, not health indicators."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import read_members
from pdmkit.errors import DataWarning


def _snapshot(path, hour, minute, second, us0, rng, n=256):
    us = (us0 + 39 * np.arange(n)) % 1_000_000
    sec = second + (us0 + 39 * np.arange(n)) // 1_000_000
    acc = rng.normal(size=(n, 2))
    table = np.column_stack([np.full(n, hour), np.full(n, minute), sec, us, acc])
    pd.DataFrame(table).to_csv(path, header=False, index=False, float_format="%.6g")


def test_header_less_clock_fields_become_conditions_and_counters_are_dropped(tmp_path, rng):
    _snapshot(tmp_path / "a.csv", 9, 39, 39, 65664, rng)
    _snapshot(tmp_path / "b.csv", 9, 48, 59, 990000, rng)  # the second ticks over
    with pytest.warns(DataWarning, match="column 'column_3' looks like a clock"):
        ens = read_members(tmp_path, fs=25600.0)
    assert sorted(ens.signal_names) == ["column_4", "column_5"]
    assert ens.conditions.loc["a", "column_1"] == 39.0
    assert ens.conditions.loc["b", "column_1"] == 48.0


def test_pronostia_raw_snapshots_rank_no_clock(tmp_path, require_data):
    from pdmkit.experiments._cli import main

    folder = require_data("femto_pronostia_bearing1_1") / "raw_subset"
    files = sorted(str(p) for p in folder.glob("*.csv"))
    args = ["features", "--members", *files, "--fs", "25600", "--quiet"]
    with pytest.warns(DataWarning, match="clock"):
        assert main([*args, "--out", str(tmp_path / "f")]) == 0
    table = pd.read_parquet(tmp_path / "f" / "features.parquet")
    signals = {c.split("/")[0] for c in table.columns if "/" in c}
    assert signals == {"column_4", "column_5"}  # the two accelerations only
    assert table["column_0"].between(0, 23).all()  # the hour, kept as a condition
