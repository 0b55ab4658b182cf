"""Verdicts follow the numbers: hand-made KPIs flip each one, with the numbers in the text."""

from __future__ import annotations

import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.report import verdicts as v

BASIS = "RC plant, 7 days"


def test_robustness_premium_is_a_few_per_cent() -> None:
    held = v.robustness_premium(100.0, 103.0, BASIS)
    assert held.verdict == v.HOLDS and "+3.0 %" in held.ours and held.basis == BASIS
    assert "+4.0 %" in held.paper  # 1,530 / 1,471 − 1
    assert v.robustness_premium(100.0, 99.0, BASIS).verdict == v.DOES_NOT_HOLD  # cheaper
    assert v.robustness_premium(100.0, 125.0, BASIS).verdict == v.DOES_NOT_HOLD  # not "a few"


def test_peak_price_costs_more_and_lowers_the_peak() -> None:
    assert v.peak_price_costs_more(100.0, 109.0, BASIS).verdict == v.HOLDS
    assert v.peak_price_costs_more(100.0, 100.0, BASIS).verdict == v.DOES_NOT_HOLD
    lowered = v.peak_price_lowers_peak(43.7, 36.0, BASIS)
    assert lowered.verdict == v.HOLDS and "43.7 → 36.0 kW" in lowered.ours
    assert "-17.6 %" in lowered.ours  # 36.0 / 43.7 − 1
    assert v.peak_price_lowers_peak(40.0, 41.0, BASIS).verdict == v.DOES_NOT_HOLD


def test_robust_keeps_comfort_needs_a_violating_nominal_mpc() -> None:
    assert v.robust_keeps_comfort(3.32, 0.0, BASIS).verdict == v.HOLDS
    assert v.robust_keeps_comfort(3.32, 0.3, BASIS).verdict == v.HOLDS  # ≤ 10 % of NMPC's
    assert v.robust_keeps_comfort(3.32, 1.0, BASIS).verdict == v.DOES_NOT_HOLD
    assert v.robust_keeps_comfort(0.005, 0.0, BASIS).verdict == v.DOES_NOT_HOLD  # NMPC kept it


def test_reserve_revenue_rises_or_is_not_comparable() -> None:
    fell = v.reserve_revenue_rises(7.93, 6.23, 3.98, BASIS)
    assert fell.verdict == v.DOES_NOT_HOLD
    assert "(b) -21.4 %" in fell.ours and "(c) -49.8 %" in fell.ours
    assert "(b) +1.8 %" in fell.paper and "(c) +12.1 %" in fell.paper  # Table 1's values
    assert v.reserve_revenue_rises(1.0, 1.1, 1.2, BASIS).verdict == v.HOLDS
    # a rise within the 0.1 % of noise (report.text.SAME_RELATIVE) is no rise
    assert v.reserve_revenue_rises(1.0, 1.0005, 1.2, BASIS).verdict == v.DOES_NOT_HOLD
    assert v.reserve_revenue_rises(0.0, 1.0, 1.0, BASIS).verdict == v.NOT_COMPARABLE


def test_peak_reduction_saturates_beyond_five() -> None:
    # 43.0 → 32.5 kW over the sweep, 43.0 → 34.9 by φ = 5: 77 % of the reduction
    held = v.peak_reduction_saturates([0.5, 1.5, 5.0, 30.0], [43.0, 36.0, 34.9, 32.5], BASIS)
    assert held.verdict == v.HOLDS and "77 %" in held.ours
    late = v.peak_reduction_saturates([30.0, 0.5, 5.0], [20.0, 43.0, 40.0], BASIS)
    assert late.verdict == v.DOES_NOT_HOLD  # 3 of 23 kW by φ = 5 (order does not matter)
    assert v.peak_reduction_saturates([0.5, 1.5], [43.0, 36.0], BASIS).verdict == (v.NOT_COMPARABLE)
    flat = v.peak_reduction_saturates([0.5, 5.0, 30.0], [40.0, 40.0, 40.0], BASIS)
    assert flat.verdict == v.DOES_NOT_HOLD and "no reduction" in flat.ours
    # EnergyPlus office5, 28 days (docs/explanation/reproduction.md): −0.1 kW end to end is no
    # reduction, though the −1.9 kW at φ = 5 is "2,400 %" of it
    tiny = v.peak_reduction_saturates(
        [0.5, 1.5, 5.0, 15.0, 30.0], [52.52, 50.97, 50.57, 52.43, 52.44], BASIS
    )
    assert tiny.verdict == v.DOES_NOT_HOLD and "no reduction" in tiny.ours


def test_level_and_reserve_share_are_not_comparable() -> None:
    assert v.cost_level(1107.81, BASIS).verdict == v.NOT_COMPARABLE
    share = v.reserve_share(7.93, 1107.81, BASIS)
    assert share.verdict == v.NOT_COMPARABLE and "0.72 %" in share.ours and "1.04 %" in share.paper


def test_verdict_table_and_unknown_verdicts() -> None:
    table = v.verdict_table([v.robustness_premium(1.0, 1.02, BASIS), v.cost_level(2.0, BASIS)])
    assert list(table.columns) == list(v.VERDICT_COLUMNS[1:]) and table.index.name == "finding"
    assert list(table["verdict"]) == [v.HOLDS, v.NOT_COMPARABLE]
    with pytest.raises(InputError, match="unknown verdict"):
        v.Verdict("f", "p", "o", "maybe", BASIS, key="f")


def _pay_table() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "controller": ["(b) RMPC", "(c) RMPC + PPP", "(b) RMPC, whole-horizon"],
            "energy_cost_sgd_per_month": [1123.29, 1212.37, 1123.29],
            "reserve_settled_sgd_per_month": [1.0, 0.0, 0.0],
            "reserve_unsettled_sgd_per_month": [5.23, 3.98, 0.0],
            "peak_charge_sgd_per_month": [65.55, 54.0, 65.55],
            "tariff_cost_sgd_per_month": [1187.84, 1266.37, 1188.84],
            "peak_power_kw": [43.7, 36.0, 43.7],
            "saving_vs_reference_sgd_per_month": [100.0, 20.0, 94.0],
            "reference": ["thermostat-25.5"] * 3,
        }
    )


def test_answers_come_from_the_does_it_pay_table() -> None:
    table = _pay_table()
    shaving = v.peak_shaving_answer(table, "(c) RMPC + PPP", "(b) RMPC")
    assert shaving.startswith("Does peak shaving pay? No")
    assert "1,266.37 SGD/month against 1,187.84" in shaving and "thermostat-25.5" in shaving
    reserve = v.reserve_answer(table, "(b) RMPC", "(b) RMPC, whole-horizon")
    assert reserve.startswith("Does selling reserve work? Yes, a little")
    assert "6.23 SGD/month of reserve revenue" in reserve
    assert "1.00 of it settled against the meter and 5.23 unsettled" in reserve
    assert "1.00 SGD/month cheaper" in reserve and "6.23 SGD/month cheaper." in reserve
    # nothing settled: the tariff cost ties; only the availability payments make it cheaper
    table.loc[0, ["reserve_settled_sgd_per_month", "tariff_cost_sgd_per_month"]] = [0.0, 1188.84]
    table.loc[0, "reserve_unsettled_sgd_per_month"] = 6.23
    reserve = v.reserve_answer(table, "(b) RMPC", "(b) RMPC, whole-horizon")
    assert reserve.startswith("Does selling reserve work? Only on availability payments")
    table.loc[1, "tariff_cost_sgd_per_month"] = 1100.0
    assert v.peak_shaving_answer(table, "(c) RMPC + PPP", "(b) RMPC").startswith(
        "Does peak shaving pay? Yes"
    )
    with pytest.raises(InputError, match="not in the does-it-pay table"):
        v.reserve_answer(table, "(a) NMPC", "(b) RMPC")
