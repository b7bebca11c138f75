"""Air-leak run-to-failure units of the pneumatic piston (Voronin, 8.1-8.2 and 8.4).

:func:`simulate_leak_runs`: units whose chamber air-leak coefficient grows along
unit-specific random paths, or along the seed author's schedule.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.ensembles._pneumatic_faults import (
    _P_AMBIENT,
    PNEUMATIC_FAULTS,
    _fault_settings,
    _operating_conditions,
    _signal_list,
    _simulate_batches,
)
from pdmkit.errors import DataError

__all__ = ["simulate_leak_runs"]


def _leak_path(rng, max_cycles, leak_start, leak_failure, shape) -> np.ndarray:
    """One unit's ``C_al`` per cycle, from ``leak_start`` to the failing cycle.

    The failing cycle is the first whose value is at or above ``leak_failure``.

    ``log C_al`` drifts to the threshold in about ``target`` cycles (drawn uniformly in
    ``[0.4 max_cycles, max_cycles]``) with gamma-distributed steps of shape ``shape``:
    a monotone random walk.
    """
    log_start, log_fail = np.log(leak_start), np.log(leak_failure)
    target = int(rng.integers(int(0.4 * max_cycles), max_cycles + 1))
    steps = rng.gamma(shape, 1.0 / shape, size=4 * target) * (log_fail - log_start) / target
    path = log_start + np.concatenate([[0.0], np.cumsum(steps)])
    end = int(np.flatnonzero(path >= log_fail)[0])
    return np.exp(path[: end + 1])


def _seed_leak_path(rng, max_cycles: int) -> np.ndarray:
    """One unit's ``C_al`` per cycle on the seed author's schedule (``mb/rul.mlx``)."""
    n = int(max_cycles / 2 + rng.uniform() * max_cycles / 2)
    base = np.linspace(1e-5, (1.0 + rng.uniform()) * 1e-3, max(n, 3))
    c_leak = base**2 + rng.uniform() * base**3
    return c_leak * (1.0 + (1.0 + 7.0 * rng.uniform(size=len(c_leak))) * 0.01)


def _check_leak_arguments(
    chamber, leak_start, leak_failure, max_cycles, walk_shape, schedule, leak_scale
) -> None:
    """Raise on an argument of :func:`simulate_leak_runs` out of its range."""
    if chamber not in ("a", "b"):
        raise ValueError(f"chamber must be 'a' or 'b'; got {chamber!r}")
    if not 0 < leak_start < leak_failure:
        raise ValueError(
            f"need 0 < leak_start < leak_failure; got {leak_start!r}, {leak_failure!r}"
        )
    if max_cycles < 3:
        raise ValueError(f"max_cycles must be >= 3; got {max_cycles!r}")
    if not (
        isinstance(walk_shape, int | float | np.integer | np.floating)
        and not isinstance(walk_shape, bool)
        and 0 < walk_shape < np.inf
    ):
        raise ValueError(
            f"walk_shape must be a positive finite number (16 by default); got "
            f"{walk_shape!r}"
        )
    if schedule not in ("walk", "seed"):
        raise DataError(f"schedule must be 'walk' or 'seed'; got {schedule!r}")
    if (
        isinstance(leak_scale, bool)
        or not isinstance(leak_scale, int | float | np.integer | np.floating)
        or not 0 < leak_scale < np.inf
    ):
        raise DataError(f"leak_scale must be a positive finite number; got {leak_scale!r}")


def simulate_leak_runs(
    n_units: int = 10,
    *,
    max_cycles: int = 60,
    leak_start: float = 1e-10,
    leak_failure: float = 1e-6,
    chamber: str = "b",
    t_end: float = 10.0,
    fs: float = 1000.0,
    signals: Sequence[str] | None = ("LeverPosition", "FlowExtrusion", "AirPressure"),
    seed: int = 0,
    batch_size: int = 500,
    walk_shape: float = 16.0,
    schedule: str = "walk",
    operating_point: tuple[float, float] | None = None,
    unit_variation: bool = True,
    leak_scale: float = 1.0,
) -> Ensemble:
    """Simulate air-leak run-to-failure units (seed sections 8.1-8.2 and 8.4).

    Each unit is a sequence of recordings ("cycles"). Its leak coefficient ``C_al``
    grows log-linearly from ``leak_start`` with a unit-specific rate and a random walk
    around it, and the unit fails at the first cycle whose ``C_al`` reaches
    ``leak_failure``. Units get random operating points and parameter variation like
    :func:`simulate_fault_ensemble`, held fixed over their life.

    The walk: each cycle adds a gamma-distributed step to ``log C_al`` (shape
    ``walk_shape``, mean ``(log leak_failure - log leak_start) / target`` for a
    unit-specific ``target`` life), so the path is monotone and a step's coefficient of
    variation is ``1 / sqrt(walk_shape)`` (0.25 by default). The walk alone makes the
    remaining life uncertain: with ``n`` cycles left its standard deviation is about
    ``sqrt(n / walk_shape)`` cycles, even for a predictor that knows the unit's rate.

    Why 16: the seed (section 8.4.1) gives each of its 25 runs its own "dynamics of
    coefficient C development" over (1e-10, 1e-6) and no cycle-to-cycle randomness,
    and its linear degradation model lands "about 10 %" from the true RUL. The default
    keeps a random walk (units with the same rate still fail at different cycles) but
    one smooth enough that a unit's own history can tell its rate, as in the seed's
    runs: with 20 cycles left the walk spreads the life by about 1.1 cycles. Shape 4
    (step CV 0.5) is the rough stress case: there even a predictor told each unit's
    rate keeps every last-half prediction within 10 % of the life for only 89 % of
    units, and one that must learn the rate for about 74 % (docs/rul.md).

    Parameters
    ----------
    n_units : int, default 10
    max_cycles : int, default 60
        Typical longest life: each unit's leak rate is drawn so that its expected
        life falls between 40 % and 100 % of this (the random walk spreads it).
    leak_start, leak_failure : float, m^2
        ``C_al`` of a new unit and the failure threshold.
    chamber : {"a", "b"}
        The leaking chamber (seed figure 8.8 shows chamber B).
    t_end, fs, signals, seed, batch_size
        As :func:`simulate_fault_ensemble`.
    walk_shape : float, default 16.0
        Shape of the gamma-distributed steps of ``log C_al``; larger is smoother
        (``inf`` is not allowed; 1e6 is practically a straight line; 4 is rough).
    schedule : {"walk", "seed"}, default "walk"
        ``"walk"``: the random walk above. ``"seed"``: the seed author's own schedule
        (``mb/rul.mlx`` of github.com/xvoron/thesis): ``L = linspace(1e-5, b 1e-3, n)``
        with ``b ~ U(1, 2)`` and ``n ~ U(max_cycles / 2, max_cycles)`` cycles (100..200
        in the seed: pass ``max_cycles=200``), ``C_al = L**2 + r L**3`` with
        ``r ~ U(0, 1)``, and each cycle's ``C_al`` raised by a random 1..8 %; it runs
        from 1e-10 to 1..4e-6 m^2 and the unit's last cycle is its last simulated one
        (the seed defines failure by an indicator threshold, not by ``C_al``);
        ``leak_start``, ``leak_failure`` and ``walk_shape`` are not used.
    operating_point : (load_kg, supply_bar), optional
        Every unit at this load and supply (bar gauge) instead of random ones (the
        seed simulated its runs at one operating point).
    unit_variation : bool, default True
        Draw each unit's unlabelled parameters (friction, valve coefficients, valve
        delay) and healthy knob settings at random, as :func:`simulate_fault_ensemble`
        does. False: every unit is the nominal healthy twin (the
        :class:`~pdmkit.models.PneumaticParams` defaults, knobs at the middle of their
        healthy range) and only its leak differs, as in the seed author's 26 runs, all
        simulated from one parameter file (``mb/rul.mlx``; its figure 8.9 shows every
        run starting at the same indicator value).
    leak_scale : float, default 1.0
        Factor applied to the leak coefficient path before simulating: a schedule
        written for another model's valve sizes (the seed's ``C_al`` is relative to its
        identified valve coefficients) is carried over to the twin's.

    Returns
    -------
    Ensemble
        Members ``"u03/c0012"``; conditions ``unit``, ``cycle`` (0, 1, ...), ``c_leak``
        (m^2, the coefficient simulated), ``c_leak_schedule`` (the schedule's value,
        ``c_leak / leak_scale``), ``rul`` (cycles left until failure; 0 at the failing
        cycle) and ``failed`` (True at the last cycle of each unit).

    Examples
    --------
    >>> from pdmkit.ensembles import simulate_leak_runs
    >>> runs = simulate_leak_runs(2, max_cycles=6, t_end=0.5, signals=["AirPressure"])
    >>> runs.conditions.groupby("unit")["rul"].min().tolist()
    [0, 0]
    """
    _check_leak_arguments(
        chamber, leak_start, leak_failure, max_cycles, walk_shape, schedule, leak_scale
    )
    signals = _signal_list(signals)
    rng = np.random.default_rng(seed)
    units, cycles, leaks = [], [], []
    for u in range(int(n_units)):
        if schedule == "seed":
            path = _seed_leak_path(rng, int(max_cycles))
        else:
            path = _leak_path(rng, max_cycles, leak_start, leak_failure, float(walk_shape))
        units += [u] * len(path)
        cycles += list(range(len(path)))
        leaks += list(path)
    n = len(units)
    units_arr = np.asarray(units)
    per_unit = _operating_conditions(int(n_units), rng)
    if operating_point is not None:
        load_kg, supply_bar = (float(v) for v in operating_point)
        per_unit["mass_load"] = np.full(int(n_units), load_kg)
        per_unit["p_supply"] = np.full(int(n_units), _P_AMBIENT + supply_bar * 1e5)
    knobs = _fault_settings(np.array(["healthy"] * int(n_units)), rng)
    if not unit_variation:  # the nominal healthy twin, only the leak differs
        from pdmkit.models import PneumaticParams

        nominal = PneumaticParams()
        for k in per_unit:
            if k not in ("mass_load", "p_supply"):
                per_unit[k] = np.full(int(n_units), float(getattr(nominal, k)))
        healthy = {
            s.parameter: float(np.mean(s.healthy)) for s in PNEUMATIC_FAULTS.values()
        }
        knobs = {k: np.full(int(n_units), healthy[k]) for k in knobs}
    cols = {k: v[units_arr] for k, v in per_unit.items()}
    cols.update(knobs)
    for k in (
        "throttle_a",
        "throttle_b",
        "damper_upper",
        "damper_bottom",
        "damper_large_damping",
    ):
        cols[k] = cols[k][units_arr]
    cols[f"c_leak_{chamber}"] = np.asarray(leaks) * float(leak_scale)
    data = _simulate_batches(
        cols,
        n,
        t_end=t_end,
        fs=fs,
        signals=signals,
        seed=seed,
        batch_size=batch_size,
        desc="simulating leak runs",
    )
    cycles_arr = np.asarray(cycles)
    last = pd.Series(cycles_arr).groupby(units_arr).transform("max").to_numpy()
    conditions = pd.DataFrame(
        {
            "unit": units_arr,
            "cycle": cycles_arr,
            "c_leak": cols[f"c_leak_{chamber}"],
            "c_leak_schedule": np.asarray(leaks),
            "rul": last - cycles_arr,
            "failed": cycles_arr == last,
            "load_kg": cols["mass_load"],
            "supply_bar": (cols["p_supply"] - _P_AMBIENT) / 1e5,
        }
    )
    ids = [f"u{u:02d}/c{c:04d}" for u, c in zip(units_arr, cycles_arr, strict=True)]
    return Ensemble(data, fs=fs, conditions=conditions, member_ids=ids)
