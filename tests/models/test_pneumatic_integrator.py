"""The batched fixed-step integrator against scipy's solve_ivp on the same piston_rhs."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pdmkit.errors import ModelError
from pdmkit.models import (
    STATE_NAMES,
    PneumaticParams,
    initial_state,
    piston_rhs,
    simulate_piston,
    stack_params,
)


def lsoda_reference(p: PneumaticParams, t_end: float, fs: float = 1000.0) -> np.ndarray:
    """solve_ivp(LSODA) on ``piston_rhs``, restarted at each jump of the valve command."""
    t_eval = np.arange(round(t_end * fs)) / fs
    first = p.cycle_start + p.valve_delay
    jumps = [
        first + k * p.cycle_period / 2 for k in range(int(t_end / p.cycle_period * 2) + 1)
    ]
    edges = [0.0, *[j for j in jumps if j < t_eval[-1]], t_eval[-1]]
    y = np.asarray(initial_state(p), dtype=float)
    out = np.empty((len(STATE_NAMES), t_eval.size))
    out[:, 0] = y
    atol = [1e-9, 1e-7, 1e-3, 1e-3, 1e-3, 1e-9]
    for a, b in itertools.pairwise(edges):
        sel = (t_eval > a) & (t_eval <= b)
        te = t_eval[sel]
        if te.size == 0 or te[-1] < b:
            te = np.append(te, b)
        sol = solve_ivp(
            piston_rhs,
            (a, b),
            y,
            method="LSODA",
            rtol=1e-6,
            atol=atol,
            t_eval=te,
            args=(p,),
        )
        assert sol.success, sol.message
        out[:, sel] = sol.y[:, : sel.sum()]
        y = sol.y[:, -1]
    return out


@pytest.mark.slow
def test_fixed_step_matches_lsoda_over_a_ten_second_recording() -> None:
    p = PneumaticParams()
    ref = lsoda_reference(p, 10.0)
    r = simulate_piston(p, t_end=10.0, sensors=False)
    err = np.abs(r.states["position"][0] - ref[0])
    assert err.max() < 0.5e-3  # metres
    assert np.abs(r.states["pressure_b"][0] - ref[3]).max() < 0.1e5  # Pa
    # the error does not accumulate over the strokes: last cycle no worse than first
    assert err[8000:].max() < 1.5 * err[:2000].max() + 1e-5


@pytest.mark.slow
def test_fixed_step_matches_lsoda_under_fault_settings() -> None:
    # a heavy load (end impacts rebound) and a large leak, over the first up stroke; the
    # 6.75 kg piston hits the top stop at speed and penetrates 1.1 mm, where the fixed
    # step lags LSODA by up to 0.64 mm for a few samples (0.27 mm at dt = 1e-4 s)
    for p, tol in (
        (PneumaticParams(mass_load=6.25), 0.75e-3),
        (PneumaticParams(c_leak_b=1e-6), 0.3e-3),
    ):
        ref = lsoda_reference(p, 1.0)
        x = simulate_piston(p, t_end=1.0, sensors=False).states["position"][0]
        assert np.abs(x - ref[0]).max() < tol


def test_error_shrinks_with_the_step() -> None:
    p = PneumaticParams()
    ref = lsoda_reference(p, 0.5)
    errs = [
        np.abs(
            simulate_piston(p, t_end=0.5, dt=dt, sensors=False).states["position"][0]
            - ref[0]
        ).max()
        for dt in (5e-4, 2e-4, 1e-4)
    ]
    assert errs[0] > errs[1] > errs[2]
    assert errs[0] / errs[2] > 3  # about first order: 5x the step, > 3x the error


def test_batched_members_equal_members_run_one_by_one() -> None:
    members = [
        PneumaticParams(),
        PneumaticParams(mass_load=6.25, throttle_a=2.0),
        PneumaticParams(c_leak_b=1e-6, damper_upper=9.0, p_supply=701325.0),
    ]
    batch = simulate_piston(stack_params(members), t_end=0.7, sensors=False)
    for i, p in enumerate(members):
        single = simulate_piston(p, t_end=0.7, sensors=False)
        for name in STATE_NAMES:
            np.testing.assert_allclose(
                batch.states[name][i], single.states[name][0], rtol=1e-9, atol=1e-12
            )


def test_rhs_batched_equals_rhs_per_member() -> None:
    members = [PneumaticParams(), PneumaticParams(mass_load=5.0, c_leak_a=1e-7)]
    batch = stack_params(members)
    rng = np.random.default_rng(3)
    y = np.asarray(initial_state(batch))
    y[:, 0] = rng.uniform(-1e-4, 0.1601, 2)
    y[:, 1] = rng.normal(0, 0.5, 2)
    y[:, 2:5] *= rng.uniform(0.8, 1.0, (2, 3))
    y[:, 5] = [0.3, -0.7]
    dy = piston_rhs(0.5, y, batch)
    for i, p in enumerate(members):
        np.testing.assert_allclose(dy[i], piston_rhs(0.5, y[i], p), rtol=1e-12)


def test_scalar_params_with_batch_give_identical_physics() -> None:
    r = simulate_piston(PneumaticParams(), t_end=0.3, batch=3, seed=0)
    x = r.states["position"]
    assert x.shape == (3, 300) and np.array_equal(x[0], x[2])
    # sensor noise differs between members
    assert not np.array_equal(r.outputs["FlowExtrusion"][0], r.outputs["FlowExtrusion"][1])


def test_timing_and_batch_are_validated() -> None:
    with pytest.raises(ModelError, match="whole number of steps"):
        simulate_piston(t_end=0.1, fs=1000.0, dt=3e-4)
    with pytest.raises(ModelError, match="batch=3"):
        simulate_piston(
            stack_params([PneumaticParams(), PneumaticParams(mass_load=1.25)]),
            t_end=0.1,
            batch=3,
        )
    with pytest.raises(ModelError, match="unknown sensors"):
        simulate_piston(t_end=0.1, sensors=["LeverPositon"])


def test_divergence_is_reported_not_returned() -> None:
    # a valve coefficient 2000x too large makes the explicit pressure step unstable
    p = PneumaticParams(c_a_in=1e-2, c_throttle_max=1e-2, throttle_a=10.0)
    with pytest.raises(ModelError, match="smaller dt"):
        simulate_piston(p, t_end=0.3, sensors=False)


@pytest.mark.torch
def test_torch_path_matches_numpy_and_has_gradients() -> None:
    torch = pytest.importorskip("torch")
    c = torch.tensor([5e-6, 3e-6], dtype=torch.float64, requires_grad=True)
    p_t = PneumaticParams(c_b_out=c)
    r_t = simulate_piston(p_t, t_end=0.15, sensors=False)
    r_n = simulate_piston(
        PneumaticParams(c_b_out=np.array([5e-6, 3e-6])), t_end=0.15, sensors=False
    )
    for name in STATE_NAMES:
        np.testing.assert_allclose(
            r_t.states[name].detach().numpy(), r_n.states[name], rtol=1e-10, atol=1e-12
        )
    loss = r_t.states["position"].mean(dim=1).sum()
    loss.backward()
    assert torch.all(torch.isfinite(c.grad)) and torch.all(c.grad > 0)
    # central finite difference of the numpy simulation, member 0
    eps = 2e-9
    plus = simulate_piston(PneumaticParams(c_b_out=5e-6 + eps), t_end=0.15, sensors=False)
    minus = simulate_piston(PneumaticParams(c_b_out=5e-6 - eps), t_end=0.15, sensors=False)
    fd = (plus.states["position"].mean() - minus.states["position"].mean()) / (2 * eps)
    assert float(c.grad[0]) == pytest.approx(fd, rel=1e-3)


@pytest.mark.torch
def test_rhs_jacobian_by_autograd_matches_finite_differences() -> None:
    torch = pytest.importorskip("torch")
    p = PneumaticParams()
    y = np.asarray(initial_state(p), dtype=float)
    y[0], y[1], y[2], y[3], y[5] = 0.08, 0.4, 4.0e5, 2.0e5, 1.0  # mid-stroke, valve up
    jac = torch.autograd.functional.jacobian(
        lambda z: piston_rhs(0.5, z, p), torch.tensor(y, dtype=torch.float64)
    ).numpy()
    scale = np.array([1e-7, 1e-6, 1.0, 1.0, 1.0, 1e-6])
    fd = np.empty((6, 6))
    for j in range(6):
        e = np.zeros(6)
        e[j] = scale[j]
        fd[:, j] = (piston_rhs(0.5, y + e, p) - piston_rhs(0.5, y - e, p)) / (2 * scale[j])
    np.testing.assert_allclose(jac, fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())


def test_sub_steps_for_the_members_with_an_event_only_change_nothing(monkeypatch):
    # a batch above _SUBSET_FROM sub-steps only its members with a contact event; the
    # outputs must be bitwise those of the whole batch sub-stepped (the arithmetic of
    # each member is the same)
    import pdmkit.models.pneumatic._integrate as integrate
    from pdmkit.models import PneumaticParams, simulate_piston

    rng = np.random.default_rng(3)
    n = 12
    params = PneumaticParams(
        mass_load=rng.uniform(2, 12, n), damper_upper=rng.uniform(1, 10, n)
    )
    out = {}
    for frm in (10**9, integrate._SUBSET_FROM):
        monkeypatch.setattr(integrate, "_SUBSET_FROM", frm)
        r = simulate_piston(params, t_end=2.5, fs=1000.0, sensors=["LeverPosition"], seed=1)
        out[frm] = np.asarray(r.outputs["LeverPosition"])
    assert np.ptp(out[10**9][:, -1]) > 1e-3  # the members differ: a real batch
    np.testing.assert_array_equal(out[10**9], out[integrate._SUBSET_FROM])
