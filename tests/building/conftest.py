"""Fixtures for the building tests: the shipped buildings and a small hand-checkable one."""

from __future__ import annotations

from pathlib import Path

import pytest
from building_fixtures import MINIMAL_TOML, write_building

from hvacflex.building.io import load_building
from hvacflex.building.model import Building


@pytest.fixture(scope="session")
def office5(shipped_buildings_dir: Path) -> Building:
    return load_building(shipped_buildings_dir / "office5.toml")


@pytest.fixture(scope="session")
def room1(shipped_buildings_dir: Path) -> Building:
    return load_building(shipped_buildings_dir / "room1.toml")


@pytest.fixture
def two_zone(tmp_path: Path) -> Building:
    return load_building(write_building(tmp_path, MINIMAL_TOML))


@pytest.fixture(params=["office5", "room1"])
def shipped(request: pytest.FixtureRequest, shipped_buildings_dir: Path) -> Building:
    return load_building(shipped_buildings_dir / f"{request.param}.toml")
