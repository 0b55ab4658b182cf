"""KPIs on small hand-made series whose answers are computed by hand in each test."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex import kpi
from hvacflex.errors import DataError

TZ = "Asia/Singapore"


def results_frame(
    n: int,
    *,
    start: str = "2014-03-03 00:00",
    freq: str = "30min",
    power_kw: float | list[float] = 10.0,
    energy_price: float | list[float] = 100.0,
    reserve_kw: float | list[float] = 0.0,
    reserve_price: float | list[float] = 0.0,
    peak_price: float | list[float] = 0.0,
    temp_end: dict[str, list[float]] | None = None,
    lower: float | list[float] = 23.0,
    upper: float | list[float] = 26.0,
) -> pd.DataFrame:
    """A results frame following docs/reference/results.md with the given
    columns."""
    index = pd.date_range(start, periods=n, freq=freq, tz=TZ, name="time")
    temp_end = temp_end or {"north": [24.0] * n, "core": [24.5] * n}
    columns: dict[str, object] = {
        "energy_price_sgd_per_mwh": energy_price,
        "reserve_price_sgd_per_mwh": reserve_price,
        "peak_price_sgd_per_kw": peak_price,
        "power_kw": power_kw,
        "power_served_kw": power_kw,
        "power_curtailed_kw": power_kw,
        "reserve_kw": reserve_kw,
        "il_activated": False,
    }
    for zone, temps in temp_end.items():
        columns[f"flow_{zone}_kg_s"] = 0.5
        columns[f"reserve_flow_{zone}_kg_s"] = 0.0
        columns[f"temp_{zone}_degc"] = temps
        columns[f"temp_end_{zone}_degc"] = temps
        columns[f"comfort_lower_{zone}_degc"] = lower
        columns[f"comfort_upper_{zone}_degc"] = upper
    columns |= {
        "d_outdoor_temp": 30.0,
        "w_outdoor_temp": 0.0,
        "solve_status": "optimal",
        "solve_time_s": 0.01,
        "fallback": False,
        "planned_slack_max_k": 0.0,
        "delta_max_k": 0.0,
    }
    return pd.DataFrame(
        {k: (v if isinstance(v, list) else [v] * n) for k, v in columns.items()}, index=index
    )


# ------------------------------------------------------------------------ structure


def test_zone_names_skip_end_served_curtailed_columns() -> None:
    df = results_frame(2, temp_end={"north": [24.0, 24.0], "core": [24.0, 24.0]})
    df["temp_served_north_degc"] = 24.0
    df["temp_curtailed_north_degc"] = 25.0
    assert kpi.zone_names(df) == ["north", "core"]


def test_step_hours_from_index_spacing_and_default() -> None:
    assert kpi.step_hours(results_frame(3)) == 0.5
    assert kpi.step_hours(results_frame(3, freq="15min")) == 0.25
    assert kpi.step_hours(results_frame(3).reset_index(drop=True)) == kpi.DEFAULT_STEP_H


def test_missing_column_names_the_column() -> None:
    df = results_frame(2).drop(columns="reserve_kw")
    with pytest.raises(DataError, match="reserve_kw"):
        kpi.reserve_revenue_sgd(df)


# ------------------------------------------------------------------------ money and energy


def test_energy_and_cost_four_steps_of_10_kw_at_100_sgd_per_mwh() -> None:
    df = results_frame(4, power_kw=10.0, energy_price=100.0)
    # 4 steps × 0.5 h × 10 kW = 20 kWh = 0.02 MWh; × 100 SGD/MWh = 2 SGD
    assert kpi.energy_kwh(df) == pytest.approx(20.0)
    assert kpi.energy_cost_sgd(df) == pytest.approx(2.0)


def test_cost_weights_each_step_with_its_price() -> None:
    df = results_frame(2, power_kw=[10.0, 20.0], energy_price=[100.0, 300.0])
    # 10·0.5·100/1000 + 20·0.5·300/1000 = 0.5 + 3.0
    assert kpi.energy_cost_sgd(df) == pytest.approx(3.5)


def test_reserve_revenue_and_net_cost() -> None:
    df = results_frame(4, power_kw=10.0, energy_price=100.0, reserve_kw=2.0, reserve_price=5.0)
    # 4 × 0.5 h × 2 kW = 4 kWh = 0.004 MWh; × 5 SGD/MWh = 0.02 SGD
    assert kpi.reserve_revenue_sgd(df) == pytest.approx(0.02)
    assert kpi.net_cost_sgd(df) == pytest.approx(2.0 - 0.02)


def test_quarter_hour_steps_use_their_own_dt() -> None:
    df = results_frame(4, freq="15min", power_kw=10.0, energy_price=100.0)
    # 4 × 0.25 h × 10 kW = 10 kWh → 1 SGD
    assert kpi.energy_kwh(df) == pytest.approx(10.0)
    assert kpi.energy_cost_sgd(df) == pytest.approx(1.0)


# ------------------------------------------------------------------------ peaks and PPP


def test_peak_is_taken_on_30min_averages() -> None:
    df = results_frame(4, freq="15min", power_kw=[10.0, 20.0, 0.0, 2.0])
    # 30-min averages: (10+20)/2 = 15, (0+2)/2 = 1 → peak 15, not the 15-min 20
    assert kpi.peak_power_kw(df) == pytest.approx(15.0)
    assert kpi.peak_power_kw(results_frame(3, power_kw=[5.0, 12.0, 7.0])) == pytest.approx(12.0)


def test_monthly_peak_and_ppp_charge_over_a_month_boundary() -> None:
    # periods 23:00, 23:30 on 31 Jan and 00:00, 00:30 on 1 Feb (local time)
    df = results_frame(4, start="2014-01-31 23:00", power_kw=[8.0, 12.0, 20.0, 4.0])
    peaks = kpi.monthly_peak_power_kw(df)
    assert list(peaks.index.astype(str)) == ["2014-01", "2014-02"]
    assert peaks.to_list() == [12.0, 20.0]
    # φ = 1.5 SGD/kW: the months billed whole, 1.5 × 12 + 1.5 × 20 = 48 SGD
    assert kpi.ppp_charge_monthly_sgd(df, peak_price_sgd_per_kw=1.5) == pytest.approx(48.0)
    # prorated: one hour of January's 31 days, one hour of February's 28
    prorated = 18.0 * (1.0 / 24.0) / 31.0 + 30.0 * (1.0 / 24.0) / 28.0
    assert kpi.ppp_charge_sgd(df, peak_price_sgd_per_kw=1.5) == pytest.approx(prorated)


def test_ppp_charge_of_one_day_is_a_thirtieth_of_a_june_month() -> None:
    df = results_frame(48, start="2014-06-02 00:00", power_kw=20.0, peak_price=1.5)
    assert kpi.ppp_charge_monthly_sgd(df) == pytest.approx(30.0)  # 1.5 × 20
    assert kpi.ppp_charge_sgd(df) == pytest.approx(30.0 / 30.0)  # June has 30 days
    whole_month = results_frame(48 * 30, start="2014-06-01 00:00", power_kw=20.0, peak_price=1.5)
    assert kpi.ppp_charge_sgd(whole_month) == pytest.approx(30.0)
    assert kpi.month_fraction(whole_month).to_list() == pytest.approx([1.0])


def test_ppp_charge_reads_the_price_column_and_handles_a_time_varying_price() -> None:
    df = results_frame(3, power_kw=[10.0, 20.0, 15.0], peak_price=1.5)
    assert kpi.ppp_charge_monthly_sgd(df) == pytest.approx(30.0)  # 1.5 × 20
    df = results_frame(3, power_kw=[10.0, 20.0, 15.0], peak_price=[4.0, 1.0, 2.0])
    # max(4·10, 1·20, 2·15) = 40
    assert kpi.ppp_charge_monthly_sgd(df) == pytest.approx(40.0)
    assert kpi.ppp_charge_sgd(results_frame(3, peak_price=0.0)) == 0.0


# ------------------------------------------------------------------------ Table 1


def test_monthly_table_partial_months_count_days_and_fractions() -> None:
    # one whole day (48 steps) in January and one in February at 10 kW, 100 SGD/MWh
    df = pd.concat(
        [
            results_frame(48, start="2014-01-10", power_kw=10.0, energy_price=100.0),
            results_frame(48, start="2014-02-10", power_kw=20.0, energy_price=100.0),
        ]
    )
    # the index spacing has a month-long gap but the median step is still 30 min
    table = kpi.monthly_table(df)
    assert list(table.index.astype(str)) == ["2014-01", "2014-02"]
    assert table["days"].to_list() == pytest.approx([1.0, 1.0])
    assert table["month_fraction"].to_list() == pytest.approx([1 / 31, 1 / 28])
    # a day at 10 kW = 240 kWh = 24 SGD; at 20 kW, 48 SGD
    assert table["energy_cost_sgd"].to_list() == pytest.approx([24.0, 48.0])
    assert table["energy_kwh"].to_list() == pytest.approx([240.0, 480.0])
    assert table["peak_power_kw"].to_list() == [10.0, 20.0]
    average = kpi.monthly_average(table)
    # month-equivalents: 1/31 + 1/28; average = (24 + 48) / (1/31 + 1/28)
    assert average["months"] == pytest.approx(1 / 31 + 1 / 28)
    assert average["energy_cost_sgd"] == pytest.approx(72.0 / (1 / 31 + 1 / 28))
    assert average["days"] == pytest.approx(2.0)


def test_monthly_average_of_complete_months_is_mean_of_month_sums() -> None:
    # February 2014 (28 days) and March 2014 (31 days), complete
    feb = results_frame(28 * 48, start="2014-02-01", power_kw=10.0, energy_price=100.0)
    mar = results_frame(31 * 48, start="2014-03-01", power_kw=10.0, energy_price=200.0)
    feb["reserve_kw"], feb["reserve_price_sgd_per_mwh"] = 1.0, 10.0
    table = kpi.monthly_table(pd.concat([feb, mar]))
    # Feb: 28 d × 24 h × 10 kW = 6720 kWh → 672 SGD; Mar: 7440 kWh × 0.2 → 1488 SGD
    assert table["energy_cost_sgd"].to_list() == pytest.approx([672.0, 1488.0])
    # Feb reserve: 672 kWh × 10 SGD/MWh = 6.72 SGD
    assert table["reserve_revenue_sgd"].to_list() == pytest.approx([6.72, 0.0])
    assert table["month_fraction"].to_list() == pytest.approx([1.0, 1.0])
    average = kpi.monthly_average(table)
    assert average["energy_cost_sgd"] == pytest.approx((672.0 + 1488.0) / 2)
    assert average["reserve_revenue_sgd"] == pytest.approx(6.72 / 2)
    assert average["net_cost_sgd"] == pytest.approx((672.0 - 6.72 + 1488.0) / 2)
    assert average["months"] == pytest.approx(2.0)


# ------------------------------------------------------------------------ comfort


def test_discomfort_max_violation_and_violation_share() -> None:
    df = results_frame(
        4,
        temp_end={"north": [23.0, 26.5, 22.0, 24.0], "core": [24.0, 24.0, 24.0, 26.005]},
    )
    # north deviations from [23, 26]: 0, 0.5, 1.0, 0 → 1.5 K × 0.5 h = 0.75 K·h
    # core: only 0.005 K above in the last step → 0.0025 K·h, below the 0.01 K tolerance
    discomfort = kpi.discomfort_kelvin_hours(df)
    assert discomfort["north"] == pytest.approx(0.75)
    assert discomfort["core"] == pytest.approx(0.0025)
    assert kpi.total_discomfort_kelvin_hours(df) == pytest.approx(0.7525)
    assert kpi.max_violation_k(df).to_dict() == pytest.approx({"north": 1.0, "core": 0.005})
    # steps 2 and 3 violate by more than 0.01 K → 2 of 4
    assert kpi.violation_share(df) == pytest.approx(0.5)
    assert kpi.violation_share(df, tolerance_k=0.001) == pytest.approx(0.75)


def test_step_discomfort_sums_the_zones_of_each_period() -> None:
    df = results_frame(
        3,
        freq="15min",
        temp_end={"north": [22.0, 26.5, 24.0], "core": [24.0, 27.0, 22.5]},
    )
    # band [23, 26], Δt = 0.25 h: north 1, 0.5, 0 K; core 0, 1, 0.5 K
    step = kpi.step_discomfort_kelvin_hours(df)
    np.testing.assert_allclose(step.to_numpy(), [0.25, 0.375, 0.125])
    assert step.index.equals(df.index)
    assert step.sum() == pytest.approx(kpi.total_discomfort_kelvin_hours(df))


def test_discomfort_uses_the_band_in_force_at_period_end() -> None:
    df = results_frame(2, temp_end={"north": [21.0, 21.0]}, lower=[20.0, 23.0], upper=[30.0, 26.0])
    # unoccupied band 20–30 then occupied 23–26: deviation 0 then 2 K → 1 K·h
    assert kpi.total_discomfort_kelvin_hours(df) == pytest.approx(1.0)


# ------------------------------------------------------------------------ controller health


def test_fallback_count_and_planned_slack_share() -> None:
    df = results_frame(5)
    df["fallback"] = [False, True, False, True, True]
    df["planned_slack_max_k"] = [0.0, np.nan, 1e-9, 0.2, 0.0]
    assert kpi.fallback_count(df) == 3
    # only 0.2 exceeds the 1e-6 K tolerance; NaN (no plan) stays in the denominator
    assert kpi.planned_slack_share(df) == pytest.approx(1 / 5)


def test_max_delta_against_the_narrowest_half_band() -> None:
    df = results_frame(3, lower=[20.0, 23.0, 23.0], upper=[30.0, 26.0, 26.0])
    df["delta_max_k"] = [0.3, 0.75, np.nan]
    # narrowest band 23–26 → half-band 1.5 K; 0.75 / 1.5 = 0.5
    assert kpi.max_delta_vs_half_band(df) == pytest.approx(0.5)
    df["delta_max_k"] = np.nan
    assert np.isnan(kpi.max_delta_vs_half_band(df))


def test_solve_time_stats() -> None:
    df = results_frame(21)
    df["solve_time_s"] = [float(t) for t in range(1, 21)] + [np.nan]
    stats = kpi.solve_time_stats_s(df)
    # 1..20: mean 10.5; p95 at rank 0.95·19 = 18.05 → 19 + 0.05·(20 − 19) = 19.05
    assert stats == pytest.approx({"mean": 10.5, "p95": 19.05, "max": 20.0})


# ------------------------------------------------------------------------ summary and I/O


def test_summary_gathers_the_kpis() -> None:
    df = results_frame(
        4,
        power_kw=10.0,
        energy_price=100.0,
        reserve_kw=2.0,
        reserve_price=5.0,
        peak_price=1.5,
        temp_end={"north": [23.0, 26.5, 22.0, 24.0]},
    )
    out = kpi.summary(df)
    assert out["energy_cost_sgd"] == pytest.approx(2.0)
    assert out["reserve_revenue_sgd"] == pytest.approx(0.02)
    assert out["net_cost_sgd"] == pytest.approx(1.98)
    prorated_sgd = 15.0 * (2.0 / 24.0) / 31.0  # 2 h of March (31 days) of a 15 SGD month
    assert out["ppp_charge_monthly_sgd"] == pytest.approx(15.0)
    assert out["ppp_charge_sgd"] == pytest.approx(prorated_sgd)
    assert out["net_cost_with_ppp_sgd"] == pytest.approx(1.98 + prorated_sgd)
    assert out["peak_power_kw"] == 10.0
    assert out["discomfort_kelvin_hours"] == pytest.approx(0.75)
    assert out["discomfort_north_kelvin_hours"] == pytest.approx(0.75)
    assert out["max_violation_north_k"] == pytest.approx(1.0)
    assert out["violation_share"] == pytest.approx(0.5)
    assert out["steps"] == 4
    assert out["days"] == pytest.approx(2.0 / 24.0)
    assert out["solve_time_max_s"] == pytest.approx(0.01)
    counts = {name: out[name] for name in kpi.COUNT_KPIS if name in out}
    assert set(kpi.COUNT_KPIS) - set(counts) == {"unplanned_periods"}  # no plan in the frame
    assert all(type(v) is int for v in counts.values()), counts
    assert all(type(v) is float for k, v in out.items() if k not in counts)


def test_kpi_command_compares_runs(tmp_path: Path) -> None:
    from hvacflex.cli import app

    (tmp_path / "nmpc").mkdir()
    results_frame(4, power_kw=10.0).to_parquet(tmp_path / "nmpc" / "results.parquet")
    results_frame(4, power_kw=20.0).to_parquet(tmp_path / "rmpc.parquet")
    result = CliRunner().invoke(
        app, ["kpi", str(tmp_path / "nmpc"), str(tmp_path / "rmpc.parquet")], env={"COLUMNS": "200"}
    )
    assert result.exit_code == 0, result.output
    assert "nmpc" in result.output and "rmpc" in result.output
    assert "energy_cost_sgd" in result.output
    assert "2.00" in result.output and "4.00" in result.output


@pytest.mark.parametrize("target", ["missing_dir", "README.md", "empty_dir"])
def test_kpi_command_exits_2_on_bad_input(tmp_path: Path, target: str) -> None:
    from hvacflex.cli import app

    (tmp_path / "README.md").write_text("# not a results file\n")
    (tmp_path / "empty_dir").mkdir()
    result = CliRunner().invoke(app, ["kpi", str(tmp_path / target)])
    assert result.exit_code == 2, result.output
    assert "error:" in result.output and target in result.output
    assert "Traceback" not in result.output


# ------------------------------------------------------------------------ IL settlement


def _event_frame() -> pd.DataFrame:
    """Six 30-min periods: offers of 4 kW, one event curtailing periods 1–2 (D = 2) with one
    recovery period (3), α = 1 K, penalty 1000 SGD/MWh."""
    df = results_frame(
        6,
        power_kw=[10.0, 7.0, 9.0, 12.0, 10.0, 10.0],
        reserve_kw=[4.0, 4.0, 4.0, 0.0, 4.0, 0.0],
        reserve_price=[50.0] * 6,
        energy_price=100.0,
        temp_end={"north": [24.0, 26.5, 27.5, 26.2, 26.4, 24.0]},
    )
    df["il_activated"] = [False, True, True, True, False, False]
    df["il_curtailed"] = [False, True, True, False, False, False]
    df["il_beyond_model"] = [False, False, False, True, False, False]
    df["il_event_window"] = [False, True, True, True, False, False]
    df["il_allowance_k"] = [0.0, 1.0, 1.0, 1.0, 0.0, 0.0]
    df["il_reference_power_kw"] = [np.nan, 11.0, 12.0, 11.0, np.nan, np.nan]
    df["il_penalty_price_sgd_per_mwh"] = 1000.0
    df["il_forfeited_price_sgd_per_mwh"] = 50.0
    return df


def test_il_settlement_on_a_hand_made_event() -> None:
    df = _event_frame()
    # pre-event baseline: 10 kW (period 0) held for periods 1–3; metered 7, 9, 12 kW
    np.testing.assert_allclose(kpi.il_delivered_kw(df), [0, 3, 1, 0, 0, 0])
    np.testing.assert_allclose(kpi.il_shortfall_kw(df), [0, 1, 3, 0, 0, 0])
    assert kpi.il_offered_kwh(df) == pytest.approx((4 + 4 + 0) * 0.5)
    assert kpi.il_delivered_metered_kwh(df) == pytest.approx((3 + 1) * 0.5)
    assert kpi.il_shortfall_kwh(df) == pytest.approx(4.0 * 0.5)
    # 2 kWh short at 1000 SGD/MWh plus the forfeited 50 SGD/MWh reserve payment
    assert kpi.il_penalty_sgd(df) == pytest.approx(2.0 * 1050 / 1000)
    assert kpi.il_delivered_ratio(df) == pytest.approx(2.0 / 4.0)
    # the plant's counterfactual: served = metered in this frame, so nothing
    assert kpi.il_delivered_counterfactual_kwh(df) == 0.0
    # recovery period 3: 12 kW against the plan's 11 kW for half an hour
    assert kpi.il_recovery_energy_kwh(df) == pytest.approx(0.5)
    assert kpi.il_event_count(df) == 1 and kpi.il_beyond_model_steps(df) == 1
    assert kpi.il_curtailment_count(df) == 1
    # of the four paid periods, 1 and 2 were activated (settled against the meter); 0 and 4
    # were paid for availability only
    assert kpi.reserve_revenue_settled_sgd(df) == pytest.approx(2 * 4.0 * 50.0 * 0.5 / 1000)
    assert kpi.reserve_revenue_unsettled_sgd(df) == pytest.approx(2 * 4.0 * 50.0 * 0.5 / 1000)
    # revenue is gross (paid on every scheduled period); the penalty enters the net cost
    revenue = 4.0 * 4 * 50.0 * 0.5 / 1000
    assert kpi.reserve_revenue_sgd(df) == pytest.approx(revenue)
    energy = sum([10.0, 7.0, 9.0, 12.0, 10.0, 10.0]) * 100.0 * 0.5 / 1000
    assert kpi.net_cost_sgd(df) == pytest.approx(energy - revenue + 2.1)
    assert kpi.monthly_table(df)["il_penalty_sgd"].sum() == pytest.approx(2.1)
    month = kpi.monthly_table(df).iloc[0]  # the settlement of Table 1, by hand as above
    assert month["il_offered_kwh"] == pytest.approx(4.0)
    assert month["il_delivered_metered_kwh"] == pytest.approx(2.0)
    assert month["il_shortfall_kwh"] == pytest.approx(2.0)
    assert month["il_net_revenue_sgd"] == pytest.approx(revenue - 2.1)
    assert kpi.reserve_offered_mean_kw(df) == pytest.approx(16.0 / 6)
    assert kpi.reserve_period_share(df) == pytest.approx(4 / 6)


def test_il_settlement_reads_the_settlement_columns_when_present() -> None:
    df = _event_frame()
    df["il_baseline_power_kw"] = [np.nan, 12.0, 12.0, 12.0, np.nan, np.nan]
    df["il_delivered_kw"] = [0.0, 5.0, 3.0, 0.0, 0.0, 0.0]
    df["il_shortfall_kw"] = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
    df["power_served_kw"] = [10.0, 11.0, 12.5, 12.0, 10.0, 10.0]
    assert kpi.il_delivered_metered_kwh(df) == pytest.approx(8.0 * 0.5)
    assert kpi.il_penalty_sgd(df) == pytest.approx(0.5 * 1050 / 1000)
    # served − metered over the activated periods 1–3: 4 + 3.5 + 0
    assert kpi.il_delivered_counterfactual_kwh(df) == pytest.approx(7.5 * 0.5)
    df.loc[df.index[2], "power_served_kw"] = np.nan  # a plant that cannot snapshot
    assert np.isnan(kpi.il_delivered_counterfactual_kwh(df))
    out = kpi.summary(df)
    for key in (
        "il_offered_kwh",
        "il_delivered_metered_kwh",
        "il_shortfall_kwh",
        "il_penalty_sgd",
        "il_delivered_counterfactual_kwh",
    ):
        assert key in out
    assert out["il_offered_kwh"] == pytest.approx(4.0)


def test_event_discomfort_against_the_normal_band_and_within_the_allowance() -> None:
    df = _event_frame()
    # in the window (periods 1–3) the strict 26 °C band: 0.5 + 1.5 + 0.2 K; with the
    # allowance (27 °C) only 27.5 exceeds it (0.5 K); outside the window the strict 26 °C:
    # period 4 at 26.4 (0.4 K)
    assert kpi.discomfort_event_kelvin_hours(df) == pytest.approx(2.2 * 0.5)
    assert kpi.discomfort_event_beyond_allowance_kelvin_hours(df) == pytest.approx(0.5 * 0.5)
    assert kpi.discomfort_event_within_allowance_kelvin_hours(df) == pytest.approx(1.7 * 0.5)
    assert kpi.discomfort_outside_events_kelvin_hours(df) == pytest.approx(0.4 * 0.5)
    out = kpi.summary(df)
    assert out["il_penalty_sgd"] == pytest.approx(2.1)
    assert out["il_beyond_model_steps"] == 1.0
    assert out["discomfort_event_beyond_allowance_kelvin_hours"] == pytest.approx(0.25)
    # the strict total still counts every deviation from the strict band
    assert out["discomfort_kelvin_hours"] == pytest.approx((0.5 + 1.5 + 0.2 + 0.4) * 0.5)


def test_results_without_il_columns_have_no_events() -> None:
    df = results_frame(4, power_kw=10.0, reserve_kw=2.0, reserve_price=50.0)
    assert kpi.il_penalty_sgd(df) == 0.0 and kpi.il_shortfall_kwh(df) == 0.0
    assert np.isnan(kpi.il_delivered_ratio(df))  # nothing was due: no delivery record
    assert kpi.il_event_count(df) == 0 and kpi.il_curtailment_count(df) == 0
    assert kpi.discomfort_event_kelvin_hours(df) == 0.0
    assert kpi.il_offered_kwh(df) == 0.0 and kpi.il_delivered_counterfactual_kwh(df) == 0.0


def test_an_activation_without_curtailment_is_an_event_with_no_delivery_ratio() -> None:
    # a rule-based run: activated in periods 1–2 and 4, nothing offered, nothing curtailed
    df = results_frame(6, power_kw=10.0)
    df["il_activated"] = [False, True, True, False, True, False]
    out = kpi.summary(df)
    assert (out["il_events"], out["il_activated_steps"], out["il_curtailments"]) == (2, 3, 0)
    assert np.isnan(out["il_delivered_ratio"])
    assert out["reserve_revenue_settled_sgd"] == 0.0


# ------------------------------------------------------------------------ occupied comfort


def _day_frame() -> pd.DataFrame:
    """Four periods: unoccupied (20–30 °C), occupied (23–26 °C) twice, unoccupied again."""
    return results_frame(
        4,
        lower=[20.0, 23.0, 23.0, 20.0],
        upper=[30.0, 26.0, 26.0, 30.0],
        temp_end={"north": [30.6, 26.4, 22.0, 24.0], "core": [31.0, 25.0, 25.0, 19.5]},
    )


def test_discomfort_split_into_occupied_and_unoccupied_periods() -> None:
    df = _day_frame()
    np.testing.assert_array_equal(kpi.occupied_mask(df)["north"], [False, True, True, False])
    # occupied: north 0.4 + 1.0 K; unoccupied: north 0.6, core 1.0 + 0.5 K; Δt = 0.5 h
    assert kpi.discomfort_occupied_kelvin_hours(df) == pytest.approx(1.4 * 0.5)
    assert kpi.discomfort_unoccupied_kelvin_hours(df) == pytest.approx(2.1 * 0.5)
    assert kpi.max_violation_occupied_k(df) == pytest.approx(1.0)
    out = kpi.summary(df)
    assert out["discomfort_occupied_kelvin_hours"] + out[
        "discomfort_unoccupied_kelvin_hours"
    ] == pytest.approx(out["discomfort_kelvin_hours"])
    assert out["max_violation_k"] == pytest.approx(1.0)  # core at 19.5 against 20 is 0.5
    assert out["max_violation_occupied_k"] == pytest.approx(1.0)
    # unoccupied: north 30.6 against 30, core 31.0 against 30 and 19.5 against 20
    assert out["max_violation_unoccupied_k"] == pytest.approx(1.0)
    assert kpi.max_violation_unoccupied_k(df.iloc[[0, 1, 2]]) == pytest.approx(1.0)
    assert kpi.max_violation_unoccupied_k(df.iloc[[1, 2, 3]]) == pytest.approx(0.5)


def test_a_run_with_one_band_is_graded_occupied_throughout() -> None:
    df = results_frame(2, temp_end={"north": [26.5, 24.0]})
    assert kpi.discomfort_occupied_kelvin_hours(df) == pytest.approx(0.25)
    assert kpi.discomfort_unoccupied_kelvin_hours(df) == 0.0


def test_kpi_command_prints_and_writes_counts_as_integers(tmp_path: Path) -> None:
    from hvacflex.cli import app

    df = results_frame(4, power_kw=10.0, peak_price=1.5)
    df["il_activated"] = [False, True, True, False]
    df.to_parquet(tmp_path / "run.parquet")
    csv = tmp_path / "kpi.csv"
    result = CliRunner().invoke(
        app, ["kpi", str(tmp_path / "run.parquet"), "--csv", str(csv)], env={"COLUMNS": "200"}
    )
    assert result.exit_code == 0, result.output
    rows = dict(line.split(",", 1) for line in csv.read_text().splitlines()[1:])
    assert rows["steps"] == "4" and rows["il_activated_steps"] == "2" and rows["il_events"] == "1"
    assert rows["il_delivered_ratio"] == ""  # no reserve was due: no ratio
    assert float(rows["ppp_charge_monthly_sgd"]) == pytest.approx(15.0)
    lines = [line for line in result.output.splitlines() if "│" in line]
    printed = {line.split("│")[1].strip(): line for line in lines}
    assert printed["il_activated_steps"].split("│")[2].strip() == "2"
    assert printed["il_delivered_ratio"].split("│")[2].strip() == "–"


def test_a_rule_based_run_has_no_model_error() -> None:
    df = results_frame(3)
    df["prediction_error_north_k"] = [0.1, -0.3, 0.2]
    df["prediction_error_core_k"] = [0.0, 0.0, 0.0]
    assert kpi.summary(df)["prediction_error_max_k"] == pytest.approx(0.3)
    df["solve_status"] = "rule"
    assert kpi.is_rule_based(df)
    out = kpi.summary(df)
    assert np.isnan(out["prediction_error_rms_k"]) and np.isnan(out["prediction_error_max_k"])


def test_facility_energy_and_peak_only_where_the_plant_meters_them() -> None:
    df = results_frame(4, power_kw=10.0)
    assert "facility_energy_kwh" not in kpi.summary(df)
    df["facility_power_kw"] = np.nan  # the RC plant: HVAC only
    assert "facility_peak_power_kw" not in kpi.summary(df)
    df["facility_power_kw"] = [30.0, 40.0, 35.0, 30.0]  # EnergyPlus meters the facility
    out = kpi.summary(df)
    assert out["facility_energy_kwh"] == pytest.approx(135.0 * 0.5)
    assert out["facility_peak_power_kw"] == pytest.approx(40.0)
    assert out["energy_kwh"] == pytest.approx(20.0)  # the HVAC's, unchanged


def test_prediction_error_rms_split_by_the_occupied_band() -> None:
    """Four periods, two zones: the band is 23–26 °C (occupied) in periods 1–2 and 20–30 °C
    in 0 and 3. Occupied errors 0.1, −0.3, 0.2, 0.4 → RMS √(0.30/4); unoccupied 1, −2, NaN
    (left out), 2 → RMS √(9/3)."""
    frame = results_frame(4, lower=[20.0, 23.0, 23.0, 20.0], upper=[30.0, 26.0, 26.0, 30.0])
    frame["prediction_error_north_k"] = [1.0, 0.1, -0.3, -2.0]
    frame["prediction_error_core_k"] = [np.nan, 0.2, 0.4, 2.0]
    split = kpi.prediction_error_rms_by_occupancy_k(frame)
    assert split["prediction_error_rms_occupied_k"] == pytest.approx(np.sqrt(0.30 / 4))
    assert split["prediction_error_rms_unoccupied_k"] == pytest.approx(np.sqrt(9.0 / 3))
    summary = kpi.summary(frame)
    assert summary["prediction_error_rms_occupied_k"] == split["prediction_error_rms_occupied_k"]
    # the overall RMS stays, over all seven finite errors
    assert summary["prediction_error_rms_k"] == pytest.approx(np.sqrt(9.30 / 7))


def test_prediction_error_rms_of_an_empty_class_is_nan_and_without_errors_absent() -> None:
    frame = results_frame(3)  # one band throughout: occupied throughout
    frame["prediction_error_north_k"] = [0.3, -0.3, 0.3]
    frame["prediction_error_core_k"] = [0.3, 0.3, -0.3]
    split = kpi.prediction_error_rms_by_occupancy_k(frame)
    assert split["prediction_error_rms_occupied_k"] == pytest.approx(0.3)
    assert np.isnan(split["prediction_error_rms_unoccupied_k"])
    assert kpi.prediction_error_rms_by_occupancy_k(results_frame(3)) == {}


def test_model_extrapolation_steps_counts_the_flagged_periods_by_hand() -> None:
    from hvacflex.kpi import model_extrapolation_steps

    frame = pd.DataFrame({"model_extrapolation": [False, True, True, False, True]})
    assert model_extrapolation_steps(frame) == 3
    assert model_extrapolation_steps(frame.drop(columns="model_extrapolation")) == 0


def test_peak_guard_steps_counts_the_periods_the_guard_shed_by_hand() -> None:
    from hvacflex.kpi import peak_guard_steps

    frame = pd.DataFrame({"peak_guard_active": [False, True, True, False, True, None]})
    assert peak_guard_steps(frame) == 3
    assert peak_guard_steps(pd.DataFrame({"power_kw": [1.0]})) == 0  # written before the column


def test_summary_grades_the_plan_by_the_meter_only_for_a_planning_controller() -> None:
    df = results_frame(2, start="2014-03-03 07:00", power_kw=[10.0, 20.0])
    assert "planned_over_metered_occupied" not in kpi.summary(df)
    df["planned_power_kw"] = [12.0, 18.0]
    out = kpi.summary(df)
    assert out["planned_over_metered_occupied"] == pytest.approx(1.0)  # 30 kW·h / 30
    assert out["planned_occupied_kwh"] == pytest.approx(15.0)
