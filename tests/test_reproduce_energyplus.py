"""The EnergyPlus section's numbers: the comparison table and the tracking error, from
hand-made results whose answers are computed here."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex import kpi
from hvacflex.reproduce_energyplus import (
    COMPARISON_COLUMNS,
    COMPARISON_CSV,
    PLANTS,
    TABLE1_CSV,
    display_week,
    energyplus_section,
    plant_comparison,
    tracking_rmse_k,
)

Factory = Callable[..., pd.DataFrame]


def test_tracking_error_is_the_rms_of_realised_minus_planned(make_results: Factory) -> None:
    frame = make_results(days=1.0)
    zones = kpi.zone_names(frame)
    for i, zone in enumerate(zones):
        frame[f"temp_end_{zone}_degc"] = frame[f"temp_served_{zone}_degc"] + (0.3 if i else -0.4)
    assert tracking_rmse_k(frame) == pytest.approx(np.sqrt((0.3**2 + 0.4**2) / 2))
    rule_based = frame.drop(columns=[f"temp_served_{zone}_degc" for zone in zones])
    assert np.isnan(tracking_rmse_k(rule_based))


def test_the_comparison_prices_every_run_alike(make_results: Factory) -> None:
    rc = make_results(seed=1)
    eplus = make_results(seed=2, power_scale=1.3)
    eplus["facility_power_kw"] = eplus["power_kw"] + 10.0
    table = plant_comparison({("(b) RMPC", "rc"): rc, ("(b) RMPC", "energyplus"): eplus}, 1.5)
    assert list(table.columns) == list(COMPARISON_COLUMNS)
    assert list(table["plant"]) == ["RC plant (hvacflex)", "EnergyPlus 25.2"]
    for row, frame in zip(table.itertuples(), (rc, eplus), strict=True):
        energy = kpi.energy_cost_sgd(frame)
        # one month's charge φ × the month's peak, prorated to the days the run covers
        peak_charge = 1.5 * frame["power_kw"].max() * kpi.month_fraction(frame).sum()
        settled = kpi.reserve_revenue_settled_sgd(frame)
        expected = energy + peak_charge + kpi.il_penalty_sgd(frame) - settled
        assert row.tariff_cost_sgd == pytest.approx(expected)
        assert row.peak_power_kw == pytest.approx(frame["power_kw"].max())
    assert np.isnan(table.loc[0, "facility_energy_kwh"])
    hours = len(eplus) * 0.5
    assert table.loc[1, "facility_energy_kwh"] == pytest.approx(
        table.loc[1, "energy_kwh"] + 10.0 * hours
    )


def test_the_section_writes_its_table_and_figure(make_results: Factory, tmp_path: Path) -> None:
    rc = {key: make_results(seed=i) for i, key in enumerate(("a", "b", "c"))}
    eplus = {key: make_results(seed=10 + i, temp_offset_k=0.6) for i, key in enumerate(rc)}
    figures = tmp_path / "figures"
    section = energyplus_section(
        eplus,
        rc,
        labels={"a": "(a) NMPC", "b": "(b) RMPC", "c": "(c) RMPC + PPP"},
        peak_price_sgd_per_kw=1.5,
        period="2 days from 2014-03-03",
        out=tmp_path,
        figures=figures,
    )
    table = pd.read_csv(tmp_path / COMPARISON_CSV)
    assert len(table) == 6 and set(table["scenario"]) == {"(a) NMPC", "(b) RMPC", "(c) RMPC + PPP"}
    week = pd.read_csv(figures / "energyplus_week.csv")
    assert set(week["plant"]) == {"rc", "energyplus"} and len(week) == 6 * len(rc["a"])
    monthly = pd.read_csv(tmp_path / TABLE1_CSV, index_col=["plant", "scenario"])
    assert list(monthly.index.get_level_values("plant").unique()) == [
        PLANTS["rc"],
        PLANTS["energyplus"],
    ]
    assert monthly.loc[(PLANTS["rc"], "(a) NMPC"), "energy_cost_change_pct"] == 0.0
    verdict_table = section.tables[0]
    assert "EnergyPlus office5" in verdict_table["basis"].iloc[0]
    # robustness premium, comfort, PPP cost, PPP peak, reserve revenue
    assert len(verdict_table) == 5
    revenue = [f for f in verdict_table.index if f.startswith("Reserve revenue rises")]
    assert len(revenue) == 1


def test_a_year_is_drawn_over_its_march_week_and_a_week_whole(make_results: Factory) -> None:
    week = make_results(seed=1)
    assert display_week(week) is week
    index = pd.date_range("2014-01-01", periods=48 * 90, freq="30min", tz=week.index.tz)
    long = pd.DataFrame({"power_kw": np.arange(len(index), dtype=float)}, index=index)
    shown = display_week(long)
    assert len(shown) == 7 * 48
    assert shown.index[0] == pd.Timestamp("2014-03-03", tz=week.index.tz)
