"""The designer's server, without a browser: its API, its export and its safety.

Checked against references the designer did not make: numpy's extremes and
scipy.signal.welch for the drawn traces, ``pdmkit features`` / ``pdmkit classify`` for the
table and the accuracy (the exported command line and script must reproduce what the
page showed), and pdmkit's safe model loader for the exported model.
"""

from __future__ import annotations

import json
import re
import runpy
import shlex

import numpy as np
import pandas as pd
import pytest
from starlette.testclient import TestClient

from pdmkit.ensembles import Ensemble
from pdmkit.errors import DataError
from pdmkit.experiments.designer import add_parser
from pdmkit.experiments.designer._app import create_app
from pdmkit.experiments.designer._project import MAX_PROJECT_BYTES
from pdmkit.experiments.designer._session import Session
from pdmkit.experiments.designer._source import Source, open_source
from pdmkit.experiments.designer._views import POINTS

TOKEN = "test-token"
H = {"x-designer-token": TOKEN}


def _twin_like(n_per_class: int = 12, n: int = 4096, seed: int = 0) -> Ensemble:
    """Three classes of noisy sines at 50/120/200 Hz; one long member with a spike."""
    rng = np.random.default_rng(seed)
    fs, freqs = 1000.0, {"healthy": 50.0, "leak": 120.0, "worn": 200.0}
    t = np.arange(n) / fs
    xs, labels = [], []
    for label, f in freqs.items():
        for _ in range(n_per_class):
            xs.append(np.sin(2 * np.pi * f * t) + 0.3 * rng.normal(size=n))
            labels.append(label)
    return Ensemble(
        {"flow": np.array(xs)},
        fs=fs,
        conditions={"fault": labels, "load_kg": rng.choice([0.0, 5.0], len(labels))},
    )


@pytest.fixture
def client() -> TestClient:
    session = Session(Source.from_ensemble(_twin_like(), "members", ["a.csv"]))
    return TestClient(create_app(session, TOKEN))


def _run(client: TestClient, kind: str, body: dict) -> dict:
    job = client.post(f"/api/run/{kind}", json=body, headers=H).json()
    for _ in range(600):
        job = client.get(f"/api/job/{job['id']}", headers=H).json()
        if job["state"] != "running":
            break
    assert job["state"] == "done", job["error"]
    return job["result"]


def test_token_guards_page_and_api(client: TestClient) -> None:
    assert client.get("/").status_code == 403
    assert client.get("/?token=wrong").status_code == 403
    page = client.get(f"/?token={TOKEN}")
    assert page.status_code == 200 and TOKEN in page.text and "cdn" not in page.text.lower()
    assert client.get("/api/state").status_code == 403
    assert client.get("/api/state", headers={"x-designer-token": "x"}).status_code == 403
    # the page's scripts come from the installed packages, not from the internet
    js = client.get("/static/plotly.min.js")
    assert js.status_code == 200 and len(js.content) > 1_000_000
    assert client.get("/static/../_app.py").status_code == 404


def test_defaults_bind_localhost_and_a_free_port() -> None:
    import argparse

    sub = argparse.ArgumentParser().add_subparsers(dest="command")
    args = add_parser(sub).parse_args(["--dataset", "cwru"])
    assert (args.host, args.port, args.no_browser) == ("127.0.0.1", 0, False)


def test_members_filter_and_paging(client: TestClient) -> None:
    res = client.post(
        "/api/members", json={"filter": {"fault": ["leak"]}, "limit": 5}, headers=H
    ).json()
    assert res["total"] == 12 and len(res["rows"]) == 5
    assert {r["fault"] for r in res["rows"]} == {"leak"}
    second = client.post("/api/members", json={"offset": 30, "limit": 100}, headers=H)
    assert len(second.json()["rows"]) == 6


def test_plot_is_decimated_and_keeps_the_extremes() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=300_000)
    x[123_457] = 25.0  # a spike an every-n-th decimation would miss
    ens = Ensemble({"v": [x, x[:1000]]}, fs=50_000.0, conditions={"fault": ["a", "b"]})
    client = TestClient(create_app(Session(Source.from_ensemble(ens)), TOKEN))
    res = client.post("/api/plot", json={"by": "fault", "signal": "v"}, headers=H).json()
    long, short = res["traces"]
    assert len(long["y"]) <= POINTS and res["decimated"]
    assert max(long["y"]) == x.max() == 25.0 and min(long["y"]) == x.min()
    assert long["x"][int(np.argmax(long["y"]))] == pytest.approx(123_457 / 50_000.0)
    assert np.all(np.diff(long["x"]) >= 0)  # still in time order
    assert short["y"] == x[:1000].tolist()  # short traces go whole


def test_spectrum_matches_scipy_welch(client: TestClient) -> None:
    from scipy.signal import welch

    res = client.post(
        "/api/plot",
        json={"by": "fault", "signal": "flow", "kind": "spectrum", "nperseg": 512},
        headers=H,
    ).json()
    peaks = {t["group"]: t["x"][int(np.argmax(t["y"]))] for t in res["traces"]}
    assert peaks == pytest.approx({"healthy": 50.0, "leak": 120.0, "worn": 200.0}, abs=2.0)
    ens = _twin_like()
    _, p = welch(ens.signal("flow")[0], fs=1000.0, nperseg=512)
    assert res["traces"][0]["y"] == pytest.approx(p.tolist(), rel=1e-12)


def test_steps_errors_are_one_line(client: TestClient) -> None:
    res = client.post("/api/run/train", json={"model": "knn"}, headers=H).json()
    job = client.get(f"/api/job/{res['id']}", headers=H).json()
    for _ in range(100):
        if job["state"] != "running":
            break
        job = client.get(f"/api/job/{res['id']}", headers=H).json()
    assert (
        job["state"] == "failed" and job["error"] == "compute the indicators first (step 2)"
    )
    bad = client.post("/api/run/features", json={"groups": ["os.system"]}, headers=H)
    job = client.get(f"/api/job/{bad.json()['id']}", headers=H).json()
    for _ in range(100):
        if job["state"] != "running":
            break
        job = client.get(f"/api/job/{bad.json()['id']}", headers=H).json()
    assert "groups must be among" in job["error"] and "\n" not in job["error"]
    wrong = client.post("/api/values", json={"columns": ["x/y/z"]}, headers=H)
    assert wrong.status_code == 400 and "\n" not in wrong.json()["error"]


def test_histogram_scatter_rank_train_sensors(client: TestClient) -> None:
    summary = _run(
        client, "features", {"signals": ["flow"], "groups": ["stats", "spectral"]}
    )
    assert summary["n_members"] == 36 and summary["n_features"] == 27
    hist = client.post(
        "/api/values", json={"columns": ["flow/spectral/PeakFreq1"]}, headers=H
    )
    groups = {g["name"]: g["values"][0] for g in hist.json()["groups"]}
    assert {k: np.median(v) for k, v in groups.items()} == pytest.approx(
        {"healthy": 50.0, "leak": 120.0, "worn": 200.0}, abs=2.0
    )
    scatter = client.post(
        "/api/values",
        json={"columns": ["flow/stats/RMS", "flow/stats/Kurtosis"], "by": "load_kg"},
        headers=H,
    ).json()
    assert {g["name"] for g in scatter["groups"]} == {"0.0", "5.0"}
    ranking = _run(client, "rank", {"method": "kruskal"})["ranking"]
    assert ranking[0]["score"] >= ranking[-1]["score"]
    trained = _run(client, "train", {"model": "knn", "top_k": 3, "seed": 1})
    assert trained["accuracy"] == 1.0 and len(trained["features"]) == 3
    assert np.trace(trained["confusion"]) == trained["n_test"]
    hand = _run(
        client,
        "train",
        {"selection": "hand", "features": ["flow/stats/Mean"], "model": "lda"},
    )
    assert hand["features"] == ["flow/stats/Mean"] and hand["accuracy"] < 0.9
    sensors = _run(client, "sensors", {"costs": "flow=600"})["sensors"]
    assert sensors[0]["sensor"] == "flow" and sensors[0]["cost"] == 600.0


def test_model_file_loads_safely_and_predicts_the_same(tmp_path) -> None:
    from pdmkit import load_model
    from pdmkit._entry import main as pdmkit_main

    session = Session(Source.from_ensemble(_twin_like(), "members", ["a.csv"]))
    client = TestClient(create_app(session, TOKEN))
    _run(client, "features", {"signals": ["flow"], "groups": ["stats"]})
    _run(client, "train", {"model": "random_forest", "top_k": 4})
    blob = client.get("/api/export/model.pdmkit", headers=H).content
    (tmp_path / "m.pdmkit").write_bytes(blob)
    loaded = load_model(tmp_path / "m.pdmkit")
    X = session.table[session.result.input_features].to_numpy()
    expected = session.result.pipeline.predict(X)
    assert (loaded.predict(session.table).to_numpy() == expected).all()
    # columns are matched by name: reversed, the same predictions; one missing, an error
    reversed_table = session.table[session.table.columns[::-1]]
    assert (loaded.predict(reversed_table).to_numpy() == expected).all()
    with pytest.raises(DataError, match="lacks 1 of the"):
        loaded.predict(session.table.drop(columns=session.result.input_features[0]))
    assert loaded.recipe["signals"] == ["flow"] and loaded.recipe["groups"] == ["stats"]
    # pdmkit predict scores a feature table with the designer's file as with classify's
    session.table.to_parquet(tmp_path / "table.parquet")
    args = ["predict", "--model", str(tmp_path / "m.pdmkit"), "--features"]
    args += [str(tmp_path / "table.parquet"), "--out", str(tmp_path / "pred"), "--quiet"]
    assert pdmkit_main(args) == 0
    got = pd.read_csv(tmp_path / "pred" / "predictions.csv", index_col="member")
    assert (got.loc[session.table.index, "predicted"].to_numpy() == expected).all()


def test_project_round_trip_and_validation(client: TestClient) -> None:
    _run(client, "features", {"signals": ["flow"], "groups": ["stats"], "options": ""})
    _run(client, "rank", {"method": "anova"})
    first = _run(client, "train", {"model": "knn", "top_k": 2, "seed": 4})
    project = client.get("/api/project", headers=H).text
    fresh = TestClient(
        create_app(Session(Source.from_ensemble(_twin_like(), "members", ["a.csv"])), TOKEN)
    )
    job = fresh.post("/api/project", content=project, headers=H).json()
    for _ in range(600):
        job = fresh.get(f"/api/job/{job['id']}", headers=H).json()
        if job["state"] != "running":
            break
    assert job["result"] == {"replayed": ["indicators", "rank", "train"]}
    state = fresh.get("/api/state", headers=H).json()
    assert state["train"]["accuracy"] == first["accuracy"]
    assert state["train"]["features"] == first["features"]
    assert state["steps"]["rank"]["method"] == "anova"

    def refused(text: str | bytes) -> str:
        res = fresh.post("/api/project", content=text, headers=H)
        assert res.status_code == 400
        return res.json()["error"]

    raw = json.loads(project)
    assert "at most" in refused(b" " * (MAX_PROJECT_BYTES + 1))
    assert "not JSON" in refused("{nope")
    assert "not a pdmkit designer project" in refused('{"format": "pickle"}')
    assert "top_k must be an integer" in refused(
        json.dumps({**raw, "train": {**raw["train"], "top_k": 10**9}})
    )
    assert "model must be one of" in refused(
        json.dumps({**raw, "train": {**raw["train"], "model": "__import__('os')"}})
    )
    deep = {**raw, "data": {"filter": {"a": [[[[[["x"]]]]]]}}}
    assert "nests deeper" in refused(json.dumps(deep))
    other = {**raw, "source": {"kind": "dataset", "value": "cwru"}}
    assert "start pdmkit designer --project" in refused(json.dumps(other))


def test_on_disk_source_streams_and_matches_memory(tmp_path) -> None:
    from pdmkit.features import extract_ensemble

    ens = _twin_like(n_per_class=10)
    path = ens.to_parquet(tmp_path / "ens", members_per_file=7)
    source = open_source("ensemble", str(path))
    assert source.ensemble is None  # never loaded whole
    member = ens.member_ids[17]
    assert np.array_equal(source.read(member, "flow"), ens.signal("flow")[17])
    session = Session(source)
    session.run_now("features", {"groups": ["stats"], "options": ""})
    reference = extract_ensemble(str(path), groups=("stats",))  # the CLI's way
    pd.testing.assert_frame_equal(session.table, reference)
    filtered = Session(source)
    filtered.run_now(
        "features",
        {"groups": ["stats"], "scope": "filtered", "filter": {"fault": ["worn"]}},
    )
    assert set(filtered.table["fault"]) == {"worn"} and len(filtered.table) == 10


@pytest.mark.real_data
def test_export_reproduces_pdmkit_commands_on_cwru(
    require_data, tmp_path, monkeypatch
) -> None:
    """The page's table and accuracy = the exported script's = ``pdmkit classify``'s."""
    from pdmkit._entry import main as pdmkit_main

    require_data("cwru_bearing")
    session = Session(open_source("dataset", "cwru"))
    client = TestClient(create_app(session, TOKEN))
    state = client.get("/api/state", headers=H).json()
    assert state["defaults"]["options"] == "nperseg=512"
    _run(
        client,
        "features",
        {
            "signals": ["FE"],
            "groups": ["stats", "spectral"],
            "options": state["defaults"]["options"],
        },
    )
    _run(client, "rank", {"method": "kruskal"})
    # Kruskal's pick here scores 0.925 on the grouped split (Fisher's: 1.0)
    page = _run(client, "train", {"model": "knn", "top_k": 2, "selection": "kruskal"})
    export = client.get("/api/export", headers=H).json()
    monkeypatch.chdir(tmp_path)
    # the command lines, run by pdmkit's own CLI
    features_cmd, _, classify_cmd = export["commands"]
    assert pdmkit_main([*shlex.split(features_cmd)[1:], "--quiet"]) == 0
    cli_table = pd.read_parquet(tmp_path / "results/designer/features/features.parquet")
    fe = [c for c in cli_table.columns if str(c).startswith("FE/")]
    np.testing.assert_array_equal(cli_table[fe].to_numpy(), session.table[fe].to_numpy())
    json_path = tmp_path / "summary.json"
    assert pdmkit_main([*shlex.split(classify_cmd)[1:], "--json", str(json_path)]) == 0
    cli = json.loads(json_path.read_text())
    assert cli["accuracy"] == page["accuracy"] and cli["features"] == page["features"]
    # the script, run as a file
    (tmp_path / "pipeline.py").write_text(export["script"])
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        runpy.run_path(str(tmp_path / "pipeline.py"), run_name="__main__")
    found = re.search(r"held-out accuracy (\d\.\d+)", out.getvalue())
    assert found and float(found.group(1)) == round(page["accuracy"], 4)
    assert 0.9 < page["accuracy"] < 1.0  # a score that can differ, not a trivial 1.0
