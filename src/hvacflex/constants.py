"""Domain defaults shared across layers.

The base layer of the package (next to :mod:`hvacflex.errors` and :mod:`hvacflex.units`):
imports nothing from hvacflex, so every subpackage (``building``, ``data``, ``opt``, the
scenario configuration) can take its defaults from here instead of from each other.
"""

from __future__ import annotations

import pandas as pd

TIMEZONE = "Asia/Singapore"
"""Time zone of every time index: the NEMS market, the weather and the occupancy schedules
(the one home of the market's time zone: every module reads it from here)."""

PERIOD_S = 1800.0
"""The market period, every control step and every row of the data [s]: NEMS dispatches and
prices in 30-min periods (the one home of the period: every module reads it from here; a
scenario's ``dt_s`` must equal it)."""

PERIOD = pd.Timedelta(seconds=PERIOD_S)
""":data:`PERIOD_S` as a time step of an index."""

PERIOD_FREQ = "30min"
""":data:`PERIOD_S` as a pandas frequency (``date_range``, ``floor``)."""

PERIODS_PER_DAY = round(24 * 3600 / PERIOD_S)
"""Periods in a day (48)."""

RUN_DIR = "results/run"
"""Folder a closed-loop run writes to when none is given (``hvacflex simulate --out`` and
``hvacflex.simulate(out=...)``), relative to the working directory."""

HORIZON_STEPS = PERIODS_PER_DAY
"""Default MPC prediction horizon: one day of 30-min steps (48)."""

AR1_COEFFICIENT = 0.9
"""Default lag-one autocorrelation of AR(1) disturbance errors per 30-min step [-]
(a correlation time of about 5 h)."""

DEFAULT_START = "2014-01-01"
"""First day of a run when none is given (every command and the scenario file) [local date]."""

DEFAULT_DAYS = 7.0
"""Days a scenario simulates unless it says otherwise (``days``)."""

MAX_HORIZON_STEPS = 7 * PERIODS_PER_DAY
"""Longest MPC prediction horizon accepted anywhere: 336 steps of 30 min, one week (the
service's cap too)."""

VALIDATION_SPINUP_DAYS = 42
"""Days both models run before a validation window against EnergyPlus, discarded [d]
(``hvacflex validate energyplus --spinup-days``). office5's slowest time constant is ≈ 9.3
days (the core: 225 MJ/K of slab against 531 W/K of partitions), so 42 days leave ≈ 1 % of
any start error; with 7 days 25–47 % of it was still in the compared week (the core's
+2.7 K March bias was +3.5 K of hvacflex's warm start less 1.1 K of EnergyPlus's;
docs/explanation/validation.md). Results stop moving between 42 and 56 days."""

MAX_VALIDATION_SPINUP_DAYS = 120
"""Longest spin-up ``hvacflex validate energyplus`` accepts [d]."""


PRESET_NAMES: tuple[str, ...] = (
    "nmpc",
    "rmpc",
    "rmpc-ppp",
    "paper-nmpc",
    "paper-rmpc",
    "paper-rmpc-ppp",
    "nmpc-no-reserve",
    "thermostat",
    "thermostat-25.5",
    "thermostat-25.5-float",
    "trim-respond",
    "demand-limit",
    "gta-dr",
    "plant-baseline",
    "rmpc-feedback",
    "rmpc-feedback-ppp",
    "rmpc-output-feedback",
)
"""The scenario presets' names, in the order they are listed (the one home of the list:
``hvacflex.config.presets.PRESETS`` defines each under these names and no other, the
command line's ``--help`` and the service's ``scenario.preset`` read them from here, without
importing the configuration)."""

MAX_FLEET_BUILDINGS = 1000
"""Most buildings a generated fleet holds: a fleet simulation solves one RMPC per building and
coordination iteration, so beyond this a run takes days."""

VALID_TIMESTEPS_PER_HOUR = (2, 4, 6, 10, 12, 20, 30, 60)
"""Zone time steps per hour that EnergyPlus accepts and that tile a 30-min period."""
