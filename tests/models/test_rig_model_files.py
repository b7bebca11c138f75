"""The source rig's model file in both styles (examples/pneumatic_rig, written from the
thesis's chapter 4 by an engineer who did not read pdmkit's code): the thesis style
(math, if/elif, max/min) evaluated per sample and the numpy style batched give the same
simulation (issue 29's first "Done when" line)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pdmkit.models.ode import load_model_file, simulate_ode

RIG = Path(__file__).resolve().parents[2] / "examples" / "pneumatic_rig"


def _program(t):
    work = ((t >= 0.05) & (t < 1.0)).astype(float)  # up stroke, then down
    return {"outValveHP": 1.0 - work, "outValveWP": work}


def test_thesis_and_numpy_styles_simulate_the_same():
    thesis = load_model_file(RIG / "model_thesis.py")
    batched = load_model_file(RIG / "model_numpy.py")
    assert thesis.evaluation == "per-sample" and batched.evaluation == "batched"
    assert thesis.outputs == batched.outputs
    t = np.arange(0.0, 1.2, 2e-3)
    a = simulate_ode(thesis, t, _program(t), n_sub=2)
    b = simulate_ode(batched, t, _program(t), n_sub=2)
    for o in batched.outputs:
        np.testing.assert_allclose(a.outputs[o], b.outputs[o], rtol=1e-9, atol=1e-9)
    x = b.outputs["LeverPosition"][0]
    assert x.max() > 0.01  # the lever moved: the valve program drives it
    assert b.outputs["FlowExtrusion"][0].max() > 1.0  # l/min into chamber A


@pytest.mark.parametrize("name", ["model_thesis.py", "model_numpy.py"])
def test_rig_model_reads_its_position_state(name):
    m = load_model_file(RIG / name)
    assert m.output_states()["LeverPosition"][:2] == ("x", 1.0)
