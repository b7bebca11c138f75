"""ResponseData / PneumaticResponse: shapes, export to pandas, plotting."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

from pdmkit.errors import ModelError
from pdmkit.models import PneumaticParams, ResponseData, simulate_piston, stack_params

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def response():
    p = stack_params([PneumaticParams(), PneumaticParams(mass_load=1.25)])
    return simulate_piston(p, t_end=0.5, seed=0)


def test_shapes_and_groups(response) -> None:
    assert response.n_members == 2 and response.n_samples == 500
    assert response.fs == pytest.approx(1000.0)
    np.testing.assert_allclose(response.time, np.arange(500) / 1000.0)
    for group in (response.states, response.outputs, response.inputs, response.signals):
        for value in group.values():
            assert value.shape == (2, 500)
    assert set(np.unique(response.inputs["valve_command"])) == {-1.0, 1.0}
    assert response["LeverPosition"] is response.outputs["LeverPosition"]
    with pytest.raises(KeyError, match="available"):
        response["nope"]


def test_to_pandas_one_member_with_units(response) -> None:
    df = response.to_pandas(member=1)
    assert df.shape == (500, len(response.names()))
    assert df.index.name == "time [s]"
    assert "position [m]" in df.columns and "FlowExtrusion [l/min]" in df.columns
    np.testing.assert_array_equal(
        df["position [m]"].to_numpy(), response.states["position"][1]
    )
    states_only = response.to_pandas(groups=("states",))
    assert states_only.columns[0] == "position [m]"
    with pytest.raises(ModelError, match="out of range"):
        response.to_pandas(member=5)


def test_plot_returns_axes(response) -> None:
    import matplotlib.pyplot as plt

    axes = response.plot(signals=["position", "AirPressure"], member=[0, 1])
    assert axes.shape == (2,) and len(axes[0].lines) == 2
    _, ax = plt.subplots()
    same = response.plot(ax=ax, signals=["pressure_a", "pressure_b"])
    assert all(a is ax for a in same) and len(ax.lines) == 2
    assert len(response.plot()) == 4  # default: a few representative signals
    plt.close("all")


def test_generic_response_validates_shapes() -> None:
    t = np.arange(10) / 10
    r = ResponseData(t, states={"x": np.ones(10)}, outputs={"y": np.zeros((1, 10))})
    assert r.n_members == 1 and "x" in r and "z" not in r
    with pytest.raises(ModelError, match=r"shape \(n_members, 10\)"):
        ResponseData(t, states={"x": np.ones(9)})
    with pytest.raises(ModelError, match="same number of members"):
        ResponseData(t, states={"x": np.ones((2, 10))}, outputs={"y": np.ones((3, 10))})


def test_torch_states_export_without_grad() -> None:
    torch = pytest.importorskip("torch")
    c = torch.tensor(5e-6, dtype=torch.float64, requires_grad=True)
    r = simulate_piston(PneumaticParams(c_a_in=c), t_end=0.05, sensors=False)
    assert r.states["position"].requires_grad
    df = r.to_pandas()
    assert df["position [m]"].dtype == np.float64
