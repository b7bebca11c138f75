"""Shared fixtures: real-data location and deterministic random generators."""

from __future__ import annotations

import os
import shutil

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from hypothesis import settings

from pdmkit._config import data_dir

# Property tests draw the same examples on every run (HYPOTHESIS_PROFILE=explore for
# fresh ones): CI must neither pass nor fail by the luck of the draw.
settings.register_profile("ci", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture
def require_data():
    """Return a function that gives a dataset folder or skips the test with the reason."""

    def _require(name: str):
        path = data_dir(name)
        if not path.is_dir():
            where = os.environ.get("PDMKIT_DATA", "../shared/data")
            pytest.skip(
                f"real dataset '{name}' not found in {where} ({path}); "
                "set PDMKIT_DATA to the folder holding the shared datasets"
            )
        return path

    return _require


_PEAK_MB_SOURCE = '''
def peak_mb():
    """This process's peak resident memory (MB). VmHWM belongs to the process image,
    so a child forked from a large pytest process does not report its parent's peak
    (ru_maxrss survives exec on Linux and would)."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource, sys
    scale = 1 / 2**20 if sys.platform == "darwin" else 1 / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale
'''


@pytest.fixture(scope="session")
def peak_mb_source() -> str:
    """Python source that defines ``peak_mb()`` for code run in a child process."""
    return _PEAK_MB_SOURCE


@pytest.fixture(scope="session")
def headless_chrome():
    """Start Debian's headless Chromium through selenium: ``start(what, *args)``.

    Skips the test, saying what to install, when chromium, chromedriver or selenium is
    missing (no browser is ever downloaded); ``args`` are further Chromium switches.
    """

    def start(what: str, *args: str):
        chromium = shutil.which("chromium") or shutil.which("chromium-browser")
        driver = shutil.which("chromedriver")
        if chromium is None or driver is None:
            missing = "chromium" if chromium is None else "chromedriver"
            pytest.skip(
                f"{missing} not found: apt-get install chromium chromium-driver to run "
                f"{what}"
            )
        webdriver = pytest.importorskip(
            "selenium.webdriver", reason="selenium not installed"
        )
        from selenium.webdriver.chrome.service import Service

        options = webdriver.ChromeOptions()
        options.binary_location = chromium
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu",
                    "--disable-dev-shm-usage", *args):  # fmt: skip
            options.add_argument(arg)
        return webdriver.Chrome(service=Service(driver), options=options)

    return start


def pytest_collection_modifyitems(config, items):
    """Modules holding a ``slow`` test run first, each module's tests kept together.

    The suite runs on every core (``-n auto --dist worksteal``): a worker that runs
    out of tests takes half of another's queue, but never a test already running, so
    a long test that starts last keeps one core busy while the others idle. Starting
    the slow modules first leaves only short tests for the end. Within a module the
    order is unchanged (its fixtures are set up once).
    """
    slow_modules = {item.module.__name__ for item in items
                    if item.get_closest_marker("slow") is not None}  # fmt: skip
    order = {id(item): k for k, item in enumerate(items)}
    items.sort(key=lambda it: (it.module.__name__ not in slow_modules, order[id(it)]))
