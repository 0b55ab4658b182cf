"""The aggregator's reserve product: one offer from every building's metered-visible offer,
the minimum bid, the dispatch of activations to the buildings and their settlement on each
building's meter (issue 62).

Each period every building's staged plan offers q₀·r₀ [kW] for the period; the part of it
its **own meter** would show (:func:`visible_offers_kw`: the baseline less the power the
plant's power model predicts at the curtailed flows, when that is smaller) is its share of
the fleet's offer. The fleet offers Σ_b of the shares
(:func:`aggregate_offer`); below the market's minimum bid (the fleet file's ``min_bid_mw``,
0.1 MW for Singapore's IL by default) nothing is bid. An accepted bid that the grid
operator activates is dispatched to the buildings by their shares (:func:`dispatched_kw`)
and each building is settled on its own meter against its own baseline, its delivery
capped at its share (:func:`building_delivery_kw`); the fleet's **delivery ratio** is
Σ delivered / Σ dispatched (:func:`delivery_ratio`). Offers per building per office-hour
period (:func:`offer_kpis`, :func:`offers_table`) size a fleet: the minimum bid over the
offer per building is the number of such buildings a bid needs.

Arrays: B buildings, T periods; powers in kW, per 30-min period.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hvacflex.control.base import FloatArray
from hvacflex.control.offers import BASELINE_TOLERANCE_KW
from hvacflex.fleet.bidding import bid_accepted
from hvacflex.settlement import settlement_columns

OFFICE_HOURS = (8, 18)
"""Office hours [h, local time]: a weekday period starting at 08:00 … 17:30 is an
office-hour period (20 a day) — when an office fleet has cooling to curtail."""

OFFERS_FILE = "offers.csv"
"""Per building and period: the metered-visible offer, the dispatched share and the
delivery on the building's meter (:func:`offers_table`)."""


@dataclass(frozen=True)
class FleetOffer:
    """The fleet's offer of one period.

    Attributes
    ----------
    offer_kw : Σ of the buildings' metered-visible offers [kW].
    bid_kw : what is bid: ``offer_kw`` when it clears the minimum bid, else 0 [kW].
    """

    offer_kw: float
    bid_kw: float

    @property
    def accepted(self) -> bool:
        """The bid was submitted (it cleared the minimum bid)."""
        return self.bid_kw > 0.0


def visible_offers_kw(
    offer_kw: FloatArray, curtailed_kw: FloatArray, baseline_kw: FloatArray
) -> FloatArray:
    """(B,) the part of each building's offer its own meter would show [kW].

    Parameters
    ----------
    offer_kw : (B,) the staged plans' first-period offers q₀·r₀ [kW].
    curtailed_kw : (B,) the power the building's meter would read in the period with the
        offer shed: the plant's power model at the curtailed flows u₀ − r₀ [kW]
        (:meth:`hvacflex.fleet.agent.FleetController.first_offer_kw`; not the LP's affine
        P₀ − p₀·r₀, whose secant over-states the shed).
    baseline_kw : (B,) each building's settlement baseline of an activation starting now
        [kW] (NaN: none, e.g. the run's first period: nothing is seen).

    Returns
    -------
    (B,) min(offer, baseline − curtailed), at least 0; 0 where anything is NaN.
    """
    offer = np.asarray(offer_kw, dtype=float)
    seen = (
        np.asarray(baseline_kw, dtype=float)
        + BASELINE_TOLERANCE_KW
        - np.asarray(curtailed_kw, dtype=float)
    )
    visible = np.clip(np.minimum(offer, seen), 0.0, None)
    return np.where(np.isfinite(visible), visible, 0.0)


def aggregate_offer(visible_kw: FloatArray, min_bid_kw: float) -> FleetOffer:
    """The fleet's offer: Σ of the buildings' visible offers (B,) [kW], bid only at or above
    the minimum bid [kW] (:func:`hvacflex.fleet.bidding.bid_accepted`)."""
    total = float(np.sum(visible_kw))
    return FleetOffer(total, total if bid_accepted(total, min_bid_kw) else 0.0)


def dispatched_kw(
    visible_kw: FloatArray, accepted: FloatArray, activated: FloatArray
) -> FloatArray:
    """(T, B) each building's share of an activation [kW]: its visible offer (T, B) where the
    fleet's bid was accepted (T,) and the grid operator activated the fleet (T,), else 0."""
    on = np.asarray(accepted, dtype=bool) & np.asarray(activated, dtype=bool)
    return np.where(on[:, None], np.asarray(visible_kw, dtype=float), 0.0)


def building_delivery_kw(
    power_kw: FloatArray,
    dispatched: FloatArray,
    activated: FloatArray,
    index: pd.DatetimeIndex,
    rule: str,
) -> FloatArray:
    """(T, B) what each building's meter shows delivered of its share [kW]: the settlement
    of :mod:`hvacflex.settlement` (max(0, baseline − metered) in activated periods, the
    baseline by ``rule`` from the building's own metered power (T, B)), capped at its
    dispatched share (T, B) — over-delivery is not paid."""
    power = np.asarray(power_kw, dtype=float)
    share = np.asarray(dispatched, dtype=float)
    flags = np.asarray(activated, dtype=bool)
    out = np.zeros_like(share)
    for b in range(power.shape[1]):
        frame = pd.DataFrame(
            {"power_kw": power[:, b], "reserve_kw": share[:, b], "il_activated": flags},
            index=index,
        )
        delivered = settlement_columns(frame, rule)["il_delivered_kw"].to_numpy(float)
        out[:, b] = np.minimum(np.nan_to_num(delivered), share[:, b])
    return out


def delivery_ratio(delivered: FloatArray, dispatched: FloatArray) -> float:
    """Σ delivered / Σ dispatched over every building and period (capped deliveries, so
    ≤ 1); NaN where nothing was dispatched."""
    total = float(np.sum(dispatched))
    return float(np.sum(delivered)) / total if total > 0.0 else float("nan")


def office_hours(index: pd.DatetimeIndex) -> np.ndarray:
    """(T,) bool: the periods of ``index`` (local time) in :data:`OFFICE_HOURS` on a
    weekday."""
    hours = index.hour + index.minute / 60.0
    start, end = OFFICE_HOURS
    return np.asarray((index.day_of_week < 5) & (hours >= start) & (hours < end), dtype=bool)


def offer_kpis(
    results: pd.DataFrame, buildings: int | None, min_bid_kw: float | None
) -> dict[str, float]:
    """The aggregator's KPIs of a fleet run's results (``fleet_offer_kw``, ``fleet_bid_kw``,
    ``il_dispatched_kw``, ``il_delivered_buildings_kw``): over the office-hour periods the
    fleet's offer and the offer per building [kW] (mean, min, max), the periods whose offer
    was bid (cleared the minimum), the buildings a bid needs at the mean offer per building
    (NaN without ``min_bid_kw``, offers or the number of ``buildings``); the dispatched
    and delivered energy [kWh] and the delivery ratio. Empty when the results have no
    offer column (an older run)."""
    if "fleet_offer_kw" not in results.columns:
        return {}
    office = office_hours(pd.DatetimeIndex(results.index))
    offer = results["fleet_offer_kw"].to_numpy(float)[office]
    per_building = offer / buildings if buildings else np.full(offer.shape, np.nan)
    dt_h = _period_h(results.index)
    dispatched = results["il_dispatched_kw"].to_numpy(float)
    delivered = results["il_delivered_buildings_kw"].to_numpy(float)
    mean_per_building = float(np.mean(per_building)) if offer.size else float("nan")
    needed = (
        float(np.ceil(min_bid_kw / mean_per_building))
        if min_bid_kw is not None and mean_per_building > 0
        else float("nan")
    )

    def stat(values: np.ndarray, how: str) -> float:
        return float(getattr(np, how)(values)) if values.size else float("nan")

    return {
        "office_periods": int(office.sum()),
        "office_periods_bid": int(np.sum(results["fleet_bid_kw"].to_numpy(float)[office] > 0)),
        "fleet_offer_office_kw_mean": stat(offer, "mean"),
        "fleet_offer_office_kw_max": stat(offer, "max"),
        "offer_per_building_office_kw_mean": mean_per_building,
        "offer_per_building_office_kw_min": stat(per_building, "min"),
        "offer_per_building_office_kw_max": stat(per_building, "max"),
        "buildings_for_min_bid": needed,
        "il_dispatched_kwh": float(np.sum(dispatched) * dt_h),
        "il_delivered_buildings_kwh": float(np.sum(delivered) * dt_h),
        "delivery_ratio": delivery_ratio(delivered, dispatched),
    }


def _period_h(index: pd.Index) -> float:
    """The periods' length [h] (30 min where the index has fewer than two periods)."""
    if isinstance(index, pd.DatetimeIndex) and len(index) > 1:
        return float((index[1] - index[0]) / pd.Timedelta(hours=1))
    return 0.5


def offers_table(
    index: pd.DatetimeIndex,
    names: Sequence[str],
    visible: FloatArray,
    dispatched: FloatArray,
    delivered: FloatArray,
) -> pd.DataFrame:
    """The long table of :data:`OFFERS_FILE`: one row per period and building — ``time``,
    ``building``, ``office_hours``, ``offer_kw`` (metered-visible), ``dispatched_kw``,
    ``delivered_kw`` (on the building's meter, capped at its share); arrays (T, B) [kW]."""
    steps, count = np.asarray(visible).shape
    return pd.DataFrame(
        {
            "time": np.repeat(index, count),
            "building": np.tile(np.asarray(names, dtype=object), steps),
            "office_hours": np.repeat(office_hours(index), count),
            "offer_kw": np.asarray(visible, dtype=float).ravel(),
            "dispatched_kw": np.asarray(dispatched, dtype=float).ravel(),
            "delivered_kw": np.asarray(delivered, dtype=float).ravel(),
        }
    )
