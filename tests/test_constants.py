"""Domain defaults: what their docstrings promise, checked from first principles."""

from __future__ import annotations

import ast
import math
from datetime import datetime
from pathlib import Path
from zoneinfo import ZoneInfo

from hvacflex import constants

SECONDS_PER_DAY = 86_400.0
PERIOD_S = 1_800.0
"""One control period: 30 min."""


def test_constants_import_nothing_from_hvacflex() -> None:
    """The base layer: every subpackage may take its defaults from here."""
    tree = ast.parse(Path(constants.__file__).read_text(encoding="utf-8"))
    imported = [
        node.module if isinstance(node, ast.ImportFrom) else alias.name
        for node in ast.walk(tree)
        if isinstance(node, ast.Import | ast.ImportFrom)
        for alias in node.names
    ]
    assert [name for name in imported if name and name.startswith("hvacflex")] == []


def test_the_time_zone_is_singapore_time_utc_plus_8() -> None:
    offset = datetime(2014, 3, 3, tzinfo=ZoneInfo(constants.TIMEZONE)).utcoffset()
    assert offset is not None and offset.total_seconds() == 8 * 3600


def test_the_default_horizon_is_one_day_of_periods() -> None:
    assert constants.HORIZON_STEPS * PERIOD_S == SECONDS_PER_DAY


def test_the_ar1_coefficient_has_a_correlation_time_of_about_five_hours() -> None:
    correlation_time_h = -0.5 / math.log(constants.AR1_COEFFICIENT)  # ρ = exp(−Δt/τ)
    assert 4.5 < correlation_time_h < 5.5


def test_the_run_folder_is_relative_to_the_working_directory() -> None:
    run_dir = Path(constants.RUN_DIR)
    assert not run_dir.is_absolute() and run_dir.parts == ("results", "run")


def test_the_preset_names_are_the_presets_the_configuration_defines() -> None:
    from hvacflex.config.presets import PRESETS
    from hvacflex.constants import PRESET_NAMES

    assert PRESET_NAMES == tuple(PRESETS)
    assert len(set(PRESET_NAMES)) == len(PRESET_NAMES)
