"""A newcomer's recordings, as they come: every case of issue 15 through the CLI.

Runs ``pdmkit`` on public recordings it was not built around, exactly as a reliability
engineer would type it (no file prepared by hand), and prints one table: case, command,
wall seconds, outcome. The data are the shared recordings (``$PDMKIT_DATA``, default
``../shared/data``); a case whose files are absent is listed as skipped.

Cases: IMS bearing test 2 (a wide table of timestamps and one column per bearing) for
RUL and for prognostic ranking; PRONOSTIA Bearing1_1 (per-snapshot indicators: ranking;
raw snapshots, header-less: condition indicators); the DaISy flexible robot arm and the
F-16 ground vibration test (identification, with the modes the issue names); C-MAPSS
FD001 (boosting, the named dataset) and FD003 histories (whitespace text, header-less)
answered by an FD001 model.

Usage::

    python benchmarks/newcomer.py [--out results/newcomer] [--json newcomer.json]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PDMKIT = [sys.executable, "-m", "pdmkit"]


def _data() -> Path:
    env = os.environ.get("PDMKIT_DATA")
    return Path(env) if env else ROOT.parent / "shared" / "data"


def _modes(text: str) -> list[float]:
    """The modes of identify's summary line (``...; modes 5.181 Hz, 6.637 Hz ...``)."""
    line = next((x for x in text.splitlines() if "; modes " in x), "")
    return [float(v) for v in re.findall(r"([0-9.]+) Hz", line.split("; modes ", 1)[-1])]


def _score_line(text: str) -> str:
    """The RUL workflow's headline (``pdmkit: boosting: RMSE ...``)."""
    line = next((x for x in text.splitlines() if re.match(r"pdmkit: [\w-]+: RMSE", x)), "")
    return line[8:].split("; see ")[0]


def _last_line(text: str) -> str:
    lines = [x for x in text.splitlines() if x.startswith("pdmkit:")]
    return lines[-1][8:200] if lines else ""


def _json_reader(path: Path, what):
    """Read the outcome from a JSON file the command wrote (``what`` picks the words)."""

    def read(text: str) -> str:
        try:
            return what(json.loads(path.read_text()))
        except (OSError, ValueError, KeyError, IndexError):
            return _last_line(text)

    return read


def _top(summary: dict) -> str:
    rows = summary["ranking"][:3]
    return "top: " + ", ".join(f"{r['feature']} ({r['score']:.3f})" for r in rows)


def _ood(text: str) -> str:
    m = re.search(r"(\d+) of (\d+) test units lie outside the training data", text)
    shown = f"{m.group(1)} of {m.group(2)} units flagged out-of-distribution" if m else ""
    n = sum(1 for x in text.splitlines() if x.startswith("unit ") and "RUL" in x)
    return f"{n} units answered; {shown or 'none flagged out-of-distribution'}"


def _within(found: list[float], wanted: list[float], tol: float) -> str:
    hits = []
    for w in wanted:
        best = min(found, key=lambda f: abs(f - w), default=float("nan"))
        ok = abs(best - w) <= tol * w
        hits.append(f"{w:g}->{best:.4g}{'' if ok else ' (miss)'}")
    return ", ".join(hits)


def cases(data: Path, out: Path) -> list[dict]:
    ims = data / "ims_bearing_features" / "merged_dataset_BearingTest_2.csv"
    femto = data / "femto_pronostia_bearing1_1"
    cm = data / "cmapss_fd001"
    model = out / "fd001_raw" / "model.pdmkit"
    return [
        {
            "case": "IMS test 2, RUL (wide table, timestamps)",
            "needs": [ims],
            "args": ["rul", "--train", ims, "--wide", "vibration", "--model", "boosting",
                     "--out", out / "ims_rul"],
            "read": _score_line,
        },
        {
            "case": "IMS test 2, prognostic ranking",
            "needs": [ims],
            "args": ["rank", "--features", ims, "--method", "monotonicity",
                     "--window", "50", "--out", out / "ims_rank"],
            "read": _json_reader(out / "ims_rank" / "summary.json", _top),
        },
        {
            "case": "PRONOSTIA Bearing1_1 indicators, ranking",
            "needs": [femto / "Bearing1_1_acc_features.csv"],
            "args": ["rank", "--features", femto / "Bearing1_1_acc_features.csv",
                     "--method", "monotonicity", "--order", "snapshot", "--window", "50",
                     "--out", out / "femto_rank"],
            "read": _json_reader(out / "femto_rank" / "summary.json", _top),
        },
        {
            "case": "PRONOSTIA raw snapshots (header-less), indicators",
            "needs": [femto / "raw_subset"],
            "args": ["features", "--members", *sorted((femto / "raw_subset").glob("*.csv")),
                     "--fs", "25600", "--signals", "column_4", "column_5",
                     "--out", out / "femto_features"],
            "read": _json_reader(
                out / "femto_features" / "summary.json",
                lambda j: f"{j['n_features']} indicators of {j['n_members']} snapshots",
            ),
        },
        {
            "case": "DaISy robot arm, identify",
            "needs": [data / "daisy" / "robot-arm.csv"],
            "args": ["identify", data / "daisy" / "robot-arm.csv", "--input", "u",
                     "--output", "y", "--fs", "1", "--out", out / "robot_arm"],
            "read": lambda o: "resonances (cycles/sample): "
            + _within(_modes(o), [0.058, 0.126, 0.34], 0.05),
        },
        {
            "case": "F-16 GVT level 1, identify --band 2,15",
            "needs": [data / "f16_gvt" / "F16Data_FullMSine_Level1.mat"],
            "args": ["identify", data / "f16_gvt" / "F16Data_FullMSine_Level1.mat",
                     "--input", "Force", "--output", "Acceleration2", "--band", "2,15",
                     "--out", out / "f16"],
            "read": lambda o: "modes (Hz): "
            + _within(_modes(o), [5.2, 6.6, 7.3, 9.2], 0.03)
            + "; " + (re.search(r"fit [-0-9.]+ %", o) or [""])[0],
        },
        {
            "case": "C-MAPSS FD001, --model boosting",
            "needs": [cm / "train_FD001.txt"],
            "args": ["rul", "--dataset", "cmapss-fd001", "--model", "boosting",
                     "--out", out / "fd001"],
            "read": _score_line,
        },
        {
            "case": "C-MAPSS FD001 raw text, trained",
            "needs": [cm / "train_FD001.txt"],
            "args": ["rul", "--train", cm / "train_FD001.txt", "--unit", "unit_number",
                     "--time", "time", "--time-unit", "cycles", "--model", "boosting",
                     "--out", out / "fd001_raw"],
            "read": _score_line,
        },
        {
            "case": "C-MAPSS FD003 histories on the FD001 model",
            "needs": [cm / "test_FD003.txt"],
            "args": ["rul", "--trained", model, "--history", cm / "test_FD003.txt",
                     "--out", out / "fd003"],
            "read": _ood,
        },
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("results/newcomer"))
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    data = _data()
    rows = []
    print(f"load average at start: {os.getloadavg()[0]:.2f}")
    for case in cases(data, args.out):
        command = [str(a) for a in case["args"]]
        shown = "pdmkit " + " ".join(shlex.quote(c) for c in command)
        shown = re.sub(
            r"(\S*/raw_subset/)\S+\.csv( \S*/raw_subset/\S+\.csv)+", r"\1*.csv", shown
        )
        shown = shown.replace(str(data), "$DATA").replace(str(args.out), "$OUT")
        if not all(Path(p).exists() for p in case["needs"]):
            rows.append({"case": case["case"], "command": shown, "wall_s": None,
                         "outcome": "skipped: data absent"})  # fmt: skip
            continue
        start = time.perf_counter()
        proc = subprocess.run([*PDMKIT, *command], capture_output=True, text=True, cwd=ROOT)
        wall = time.perf_counter() - start
        text = proc.stdout + proc.stderr
        if proc.returncode == 0:
            outcome = case["read"](text)
        else:
            last = [x for x in text.splitlines() if x.strip()][-1:] or ["(no output)"]
            outcome = f"exit {proc.returncode}: {last[0][:200]}"
        rows.append({"case": case["case"], "command": shown, "wall_s": round(wall, 1),
                     "exit": proc.returncode, "outcome": outcome})  # fmt: skip
        print(f"{case['case']}: {wall:.1f} s, exit {proc.returncode}", flush=True)
    print()
    print("| case | command | wall s | outcome |")
    print("|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | `{r['command']}` | {r['wall_s']} | {r['outcome']} |")
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0 if all(r.get("exit", 0) == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
