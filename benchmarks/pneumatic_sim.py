"""Batched fixed-step piston simulator vs scipy solve_ivp (LSODA) on the same piston_rhs.

One run measures both: ``simulate_piston`` steps ``--members`` members (varied fault
settings
of seed table 3.2) over ``--t-end`` seconds at once; ``solve_ivp`` (LSODA, rtol 1e-6,
tight atol, restarted at each valve switch) integrates ``--reference`` of those members
one at a time on ``pdmkit.models.piston_rhs``. Reported: the per-member speed ratio
(LSODA seconds per member / batched seconds per member) and the largest position error
of the batched result against LSODA on the reference members.

Usage::

    .venv/bin/python benchmarks/pneumatic_sim.py [--members 256] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from pdmkit.models import (
    PneumaticParams,
    simulate_piston,
    simulate_piston_ivp,
    stack_params,
)


def fault_members(n: int, seed: int = 0) -> list[PneumaticParams]:
    """Member 0 healthy; the others draw table-3.2 settings and leaks at random."""
    rng = np.random.default_rng(seed)
    base = PneumaticParams()
    members = [base]
    for _ in range(n - 1):
        members.append(
            base.replace(
                throttle_a=float(rng.choice([1.0, 3.0, 5.0, 8.0, 10.0])),
                throttle_b=float(rng.choice([1.0, 3.0, 5.0, 8.0, 10.0])),
                damper_upper=float(rng.integers(1, 11)),
                damper_bottom=float(rng.integers(1, 11)),
                mass_load=float(rng.choice([0.0, 1.25, 5.0, 6.25])),
                p_supply=float(rng.choice([5e5, 6e5])) + 101325.0,
                c_leak_b=float(10 ** rng.uniform(-10, -6)),
            )
        )
    return members


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=256)
    ap.add_argument(
        "--reference",
        type=int,
        default=3,
        help="members integrated with solve_ivp (LSODA) one by one",
    )
    ap.add_argument("--t-end", type=float, default=10.0)
    ap.add_argument(
        "--dt", type=float, default=None, help="fixed step (default: simulate's)"
    )
    ap.add_argument("--json", type=str, default=None, help="write the results here")
    args = ap.parse_args(argv)

    members = fault_members(args.members)
    params = stack_params(members)
    kw = {} if args.dt is None else {"dt": args.dt}
    simulate_piston(
        members[0], t_end=0.05, sensors=False, **kw
    )  # warm up imports and caches

    t0, c0 = time.perf_counter(), time.process_time()
    batched = simulate_piston(params, t_end=args.t_end, sensors=False, **kw)
    t_batch, c_batch = time.perf_counter() - t0, time.process_time() - c0

    ref_ids = list(range(min(args.reference, args.members)))
    errors, t_ref, c_ref = [], 0.0, 0.0
    for i in ref_ids:
        t0, c0 = time.perf_counter(), time.process_time()
        ref = simulate_piston_ivp(members[i], t_end=args.t_end, method="LSODA", rtol=1e-6)
        t_ref += time.perf_counter() - t0
        c_ref += time.process_time() - c0
        err = np.abs(batched.states["position"][i] - ref.states["position"][0]).max()
        errors.append(float(err))

    per_member_batched = t_batch / args.members
    per_member_lsoda = t_ref / len(ref_ids)
    result = {
        "speed_ratio": per_member_lsoda / per_member_batched,
        "speed_ratio_cpu_time": (c_ref / len(ref_ids)) / (c_batch / args.members),
        "max_position_error_m": max(errors),
        "position_error_m_per_reference_member": errors,
        "n_members": args.members,
        "t_end_s": args.t_end,
        "dt_s": args.dt if args.dt is not None else 2e-4,
        "batched_seconds": t_batch,
        "batched_cpu_seconds": c_batch,
        "batched_seconds_per_member": per_member_batched,
        "lsoda_seconds_per_member": per_member_lsoda,
        "lsoda_cpu_seconds_per_member": c_ref / len(ref_ids),
        "n_reference_members": len(ref_ids),
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "python": platform.python_version(),
    }
    print(
        f"batched simulate_piston : {args.members} members x {args.t_end:g} s "
        f"in {t_batch:.2f} s "
        f"({per_member_batched * 1e3:.1f} ms per member)"
    )
    print(
        f"solve_ivp LSODA  : {per_member_lsoda:.2f} s per member "
        f"(mean of {len(ref_ids)} members)"
    )
    print(
        f"speed ratio      : {result['speed_ratio']:.0f}x per member, wall clock "
        f"({result['speed_ratio_cpu_time']:.0f}x in CPU time; target >= 50x)"
    )
    print(
        f"max position error vs LSODA: {result['max_position_error_m'] * 1e3:.3f} mm "
        "(target < 0.5 mm)"
    )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
    return result


if __name__ == "__main__":
    main()
