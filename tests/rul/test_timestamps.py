"""Run-to-failure tables whose time column holds wall-clock timestamps (issue 15)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError
from pdmkit.experiments._cli import main
from pdmkit.rul import timestamps_to_seconds


def _units(path, n_units=6, stamps=True):
    rng = np.random.default_rng(0)
    start = pd.Timestamp("2004-03-04 09:27:46")
    rows = []
    for u in range(n_units):
        n = 30 + 5 * u
        for i in range(n):
            when = start + pd.Timedelta(hours=i)
            rows.append(
                {
                    "unit": u,
                    "time": str(when) if stamps else i * 3600.0,
                    "s1": i / n + 0.02 * rng.normal(),
                }
            )
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def test_text_and_datetime_stamps_become_seconds_since_the_earliest():
    text = pd.DataFrame({"time": ["2004-03-04 10:00:00", "2004-03-04 09:00:00"]})
    table, origin = timestamps_to_seconds(text)
    assert table["time"].tolist() == [3600.0, 0.0] and origin == "2004-03-04T09:00:00"
    dt = text.assign(time=pd.to_datetime(text["time"]))
    assert timestamps_to_seconds(dt)[0]["time"].tolist() == [3600.0, 0.0]
    numbers = pd.DataFrame({"time": [1.0, 2.0]})
    same, none = timestamps_to_seconds(numbers)
    assert same is numbers and none is None
    with pytest.raises(DataError, match="row 1 holds 'soon'"):
        timestamps_to_seconds(pd.DataFrame({"time": ["2004-03-04 09:00:00", "soon"]}))


def test_cli_trains_on_timestamped_units_like_on_seconds(tmp_path, capsys):
    # the same units with stamps and with plain seconds give the same held-out scores
    for name, stamps in (("stamps", True), ("seconds", False)):
        units = _units(tmp_path / f"{name}.csv", stamps=stamps)
        argv = ["rul", "--train", str(units), "--model", "linear-degradation"]
        argv += ["--rul-cap", "1e9"]  # hours of life in seconds: no C-MAPSS cap
        argv += ["--out", str(tmp_path / name), "--json", str(tmp_path / f"{name}.json")]
        assert main(argv) == 0
    said = capsys.readouterr().err
    assert "holds timestamps: seconds since 2004-03-04T09:27:46" in said
    a = pd.read_json(tmp_path / "stamps.json", typ="series")
    b = pd.read_json(tmp_path / "seconds.json", typ="series")
    assert a["rmse"] > 0 and a["n_units"] == b["n_units"]
    assert a["rmse"] == pytest.approx(b["rmse"])
    # a history with stamps is predicted by the saved model
    history = pd.read_csv(tmp_path / "stamps.csv").query("unit == 0").head(20)
    history.to_csv(tmp_path / "history.csv", index=False)
    model = tmp_path / "stamps" / "model.pdmkit"
    assert (
        main(["rul", "--trained", str(model), "--history", str(tmp_path / "history.csv")])
        == 0
    )
