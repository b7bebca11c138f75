"""An RUL model attached to the health history (``pdmkit monitor score --rul``).

The reference for every stored RUL is an independent route: the public
``predict_rul`` on the exported history cut at that file's last row; and the
physics: a fleet whose indicator degrades so that the health score grows linearly
to failure, where a linear degradation model must find each test unit's true RUL.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

from pdmkit import save_model
from pdmkit._persist import load_model
from pdmkit.errors import ModelError
from pdmkit.experiments._cli import main
from pdmkit.experiments._monitor import (
    run_monitor_score,
    score_file,
    watch_folder,
)
from pdmkit.experiments._monitor_history import HealthHistory
from pdmkit.experiments._monitor_rul import RULAttachment, export_history, history_table
from pdmkit.experiments._rul import predict_rul
from pdmkit.models.diagnosis import HealthModel
from pdmkit.rul import LinearDegradationModel

#: each test file's rows: [start, stop) of the time column
FILES = [(0, 60), (60, 110), (110, 150), (150, 180)]
LIVES = {"te0": 200, "te1": 240}


def _unit(rng, name: str, life: int) -> pd.DataFrame:
    t = np.arange(float(life))
    # sqrt drift: the squared Mahalanobis score then grows linearly with time
    rms = 1.0 + 0.05 * rng.normal(size=life) + 2.0 * np.sqrt(t / life)
    return pd.DataFrame(
        {"unit": name, "t": t, "v/rms": rms, "v/kurt": 3 + 0.05 * rng.normal(size=life)}
    )


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """A health model and an RUL model trained on run-to-failure units' histories."""
    d = tmp_path_factory.mktemp("fleet")
    rng = np.random.default_rng(0)
    lives = rng.integers(150, 260, size=10)
    train = pd.concat([_unit(rng, f"tr{k}", int(n)) for k, n in enumerate(lives)])
    train.to_csv(d / "train.csv", index=False)
    keys = {"unit": "unit", "time": "t"}
    healthy = train[train["t"] < 0.3 * train.groupby("unit")["t"].transform("max")]
    (d / "m").mkdir()
    health = HealthModel(method="mahalanobis", false_alarm_rate=0.01)
    health.fit(healthy[["v/rms", "v/kurt"]], groups=healthy["unit"])
    save_model(health, d / "m" / "model.pdmkit")
    with HealthHistory(d / "train.sqlite") as history:
        score_file(load_model(d / "m" / "model.pdmkit"), d / "train.csv", history, **keys)
    assert export_history(d / "train.sqlite", d / "history.csv") == len(train)
    history = pd.read_csv(d / "history.csv")
    save_model(LinearDegradationModel(indicator="score").fit(history), d / "rul.pdmkit")
    test = pd.concat([_unit(rng, u, n) for u, n in LIVES.items()])
    for k, (a, b) in enumerate(FILES):
        test[(test["t"] >= a) & (test["t"] < b)].to_csv(d / f"f{k}.csv", index=False)
    return d, keys


def _score_all(d, keys, db):
    """Each test file in turn, as ``monitor score --rul`` does (without its report)."""
    model = load_model(d / "m" / "model.pdmkit")
    rul = RULAttachment(d / "rul.pdmkit")
    with HealthHistory(db) as history:
        for k in range(len(FILES)):
            score_file(model, d / f"f{k}.csv", history, rul=rul, **keys)


def test_each_file_adds_each_unit_the_rul_that_predict_rul_gives(fleet, tmp_path):
    d, keys = fleet
    db = tmp_path / "h.sqlite"
    _score_all(d, keys, db)
    with HealthHistory(db, read_only=True) as h:
        ruls, scored = h.rul_history(), h.history()
    assert len(ruls) == len(FILES) * len(LIVES)
    exported = history_table(scored)
    for row in ruls.itertuples():
        assert row.time == FILES[[b - 1 for _, b in FILES].index(int(row.time))][1] - 1
        cut = exported[exported["time"] <= row.time]
        cut = cut[cut["unit"] == row.unit]
        ref = predict_rul(d / "rul.pdmkit", cut, unit="unit", time="time")["units"][0]
        assert row.rul == pytest.approx(ref["rul"], rel=1e-9)
        assert row.lower == pytest.approx(ref["lower"], rel=1e-9)
        assert row.upper == pytest.approx(ref["upper"], rel=1e-9)


def test_the_last_rul_finds_the_true_remaining_life(fleet, tmp_path):
    d, keys = fleet
    db = tmp_path / "h.sqlite"
    _score_all(d, keys, db)
    with HealthHistory(db, read_only=True) as h:
        last = h.rul_history().groupby("unit").tail(1).set_index("unit")
    for unit, life in LIVES.items():
        true = life - 1 - last.loc[unit, "time"]  # failure at the last row
        assert last.loc[unit, "rul"] == pytest.approx(true, rel=0.25)
        assert last.loc[unit, "lower"] < last.loc[unit, "rul"] < last.loc[unit, "upper"]


def test_rescoring_a_file_adds_no_rul_and_watch_gives_the_same(fleet, tmp_path, capsys):
    d, keys = fleet
    _score_all(d, keys, tmp_path / "batch.sqlite")
    _score_all(d, keys, tmp_path / "batch.sqlite")  # each file seen: nothing added
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(len(FILES)):
        (folder / f"f{k}.csv").write_bytes((d / f"f{k}.csv").read_bytes())
    watched = watch_folder(d / "m" / "model.pdmkit", folder, db=tmp_path / "w.sqlite",
                           once=True, rul_model=d / "rul.pdmkit", **keys)  # fmt: skip
    assert watched == len(FILES)
    alarms = [x for x in capsys.readouterr().err.splitlines() if "ALARM" in x]
    assert len(alarms) == len(LIVES)  # one line per unit, with its RUL then
    assert all(re.search(r"; RUL [0-9.]+ s \[[0-9.]+, [0-9.]+\]$", x) for x in alarms)
    with HealthHistory(tmp_path / "batch.sqlite", read_only=True) as a:
        batch = a.rul_history()
    with HealthHistory(tmp_path / "w.sqlite", read_only=True) as b:
        watch = b.rul_history()
    assert len(batch) == len(FILES) * len(LIVES)
    pd.testing.assert_frame_equal(batch, watch)


def test_a_health_model_given_as_rul_is_refused_before_scoring(fleet, tmp_path):
    d, keys = fleet
    db = tmp_path / "h.sqlite"
    with pytest.raises(ModelError, match=r"--rul .*model\.pdmkit: holds a HealthModel"):
        run_monitor_score(d / "m" / "model.pdmkit", d / "f0.csv", db=db,
                          out_dir=tmp_path / "o", rul_model=d / "m" / "model.pdmkit",
                          **keys)  # fmt: skip
    assert not db.exists()


def test_the_cli_writes_the_rul_into_the_json_and_export_refuses_overwriting(
    fleet, tmp_path, capsys
):
    d, _ = fleet
    code = main(
        ["monitor", "score", "--model", str(d / "m" / "model.pdmkit"), "--features",
         str(d / "f0.csv"), "--unit", "unit", "--time", "t", "--db",
         str(tmp_path / "h.sqlite"), "--rul", str(d / "rul.pdmkit"), "--json",
         str(tmp_path / "s.json"), "--out", str(tmp_path / "o"), "--quiet"]
    )  # fmt: skip
    assert code == 0
    units = json.loads((tmp_path / "s.json").read_text())["units"]
    assert set(units) == set(LIVES)
    assert all(0 < u["rul"]["lower"] <= u["rul"]["rul"] <= u["rul"]["upper"]
               for u in units.values())  # fmt: skip
    (tmp_path / "mine.csv").write_text("my own data\n")
    export = ["monitor", "export", "--db", str(tmp_path / "h.sqlite"), "--csv"]
    assert main([*export, str(tmp_path / "mine.csv")]) == 2
    assert "mine.csv exists" in capsys.readouterr().err
    assert (tmp_path / "mine.csv").read_text() == "my own data\n"
