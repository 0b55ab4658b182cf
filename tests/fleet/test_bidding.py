"""The fleet's bid against the minimum, and its settlement on the fleet's meter."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacflex.fleet.bidding import MIN_BID_FLOOR_KW, bid_accepted, settle_fleet


def test_the_minimum_bid_by_hand() -> None:
    assert bid_accepted(10.0, 10.0) and not bid_accepted(9.99, 10.0)
    assert not bid_accepted(1e-4, 0.0)  # round-off is no bid
    assert bid_accepted(MIN_BID_FLOOR_KW, 0.0)


def test_the_fleet_is_settled_on_its_metered_power_by_hand() -> None:
    """Pre-event: the baseline is the fleet's meter in the period before the activation; a
    period delivering 30 kW of a 40 kW bid falls 10 kW short."""
    index = pd.date_range("2014-03-03 10:00", periods=4, freq="30min", tz="Asia/Singapore")
    frame = pd.DataFrame(
        {
            "fleet_power_kw": [500.0, 470.0, 460.0, 520.0],
            "settled_reserve_kw": [0.0, 40.0, 30.0, 0.0],
            "il_activated": [False, True, True, False],
        },
        index=index,
    )
    settled = settle_fleet(frame, "pre-event")
    np.testing.assert_allclose(settled["il_baseline_power_kw"].to_numpy()[1:3], [500.0, 500.0])
    np.testing.assert_allclose(settled["il_delivered_kw"], [0.0, 30.0, 40.0, 0.0])
    np.testing.assert_allclose(settled["il_shortfall_kw"], [0.0, 10.0, 0.0, 0.0])
    assert np.isnan(settled["il_baseline_power_kw"].iloc[0])
    assert settled["fleet_power_kw"].equals(frame["fleet_power_kw"])
    with pytest.raises(KeyError):
        settle_fleet(frame.drop(columns="settled_reserve_kw"), "pre-event")
