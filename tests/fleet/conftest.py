from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from hvacflex.fleet.generate import generate_fleet, write_fleet


@pytest.fixture(scope="session")
def small_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three generated buildings with a feeder limit that binds in the morning."""
    doc = generate_fleet(3, 3, feeder_limit_kw=110.0, min_bid_mw=0.1)
    doc["coordination"]["max_iterations"] = 6
    return write_fleet(doc, tmp_path_factory.mktemp("fleet") / "fleet.toml")


@pytest.fixture
def guard_limits(monkeypatch: pytest.MonkeyPatch) -> Callable[[ModuleType], list[float]]:
    """``record(module) → limits``: the limits [kW] ``module.guarded_advance`` (the fleet's
    guard as ``module`` calls it) is given, one per call, from now on."""

    def record(module: ModuleType) -> list[float]:
        limits: list[float] = []
        advance = module.guarded_advance

        def recording(groups: Any, limit_kw: float, activated: bool) -> list[Any]:
            limits.append(limit_kw)
            return advance(groups, limit_kw, activated)  # type: ignore[no-any-return]

        monkeypatch.setattr(module, "guarded_advance", recording)
        return limits

    return record
