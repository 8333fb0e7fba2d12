"""Browser fixtures for the book's tests: headless Chromium (Debian's) driven by Selenium.

Tests marked ``browser`` need ``/usr/bin/chromium``, ``/usr/bin/chromedriver`` (Debian's ``chromium`` and
``chromium-driver`` packages, one source package, so their versions match) and the ``selenium`` package (in the
``test`` extra). Where one is missing they skip, and the run ends with one line saying how to enable them; with
``MOTIONLAB_BROWSER_TESTS=required`` (``.ci/run`` sets it) they fail instead.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

CHROMIUM = Path(os.environ.get("MOTIONLAB_CHROMIUM", "/usr/bin/chromium"))
CHROMEDRIVER = Path(os.environ.get("MOTIONLAB_CHROMEDRIVER", "/usr/bin/chromedriver"))
REQUIRED = os.environ.get("MOTIONLAB_BROWSER_TESTS") == "required"
WINDOW = (1300, 1000)  # the width the book's layout is checked at
ENABLE = (
    "install Debian's browser and driver (apt-get install chromium chromium-driver) and the test extra "
    "(.venv/bin/pip install -e '.[test]')"
)


def browser_missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append("the selenium package")
    return f"{', '.join(missing)} not found" if missing else None


def pytest_configure(config):
    config.addinivalue_line("markers", "browser: drives a real (headless Chromium) browser")


_skipped: list[str] = []


def pytest_collection_modifyitems(config, items):
    why = browser_missing()
    if why is None:
        return
    for item in items:
        if "browser" in item.keywords and not REQUIRED:  # required: browser_factory fails instead
            item.add_marker(pytest.mark.skip(reason=f"browser tests skipped: {why}"))
            _skipped.append(item.nodeid)


def pytest_terminal_summary(terminalreporter):
    if _skipped:
        terminalreporter.write_line(
            f"{len(_skipped)} browser tests skipped ({browser_missing()}): to run them, {ENABLE}"
        )


@pytest.fixture(scope="module")
def browser_factory(tmp_path_factory):
    """``make(offline=True)`` -> a headless Chromium at 1300×1000 with console and network logs.

    ``offline``: every http(s) request goes to a dead proxy (file:// and data: are unaffected), so a page that
    needs the network shows it as a failed request instead of silently fetching.
    """
    if REQUIRED and browser_missing():
        pytest.fail(f"MOTIONLAB_BROWSER_TESTS=required but {browser_missing()}: {ENABLE}")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    drivers = []

    def make(offline: bool = True, bypass: str | None = None):
        opts = webdriver.ChromeOptions()
        opts.binary_location = str(CHROMIUM)
        profile = tmp_path_factory.mktemp("chromium-profile")
        for arg in (
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--disable-background-networking",
            "--disable-component-update",
            "--no-first-run",
            "--disable-extensions",
            "--disable-sync",
            "--mute-audio",
            f"--user-data-dir={profile}",
            f"--window-size={WINDOW[0]},{WINDOW[1]}",
            "--allow-file-access-from-files",
        ):
            opts.add_argument(arg)
        if offline:
            opts.add_argument("--proxy-server=127.0.0.1:9")
            opts.add_argument(f"--proxy-bypass-list={bypass or '<-loopback>'}")
        opts.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
        driver = webdriver.Chrome(service=Service(executable_path=str(CHROMEDRIVER)), options=opts)
        driver.set_page_load_timeout(120)
        driver.set_script_timeout(120)
        drivers.append(driver)
        return driver

    yield make
    for driver in drivers:
        driver.quit()
