"""The OpenADR 2.0b mapping of ``serve openadr-ven``: hand-computed cases."""

from __future__ import annotations

from datetime import timedelta
from typing import Any

import pandas as pd
import pytest
from openadr_events import HALF_HOUR, OFFSET, SERVICE_T0, T0, make_plan, make_signal

from hvacflex.service.openadr_mapping import (
    OPT_IN,
    OPT_OUT,
    EventRefused,
    activation_runs,
    capacity_key,
    capacity_limit_windows,
    decide_dispatch,
    demand_charge_sgd_per_kw,
    dispatched_periods,
    energy_prices,
    event_buildings,
    is_capacity_limit,
    to_service_time,
    to_vtn_time,
)


def test_the_clock_offset_maps_vtn_times_onto_the_2014_calendar_and_back() -> None:
    assert OFFSET == pd.Timestamp("2014-03-03T01:30Z") - pd.Timestamp("2026-12-01T12:00Z")
    assert to_service_time(T0, OFFSET) == SERVICE_T0
    assert to_vtn_time("2014-03-03T09:30:00+08:00", OFFSET) == T0
    assert to_vtn_time("2014-03-03T10:00:00", OFFSET) == T0 + HALF_HOUR  # no offset: Singapore


def test_prices_in_sgd_per_kwh_become_sgd_per_mwh_per_period() -> None:
    start, prices = energy_prices(make_signal("ELECTRICITY_PRICE", "price", [0.1, 0.25]), OFFSET)
    assert start == SERVICE_T0
    assert prices == pytest.approx([100.0, 250.0])
    # an interval of an hour is two periods; a scale of milli multiplies by 1e-3
    signal = make_signal(
        "ENERGY_PRICE", "price", [120.0], measurement={"unit": "SGD", "scale": "m"}
    )
    signal["intervals"][0]["duration"] = timedelta(hours=1)
    assert energy_prices(signal, OFFSET) == (SERVICE_T0, pytest.approx([120.0, 120.0]))


@pytest.mark.parametrize(
    ("signal", "reason"),
    [
        (make_signal("ELECTRICITY_PRICE", "priceRelative", [0.1]), "only absolute prices"),
        (make_signal("ELECTRICITY_PRICE", "price", [0.1], measurement={"unit": "USD"}), "USD"),
        (
            {
                **make_signal("ELECTRICITY_PRICE", "price", [0.1]),
                "intervals": [
                    {"dtstart": T0, "duration": HALF_HOUR, "signal_payload": 0.1},
                    {"dtstart": T0 + 2 * HALF_HOUR, "duration": HALF_HOUR, "signal_payload": 0.1},
                ],
            },
            "gaps",
        ),
        (
            {
                **make_signal("ELECTRICITY_PRICE", "price", [0.1]),
                "intervals": [
                    {"dtstart": T0, "duration": timedelta(minutes=15), "signal_payload": 0.1}
                ],
            },
            "30-min",
        ),
    ],
    ids=["relative", "currency", "gap", "15-min"],
)
def test_prices_the_service_cannot_take_are_refused(signal: dict[str, Any], reason: str) -> None:
    with pytest.raises(EventRefused, match=reason):
        energy_prices(signal, OFFSET)


def test_a_demand_charge_is_one_phi() -> None:
    assert demand_charge_sgd_per_kw(make_signal("DEMAND_CHARGE", "price", [3.5, 3.5])) == 3.5
    with pytest.raises(EventRefused, match="one φ"):
        demand_charge_sgd_per_kw(make_signal("DEMAND_CHARGE", "price", [3.5, 4.0]))


def test_dispatched_periods_and_their_activation_runs() -> None:
    periods = dispatched_periods(make_signal("SIMPLE", "level", [1, 2, 0, 1]), OFFSET)
    half = pd.Timedelta(minutes=30)
    assert periods == [SERVICE_T0, SERVICE_T0 + half, SERVICE_T0 + 3 * half]
    assert activation_runs(periods) == [
        (SERVICE_T0, SERVICE_T0 + 2 * half),
        (SERVICE_T0 + 3 * half, SERVICE_T0 + 4 * half),
    ]


def test_only_buildings_that_offered_every_dispatched_period_are_activated() -> None:
    periods = dispatched_periods(make_signal("LOAD_DISPATCH", "delta", [5.0, 5.0]), OFFSET)
    plans = {
        "full": make_plan([2.0, 3.0, 0.0]),
        "partial": make_plan([2.0, 0.0, 4.0]),
        "none": None,
    }
    decision = decide_dispatch(periods, plans)
    assert decision.activated == ("full",)
    assert decision.opt == OPT_IN
    assert "1 period(s): 2014-03-03T10:00:00+08:00" in decision.refused["partial"]
    assert "2 period(s)" in decision.refused["none"]
    partial_only = decide_dispatch(periods, {"partial": plans["partial"]})
    assert partial_only.activated == () and partial_only.opt == OPT_OUT


def test_an_event_targets_the_named_buildings_else_all() -> None:
    ours = ("b1", "b2")
    assert event_buildings({"targets": [{"resource_id": "b2"}]}, ours) == ("b2",)
    assert event_buildings({"targets": [{"ven_id": "ven-1"}]}, ours) == ours
    assert event_buildings({"targets": [{"resource_id": "elsewhere"}]}, ours) == ()


def test_a_capacity_limit_is_a_load_setpoint_and_becomes_windows_of_equal_limits() -> None:
    limit = make_signal("LOAD_DISPATCH", "setpoint", [300.0, 300.0, 250.0, 300.0])
    assert is_capacity_limit(limit)
    assert not is_capacity_limit(make_signal("LOAD_DISPATCH", "delta", [5.0]))  # a dispatch
    assert not is_capacity_limit(make_signal("SIMPLE", "setpoint", [1.0]))
    windows = capacity_limit_windows(limit, OFFSET)
    start = SERVICE_T0  # 09:30 service time
    at = [(start + j * pd.Timedelta(minutes=30)).isoformat() for j in range(5)]
    assert windows == [
        {"start": at[0], "end": at[2], "limit_kw": 300.0},
        {"start": at[2], "end": at[3], "limit_kw": 250.0},
        {"start": at[3], "end": at[4], "limit_kw": 300.0},
    ]


def test_a_capacity_limit_in_watts_is_scaled_to_kw_and_a_bad_one_refused() -> None:
    in_w = make_signal(
        "LOAD_DISPATCH", "setpoint", [0.4], measurement={"unit": "W", "scale": "M"}
    )  # 0.4 MW
    assert capacity_limit_windows(in_w, OFFSET)[0]["limit_kw"] == pytest.approx(400.0)
    with pytest.raises(EventRefused, match="must be > 0"):
        capacity_limit_windows(make_signal("LOAD_DISPATCH", "setpoint", [100.0, 0.0]), OFFSET)
    in_a = make_signal("LOAD_DISPATCH", "setpoint", [1.0], measurement={"unit": "A"})
    with pytest.raises(EventRefused, match="'A'"):
        capacity_limit_windows(in_a, OFFSET)


def test_a_capacity_signal_is_stored_under_its_event_and_signal() -> None:
    assert capacity_key("e1", {"signal_id": "s9"}, 0) == "e1/s9"
    assert capacity_key("e1", {}, 2) == "e1/2"
