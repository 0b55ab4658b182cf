"""Domain defaults shared across layers.

The base layer of the package (next to :mod:`hvacflex.errors` and :mod:`hvacflex.units`):
imports nothing from hvacflex, so every subpackage (``building``, ``data``, ``opt``, the
scenario configuration) can take its defaults from here instead of from each other.
"""

from __future__ import annotations

TIMEZONE = "Asia/Singapore"
"""Time zone of every time index: the NEMS market, the weather and the occupancy schedules."""

RUN_DIR = "results/run"
"""Folder a closed-loop run writes to when none is given (``hvacflex simulate --out`` and
``hvacflex.simulate(out=...)``), relative to the working directory."""

HORIZON_STEPS = 48
"""Default MPC prediction horizon: 48 steps of 30 min, one day."""

AR1_COEFFICIENT = 0.9
"""Default lag-one autocorrelation of AR(1) disturbance errors per 30-min step [-]
(a correlation time of about 5 h)."""

DEFAULT_START = "2014-01-01"
"""First day of a run when none is given (every command and the scenario file) [local date]."""

MAX_HORIZON_STEPS = 336
"""Longest MPC prediction horizon accepted anywhere: 336 steps of 30 min, one week (the
service's cap, ``hvacflex.service.runtime.MAX_HORIZON_STEPS``)."""
