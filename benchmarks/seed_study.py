"""The seed's whole study on the twin: its data set, its recipes, its sensor table.

Simulates the seed's data set as the seed built it
(:func:`pdmkit.ensembles.simulate_seed_ensemble`: 4840 recordings of 242 fault codes,
20 repeats each, grouped into the seed's 20 labels), runs each of the seed's recipes
(:mod:`pdmkit.experiments.thesis`: ``seed_flow_knn``, ``seed_flow_bagged_trees``,
``seed_flow_pca_bagged_trees``, ``seed_residual_classification``,
``seed_sensor_faults``, ``seed_air_leak_rul``) and prints the comparison
"seed's number | pdmkit on the twin | why they differ", then the sensor table of the
seed's table 9.1 with the Spearman rank correlation against the seed's order.

Usage::

    python benchmarks/seed_study.py                 # the full 4840 members (~7-10 min)
    python benchmarks/seed_study.py --members 484 --repeats 2 --leak-runs 5 \
        --json out.json

``--split code`` holds whole fault codes out (settings never seen in training)
instead of the seed's random member split. Peak memory stays at one part of
``--part-size`` members' recordings (about 1.2 MB a member).

Measured (4840 members, seed 0, the seed rig's machine and its recording sessions, the
twin's five cycles; afc3e09, 6 min 23 s wall, 425 s CPU, 2.1 GB at load 1.1): flow kNN
99.72, bagged trees 99.50, PCA + bagged trees 96.94, residual 100, sensor faults 100,
air-leak RUL 8.5 %; table 9.1 Flow 99.72, Encoder 99.04, Mics 87.26, Strain 93.18, Acc
98.69, Proximity 77.34, Pressure 76.79 (Spearman 0.857, 7 of 7 within 10 points; over
the holdouts ``seed_sensor_table(table, seed=0..4)``: rho 0.714-0.857, 7 of 7 in all).
The same recipes on the rig's own feature tables (the author's
``sb/sensor_*/*Features*.mat``) give Flow 97.25, Encoder 95.11, Mics 90.43, Strain 92.29,
Acc 94.42 (Z axes), Proximity 86.29, Pressure 77.75: Spearman 0.857 against table 9.1,
every sensor within 6 points. ``--test-cycle seed_rig`` (the rig's one 5 s stroke, full
size) gave Mics 75.8 and Pressure 65.4 (rho 0.571): the twin's one down stroke carries
too little of the faults (docs/seed_study.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import pandas as pd


def _explain_table_9_1(sensors, rho: float, within: int) -> None:
    """Where the table 9.1 line is missed: by how much, and the measurement why."""
    if rho >= 0.7 and within == len(sensors):
        return
    far = sensors[sensors["difference"].abs() > 10]
    gaps = ", ".join(
        f"{r.sensor} {r.difference:+.1f} (band 10, rig's own tables {r.rig_tables:.1f})"
        for r in far.itertuples()
    )
    missed = [f"rho short by {0.7 - rho:.3f}"] if rho < 0.7 else []
    missed += [f"outside the band: {gaps}"] if gaps else []
    print("table 9.1 line missed: " + "; ".join(missed))
    print(
        "why: the same recipes on the rig's own feature tables (rig_tables, the "
        "author's sb/sensor_*/*Features*.mat) give rho "
        f"{sensors.attrs['rig_tables_rho']:.3f} against table 9.1, every sensor within "
        "6 points: the gap is the twin's. Its valve program is five 1 s strokes where "
        "the rig's is one 5 s stroke (with the rig's, the twin's one down stroke "
        "carries too little of the faults for the microphones and the pressure "
        "transmitter), and in 1 s strokes its upper proximity switch stays off in 70 % "
        "of the recordings (the rig's: 26 %), which MATLAB's trees classify unlike the "
        "rig's (docs/seed_study.md)"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--members", type=int, default=4840)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--variation", choices=("rig", "code", "member"), default="rig")
    parser.add_argument(
        "--jitter", type=float, default=None, help="run-to-run spread (default 0.02)"
    )
    parser.add_argument("--split", choices=("seed", "code"), default="seed")
    parser.add_argument("--part-size", type=int, default=242)
    parser.add_argument("--leak-runs", type=int, default=25, help="0 skips the RUL")
    parser.add_argument("--leak-max-cycles", type=int, default=200)
    parser.add_argument("--sensor-fault-members", type=int, default=150)
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--test-cycle",
        choices=("twin", "seed_rig"),
        default="twin",
        help="valve program: the twin's five 2 s cycles or the rig's one (up 1-6 s)",
    )
    parser.add_argument(
        "--rig",
        choices=("seed", "twin"),
        default="seed",
        help="machine: the seed rig's identified one (params.m) or the generic twin",
    )
    parser.add_argument("--json", help="write the results to this JSON file")
    parser.add_argument("--table", help="write the indicator table to this parquet file")
    args = parser.parse_args(argv)

    from pdmkit._outputs import to_jsonable
    from pdmkit.experiments.thesis import run_seed_study

    started = time.perf_counter()
    out = run_seed_study(
        args.members,
        repeats=args.repeats,
        variation=args.variation,
        jitter=args.jitter,
        part_size=args.part_size,
        leak_runs=args.leak_runs,
        leak_max_cycles=args.leak_max_cycles,
        sensor_fault_members=args.sensor_fault_members,
        t_end=args.t_end,
        split=args.split,
        seed=args.seed,
        test_cycle=args.test_cycle,
        rig=args.rig,
    )
    wall = time.perf_counter() - started
    pd.set_option("display.width", 200)
    pd.set_option("display.max_colwidth", 90)
    print(
        f"\nseed study: {args.members} members, {args.repeats} repeats per fault code, "
        f"variation per {args.variation}, split {args.split}, seed {args.seed}, "
        f"machine {args.rig}"
    )
    print("\nseed's number | pdmkit on the twin | why they differ")
    print(out["comparison"].to_string(index=False))
    sensors = out["sensors"]
    print("\nsensors (seed table 9.1)")
    columns = ["sensor", "seed", "rig_tables", "pdmkit", "difference", "model"]
    print(sensors[columns].to_string(index=False))
    rho = sensors.attrs["spearman_rho"]
    within = int((sensors["difference"].abs() <= 10).sum())
    print(
        f"Spearman rho against the seed's order: {rho:.3f}; "
        f"{within}/{len(sensors)} sensors within 10 points"
    )
    _explain_table_9_1(sensors, rho, within)
    if args.table:
        out["table"].to_parquet(args.table)
        print(f"wrote {args.table}")
    rul = out["results"].get("air_leak_rul")
    if rul is not None:
        d = rul.details
        print(
            f"\nair-leak RUL: deviation {rul.pdmkit:.1f} % (seed about 10 %), test run "
            f"{d['test_run']}; leave-one-out median "
            f"{d['leave_one_out_median_deviation']}, within 10 %: "
            f"{d['leave_one_out_within_10pct']}"
        )
    print(f"\nseconds: {out['seconds']} (wall {wall:.1f})")
    if args.json:
        payload = {
            "settings": out["settings"],
            "results": {k: r.to_dict() for k, r in out["results"].items()},
            "sensors": sensors.to_dict(orient="records"),
            "spearman_rho": rho,
            "seconds": out["seconds"],
            "wall_seconds": round(wall, 1),
        }
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(to_jsonable(payload), fh, indent=2)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
