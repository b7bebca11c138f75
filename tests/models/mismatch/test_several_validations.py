"""Several validation recordings scored together (issue 29, item 4).

Each validation recording starts from its own fitted state; together they give one
RMSE and one significance test. The pooled RMSE must be exactly the sample-weighted
mean square of the RMSEs each recording gives alone (the nominal fit does not depend
on the validation data), which a join that let one recording run into the next would
break: the second recording's state at its start would be the first one's end.
"""

import json
import math

import numpy as np
import pytest

from pdmkit.errors import ModelError
from pdmkit.experiments._cli import main
from pdmkit.models.mismatch import discover_mismatch, join_recordings, make_recording
from pdmkit.models.mismatch._cases import generate_concealed_case
from pdmkit.models.mismatch._recording import segments


@pytest.fixture(scope="module")
def thirds():
    case = generate_concealed_case("sensor_offset", 0.3, seed=4, target="x", n_samples=900)
    d = case.data
    k = len(d) // 3
    parts = [d.iloc[i * k : (i + 1) * k].reset_index(drop=True) for i in range(3)]
    return case, parts


def test_pooled_validation_rmse_is_the_mean_square_of_each(thirds, tmp_path):
    case, parts = thirds
    files = [tmp_path / f"part{i}.csv" for i in range(3)]
    for f, p in zip(files, parts, strict=True):
        p.to_csv(f, index=False)
    # both validation recordings through the command line (its plumbing is the point)
    code = main(
        [
            "mismatch", str(case.write(tmp_path)["model"]), str(files[0]),
            "--validation", str(files[1]), str(files[2]),
            "--effects", "sensor_offset", "--out", str(tmp_path / "out"),
            "--json", str(tmp_path / "m.json"),
        ]
    )  # fmt: skip
    assert code == 0
    both = json.loads((tmp_path / "m.json").read_text())
    assert both["fit"]["validation"] == "2 separate recordings"
    assert both["sources"]["validation"] == [str(files[1]), str(files[2])]
    alone = [
        discover_mismatch(
            case.model, parts[0], v, effects=["sensor_offset"], progress=False
        )
        for v in parts[1:]
    ]
    assert alone[0].fit["validation"] == "separate recording"
    n_b, n_c = len(parts[1]), len(parts[2])
    for key in ("rmse_nominal", "rmse_augmented"):
        pooled = math.sqrt(
            (n_b * alone[0].fit[key] ** 2 + n_c * alone[1].fit[key] ** 2) / (n_b + n_c)
        )
        assert both["fit"][key] == pytest.approx(pooled, rel=1e-3), key
    # one output: its RMSE in its own units is the overall one
    by_output = both["fit"]["rmse_by_output"]["x"]
    assert by_output["nominal"] == pytest.approx(both["fit"]["rmse_nominal"], rel=1e-9)
    assert by_output["augmented"] == pytest.approx(both["fit"]["rmse_augmented"], rel=1e-9)
    # the concealed offset is found on both, at the generator's value
    assert both["verdict"]["effect"] == "sensor_offset"
    offset = both["verdict"]["params"]["offset"]
    assert offset == pytest.approx(case.params["offset"], rel=0.05)


def test_join_keeps_each_recordings_start(thirds):
    case, (a, b, _) = thirds
    ra, rb = make_recording(case.model, a, "a"), make_recording(case.model, b, "b")
    joined = join_recordings([ra, rb])
    assert joined.starts == (0, ra.n)
    assert np.allclose(np.diff(joined.time), ra.ts)
    back = segments(joined)
    assert [s.n for s in back] == [ra.n, rb.n]
    np.testing.assert_array_equal(back[1].outputs["x"], rb.outputs["x"])
    assert back[1].t_origin == joined.time[ra.n]


def test_validation_at_another_step_is_refused_by_name(thirds):
    case, (a, b, c) = thirds
    coarse = c.iloc[::2].reset_index(drop=True)
    with pytest.raises(ModelError, match=r"val\[1\] is sampled every"):
        discover_mismatch(case.model, a, [b, coarse], validation_name=["val[0]", "val[1]"])
    with pytest.raises(ModelError, match="2 validation recordings but 1 names"):
        discover_mismatch(case.model, a, [b, c], validation_name=["only"])
