"""Table 1 layout, the published values, and Markdown/HTML rendering."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
import pytest

from hvacflex import kpi
from hvacflex.errors import InputError
from hvacflex.report import tables

Factory = Callable[..., pd.DataFrame]


def _monthly(energy_cost: list[float], reserve: list[float]) -> pd.DataFrame:
    """A hand-made monthly table of complete months."""
    n = len(energy_cost)
    return pd.DataFrame(
        {
            "days": [31.0] * n,
            "month_fraction": [1.0] * n,
            "energy_cost_sgd": energy_cost,
            "reserve_revenue_sgd": reserve,
            "net_cost_sgd": [c - r for c, r in zip(energy_cost, reserve, strict=True)],
            "energy_kwh": [1000.0] * n,
            "peak_power_kw": [20.0] * n,
            "ppp_charge_sgd": [0.0] * n,
        },
        index=pd.period_range("2014-01", periods=n, freq="M", name="month"),
    )


def test_table1_monthly_averages_and_change_vs_first_scenario() -> None:
    table = tables.table1(
        {
            "(a)": _monthly([1000.0, 1200.0], [10.0, 12.0]),  # averages 1100, 11, 1089
            "(b)": _monthly([1100.0, 1320.0], [11.0, 11.0]),  # 1210 (+10 %), 11 (0 %), 1199
        }
    )
    assert list(table.index) == ["(a)", "(b)"]
    assert table.loc["(a)", "energy_cost_sgd"] == pytest.approx(1100.0)
    assert table.loc["(a)", "net_cost_sgd"] == pytest.approx(1089.0)
    assert table.loc["(a)", "energy_cost_change_pct"] == 0.0
    assert table.loc["(b)", "energy_cost_sgd"] == pytest.approx(1210.0)
    assert table.loc["(b)", "energy_cost_change_pct"] == pytest.approx(10.0)
    assert table.loc["(b)", "reserve_revenue_change_pct"] == pytest.approx(0.0)
    assert table.loc["(b)", "net_cost_change_pct"] == pytest.approx(100 * (1199 / 1089 - 1))
    assert table.loc["(b)", "months"] == 2.0


def test_table1_reports_the_reserve_settlement_per_month() -> None:
    two = _monthly([1000.0, 1200.0], [10.0, 12.0])
    two["il_offered_kwh"] = [4.0, 6.0]
    two["il_delivered_metered_kwh"] = [3.0, 6.0]
    two["il_shortfall_kwh"] = [1.0, 0.0]
    two["il_penalty_sgd"] = [4.55, 0.0]
    two["il_net_revenue_sgd"] = two["reserve_revenue_sgd"] - two["il_penalty_sgd"]
    table = tables.table1({"(a)": two})
    assert list(table.columns[-7:-2]) == list(tables.TABLE1_IL_COLUMNS)
    row = table.loc["(a)"]
    assert row["il_offered_kwh"] == pytest.approx(5.0)  # per month of two
    assert row["il_delivered_metered_kwh"] == pytest.approx(4.5)
    assert row["il_shortfall_kwh"] == pytest.approx(0.5)
    assert row["il_penalty_sgd"] == pytest.approx(2.275)
    assert row["il_net_revenue_sgd"] == pytest.approx(11.0 - 2.275)
    # tables without the settlement (older runs) keep the paper's columns only
    assert "il_offered_kwh" not in tables.table1({"(a)": _monthly([1.0], [0.0])}).columns


def test_table1_from_fabricated_runs(make_results: Factory) -> None:
    monthly = {
        "a": kpi.monthly_table(make_results(seed=1)),
        "c": kpi.monthly_table(make_results(seed=1, power_scale=1.1)),
    }
    table = tables.table1(monthly)
    assert table.loc["c", "energy_cost_change_pct"] > 0.0
    assert table.loc["a", "days"] == pytest.approx(2.0)


def test_paper_table1_is_consistent() -> None:
    paper = tables.paper_table1()
    # "Total" = cost − revenue, to the published rounding
    assert (paper["energy_cost_sgd"] - paper["reserve_revenue_sgd"]).to_list() == pytest.approx(
        paper["net_cost_sgd"].to_list(), abs=0.06
    )
    # printed % changes vs (a), to the printed precision (+1.77 % printed 1.7, +12.1 % as 12)
    for quantity in tables.TABLE1_QUANTITIES:
        change = 100 * (paper[quantity] / paper[quantity].iloc[0] - 1)
        printed = paper[quantity.replace("_sgd", "_change_pct")]
        assert change.to_list() == pytest.approx(printed.to_list(), abs=0.15)
    paper.iloc[0, 0] = -1.0
    assert tables.PAPER_TABLE1.iloc[0, 0] == 1471.0


def test_side_by_side_aligns_rows_in_order() -> None:
    ours = tables.table1(
        {
            "nmpc": _monthly([1000.0], [10.0]),
            "rmpc": _monthly([1050.0], [10.5]),
            "rmpc-ppp": _monthly([1080.0], [11.0]),
            "thermostat": _monthly([1200.0], [0.0]),
        }
    )
    side = tables.side_by_side(ours, tables.PAPER_TABLE1)
    assert list(side.index) == ["nmpc", "rmpc", "rmpc-ppp", "thermostat"]
    assert side.loc["rmpc", "energy_cost_sgd (ours)"] == 1050.0
    assert side.loc["rmpc", "energy_cost_sgd (paper)"] == 1530.0
    assert side.loc["rmpc-ppp", "reserve_revenue_change_pct (paper)"] == 12.0
    assert side.loc["rmpc-ppp", "paper_scenario"].startswith("(c)")
    assert pd.isna(side.loc["thermostat", "net_cost_sgd (paper)"])


def test_to_markdown_and_to_html_render_every_cell() -> None:
    frame = pd.DataFrame(
        {"energy_cost_sgd": [1471.0, 1530.0], "energy_cost_change_pct": [0.0, 4.0]},
        index=pd.Index(["(a) <NMPC>", "(b) RMPC|x"], name="scenario"),
    )
    markdown = tables.to_markdown(frame)
    lines = markdown.splitlines()
    assert lines[0] == "| scenario | energy_cost_sgd | energy_cost_change_pct |"
    assert lines[1] == "| --- | ---: | ---: |"
    assert lines[3] == r"| (b) RMPC\|x | 1,530.00 | +4.0 % |"
    html = tables.to_html(frame, caption="Table 1")
    assert "<caption>Table 1</caption>" in html
    assert "(a) &lt;NMPC&gt;" in html
    assert '<td class="num">+4.0 %</td>' in html
    assert tables.format_value("x_sgd", float("nan")) == "–"
    assert tables.format_value("violation_share", 0.25) == "25.00 %"


def test_format_value_formats_kpi_names_by_their_unit() -> None:
    assert tables.format_value("steps", 1234.0) == "1,234"
    assert tables.format_value("fallback_count", 0.0) == "0"
    assert tables.format_value("solve_time_max_s", 0.0123456) == "0.01235"
    assert tables.format_value("max_delta_vs_half_band", 0.83125) == "0.8313"
    assert tables.format_value("net_cost_sgd", 1234.5) == "1,234.50"
    assert tables.format_value("controller", "rmpc") == "rmpc"


def test_table1_models_has_a_block_of_rows_per_model() -> None:
    event = tables.table1({"(a)": _monthly([1000.0], [10.0]), "(b)": _monthly([1100.0], [12.0])})
    whole = tables.table1(
        {"(a) wh": _monthly([1010.0], [0.0]), "(b) wh": _monthly([1111.0], [0.0])}
    )
    both = tables.table1_models({"event": event, "whole-horizon": whole})
    assert list(both.index) == ["(a)", "(b)", "(a) wh", "(b) wh"]
    assert both.columns[0] == tables.RESERVE_MODEL_COLUMN
    assert both[tables.RESERVE_MODEL_COLUMN].to_list() == ["event"] * 2 + ["whole-horizon"] * 2
    # each block keeps its % against its own (a)
    assert both.loc["(b)", "energy_cost_change_pct"] == pytest.approx(10.0)
    assert both.loc["(b) wh", "energy_cost_change_pct"] == pytest.approx(10.0)
    assert np.isnan(both.loc["(b) wh", "reserve_revenue_change_pct"])  # against zero
    assert both.loc["(a) wh", "net_cost_sgd"] == pytest.approx(1010.0)
    side = tables.table1_models(
        {model: tables.side_by_side(t) for model, t in (("event", event), ("wh", whole))}
    )
    assert side.loc["(b) wh", "energy_cost_sgd (paper)"] == 1530.0
    assert side.loc["(b) wh", "paper_scenario"] == "(b) RMPC"


def test_table1_models_refuses_no_model_and_repeated_labels() -> None:
    with pytest.raises(InputError, match="at least one model"):
        tables.table1_models({})
    event = tables.table1({"(a)": _monthly([1000.0], [10.0])})
    with pytest.raises(InputError, match="repeat") as info:
        tables.table1_models({"event": event, "whole-horizon": event})
    assert "(a)" in str(info.value)


def test_integers_print_as_integers() -> None:
    assert tables.format_value("rank", np.int64(3)) == "3"
    assert tables.format_value("steps", 336) == "336"
    assert tables.format_value("energy_kwh", 336.0) == "336.00"  # a float stays a float
    table = pd.DataFrame({"rank": [1, 2], "cost_sgd": [1.5, 2.25]}, index=["a", "b"])
    assert '<td class="num">1</td>' in tables.to_html(table)


def test_per_m2_without_a_floor_area_is_not_available_and_booleans_read_yes_no() -> None:
    assert tables.format_value("tariff_cost_sgd_per_m2_month", float("nan")) == "not available"
    assert tables.format_value("energy_kwh", float("nan")) == "–"
    assert tables.format_value("pays", True) == "yes"
    assert tables.format_value("pays", np.bool_(False)) == "no"
    assert tables.format_value("il_events", 3.0) == "3"  # a count stored as float
