"""Shared fixtures: paths to the shipped data and building files."""

from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex.paths import buildings_dir, data_dir


@pytest.fixture(scope="session")
def shared_data_dir() -> Path:
    return data_dir()


@pytest.fixture(scope="session")
def shipped_buildings_dir() -> Path:
    return buildings_dir()
