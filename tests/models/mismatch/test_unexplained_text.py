"""An ``unexplained`` verdict says whether the data-driven stage ran and found nothing.

Found on the rig with both flow meters as outputs: the stage ran (16 s) and returned no
equation, yet the verdict said it "did not run". Here a concealed Coulomb friction is
offered only a sensor offset (which cannot explain it), with and without the
data-driven stage; with it, the stage is made to find nothing.
"""

import pdmkit.models.mismatch._discover as discover_module
from pdmkit.models.mismatch._cases import generate_concealed_case
from pdmkit.models.mismatch._discover import discover_mismatch


def _case():
    return generate_concealed_case("coulomb_friction", 0.4, seed=1, n_samples=600)


def test_stage_skipped_is_said_so():
    case = _case()
    res = discover_mismatch(case.model, case.data, effects=["sensor_offset"], pairs=False)
    assert res.verdict["effect"] == "unexplained"
    assert "that stage did not run" in res.verdict["physics"]


def test_stage_that_ran_and_found_nothing_is_not_said_to_have_skipped(monkeypatch):
    case = _case()
    calls = []

    def nothing(*args, **kwargs):
        calls.append(1)
        return []

    monkeypatch.setattr(discover_module, "fit_sparse", nothing)
    res = discover_mismatch(
        case.model, case.data, effects=["sensor_offset", "sparse"], pairs=False
    )
    assert calls, "the data-driven stage was not reached"
    assert res.verdict["effect"] == "unexplained"
    assert "did not run" not in res.verdict["physics"]
    assert "found no equation" in res.verdict["physics"]
