"""Shared fixtures: paths to the shipped data and building files."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from hvacflex.paths import buildings_dir, data_dir


@pytest.fixture(scope="session")
def shared_data_dir() -> Path:
    return data_dir()


@pytest.fixture(scope="session")
def shipped_buildings_dir() -> Path:
    return buildings_dir()


CHROMIUM_PATHS = ("/usr/bin/chromium", "/usr/bin/chromium-browser")
"""Debian's chromium (.ci/run installs it); Playwright drives it, no browser download."""


@pytest.fixture(scope="session")
def chromium() -> Iterator[Any]:
    """A headless Chromium (Playwright ``Browser``) on Debian's binary; the test is skipped
    where neither the binary nor the ``playwright`` package is installed."""
    import shutil

    sync_api = pytest.importorskip("playwright.sync_api")
    found = [path for path in CHROMIUM_PATHS if shutil.which(path)]
    if not found:
        pytest.skip("no chromium binary (apt-get install -y chromium)")
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=found[0], headless=True, args=["--no-sandbox", "--disable-gpu"]
        )
        yield browser
        browser.close()
