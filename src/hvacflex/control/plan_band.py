"""The comfort band a plan keeps: the bounds on the zone temperatures at the ends of the
horizon's periods (:func:`band_at_period_ends`) and the margins inside them the MPC plans
with (:func:`plan_band`; docs/explanation/model.md §3). Pure functions over arrays."""

from __future__ import annotations

import numpy as np

from hvacflex.config import ControllerConfig
from hvacflex.control.base import FloatArray
from hvacflex.data.forecast import Forecast

__all__ = ["band_at_period_ends", "comfort_bounds_at_period_ends", "controller_band", "plan_band"]


def comfort_bounds_at_period_ends(
    forecast: Forecast, horizon: int
) -> tuple[FloatArray, FloatArray]:
    """(N, m) comfort bounds on the temperatures x_1 … x_N at the ends of periods 0 … N−1:
    :func:`band_at_period_ends` of the forecast's band."""
    return band_at_period_ends(forecast.comfort_lower_degc, forecast.comfort_upper_degc, horizon)


def band_at_period_ends(
    lower_degc: FloatArray, upper_degc: FloatArray, horizon: int
) -> tuple[FloatArray, FloatArray]:
    """(N, m) comfort bounds [°C] on the temperatures at the ends of periods 0 … N−1 of the
    per-period band ``lower_degc``, ``upper_degc`` ((≥ N, m) [°C], one row a period).

    The end of period k is the start of period k + 1: the bound is the tighter of the two
    periods' bands. The band must cover ``horizon + 1`` periods; with exactly ``horizon``
    the last period's band is used alone.
    """
    lower, upper = np.asarray(lower_degc), np.asarray(upper_degc)
    nxt = slice(1, horizon + 1)
    lower_next = np.vstack([lower[nxt], lower[horizon - 1 : horizon]])[:horizon]
    upper_next = np.vstack([upper[nxt], upper[horizon - 1 : horizon]])[:horizon]
    return (
        np.maximum(lower[:horizon], lower_next),
        np.minimum(upper[:horizon], upper_next),
    )


def plan_band(
    forecast: Forecast,
    y_min: FloatArray,
    y_max: FloatArray,
    *,
    unoccupied_plan_margin_k: float,
    lower_plan_margin_k: float,
) -> tuple[FloatArray, FloatArray]:
    """(N, m) lower and upper bounds [°C] the plan keeps inside the band ``y_min … y_max``:

    * the upper bound with ``unoccupied_plan_margin_k`` [K] taken off where the end of
      period k is unoccupied (periods k and k + 1 both unoccupied), never below ``y_min``:
      the MPC plans below the night bound instead of riding it;
    * the lower bound raised by ``lower_plan_margin_k`` [K] everywhere; where that would
      pass the upper bound, the middle of the two (as :func:`tightened_bounds
      <hvacflex.control.estimation.tightened_bounds>` does): a plan that pre-cools stops
      short of the lower bound.

    Either way the plant's excursions past the plan stay inside the band, which itself
    (``comfort_*`` columns, what the KPIs grade) is unchanged. A band whose ``y_min`` lies
    above ``y_max`` stays so (the problem refuses it).

    Parameters
    ----------
    forecast : covers N + 1 periods (``occupied``); with exactly N the last is repeated.
    y_min, y_max : (N, m) the bounds on the period-end temperatures [°C].
    unoccupied_plan_margin_k, lower_plan_margin_k : ≥ 0 [K].
    """
    horizon = y_max.shape[0]
    occupied = np.asarray(forecast.occupied, dtype=bool)
    now = occupied[:horizon]
    nxt = np.concatenate([occupied[1 : horizon + 1], occupied[horizon - 1 : horizon]])[:horizon]
    night = ~(now | nxt)
    upper: FloatArray = np.where(
        night[:, None], np.maximum(y_max - unoccupied_plan_margin_k, y_min), y_max
    )
    raised = y_min + lower_plan_margin_k
    lower: FloatArray = np.where(raised <= upper, raised, np.maximum(0.5 * (y_min + upper), y_min))
    return lower, upper


def controller_band(
    forecast: Forecast, horizon: int, config: ControllerConfig
) -> tuple[FloatArray, FloatArray]:
    """(N, m) lower and upper bounds [°C] a controller's plan keeps: :func:`plan_band` of the
    forecast's comfort bounds at the period ends with ``config``'s margins."""
    return plan_band(
        forecast,
        *comfort_bounds_at_period_ends(forecast, horizon),
        unoccupied_plan_margin_k=config.unoccupied_plan_margin_k,
        lower_plan_margin_k=config.lower_plan_margin_k,
    )
