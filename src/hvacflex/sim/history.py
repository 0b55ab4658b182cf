"""What every driver keeps of a building's periods, and the one builder of a period's inputs.

A period's decision needs the same things whoever drives it: the state, the forecast with
the operator's signals laid over it, the month's peak so far, the settlement baselines of an
activation starting now or later, the meter of the period before and what the air system
delivered in it. :class:`PeriodHistory` is the record they come from — the metered power and
the activations of the periods so far, the plant's latest delivered input — filled by the
closed loop from its plant (:mod:`hvacflex.sim.closed_loop`), by the service from its
database rows (:mod:`hvacflex.service.runtime`) and by a fleet's building from its own loop
(:mod:`hvacflex.fleet.agent`); :func:`period_inputs` turns it into the period's
:class:`~hvacflex.control.base.PeriodInputs`, the one place that does. The control step
(:mod:`hvacflex.sim.step`) keeps the plan's side of the history (commitments, the plan's
power for ρ, the flows it decided) and lays it over these inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from hvacflex.config import ReserveConfig, ScenarioConfig
from hvacflex.control.base import FloatArray, PeriodInputs
from hvacflex.data.forecast import Forecaster
from hvacflex.data.signals import OperatorSignals
from hvacflex.settlement import ahead_baselines_kw, start_baseline_kw

BoolArray = npt.NDArray[np.bool_]


@dataclass
class PeriodHistory:
    """The metered record of a building's periods so far.

    Attributes
    ----------
    index : (T + J,) the periods' start times (the run's, and the J periods after its last
        whose ``similar-days`` baselines a plan may need).
    power_kw : (T,) metered HVAC power of each period [kW] (NaN: not metered yet).
    activated : (T,) whether IL was activated in each period.
    delivered_flow_kg_s : (m,) the plant's report of :attr:`delivered_period`: the air
        system's input as the model takes it [kg/s]; None where the plant reports none.
    delivered_period : the period :attr:`delivered_flow_kg_s` belongs to (−1: none).
    opening_peak_kw : the peak the first period's month had reached before the history's
        first period [kW] (a bill that started before the run; 0: none).
    """

    index: pd.DatetimeIndex
    power_kw: FloatArray
    activated: BoolArray
    delivered_flow_kg_s: FloatArray | None = None
    delivered_period: int = -1
    opening_peak_kw: float = 0.0
    _month: npt.NDArray[np.int64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._month = np.asarray(self.index.year * 12 + self.index.month, dtype=np.int64)

    @classmethod
    def empty(cls, index: pd.DatetimeIndex, steps: int) -> PeriodHistory:
        """A history of ``steps`` periods with nothing metered (``index`` ≥ ``steps``
        period starts)."""
        return cls(index, np.full(steps, np.nan), np.zeros(steps, dtype=bool))

    @property
    def steps(self) -> int:
        return int(self.power_kw.shape[0])

    def record(
        self,
        k: int,
        power_kw: float,
        activated: bool,
        delivered_flow_kg_s: FloatArray | None = None,
    ) -> None:
        """Period ``k`` as metered: its power [kW], whether it was activated, and the air
        system's delivered input (m,) [kg/s] where the plant reports one."""
        self.power_kw[k] = power_kw
        self.activated[k] = activated
        if delivered_flow_kg_s is not None:
            self.delivered_flow_kg_s = np.asarray(delivered_flow_kg_s, dtype=float)
            self.delivered_period = k

    def previous_power_kw(self, k: int) -> float | None:
        """The metered power of period k − 1 [kW] (None: k = 0 or not metered)."""
        if k == 0 or not math.isfinite(self.power_kw[k - 1]):
            return None
        return float(self.power_kw[k - 1])

    def peak_floor_kw(self, k: int) -> float:
        """The largest metered power of the periods before ``k`` in k's calendar month [kW]
        (0 at a month's first period; at least :attr:`opening_peak_kw` in the first
        period's month): the peak the month's bill already holds."""
        month = self._month
        first = int(np.searchsorted(month[:k], month[k], side="left"))
        metered = self.power_kw[first:k]
        metered = metered[np.isfinite(metered)]
        opening = self.opening_peak_kw if first == 0 else 0.0
        return max(opening, float(metered.max(initial=0.0)))

    def start_baseline_kw(self, k: int, rule: str) -> float | None:
        """The baseline an activation starting at ``k`` would be settled against under
        ``rule`` [kW] (:func:`hvacflex.settlement.start_baseline_kw`); None where the period
        before is not metered (k = 0, a building that posted no power): unknown."""
        if self.previous_power_kw(k) is None:
            return None
        return start_baseline_kw(rule, self.power_kw[:k], self.activated[:k], self.index[: k + 1])

    def ahead_baselines_kw(self, k: int, reserve: ReserveConfig) -> FloatArray | None:
        """The ``similar-days`` baselines of periods k … k + J − 1 (J
        :attr:`ReserveConfig.ahead_offer_steps`; None under ``pre-event``)."""
        if reserve.il_baseline != "similar-days":
            return None
        index = self.index[: k + reserve.ahead_offer_steps]
        return ahead_baselines_kw(reserve.il_baseline, self.power_kw[:k], self.activated[:k], index)

    def delivered_before_kg_s(self, k: int) -> FloatArray | None:
        """The plant's delivered input of period k − 1 (m,) [kg/s], or None."""
        if self.delivered_period != k - 1 or self.delivered_flow_kg_s is None:
            return None
        return self.delivered_flow_kg_s

    def get_state(self) -> dict[str, Any]:
        return {
            "power_kw": self.power_kw.copy(),
            "activated": self.activated.copy(),
            "delivered_flow_kg_s": self.delivered_flow_kg_s,
            "delivered_period": self.delivered_period,
            "opening_peak_kw": self.opening_peak_kw,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        self.power_kw = np.asarray(state["power_kw"], dtype=float).copy()
        self.activated = np.asarray(state["activated"], dtype=bool).copy()
        delivered = state["delivered_flow_kg_s"]
        self.delivered_flow_kg_s = None if delivered is None else np.asarray(delivered, float)
        self.delivered_period = int(state["delivered_period"])
        self.opening_peak_kw = float(state["opening_peak_kw"])


def period_inputs(
    k: int,
    history: PeriodHistory,
    forecaster: Forecaster,
    signals: OperatorSignals,
    config: ScenarioConfig,
    *,
    x_degc: FloatArray,
    measured_zone_temp_degc: FloatArray | None = None,
    plan: Any = None,
) -> PeriodInputs:
    """The complete driver's inputs of period ``k`` (the one builder every driver calls).

    Parameters
    ----------
    k : the period (steps from the scenario's start).
    history : the building's metered periods before ``k``.
    forecaster : the controller's view of the exogenous series.
    signals : operator signals laid over the forecast (prices, φ, a posted forecast).
    config : the scenario (horizon, the settlement baseline rule, billing).
    x_degc : (n,) node temperatures now [°C].
    measured_zone_temp_degc : (m,) zone-air readings [°C] for a controller with a filter.
    plan : a plan of this period decided elsewhere (a fleet coordinator's), or None.
    """
    # one period beyond the horizon: the band at the end of the last planned period
    forecast = signals.apply(forecaster.forecast(k, config.controller.horizon_steps + 1))
    reserve = config.reserve
    return PeriodInputs(
        x_degc,
        forecast,
        history.peak_floor_kw(k),
        measured_zone_temp_degc=measured_zone_temp_degc,
        plan=plan,
        baseline_power_kw=history.start_baseline_kw(k, reserve.il_baseline),
        baseline_ahead_kw=history.ahead_baselines_kw(k, reserve),
        previous_power_kw=history.previous_power_kw(k),
        delivered_flow_kg_s=history.delivered_before_kg_s(k),
    )
