"""Run `pdmkit mismatch` on every independent case and score the verdicts against the truth.

    .venv/bin/python benchmarks/mismatch_independent/score.py /tmp/indep_cases
    .venv/bin/python benchmarks/mismatch_independent/score.py DIR --only msd_coulomb

One case at a time, each under ``nice -n 10``; wall seconds and CPU seconds (user +
system of the pdmkit process and its children) per case.  Scores: *named right* (the
verdict's effect and target equal the truth's), *controls none* (a control's verdict
is ``none``), *spurious extra* (a single-effect case whose verdict lists more than one
effect, under ``verdict.also``); *truth tied* (the truth is among the verdict's
``alternatives``, the effects pdmkit says these data do not tell apart from its
verdict).  Writes ``DIR/results.csv`` (rows merged by case, so ``--only`` updates
some) and prints a Markdown table with ``--markdown``; ``--rescore`` re-reads the
verdicts already there and keeps the measured times.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import signal
import statistics
import subprocess
import time
from pathlib import Path

PDMKIT = "/work/main/.venv/bin/pdmkit"
FIELDS = [
    "case", "plant", "truth_effect", "truth_target", "impact", "refit_rms_over_noise",
    "verdict_effect", "verdict_target", "also", "alternatives", "named_right",
    "effect_right", "truth_in_alternatives", "control_none", "spurious_extra",
    "rmse_nominal", "rmse_augmented", "rc", "wall_s", "cpu_s", "stderr",
]  # fmt: skip


def run_pdmkit(case_dir, timeout_s):
    """One `pdmkit mismatch` run; returns (rc, wall s, cpu s, stderr text)."""
    out_json = case_dir / "verdict.json"
    out_json.unlink(missing_ok=True)
    cmd = [
        "nice", "-n", "10", PDMKIT, "mismatch", str(case_dir / "model.py"),
        str(case_dir / "est.csv"), "--validation", str(case_dir / "val.csv"),
        "--json", str(out_json), "--out", str(case_dir / "report"), "--quiet",
    ]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,
    )  # fmt: skip
    try:
        stdout, stderr = proc.communicate(timeout=timeout_s)
        rc = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate()
        rc, stderr = -9, stderr + f"\n[score.py] killed after {timeout_s} s"
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return rc, wall, cpu, (stdout + stderr).strip()


def effect_labels(items):
    """``effect@target`` strings from the verdict's ``also`` / ``alternatives`` lists."""
    labels = []
    for item in items or []:
        if isinstance(item, dict):
            labels.append(f"{item.get('effect')}@{item.get('target')}")
        else:
            labels.append(str(item))
    return labels


def score_case(truth, case_dir, rc, verdict_path):
    """The scores of one case from its truth and the verdict JSON (if any)."""
    row = {
        "case": truth["case"],
        "plant": truth["plant"],
        "truth_effect": truth["effect"],
        "truth_target": truth["target"] or "",
        "impact": truth["impact"],
        "refit_rms_over_noise": truth.get("refit_rms_over_noise", ""),
    }
    if rc != 0 or not verdict_path.exists():
        crash = {"verdict_effect": "CRASH", "named_right": False, "effect_right": False,
                 "truth_in_alternatives": False}  # fmt: skip
        return row | crash | {"control_none": "", "spurious_extra": ""}
    summary = json.loads(verdict_path.read_text())
    verdict = summary.get("verdict", {})
    fit = summary.get("fit", {})
    effect, target = verdict.get("effect"), verdict.get("target")
    also = effect_labels(verdict.get("also"))
    alternatives = effect_labels(verdict.get("alternatives"))
    control = truth["effect"] == "none"
    effect_right = effect == truth["effect"]
    return row | {
        "verdict_effect": effect,
        "verdict_target": target or "",
        "also": ";".join(also),
        "alternatives": ";".join(alternatives),
        "named_right": effect_right and (control or target == truth["target"]),
        "effect_right": effect_right,
        "truth_in_alternatives": f"{truth['effect']}@{truth['target']}" in alternatives,
        "control_none": (effect == "none") if control else "",
        "spurious_extra": "" if control else bool(also),
        "rmse_nominal": fit.get("rmse_nominal", ""),
        "rmse_augmented": fit.get("rmse_augmented", ""),
    }


def totals(rows):
    """Summary lines: shares named right, controls none, spurious extras, CPU."""
    single = [r for r in rows if r["truth_effect"] != "none"]
    controls = [r for r in rows if r["truth_effect"] == "none"]
    cpu = [r["cpu_s"] for r in rows]
    crashes = [r["case"] for r in rows if r["rc"] != 0]
    n_none = sum(r["control_none"] is True for r in controls)
    n_alt = sum(r["named_right"] or r["truth_in_alternatives"] is True for r in single)
    n_extra = sum(r["spurious_extra"] is True for r in single)
    return [
        f"named right: {sum(r['named_right'] for r in single)}/{len(single)} "
        f"(effect alone right: {sum(r['effect_right'] for r in single)}/{len(single)})",
        f"named right or the truth among the tied alternatives: {n_alt}/{len(single)}",
        f"controls none: {n_none}/{len(controls)}",
        f"spurious extras: {n_extra}/{len(single)}",
        f"CPU s per case: median {statistics.median(cpu):.1f}, max {max(cpu):.1f}; "
        f"wall s: median {statistics.median(r['wall_s'] for r in rows):.1f}, "
        f"max {max(r['wall_s'] for r in rows):.1f}",
        f"crashes / non-zero exits: {len(crashes)} {crashes}",
    ]


def markdown(rows):
    """The per-case table for the README."""
    head = ("| case | truth | impact | refit/noise | verdict | also | named right | "
            "truth tied | CPU s | wall s |")  # fmt: skip
    lines = [head, "|" + " --- |" * 10]
    for r in rows:
        truth = f"{r['truth_effect']} {r['truth_target']}".strip()
        verdict = f"{r.get('verdict_effect')} {r.get('verdict_target', '')}".strip()
        right = r["named_right"] if r["truth_effect"] != "none" else r["control_none"]
        lines.append(
            f"| {r['case']} | {truth} | {r['impact']} | {r['refit_rms_over_noise']} | "
            f"{verdict} | {r.get('also', '')} | {'yes' if right else 'NO'} | "
            f"{'yes' if r.get('truth_in_alternatives') is True else ''} | "
            f"{r['cpu_s']:.1f} | {r['wall_s']:.1f} |"
        )
    return lines


def load_results(path):
    """Earlier rows of results.csv, keyed by case, with their types restored."""
    if not path.exists():
        return {}
    rows = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            for key, value in row.items():
                if value in ("True", "False"):
                    row[key] = value == "True"
            row |= {"rc": int(row["rc"]), "wall_s": float(row["wall_s"]),
                    "cpu_s": float(row["cpu_s"])}  # fmt: skip
            rows[row["case"]] = row
    return rows


def print_row(row):
    """One line per case."""
    mark = "ok" if (row["named_right"] or row["control_none"] is True) else "MISS"
    print(f"{row['case']:24s} truth {row['truth_effect']}@{row['truth_target']:4s} "
          f"verdict {row.get('verdict_effect')}@{row.get('verdict_target', '')} "
          f"also [{row.get('also', '')}] {mark} rc {row['rc']} wall {row['wall_s']:.0f} s "
          f"cpu {row['cpu_s']:.0f} s", flush=True)  # fmt: skip


def main(argv=None):
    """Command line: run (or re-score), print, write results.csv (merged by case)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases_dir", nargs="?", default="/tmp/indep_cases")
    parser.add_argument("--only", default="", help="comma-separated case ids")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per case")
    parser.add_argument(
        "--rescore", action="store_true", help="score the verdict.json files there, no run"
    )
    parser.add_argument("--markdown", action="store_true")
    args = parser.parse_args(argv)
    root = Path(args.cases_dir)
    only = {c for c in args.only.split(",") if c}
    truths = json.loads((root / "cases.json").read_text())
    earlier = load_results(root / "results.csv")
    print(f"load average at start: {os.getloadavg()}", flush=True)
    rows = {}
    for truth in truths:
        case_dir = root / truth["case"]
        if (only and truth["case"] not in only) or args.rescore:
            if truth["case"] not in earlier:
                continue
            old = earlier[truth["case"]]
            rc, wall, cpu, stderr = old["rc"], old["wall_s"], old["cpu_s"], old["stderr"]
        else:
            rc, wall, cpu, stderr = run_pdmkit(case_dir, args.timeout)
            stderr = stderr[-600:].replace("\n", " | ")
        row = score_case(truth, case_dir, rc, case_dir / "verdict.json")
        row |= {"rc": rc, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
                "stderr": stderr}  # fmt: skip
        rows[truth["case"]] = row
        if not only or truth["case"] in only:
            print_row(row)
            if stderr and not args.rescore:
                print(f"    stderr: {stderr[-400:]}", flush=True)
    print(f"load average at end: {os.getloadavg()}")
    rows = list(rows.values())
    for line in totals(rows):
        print(line)
    with open(root / "results.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    if args.markdown:
        print("\n".join(markdown(rows)))


if __name__ == "__main__":
    main()
