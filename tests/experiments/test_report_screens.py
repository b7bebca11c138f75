"""Reports read in a browser 1400 px wide (issue 32): nothing wider, no raw JSON.

The demo, features, classify, identify and mismatch reports are each built once, from
the smallest inputs that exercise them (the demo is the quick run that
``test_demo.py`` checks, shared through ``conftest.py``), and opened in headless
Chromium 1400 px wide: the page does not scroll sideways, no element spills out of its
box unless it is a scroll container (a wide table scrolls in its own box), and no
text is a JSON or dict dump. Every axis of their figures says its unit.

Set ``PDMKIT_REPORT_SHOTS=DIR`` to also save a full-page PNG of each report there.
Needs Debian's ``chromium`` and ``chromium-driver`` and the ``selenium`` package;
skips with the reason when one is missing (no browser is ever downloaded).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import signal

from pdmkit.ensembles import SEED_LABELS
from pdmkit.experiments._cli import main
from pdmkit.experiments._demo_mismatch import (
    TANKS_CASE,
    add_mismatch_section,
    cascaded_tanks_case,
)
from pdmkit.experiments._identify import run_identify
from pdmkit.experiments._mismatch import run_mismatch
from pdmkit.experiments._report import Report
from pdmkit.models.mismatch._cases import generate_concealed_case

WIDTH = 1400

#: What the page measures: its width, elements spilling out of their box (outside any
#: scroll container), and text that is a JSON / dict dump.
_MEASURE = r"""
const W = document.documentElement.clientWidth;
const scrolls = el => ['auto', 'scroll'].includes(getComputedStyle(el).overflowX);
const inScroller = el => {
  for (let p = el.parentElement; p && p !== document.body; p = p.parentElement)
    if (scrolls(p)) return true;
  return false;
};
const name = el => el.tagName.toLowerCase() + (el.className ? '.' + el.className : '')
  + ' "' + (el.textContent || '').trim().slice(0, 50) + '"';
const spill = [];
for (const el of document.body.querySelectorAll('*')) {
  if (inScroller(el)) continue;
  const r = el.getBoundingClientRect();
  const cs = getComputedStyle(el);
  if (r.right > W + 0.5) spill.push(name(el) + ' ends at ' + Math.round(r.right) + 'px');
  else if (!scrolls(el) && cs.overflowX !== 'hidden' && el.clientWidth > 0
           && el.scrollWidth > el.clientWidth + 1)
    spill.push(name(el) + ' holds ' + el.scrollWidth + 'px in ' + el.clientWidth + 'px');
}
const dumps = [...document.querySelectorAll('pre')]
  .map(p => 'pre: ' + p.textContent.slice(0, 60));
for (const m of document.body.innerText.matchAll(/[{\[]\s*["'][^\n]{0,60}/g))
  dumps.push('text: ' + m[0]);
return {scrollWidth: document.documentElement.scrollWidth,
        height: document.documentElement.scrollHeight, spill: spill.slice(0, 20), dumps};
"""

#: Axis labels of quantities without a unit (classes, counts, the z-plane, accuracy,
#: coherence; the RUL step's health indicator, a log-RMS, in the demo's rul/report.html).
_UNITLESS = re.compile(
    r"^(predicted class|true class|members|fraction of true class|re z|im z|"
    r"(held-out )?accuracy|coherence|health indicator)$",
    re.IGNORECASE,
)


def _has_unit(label: str) -> bool:
    """``x [m]``, ``position (mm)``, ``acc (as recorded)``, or a unitless quantity."""
    return bool(re.search(r"\[[^\]]+\]|\([^)]*\)", label)) or bool(
        _UNITLESS.match(label.strip())
    )


@pytest.fixture(scope="module")
def browser(headless_chrome):
    driver = headless_chrome(
        "the report screenshot tests", "--hide-scrollbars", f"--window-size={WIDTH},1000"
    )
    yield driver
    driver.quit()


def _open(browser, report: Path, name: str) -> dict:
    """Measure ``report`` 1400 px wide; save a full-page PNG when asked to."""
    browser.set_window_size(WIDTH, 1000)
    browser.get(report.resolve().as_uri())
    measured = browser.execute_script(_MEASURE)
    shots = os.environ.get("PDMKIT_REPORT_SHOTS")
    if shots:
        Path(shots).mkdir(parents=True, exist_ok=True)
        browser.set_window_size(WIDTH, min(int(measured["height"]) + 150, 16000))
        browser.save_screenshot(str(Path(shots) / f"{name}.png"))
    return measured


def _assert_reads(measured: dict, name: str) -> None:
    assert measured["scrollWidth"] <= WIDTH, (
        f"{name}: the page is {measured['scrollWidth']} px wide: {measured['spill']}"
    )
    assert measured["spill"] == [], f"{name}: elements spill out: {measured['spill']}"
    assert measured["dumps"] == [], f"{name}: raw JSON / dicts: {measured['dumps']}"


# ------------------------------------------------------------------------ the reports
@pytest.fixture(scope="module")
def built(tmp_path_factory, label_recorder):
    """The features, classify, identify and mismatch reports from the smallest inputs,
    with the axis labels of every figure they hold."""
    root = tmp_path_factory.mktemp("reports")
    rng = np.random.default_rng(0)
    labels: dict[str, list[str]] = {}
    with pytest.MonkeyPatch.context() as mp:
        for name, build in (
            ("features", _features),
            ("classify", _classify),
            ("identify", _identify),
            ("mismatch", _mismatch),
        ):
            labels[name] = []
            label_recorder(mp, labels[name])
            build(root, rng)
            mp.undo()
    return root, labels


def _features(root: Path, rng) -> None:
    members = root / "members"
    members.mkdir()
    t = np.arange(1000) / 1000.0
    for i in range(9):
        fault = ("healthy", "inner_race", "outer_race")[i % 3]
        drive_end = rng.normal(size=t.size) + (i % 3) * np.sin(2 * np.pi * 50 * t)
        pd.DataFrame(
            {
                "time": t,
                "drive_end_accelerometer": drive_end,
                "fan_end_accelerometer": rng.normal(size=t.size),
            }
        ).to_csv(members / f"{fault}_{i}.csv", index=False)
    argv = ["features", "--members", str(members), "--quiet", "--groups", "stats"]
    argv += ["--label-from-name", r"^([a-z_]+)_\d+", "--out", str(root / "features")]
    assert main(argv) == 0


def _classify(root: Path, rng) -> None:
    y = np.repeat(["healthy", "inner_race_fault", "outer_race_fault"], 20)
    table = pd.DataFrame(
        {
            "drive_end_accelerometer/stats/RMS": rng.normal(size=60)
            + 4.0 * (y == "inner_race_fault"),
            "drive_end_accelerometer/stats/Kurtosis": rng.normal(size=60)
            + 4.0 * (y == "outer_race_fault"),
            "fan_end_accelerometer/stats/RMS": rng.normal(size=60),
            "fault": y,
        }
    )
    table.to_parquet(root / "features.parquet")
    argv = ["classify", "--features", str(root / "features.parquet"), "--label"]
    argv += ["fault", "--top-k", "2", "--quiet", "--out", str(root / "classify")]
    assert main(argv) == 0


def _identify(root: Path, rng) -> None:
    # 6000 samples: longer than a figure draws sample by sample (the envelope path)
    fs, fn, zeta = 500.0, 40.0, 0.03
    wn = 2 * np.pi * fn
    num, den, _ = signal.cont2discrete(
        ([wn**2], [1.0, 2 * zeta * wn, wn**2]), 1 / fs, method="zoh"
    )
    u = rng.normal(size=6000)
    y = signal.lfilter(np.ravel(num), np.ravel(den), u)
    y = y + 0.05 * np.std(y) * rng.normal(size=y.size)
    path = root / "rig.csv"
    pd.DataFrame({"time": np.arange(u.size) / fs, "F": u, "acc": y}).to_csv(
        path, index=False
    )
    order = {"nb": 2, "nf": 2, "nk": 1}
    run_identify(path, input="F", output="acc", structure="oe", order=order,
                 out_dir=root / "identify")  # fmt: skip


def _mismatch(root: Path, rng) -> None:
    case = generate_concealed_case("sensor_offset", 0.3, seed=2, target="x", n_samples=300)
    paths = case.write(root / "case")
    run_mismatch(
        paths["model"], paths["data"], out_dir=root / "mismatch", effects=["sensor_offset"]
    )


# ------------------------------------------------------------------------ the checks
@pytest.mark.slow
def test_demo_report_reads_at_1400_px(browser, demo_run):
    assert demo_run.code == 0
    report = demo_run.out / "report.html"
    _assert_reads(_open(browser, report, "demo"), "demo")
    html = report.read_text(encoding="utf-8")
    # one vocabulary: pdmkit's fault codes; the seed's strings only in the column that
    # maps them, once each
    for code, seed_name in SEED_LABELS.items():
        assert len(re.findall(rf"<td[^>]*>{re.escape(seed_name)}</td>", html)) == 1
        assert re.search(rf"<td[^>]*>{re.escape(code)}</td>", html), code
    for word in ("valve1", "damp_small_bot"):
        assert html.count(word) == sum(v.count(word) for v in SEED_LABELS.values())
    # the seed comparison and the time per step are tables without pandas' row numbers
    assert "<th>0</th>" not in html
    assert "simulating the recordings and their indicators" in html
    # the real-data case the quick run leaves out is said to be skipped, and why
    assert re.search(
        rf'class="skipped"><strong>{re.escape(TANKS_CASE)}</strong>: skipped: a quick run',
        html,
    )
    assert "except the Cascaded Tanks" not in html
    missing = [label for label in demo_run.axis_labels if not _has_unit(label)]
    assert not missing, f"demo axes without a unit: {missing}"
    assert "pa [Pa]" in demo_run.axis_labels  # the mismatch plot's state, with its unit


@pytest.mark.parametrize("name", ["features", "classify", "identify", "mismatch"])
def test_command_report_reads_at_1400_px(browser, built, name):
    root, labels = built
    report = root / name / "report.html"
    _assert_reads(_open(browser, report, name), name)
    missing = [label for label in labels[name] if not _has_unit(label)]
    assert not missing, f"{name} axes without a unit: {missing}"
    if name == "mismatch":
        assert "x [m]" in labels[name]  # a position state of the model file, in m
    if name == "identify":
        assert "acc (as recorded)" in labels[name]  # the user's column, unit unknown
        html = report.read_text(encoding="utf-8")
        assert "6000 samples per line, drawn in 1000 bins" in html


def test_a_skipped_real_data_case_says_where_it_looked(tmp_path, monkeypatch):
    monkeypatch.setenv("PDMKIT_DATA", str(tmp_path))
    reason = cascaded_tanks_case()  # no data: the reason, and no discovery run
    where, _, why = reason.partition(" not found ")
    assert Path(where).resolve() == (tmp_path / "cascaded_tanks").resolve()
    assert why == "(set PDMKIT_DATA to the folder that holds cascaded_tanks)"
    report = Report("r")
    add_mismatch_section(report, [], 5, skipped=reason)
    assert f"{TANKS_CASE}</strong>: skipped: " in report.to_html()
