from __future__ import annotations

from pathlib import Path

import pytest

from hvacflex.fleet.generate import generate_fleet, write_fleet


@pytest.fixture(scope="session")
def small_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three generated buildings with a feeder limit that binds in the morning."""
    doc = generate_fleet(3, 3, feeder_limit_kw=110.0, min_bid_mw=0.1)
    doc["coordination"]["max_iterations"] = 6
    return write_fleet(doc, tmp_path_factory.mktemp("fleet") / "fleet.toml")
