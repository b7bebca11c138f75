"""Safe persistence: real fitted models round-trip; tampered files are refused."""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import zipfile

import numpy as np
import pandas as pd
import pytest

from pdmkit._persist import load_model, save_model
from pdmkit.errors import ModelError


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def runs():
    """Run-to-failure histories: a noisy rising indicator, one operating setting."""
    rng = np.random.default_rng(5)
    rows = []
    for u in range(12):
        life = int(rng.integers(40, 80))
        t = np.arange(life)
        rows.append(
            pd.DataFrame(
                {
                    "unit": u,
                    "time": t,
                    "hi": 1
                    + 0.02 * t * (1 + 0.1 * rng.normal())
                    + 0.05 * rng.normal(size=life),
                    "s2": np.exp(0.02 * t) + 0.05 * rng.normal(size=life),
                    "op": rng.integers(0, 2, size=life).astype(float),
                }
            )
        )
    table = pd.concat(rows, ignore_index=True)
    train = table[table.unit < 9]
    test = table[table.unit >= 9].groupby("unit").head(30)
    return train, test


def _rewrite(path, changes, *, fix_checksums=True):
    """Replace zip members of a model file; optionally recompute the checksums."""
    with zipfile.ZipFile(path) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    members.update(changes)
    manifest = json.loads(members["manifest.json"])
    if fix_checksums:
        manifest["sha256"] = {
            n: hashlib.sha256(b).hexdigest()
            for n, b in members.items()
            if n != "manifest.json"
        }
    members["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(path, "w") as zf:
        for n, b in members.items():
            zf.writestr(n, b)


# --------------------------------------------------------------------------- round trips
@pytest.mark.slow  # importing skops.io takes several seconds (it imports torch)
def test_sklearn_pipeline_round_trips(tmp_path):
    from sklearn.datasets import make_classification
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.feature_selection import SelectKBest, f_classif
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    X, y = make_classification(200, 8, n_informative=4, random_state=0)
    model = make_pipeline(
        StandardScaler(),
        SelectKBest(f_classif, k=4),
        RandomForestClassifier(20, random_state=0),
    ).fit(X, y)
    loaded = load_model(save_model(model, tmp_path / "clf.pdmkit"))
    assert type(loaded) is type(model)
    np.testing.assert_array_equal(loaded.predict_proba(X), model.predict_proba(X))
    with zipfile.ZipFile(tmp_path / "clf.pdmkit") as zf:
        assert sorted(zf.namelist()) == ["manifest.json", "model.skops"]


@pytest.mark.slow  # skops import
@pytest.mark.parametrize("name", ["knn", "bagged_trees", "svm", "random_forest", "lda"])
def test_pdmkit_classifier_pipelines_round_trip(name, tmp_path):
    from pdmkit.experiments import make_classifier

    rng = np.random.default_rng(2)
    y = np.repeat(["ok", "ir", "or"], 30)
    X = pd.DataFrame(rng.normal(size=(90, 6)), columns=[f"v/stats/f{i}" for i in range(6)])
    X.iloc[:, 0] += (y == "ir") * 3
    X.iloc[:, 1] += (y == "or") * 3
    model = make_classifier(name, top_k=3).fit(X, y)
    loaded = load_model(save_model(model, tmp_path / "c.pdmkit"))
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    assert loaded.named_steps["select"].get_feature_names_out().tolist() == (
        model.named_steps["select"].get_feature_names_out().tolist()
    )


RUL_MODELS = [
    ("LinearDegradationModel", {}),
    ("ExponentialDegradationModel", {}),
    ("ResidualSimilarityModel", {}),
    ("PairwiseSimilarityModel", {}),
    ("HashSimilarityModel", {}),
    ("ReliabilitySurvivalModel", {}),
    ("CovariateSurvivalModel", {"covariates": ["hi"]}),
    ("WienerDegradationModel", {}),
    ("GammaProcessDegradationModel", {"transform": "auto"}),
]


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize(("name", "params"), RUL_MODELS, ids=[m for m, _ in RUL_MODELS])
def test_rul_models_round_trip(name, params, runs, tmp_path):
    import pdmkit.rul as rul

    train, test = runs
    model = getattr(rul, name)(**params).fit(train)
    path = save_model(model, tmp_path / "m.pdmkit")
    with zipfile.ZipFile(path) as zf:
        assert "model.skops" not in zf.namelist()  # JSON + npz, no pickle anywhere
    loaded = load_model(path)
    assert loaded.get_params() == model.get_params()
    pd.testing.assert_frame_equal(
        loaded.predict(test).to_pandas(), model.predict(test).to_pandas(), check_exact=True
    )


def test_health_indicator_and_normalizer_round_trip(runs, tmp_path):
    from pdmkit.rul import HealthIndicator, RegimeNormalizer

    train, test = runs
    for model in (
        HealthIndicator().fit(train),
        RegimeNormalizer(settings=["op"]).fit(train),
    ):
        loaded = load_model(save_model(model, tmp_path / "h.pdmkit"))
        pd.testing.assert_frame_equal(loaded.transform(test), model.transform(test))


@pytest.mark.torch
@pytest.mark.slow
def test_neural_rul_model_keeps_its_weights(runs, tmp_path):
    from pdmkit.rul import NeuralRULModel

    train, test = runs
    model = NeuralRULModel(epochs=2, n_folds=2, hidden=8, random_state=1).fit(train)
    path = save_model(model, tmp_path / "nn.pdmkit")
    with zipfile.ZipFile(path) as zf:
        assert "tensors.pt" in zf.namelist()
    loaded = load_model(path)
    pd.testing.assert_frame_equal(
        loaded.predict(test).to_pandas(), model.predict(test).to_pandas(), check_exact=True
    )


@pytest.mark.torch
def test_torch_module_as_state_dict_and_config(tmp_path):
    import torch

    torch.manual_seed(0)
    net = torch.nn.Linear(3, 2)
    path = save_model(
        net, tmp_path / "lin.pdmkit", config={"in_features": 3, "out_features": 2}
    )
    loaded = load_model(path)
    x = torch.randn(5, 3)
    torch.testing.assert_close(loaded(x), net(x), rtol=0, atol=0)
    with pytest.raises(ModelError, match="needs config="):
        save_model(net, tmp_path / "x.pdmkit")


# --------------------------------------------------------------------------- tampering
@pytest.fixture
def saved(runs, tmp_path):
    from pdmkit.rul import ResidualSimilarityModel

    train, _ = runs
    return save_model(ResidualSimilarityModel().fit(train), tmp_path / "m.pdmkit")


def test_changed_bytes_fail_the_checksum(saved):
    with zipfile.ZipFile(saved) as zf:
        state = zf.read("state.json")
    _rewrite(saved, {"state.json": state.replace(b'"k"', b'"K"', 1)}, fix_checksums=False)
    with pytest.raises(ModelError, match=r"checksum mismatch for state\.json"):
        load_model(saved)


def test_a_flipped_byte_anywhere_is_refused(saved):
    raw = bytearray(saved.read_bytes())
    for position in (len(raw) // 3, len(raw) // 2, len(raw) - 30):
        broken = raw.copy()
        broken[position] ^= 0xFF
        saved.write_bytes(bytes(broken))
        with pytest.raises(ModelError, match=str(saved)):
            load_model(saved)


class _Boom:
    def __reduce__(self):
        return (os.system, ("touch pwned",))


@pytest.mark.filterwarnings("ignore:Detected pickle protocol:UserWarning")
def test_pickled_payloads_are_never_unpickled(saved, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # an object array in arrays.npz (np.save pickles it); checksums made to match
    buffer = io.BytesIO()
    np.savez(buffer, a0=np.array([_Boom()], dtype=object))
    _rewrite(saved, {"arrays.npz": buffer.getvalue()})
    with pytest.raises(ModelError, match="pickled object array"):
        load_model(saved)
    # a pickle posing as the torch weights
    pytest.importorskip("torch")
    _rewrite(saved, {"tensors.pt": pickle.dumps({"w": _Boom()})})
    with pytest.raises(ModelError, match="weights_only=True"):
        load_model(saved)
    assert not (tmp_path / "pwned").exists()


def test_disallowed_classes_are_refused(saved, tmp_path):
    with zipfile.ZipFile(saved) as zf:
        state = json.loads(zf.read("state.json"))
        manifest = json.loads(zf.read("manifest.json"))
    state["class"] = manifest["class"] = "subprocess.Popen"
    _rewrite(
        saved,
        {
            "state.json": json.dumps(state).encode(),
            "manifest.json": json.dumps(manifest).encode(),
        },
    )
    with pytest.raises(ModelError, match=r"'subprocess\.Popen', which is not one"):
        load_model(saved)
    # a skops file naming a function outside sklearn / numpy / scipy / pdmkit
    from sklearn.preprocessing import FunctionTransformer

    path = save_model(FunctionTransformer(os.getcwd), tmp_path / "ft.pdmkit")
    with pytest.raises(ModelError, match=r"\['posix.getcwd'\], which are not allowed"):
        load_model(path)


def test_extra_members_and_non_model_files_are_refused(saved, tmp_path):
    _rewrite(saved, {"payload.pkl": b"x"})
    with pytest.raises(ModelError, match=r"unexpected member\(s\) \['payload.pkl'\]"):
        load_model(saved)
    other = tmp_path / "notes.pdmkit"
    other.write_text("hello")
    with pytest.raises(ModelError, match="not a pdmkit model file"):
        load_model(other)


def test_unsafe_attributes_are_refused_at_save(tmp_path):
    from pdmkit.rul import ResidualSimilarityModel

    model = ResidualSimilarityModel()
    model.hook_ = print
    with pytest.raises(ModelError, match=r"ResidualSimilarityModel\['hook_'\]"):
        save_model(model, tmp_path / "m.pdmkit")
    assert not (tmp_path / "m.pdmkit").exists()


def test_a_model_saved_before_its_module_was_split_still_loads(tmp_path):
    """Issue 16 moved classes between private modules; older files name the old place."""
    from pdmkit.rul import GammaProcessDegradationModel

    rng = np.random.default_rng(0)
    t = np.arange(30.0)
    hi = [0.05 * t + 0.01 * rng.random(30).cumsum() for _ in range(3)]
    table = pd.DataFrame(
        {"unit": np.repeat([1, 2, 3], 30), "time": np.tile(t, 3), "hi": np.concatenate(hi)}
    )
    model = GammaProcessDegradationModel(threshold=1.5).fit(table)
    path = save_model(model, tmp_path / "new.pdmkit")
    # the same file as the release before the split wrote it: the old class path, and
    # the manifest's checksums of that content
    old = tmp_path / "old.pdmkit"
    with zipfile.ZipFile(path) as src:
        members = {name: src.read(name) for name in src.namelist()}
    members["state.json"] = members["state.json"].replace(
        b"pdmkit.rul._gamma.", b"pdmkit.rul._wiener."
    )
    manifest = json.loads(members["manifest.json"])
    manifest["class"] = manifest["class"].replace("rul._gamma.", "rul._wiener.")
    manifest["sha256"]["state.json"] = hashlib.sha256(members["state.json"]).hexdigest()
    members["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(old, "w") as dst:
        for name, data in members.items():
            dst.writestr(name, data)
    loaded = load_model(old)
    assert type(loaded) is GammaProcessDegradationModel
    assert loaded.predict(table).to_pandas().equals(model.predict(table).to_pandas())
