"""The fleet's side of the IL market: its bid, whether its meter would show it, when the
grid activates it, and how it is settled.

The fleet sells one aggregate offer (Σ of its buildings' metered-visible offers,
:mod:`hvacflex.fleet.aggregation`), accepted at or above the market's minimum bid
(:func:`bid_accepted`), activated by the fleet file's ``[activation]`` schedule
(:func:`fleet_activation_schedule`) and settled on the fleet's metered power
(:func:`settle_fleet`, :mod:`hvacflex.settlement`). Used by :mod:`hvacflex.fleet.run`.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

from hvacflex.config import NEMS_MAX_INTERRUPTION_STEPS
from hvacflex.settlement import settlement_columns
from hvacflex.sim.activation import activation_schedule

MIN_BID_FLOOR_KW = 1e-3
"""Smallest aggregate offer that is a bid at all [kW] (below it: solver round-off)."""


def bid_accepted(bid_kw: float, min_bid_kw: float) -> bool:
    """Whether the fleet's bid [kW] clears the market's minimum [kW] (and is a bid at all:
    at least ``MIN_BID_FLOOR_KW``)."""
    return bid_kw >= max(min_bid_kw, MIN_BID_FLOOR_KW)


def fleet_activation_schedule(fleet: Any, index: pd.DatetimeIndex) -> Any:
    """(steps,) bool: the periods the grid operator activates IL (the fleet file's
    ``[activation]``, seeded by the fleet's seed; :mod:`hvacflex.sim.activation`)."""
    spec = fleet.spec
    config = fleet.activation
    duration = config.duration_steps or spec.reserve.event_max_steps or NEMS_MAX_INTERRUPTION_STEPS
    return activation_schedule(config, index, seed=spec.seed, max_steps=duration)


def settle_fleet(frame: pd.DataFrame, rule: str) -> pd.DataFrame:
    """``frame`` with the fleet's IL settlement filled in: the metered fleet power
    (``fleet_power_kw``) against the baseline ``rule`` in the activated periods, for the
    settled bid (``settled_reserve_kw``) — :func:`hvacflex.settlement.settlement_columns`,
    as for one building (``il_baseline_power_kw``, ``il_delivered_kw``, ``il_shortfall_kw``)."""
    metered = pd.DataFrame(
        {
            "power_kw": frame["fleet_power_kw"].to_numpy(float),
            "reserve_kw": frame["settled_reserve_kw"].to_numpy(float),
            "il_activated": frame["il_activated"].to_numpy(bool),
        },
        index=frame.index,
    )
    settled = settlement_columns(metered, rule)
    out = frame.copy()
    for name in settled.columns:
        out[name] = settled[name].to_numpy(float)
    return out
