"""Opening a 4840-member on-disk ensemble in ``pdmkit designer`` (issue 17).

The line: the first plot shows within 3 s of opening the page, and the server stays
within 1 GB of memory.

The ensemble is the seed's full size, simulated by pdmkit's twin
(``simulate_seed_ensemble(4840)``: 242 fault codes x 20 repeats, the seed's 20 labels,
10 s at 1 kHz) with the two flow sensors of the seed's section 7.3 (FlowExtrusion,
FlowContraction), written to Parquet in parts of 250 members
(``write_parquet_batches``): 96.8 M samples, 0.13 GB on disk (built in 199 s). It is
built once into ``--path`` (default results/bench/designer_seed4840) and reused.

Each repeat starts a fresh ``pdmkit designer --ensemble PATH --no-browser`` process,
opens its URL in a fresh headless Chromium (Debian's chromium + chromedriver through
Selenium) and measures

* ``first_plot_s``: from ``driver.get(url)`` until the page has drawn its first plot
  (the signals of one member per label: ``window.designerFirstPlotMs`` is set right
  after Plotly draws it);
* ``server_start_s``: from starting the process until it prints its URL;
* ``server_rss_mb``: the server's resident memory after the plot, and its peak
  (``VmHWM``) at the end, after also computing the stats indicators of all 4840
  members through the page's API (``--features``, streaming in batches).

Prints the medians over ``--repeats`` (default 3), with CPU seconds beside wall
seconds and the load average.

Run: ``.venv/bin/python benchmarks/designer_open.py [--repeats 3] [--features]``
(``--screenshots docs/img``: the docs' screenshots instead of timing)
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SIGNALS = ["FlowExtrusion", "FlowContraction"]
N_MEMBERS = 4840
PART = 250


def build(path: Path) -> None:
    from pdmkit.ensembles import simulate_seed_ensemble, write_parquet_batches

    def parts():
        for start in range(0, N_MEMBERS, PART):
            stop = min(start + PART, N_MEMBERS)
            t = time.perf_counter()
            batch = simulate_seed_ensemble(
                N_MEMBERS, members=slice(start, stop), signals=SIGNALS, batch_size=PART
            )
            print(f"  members {start}-{stop}: {time.perf_counter() - t:.1f} s", flush=True)
            yield batch

    t0, c0 = time.perf_counter(), time.process_time()
    write_parquet_batches(parts(), path)
    size = sum(p.stat().st_size for p in path.iterdir()) / 1e9
    print(
        f"built {path}: {N_MEMBERS} members, {size:.2f} GB, "
        f"{time.perf_counter() - t0:.0f} s wall, {time.process_time() - c0:.0f} s CPU"
    )


def _rss_mb(pid: int, key: str = "VmRSS") -> float:
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024
    return float("nan")


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _driver():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--window-size=1400,1000",
    ):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)


def _features(base: str, token: str) -> float:
    import httpx

    headers = {"x-designer-token": token}
    body = {"signals": SIGNALS, "groups": ["stats"], "options": ""}
    t = time.perf_counter()
    job = httpx.post(f"{base}/api/run/features", json=body, headers=headers).json()
    while job["state"] == "running":
        time.sleep(0.5)
        job = httpx.get(f"{base}/api/job/{job['id']}", headers=headers).json()
    if job["state"] != "done":
        raise SystemExit(f"features failed: {job['error']}")
    return time.perf_counter() - t


def once(path: Path, features: bool) -> dict:
    from selenium.webdriver.support.ui import WebDriverWait

    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pdmkit",
            "designer",
            "--ensemble",
            str(path),
            "--no-browser",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        url = None
        for line in proc.stdout:
            found = re.search(r"open (http://\S+)", line)
            if found:
                url = found.group(1)
                break
        if url is None:
            raise SystemExit("the designer printed no URL")
        started = time.perf_counter() - t0
        driver = _driver()
        try:
            t = time.perf_counter()
            driver.get(url)
            WebDriverWait(driver, 60, poll_frequency=0.02).until(
                lambda d: d.execute_script("return window.designerFirstPlotMs")
            )
            first = time.perf_counter() - t
            traces = driver.execute_script(
                "return document.getElementById('plot-signals').data.length"
            )
        finally:
            driver.quit()
        row = {
            "server_start_s": started,
            "first_plot_s": first,
            "traces": traces,
            "rss_after_plot_mb": _rss_mb(proc.pid),
            "server_cpu_s": _cpu_s(proc.pid),
        }
        if features:
            base, token = url.split("/?")[0], url.split("token=")[1]
            row["features_4840_s"] = _features(base, token)
        row["peak_rss_mb"] = _rss_mb(proc.pid, "VmHWM")
        row["server_cpu_s_end"] = _cpu_s(proc.pid)
        return row
    finally:
        proc.terminate()
        proc.wait(10)


def _wait(driver, condition, timeout: float = 600.0):
    from selenium.webdriver.support.ui import WebDriverWait

    def check(d):
        status = d.find_element("id", "status")
        if "error" in (status.get_attribute("class") or ""):
            raise SystemExit(f"the page shows an error: {status.text}")
        return condition(d)

    return WebDriverWait(driver, timeout, poll_frequency=0.2).until(check)


def _traces(driver, plot_id: str) -> int:
    return driver.execute_script(
        f"const p = document.getElementById('{plot_id}'); return p.data ? p.data.length : 0"
    )


def screenshots(path: Path, folder: Path) -> None:
    """The seed's section 7.3.2 workflow on the twin, one screenshot per step."""
    from selenium.webdriver.support.ui import Select

    folder.mkdir(parents=True, exist_ok=True)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pdmkit",
            "designer",
            "--ensemble",
            str(path),
            "--no-browser",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    driver = _driver()
    driver.set_window_size(1400, 900)
    try:
        url = next(
            m.group(1) for line in proc.stdout if (m := re.search(r"open (\S+)", line))
        )
        driver.get(url)
        _wait(driver, lambda d: d.execute_script("return window.designerFirstPlotMs"))
        pick = lambda el, v: Select(driver.find_element("id", el)).select_by_value(v)  # noqa: E731
        pick("plot-signal", "FlowContraction")
        pick("plot-by", "seed_label")
        time.sleep(1.5)
        driver.save_screenshot(str(folder / "designer_1_signals.png"))
        pick("plot-kind", "spectrum")
        _wait(driver, lambda d: "PSD" in d.find_element("id", "plot-signals").text)
        time.sleep(1.0)
        driver.save_screenshot(str(folder / "designer_2_spectra.png"))
        driver.find_element("id", "tab-indicators").click()
        pick("label", "seed_label")
        time.sleep(0.5)
        t = time.perf_counter()
        driver.find_element("id", "compute").click()
        _wait(
            driver, lambda d: "indicators" in d.find_element("id", "features-message").text
        )
        print(f"indicators of {N_MEMBERS} members: {time.perf_counter() - t:.1f} s")
        pick("hist-feature", "FlowContraction/spectral/PeakAmp1")
        pick("scatter-x", "FlowContraction/spectral/PeakAmp1")
        pick("scatter-y", "FlowContraction/stats/CrestFactor")
        time.sleep(2.0)
        driver.save_screenshot(str(folder / "designer_3_indicators.png"))
        driver.find_element("id", "tab-train").click()
        driver.find_element("id", "rank").click()
        _wait(driver, lambda d: _traces(d, "plot-rank") == 1)
        pick("selection", "anova")
        pick("model", "knn")
        driver.find_element("id", "train").click()
        _wait(driver, lambda d: d.find_elements("id", "accuracy"))
        print("page:", driver.find_element("id", "train-result").text)
        time.sleep(1.0)
        driver.save_screenshot(str(folder / "designer_4_rank_train.png"))
        driver.execute_script("document.getElementById('train-result').scrollIntoView()")
        time.sleep(0.5)
        driver.save_screenshot(str(folder / "designer_5_confusion.png"))
        driver.execute_script("window.scrollTo(0, 0)")
        driver.find_element("id", "tab-export").click()
        _wait(driver, lambda d: "classify(" in d.find_element("id", "script").text)
        time.sleep(0.5)
        driver.save_screenshot(str(folder / "designer_6_export.png"))
        script = driver.execute_script(
            "return document.getElementById('script').textContent"
        )
        exported = Path(tempfile.gettempdir()) / "designer_twin_pipeline.py"
        exported.write_text(script)  # not under the repository: it is no module of it
        print(f"exported script: {exported}")
    finally:
        driver.quit()
        proc.terminate()
        proc.wait(10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--path", type=Path, default=Path("results/bench/designer_seed4840")
    )
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--features", action="store_true", help="also compute stats of all members"
    )
    parser.add_argument(
        "--screenshots",
        type=Path,
        metavar="DIR",
        help="instead of timing: walk the seed's section 7.3.2 through the page and save "
        "a screenshot of each step into DIR (docs/img)",
    )
    args = parser.parse_args()
    if not (args.path / "_pdmkit_ensemble.json").is_file():
        print(f"building the {N_MEMBERS}-member twin ensemble (seed section 7.2.1)...")
        args.path.parent.mkdir(parents=True, exist_ok=True)
        build(args.path)
    if args.screenshots is not None:
        screenshots(args.path, args.screenshots)
        return
    wall0, cpu0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    rows = [once(args.path, args.features) for _ in range(args.repeats)]
    for i, row in enumerate(rows, 1):
        print(f"run {i}: " + ", ".join(f"{k} {v:.2f}" for k, v in row.items()))
    print(f"medians over {len(rows)} runs (fresh server and browser each):")
    for key in rows[0]:
        print(f"  {key:20s} {statistics.median(r[key] for r in rows):9.2f}")
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(
        f"total {time.perf_counter() - wall0:.1f} s wall, "
        f"{cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime:.1f} s CPU of the "
        f"servers (children); load average {os.getloadavg()}"
    )
    print(
        "line: first plot <= 3 s: "
        + ("met" if statistics.median(r["first_plot_s"] for r in rows) <= 3 else "NOT met")
        + "; server memory <= 1024 MB: "
        + ("met" if max(r["peak_rss_mb"] for r in rows) <= 1024 else "NOT met")
    )


if __name__ == "__main__":
    main()
