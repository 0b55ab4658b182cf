"""Settlement against metered power (hvacflex.settlement) on hand-made series."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacflex import kpi, settlement
from hvacflex.errors import ConfigError

TZ = "Asia/Singapore"


def _frame(power_kw: list[float], reserve_kw: list[float], activated: list[bool]) -> pd.DataFrame:
    index = pd.date_range("2014-03-03 09:00", periods=len(power_kw), freq="30min", tz=TZ)
    return pd.DataFrame(
        {"power_kw": power_kw, "reserve_kw": reserve_kw, "il_activated": activated},
        index=index,
    )


def test_a_two_period_event_is_settled_against_the_period_before() -> None:
    # baseline 20 kW (period 1) held for periods 2–3; metered 14 and 16 kW; offers 5 kW
    frame = _frame([18.0, 20.0, 14.0, 16.0, 21.0], [5.0] * 5, [False, False, True, True, False])
    out = settlement.settlement_columns(frame)
    np.testing.assert_allclose(
        out["il_baseline_power_kw"].to_numpy(), [np.nan, np.nan, 20.0, 20.0, np.nan]
    )
    # delivered 6 (more than the 5 offered: not capped) and 4 kW; shortfall 0 and 1 kW
    np.testing.assert_allclose(out["il_delivered_kw"].to_numpy(), [0, 0, 6, 4, 0])
    np.testing.assert_allclose(out["il_shortfall_kw"].to_numpy(), [0, 0, 0, 1, 0])


def test_a_partial_shortfall_is_charged_at_the_penalty_and_forfeits_its_payment() -> None:
    frame = _frame([30.0, 27.0, 29.0], [0.0, 4.0, 4.0], [False, True, True])
    frame["reserve_price_sgd_per_mwh"] = 20.0
    frame["il_penalty_price_sgd_per_mwh"] = 4500.0
    frame["il_forfeited_price_sgd_per_mwh"] = 20.0
    for name, column in settlement.settlement_columns(frame).items():
        frame[name] = column
    # delivered 3 and 1 kW of 4: short 1 + 3 = 4 kW for 0.5 h = 2 kWh
    assert kpi.il_shortfall_kwh(frame) == pytest.approx(2.0)
    assert kpi.il_delivered_metered_kwh(frame) == pytest.approx(2.0)
    assert kpi.il_offered_kwh(frame) == pytest.approx(4.0)
    # 2 kWh × (4500 + 20) SGD/MWh
    assert kpi.il_penalty_sgd(frame) == pytest.approx(2.0 * 4520.0 / 1000.0)
    frame["il_forfeited_price_sgd_per_mwh"] = 0.0  # a contract that keeps the payment
    assert kpi.il_penalty_sgd(frame) == pytest.approx(2.0 * 4.5)


def test_an_air_handler_off_before_the_event_delivers_nothing() -> None:
    # the AHU was off at 07:00 (0.4 kW of controls); at 07:30 the pull-down runs at 25 kW
    # although it was curtailed by the 6 kW offered: metered above the baseline
    frame = _frame([0.4, 25.0, 30.0], [6.0, 6.0, 0.0], [False, True, False])
    out = settlement.settlement_columns(frame)
    assert out["il_baseline_power_kw"].iloc[1] == pytest.approx(0.4)
    assert out["il_delivered_kw"].iloc[1] == 0.0
    assert out["il_shortfall_kw"].iloc[1] == pytest.approx(6.0)


def test_an_event_in_the_first_period_has_no_baseline() -> None:
    out = settlement.settlement_columns(_frame([10.0, 12.0], [2.0, 2.0], [True, False]))
    assert np.isnan(out["il_baseline_power_kw"].iloc[0])
    assert out["il_delivered_kw"].iloc[0] == 0.0 and out["il_shortfall_kw"].iloc[0] == 2.0


def test_two_events_each_hold_their_own_pre_event_power() -> None:
    activated = np.array([False, True, False, False, True, True])
    baseline = settlement.pre_event_baseline_kw(np.array([5.0, 1.0, 2.0, 8.0, 3.0, 4.0]), activated)
    np.testing.assert_allclose(baseline, [np.nan, 5.0, np.nan, np.nan, 8.0, 8.0])


def test_similar_days_average_the_same_period_of_earlier_days_of_the_same_kind() -> None:
    # Thursday 2014-03-06 … Tuesday 03-11, one period a day at 10:00; the event on Tuesday:
    # earlier weekdays Thu, Fri, Mon (Sat and Sun are not similar)
    index = pd.DatetimeIndex(
        [pd.Timestamp(f"2014-03-{day:02d} 10:00", tz=TZ) for day in (6, 7, 8, 9, 10, 11)]
    )
    power = np.array([10.0, 12.0, 3.0, 3.0, 14.0, 9.0])
    activated = np.array([False, False, False, False, False, True])
    baseline = settlement.similar_days_baseline_kw(power, activated, index)
    assert baseline[5] == pytest.approx((10.0 + 12.0 + 14.0) / 3)
    # only the last two similar days
    assert settlement.similar_days_baseline_kw(power, activated, index, days=2)[5] == (
        pytest.approx((12.0 + 14.0) / 2)
    )
    # a similar day on which the same period was activated is left out
    activated[4] = True
    twice = settlement.similar_days_baseline_kw(power, activated, index)
    assert twice[5] == pytest.approx(11.0)
    # Monday's event has Thursday and Friday before it
    assert twice[4] == pytest.approx(11.0)
    # a weekday with no similar day in the run: the pre-event rule (Sunday's 3 kW)
    weekend_first = settlement.similar_days_baseline_kw(
        power[2:5], np.array([False, False, True]), index[2:5]
    )
    assert weekend_first[2] == pytest.approx(3.0)


def test_an_unknown_baseline_rule_is_a_config_error() -> None:
    frame = _frame([1.0], [0.0], [False])
    with pytest.raises(ConfigError, match="baseline"):
        settlement.settlement_columns(frame, "yesterday")


def test_the_baseline_of_an_activation_starting_now_uses_only_the_history() -> None:
    index = pd.date_range("2014-03-03 00:00", periods=3 * 48 + 21, freq="30min", tz=TZ)
    power = np.arange(len(index) - 1, dtype=float)  # the history before the coming period
    activated = np.zeros(len(power), dtype=bool)
    assert np.isnan(settlement.start_baseline_kw("pre-event", power[:0], activated[:0], index[:1]))
    assert settlement.start_baseline_kw("pre-event", power, activated, index) == power[-1]
    # Thursday 10:00 (period 3·48 + 20 = 164): Mon, Tue, Wed at 10:00 → 20, 68, 116
    now = len(index) - 1
    assert index[now].hour == 10 and index[now].minute == 0
    expected = np.mean([now - 48 * d for d in (1, 2, 3)])
    similar = settlement.start_baseline_kw("similar-days", power, activated, index)
    assert similar == pytest.approx(expected)


def test_the_coming_periods_similar_days_baselines_are_known_before_they_start() -> None:
    # Mon 2014-03-03 00:00 … Wed 23:30 of history, then the 3 coming periods Thu 00:00–01:00
    index = pd.date_range("2014-03-03 00:00", periods=3 * 48 + 3, freq="30min", tz=TZ)
    power = np.arange(3 * 48, dtype=float)
    activated = np.zeros(3 * 48, dtype=bool)
    activated[2 * 48 + 1] = True  # Wednesday 00:30 was activated: not a similar day's reading
    ahead = settlement.ahead_baselines_kw("similar-days", power, activated, index)
    assert ahead is not None
    np.testing.assert_allclose(
        ahead, [np.mean([0, 48, 96]), np.mean([1, 49]), np.mean([2, 50, 98])]
    )
    # whenever an activation covering Thursday 00:30 starts, the settlement sees the same
    history = np.append(power, [np.nan, np.nan])
    for start in (3 * 48, 3 * 48 + 1):
        covering = np.append(activated, [True, True]) & (np.arange(len(history)) >= start)
        covering[: 3 * 48] = activated
        settled = settlement.similar_days_baseline_kw(history, covering, index[:-1])
        assert settled[3 * 48 + 1] == pytest.approx(ahead[1])
    # the pre-event rule fixes nothing ahead; with no similar day yet: NaN
    assert settlement.ahead_baselines_kw("pre-event", power, activated, index) is None
    first_day = settlement.ahead_baselines_kw(
        "similar-days", power[:10], activated[:10], index[:12]
    )
    assert first_day is not None and np.isnan(first_day).all()
