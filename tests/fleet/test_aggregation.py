"""The aggregator's offer, dispatch and settlement on the buildings' meters, by hand."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacflex.constants import TIMEZONE
from hvacflex.fleet.aggregation import (
    OFFICE_HOURS,
    aggregate_offer,
    building_delivery_kw,
    delivery_ratio,
    dispatched_kw,
    offer_kpis,
    offers_table,
    office_hours,
    visible_offers_kw,
)


def test_each_building_offers_what_its_own_meter_would_show() -> None:
    offer = np.array([10.0, 10.0, 10.0, 5.0])
    curtailed = np.array([90.0, 95.0, 120.0, 50.0])  # the meter's power with the offer shed
    baseline = np.array([100.0, 100.0, 100.0, np.nan])
    visible = visible_offers_kw(offer, curtailed, baseline)
    # 100 − 90 ≥ 10: all; 100 − 95 = 5 seen; curtailed above the baseline: nothing;
    # no baseline (nothing metered): nothing
    np.testing.assert_allclose(visible, [10.0, 5.0, 0.0, 0.0], atol=1e-5)


def test_the_aggregate_is_bid_only_at_or_above_the_minimum() -> None:
    shares = np.full(200, 0.5)  # 200 buildings × 0.5 kW = 100 kW = the 0.1 MW minimum
    offer = aggregate_offer(shares, 100.0)
    assert offer.offer_kw == pytest.approx(100.0) and offer.bid_kw == offer.offer_kw
    assert offer.accepted
    short = aggregate_offer(shares[:199], 100.0)
    assert short.offer_kw == pytest.approx(99.5)
    assert short.bid_kw == 0.0 and not short.accepted


def _index(steps: int, start: str = "2014-03-03 10:00") -> pd.DatetimeIndex:
    return pd.date_range(start, periods=steps, freq="30min", tz=TIMEZONE)


def test_activations_are_dispatched_by_share_and_settled_on_each_meter() -> None:
    visible = np.array([[4.0, 6.0], [3.0, 2.0], [5.0, 5.0], [1.0, 1.0]])
    accepted = np.array([True, True, False, True])
    activated = np.array([False, True, True, True])
    shares = dispatched_kw(visible, accepted, activated)
    np.testing.assert_array_equal(shares, [[0, 0], [3.0, 2.0], [0, 0], [1.0, 1.0]])
    # metered power; pre-event baseline = the period before the event (100 and 50 kW)
    power = np.array([[100.0, 50.0], [98.5, 47.0], [97.0, 49.0], [99.5, 52.0]])
    delivered = building_delivery_kw(power, shares, activated, _index(4), "pre-event")
    # building 0: 1.5 of 3 (short), 0 of 0, 0.5 of 1; building 1: 3 capped at 2, 0, 0 of 1
    np.testing.assert_allclose(delivered, [[0, 0], [1.5, 2.0], [0, 0], [0.5, 0.0]])
    assert delivery_ratio(delivered, shares) == pytest.approx(4.0 / 7.0)
    assert np.isnan(delivery_ratio(np.zeros(3), np.zeros(3)))


def test_office_hours_are_weekday_periods_from_8_to_18() -> None:
    day = _index(48 * 7, "2014-03-03 00:00")  # Monday … Sunday
    office = office_hours(day)
    start, end = OFFICE_HOURS
    assert office.sum() == 5 * 2 * (end - start)
    assert office[2 * start] and not office[2 * start - 1] and not office[2 * end]
    assert not office[5 * 48 :].any()


def _results(offer_kw: np.ndarray, bid_kw: np.ndarray) -> pd.DataFrame:
    index = _index(len(offer_kw), "2014-03-03 07:00")
    return pd.DataFrame(
        {
            "fleet_offer_kw": offer_kw,
            "fleet_bid_kw": bid_kw,
            "il_dispatched_kw": np.where(bid_kw > 0, offer_kw, 0.0),
            "il_delivered_buildings_kw": 0.9 * np.where(bid_kw > 0, offer_kw, 0.0),
        },
        index=index,
    )


def test_offer_kpis_by_hand() -> None:
    # 07:00, 07:30 (not office hours), 08:00 … 09:30
    offer = np.array([500.0, 500.0, 40.0, 80.0, 120.0, 160.0])
    bid = np.where(offer >= 100.0, offer, 0.0)
    kpis = offer_kpis(_results(offer, bid), buildings=40, min_bid_kw=100.0)
    assert kpis["office_periods"] == 4
    assert kpis["office_periods_bid"] == 2  # 120 and 160 kW (07:00–07:30 left out)
    assert kpis["fleet_offer_office_kw_mean"] == pytest.approx(100.0)
    assert kpis["fleet_offer_office_kw_max"] == pytest.approx(160.0)
    assert kpis["offer_per_building_office_kw_mean"] == pytest.approx(2.5)
    assert kpis["offer_per_building_office_kw_min"] == pytest.approx(1.0)
    assert kpis["offer_per_building_office_kw_max"] == pytest.approx(4.0)
    assert kpis["buildings_for_min_bid"] == 40.0  # 100 kW / 2.5 kW
    dispatched = (500 + 500 + 120 + 160) * 0.5
    assert kpis["il_dispatched_kwh"] == pytest.approx(dispatched)
    assert kpis["il_delivered_buildings_kwh"] == pytest.approx(0.9 * dispatched)
    assert kpis["delivery_ratio"] == pytest.approx(0.9)
    unknown = offer_kpis(_results(offer, bid), buildings=None, min_bid_kw=100.0)
    assert np.isnan(unknown["offer_per_building_office_kw_mean"])
    assert np.isnan(unknown["buildings_for_min_bid"])
    assert offer_kpis(pd.DataFrame({"x": [1.0]}), buildings=1, min_bid_kw=None) == {}


def test_offers_table_is_long_by_period_and_building() -> None:
    index = _index(2, "2014-03-03 07:30")
    visible = np.array([[1.0, 2.0], [3.0, 4.0]])
    table = offers_table(index, ["a", "b"], visible, visible * 0.5, visible * 0.25)
    assert table["building"].tolist() == ["a", "b", "a", "b"]
    assert table["office_hours"].tolist() == [False, False, True, True]
    assert table.groupby("time")["offer_kw"].sum().tolist() == [3.0, 7.0]
    np.testing.assert_allclose(table["delivered_kw"], [0.25, 0.5, 0.75, 1.0])
