"""The designer in a real headless Chromium, as a user drives it (issue 17).

Loads the CWRU bearing recordings, plots the signals by fault, computes stats and
spectral indicators of the fan-end accelerometer, ranks them, trains kNN on the top
two, reads the held-out accuracy off the page, exports the script, runs it, and gets
the same accuracy; a screenshot of each step lands in the test's tmp folder.

Needs Debian's ``chromium`` and ``chromium-driver`` and the ``selenium`` package; skips
with the reason when one is missing (no browser is ever downloaded).
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import pytest


def _wait(driver, condition, timeout: float = 30.0, what: str = ""):
    from selenium.webdriver.support.ui import WebDriverWait

    def check(d):
        status = d.find_element("id", "status")
        if "error" in (status.get_attribute("class") or ""):
            raise AssertionError(f"the page shows an error: {status.text}")
        return condition(d)

    return WebDriverWait(driver, timeout, poll_frequency=0.1).until(check, what)


def _click(driver, element_id: str) -> None:
    driver.find_element("id", element_id).click()


def _select(driver, element_id: str, value: str) -> None:
    from selenium.webdriver.support.ui import Select

    Select(driver.find_element("id", element_id)).select_by_value(value)


def _traces(driver, plot_id: str) -> int:
    return driver.execute_script(
        f"const p = document.getElementById('{plot_id}'); return p.data ? p.data.length : 0"
    )


@pytest.mark.real_data
def test_designer_end_to_end_in_chromium(
    tmp_path: Path, require_data, start_designer, headless_chrome
) -> None:
    require_data("cwru_bearing")
    shots = tmp_path / "screenshots"
    shots.mkdir()
    driver = headless_chrome("the browser test", "--window-size=1400,1000")
    server = start_designer("--dataset", "cwru")
    try:
        driver.get(server.url)
        # 1: members and their signals by fault
        _wait(driver, lambda d: d.execute_script("return window.designerFirstPlotMs"))
        assert _traces(driver, "plot-signals") == 5  # one member of each fault
        _select(driver, "plot-signal", "FE")
        _select(driver, "plot-kind", "spectrum")
        _wait(driver, lambda d: "PSD of FE" in d.find_element("id", "plot-signals").text)
        driver.save_screenshot(str(shots / "1_data.png"))

        # 2: stats + spectral indicators of the fan-end accelerometer
        _click(driver, "tab-indicators")
        for box in driver.find_elements("css selector", ".sig"):
            if box.is_selected() != (box.get_attribute("value") == "FE"):
                box.click()
        assert driver.find_element("id", "options").get_attribute("value") == "nperseg=512"
        _click(driver, "compute")
        _wait(
            driver, lambda d: "indicators" in d.find_element("id", "features-message").text
        )
        _wait(
            driver,
            lambda d: _traces(d, "plot-hist") == 5 and _traces(d, "plot-scatter") == 5,
        )
        driver.save_screenshot(str(shots / "2_indicators.png"))

        # 3: rank, then kNN on the two best
        _click(driver, "tab-train")
        _click(driver, "rank")
        _wait(driver, lambda d: _traces(d, "plot-rank") == 1)
        top_k = driver.find_element("id", "top-k")
        top_k.clear()
        top_k.send_keys("2")
        _select(driver, "model", "knn")
        _click(driver, "train")
        accuracy = _wait(
            driver,
            lambda d: (
                d.find_elements("id", "accuracy")
                and d.find_element("id", "accuracy").get_attribute("data-accuracy")
            ),
        )
        page_accuracy = float(accuracy)
        driver.save_screenshot(str(shots / "3_rank_train.png"))

        # 4: the exported script, run as the user would
        _click(driver, "tab-export")
        _wait(driver, lambda d: "classify(" in d.find_element("id", "script").text)
        driver.save_screenshot(str(shots / "4_export.png"))
        script = driver.execute_script(
            "return document.getElementById('script').textContent"
        )
    finally:
        driver.quit()
        server.stop()
    (tmp_path / "pipeline.py").write_text(script, encoding="utf-8")
    start = time.perf_counter()
    run = subprocess.run(
        [sys.executable, "pipeline.py"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    found = re.search(r"held-out accuracy (\d\.\d+)", run.stdout)
    assert found, run.stdout[-2000:]
    print(f"script ran in {time.perf_counter() - start:.1f} s: {found.group(0)}")
    # the page's accuracy, reproduced by the script on the whole data set
    assert float(found.group(1)) == pytest.approx(round(page_accuracy, 4), abs=1e-12)
    # a real, not a trivial, score: 2 of 67 held-out frames wrong (FE is harder than DE)
    assert 0.9 < page_accuracy < 1.0
    assert (tmp_path / "model.pdmkit").is_file()
    assert sorted(p.name for p in shots.iterdir()) == [
        "1_data.png",
        "2_indicators.png",
        "3_rank_train.png",
        "4_export.png",
    ]
