"""Figures: each writes a PNG and the CSV behind it, and the CSV holds what the figure claims."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex import kpi
from hvacflex.errors import DataError, InputError
from hvacflex.report import plots

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
Factory = Callable[..., pd.DataFrame]


def _assert_png_and_csv(path: Path, expected: Path) -> pd.DataFrame:
    assert path == expected
    assert path.read_bytes().startswith(PNG_MAGIC)
    assert path.stat().st_size > 5_000
    return pd.read_csv(plots.csv_path(path))


@pytest.fixture
def scenarios(make_results: Factory) -> dict[str, pd.DataFrame]:
    return {
        "(a) NMPC": make_results(seed=1, temp_offset_k=0.8),
        "(b) RMPC": make_results(seed=2),
        "(c) RMPC + PPP": make_results(seed=3, power_scale=0.8),
    }


def test_plot_prices_marks_the_reserve_price_synthetic(
    tmp_path: Path, make_results: Factory
) -> None:
    results = make_results()
    path = plots.plot_prices(results, tmp_path / "fig2_prices.png")
    data = _assert_png_and_csv(path, tmp_path / "fig2_prices.png")
    assert len(data) == len(results)
    assert data["energy_price_sgd_per_mwh"].to_numpy() == pytest.approx(
        results["energy_price_sgd_per_mwh"].to_numpy()
    )
    assert data["reserve_price_synthetic"].all()


def test_plot_temperatures_writes_served_and_curtailed(
    tmp_path: Path, scenarios: dict[str, pd.DataFrame]
) -> None:
    path = plots.plot_temperatures(scenarios, tmp_path / "fig5.png")
    data = _assert_png_and_csv(path, tmp_path / "fig5.png")
    assert set(data["scenario"]) == set(scenarios)
    assert set(data["zone"]) == {"north", "core"}
    assert len(data) == 3 * 2 * 96
    # cooling: curtailing the flow can only warm the zone
    assert (data["temp_curtailed_degc"] >= data["temp_served_degc"]).all()
    # realised end temperature is the curtailed one where IL was activated
    active = data[data["il_activated"]]
    assert not active.empty
    assert active["temp_end_degc"].to_numpy() == pytest.approx(
        active["temp_curtailed_degc"].to_numpy()
    )
    # period ends: first row is 30 min after the first period start (local time)
    first = pd.Timestamp(data["time_end"].iloc[0])
    assert first == pd.Timestamp("2014-03-03 00:30")


def test_plot_temperatures_without_predictions_and_a_zone_subset(
    tmp_path: Path, make_results: Factory
) -> None:
    results = make_results(predictions=False)
    path = plots.plot_temperatures({"rmpc": results}, tmp_path / "t.png", zones=["core"])
    data = _assert_png_and_csv(path, tmp_path / "t.png")
    assert set(data["zone"]) == {"core"}
    assert data["temp_served_degc"].isna().all()
    assert data["temp_end_degc"].notna().all()


def test_plot_temperatures_draws_the_worst_il_event_series(
    tmp_path: Path, scenarios: dict[str, pd.DataFrame]
) -> None:
    path = plots.plot_temperatures(
        scenarios, tmp_path / "fig5.png", series=("temp_end", "temp_served", "event_worst")
    )
    data = _assert_png_and_csv(path, tmp_path / "fig5.png")
    for label, results in scenarios.items():
        rows = data[(data["scenario"] == label) & (data["zone"] == "north")]
        assert rows["event_worst_degc"].to_numpy() == pytest.approx(
            results["event_worst_north_degc"].to_numpy()
        )
    # the CSV keeps every series, also those not drawn
    assert data["temp_curtailed_degc"].notna().all()
    assert (data["event_worst_degc"] >= data["temp_curtailed_degc"]).all()


def test_plot_temperatures_without_the_event_column_and_an_unknown_series(
    tmp_path: Path, make_results: Factory
) -> None:
    results = make_results().drop(columns=["event_worst_north_degc", "event_worst_core_degc"])
    path = plots.plot_temperatures({"older run": results}, tmp_path / "t.png")
    data = _assert_png_and_csv(path, tmp_path / "t.png")
    assert data["event_worst_degc"].isna().all()
    assert data["temp_served_degc"].notna().all()
    with pytest.raises(InputError, match="series") as info:
        plots.plot_temperatures({"x": results}, tmp_path / "u.png", series=("temp_worst",))
    assert "event_worst" in str(info.value)


def test_plot_power_reserve(tmp_path: Path, scenarios: dict[str, pd.DataFrame]) -> None:
    path = plots.plot_power_reserve(scenarios, tmp_path / "fig6.png")
    data = _assert_png_and_csv(path, tmp_path / "fig6.png")
    for label, results in scenarios.items():
        rows = data[data["scenario"] == label]
        # each run on its own peak day: the calendar day of its largest power, 48 periods
        peak_at = results["power_kw"].idxmax()
        day = results[results.index.normalize() == peak_at.normalize()]
        assert len(rows) == len(day) == 48
        assert rows["power_kw"].max() == pytest.approx(kpi.peak_power_kw(results))
        assert rows.loc[rows["is_peak"], "power_kw"].to_list() == [results["power_kw"].max()]
        assert rows["reserve_kw"].to_numpy() == pytest.approx(day["reserve_kw"].to_numpy())
        # the band runs from the served power down by the reserve offered
        upper = rows["reserve_band_upper_kw"].to_numpy()
        lower = rows["reserve_band_lower_kw"].to_numpy()
        assert upper == pytest.approx(day["power_served_kw"].to_numpy())
        assert upper - lower == pytest.approx(day["reserve_kw"].to_numpy())
        offered = day["reserve_kw"].to_numpy() > 0
        assert offered.any() and (upper[offered] > lower[offered]).all()
        assert (upper[~offered] == lower[~offered]).all()
    whole = plots.plot_power_reserve(scenarios, tmp_path / "whole.png", whole_period=True)
    assert len(pd.read_csv(plots.csv_path(whole))) == sum(len(f) for f in scenarios.values())


def test_a_run_without_reserve_gets_no_reserve_panel(tmp_path: Path, make_results: Factory) -> None:
    with_reserve = make_results(seed=1)
    rule_based = make_results(seed=2).assign(reserve_kw=0.0)
    assert plots.offers_reserve(with_reserve) and not plots.offers_reserve(rule_based)
    plots.plot_power_reserve({"mpc": with_reserve}, tmp_path / "one.png")
    plots.plot_power_reserve({"mpc": with_reserve, "thermostat": rule_based}, tmp_path / "two.png")
    from PIL import Image

    heights = [Image.open(tmp_path / name).size[1] for name in ("one.png", "two.png")]
    # the thermostat adds its power panel only: 3 panels, not 4 (a panel is 2.1 in at 150 dpi)
    assert 0.8 * 2.1 * plots.DPI < heights[1] - heights[0] < 1.2 * 2.1 * plots.DPI


def test_fig5_draws_at_most_five_lines_a_panel(tmp_path: Path, make_results: Factory) -> None:
    zones = tuple(f"z{i}" for i in range(7))
    results = make_results(zones=zones)
    for i, zone in enumerate(zones):  # z6 warmest, z0 coolest
        results[f"temp_end_{zone}_degc"] += 0.1 * i
    assert plots.warmest_zones({"x": results}) == ["z2", "z3", "z4", "z5", "z6"]
    from matplotlib.axes import Axes

    drawn: list[int] = []
    original = Axes.plot

    def counting(self: Axes, *args: object, **kwargs: object) -> object:
        drawn.append(id(self))
        return original(self, *args, **kwargs)

    Axes.plot = counting  # type: ignore[method-assign]
    try:
        plots.plot_temperatures({"x": results, "y": results}, tmp_path / "fig5.png")
    finally:
        Axes.plot = original  # type: ignore[method-assign]
    per_panel = pd.Series(drawn).value_counts()
    assert len(per_panel) == 4 and per_panel.max() <= plots.MAX_LINES_PER_PANEL


def test_discomfort_labels_keep_small_values(tmp_path: Path) -> None:
    assert plots.kelvin_hours_text(0.06) == "0.06"
    assert plots.kelvin_hours_text(0.0) == "0"
    assert plots.kelvin_hours_text(11.65) == "11.7"
    assert plots.kelvin_hours_text(336.4) == "336"


def test_power_reserve_band_without_served_power_hangs_from_the_plant_power(
    make_results: Factory,
) -> None:
    results = make_results().drop(columns=["power_served_kw", "power_curtailed_kw"])
    data = plots.power_reserve_data({"x": results})
    assert data["reserve_band_upper_kw"].to_numpy() == pytest.approx(results["power_kw"].to_numpy())
    assert (data["reserve_band_upper_kw"] - data["reserve_band_lower_kw"]).to_numpy() == (
        pytest.approx(results["reserve_kw"].to_numpy())
    )


def test_plot_ppp_sweep_normalises_by_the_maximum(tmp_path: Path) -> None:
    sweep = pd.DataFrame(
        {
            "peak_price_sgd_per_kw": [30.0, 0.5, 5.0, 1.5],
            "total_cost_sgd": [200.0, 160.0, 190.0, 180.0],
            "peak_power_kw": [12.0, 20.0, 12.5, 16.0],
            "net_cost_with_ppp_sgd": [560.0, 170.0, 252.5, 204.0],
        }
    )
    path = plots.plot_ppp_sweep(sweep, tmp_path / "fig7.png")
    data = _assert_png_and_csv(path, tmp_path / "fig7.png")
    assert data["peak_price_sgd_per_kw"].to_list() == [0.5, 1.5, 5.0, 30.0]
    # 160/200, 180/200, 190/200, 200/200 and 20/20, 16/20, 12.5/20, 12/20
    assert data["normalised_total_cost_pct"].to_list() == pytest.approx([80, 90, 95, 100])
    assert data["normalised_peak_power_pct"].to_list() == pytest.approx([100, 80, 62.5, 60])
    assert data["net_cost_with_ppp_sgd"].to_list() == [170.0, 204.0, 252.5, 560.0]


def test_plot_ppp_sweep_names_missing_columns(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="total_cost_sgd"):
        plots.plot_ppp_sweep(pd.DataFrame({"peak_price_sgd_per_kw": [1.0]}), tmp_path / "x.png")


def test_plot_discomfort_totals_per_scenario(
    tmp_path: Path, scenarios: dict[str, pd.DataFrame]
) -> None:
    path = plots.plot_discomfort(scenarios, tmp_path / "discomfort.png")
    data = _assert_png_and_csv(path, tmp_path / "discomfort.png").set_index("scenario")
    for label, results in scenarios.items():
        assert data.loc[label, "total"] == pytest.approx(kpi.total_discomfort_kelvin_hours(results))
    # the warmer (a) run violates the occupied upper bound; (b) does not
    assert data.loc["(a) NMPC", "total"] > data.loc["(b) RMPC", "total"] == 0.0


def test_plot_robustness_price_with_and_without_controller(tmp_path: Path) -> None:
    levels = np.array([0.0, 0.1, 0.3, 0.5])
    sweep = pd.DataFrame(
        {
            "uncertainty_level": np.tile(levels, 2),
            "controller": ["open-loop"] * 4 + ["closed-loop"] * 4,
            "energy_cost_sgd": np.tile(100 + 50 * levels, 2),
            "reserve_revenue_sgd": np.tile(1 - levels, 2),
            "discomfort_kelvin_hours": np.tile(5 * levels, 2),
            "planned_slack_share": np.tile(levels, 2),
        }
    )
    path = plots.plot_robustness_price(sweep, tmp_path / "robust.png")
    data = _assert_png_and_csv(path, tmp_path / "robust.png")
    assert len(data) == 8
    single = sweep.drop(columns="controller").iloc[:4].sample(frac=1.0, random_state=0)
    path = plots.plot_robustness_price(single, tmp_path / "robust1.png")
    data = _assert_png_and_csv(path, tmp_path / "robust1.png")
    assert data["uncertainty_level"].to_list() == list(levels)


def test_plot_discomfort_from_a_precomputed_table(tmp_path: Path) -> None:
    totals = pd.DataFrame({"scenario": ["nmpc", "rmpc"], "discomfort_kelvin_hours": [12.5, 0.25]})
    path = plots.plot_discomfort(totals, tmp_path / "d.png")
    data = _assert_png_and_csv(path, tmp_path / "d.png").set_index("scenario")
    assert data["total"].to_dict() == pytest.approx({"nmpc": 12.5, "rmpc": 0.25})


def test_plot_robustness_price_prefers_net_cost_and_keeps_extra_columns(tmp_path: Path) -> None:
    sweep = pd.DataFrame(
        {
            "uncertainty_level": [0.5, 0.0, 0.2],
            "net_cost_sgd": [130.0, 100.0, 110.0],
            "reserve_revenue_sgd": [0.0, 1.0, 0.6],
            "discomfort_kelvin_hours": [0.0, 3.0, 0.5],
            "planned_slack_share": [0.4, 0.0, 0.0],
            "max_delta_vs_half_band": [1.2, 0.0, 0.5],
        }
    )
    path = plots.plot_robustness_price(sweep, tmp_path / "r.png")
    data = _assert_png_and_csv(path, tmp_path / "r.png")
    assert data["net_cost_sgd"].to_list() == [100.0, 110.0, 130.0]
    assert "max_delta_vs_half_band" in data
    with pytest.raises(DataError, match="energy_cost_sgd"):
        plots.plot_robustness_price(sweep.drop(columns="net_cost_sgd"), tmp_path / "x.png")


MIN_LABEL_GAP_PX = 8.0
"""Space two tick labels need between them to read as two [px at the figures' DPI]."""


def _tick_labels_overlap(max_ticks: int | None) -> bool:
    """Whether the date tick labels of a Fig. 5 panel (half the figure wide, two days) run
    into each other when drawn: less than :data:`MIN_LABEL_GAP_PX` between two."""
    from hvacflex.report.plots import format_time_axis, new_figure

    figure, axes = new_figure(3, 2, sharex="row", sharey=True)
    times = pd.date_range("2014-03-04", periods=97, freq="30min").to_numpy()
    axes[0].plot(times, np.arange(97.0))
    format_time_axis(axes[0], max_ticks)
    figure.tight_layout()
    renderer = figure.canvas.get_renderer()  # type: ignore[attr-defined]
    boxes = sorted(
        (t.get_window_extent(renderer) for t in axes[0].get_xticklabels() if t.get_text()),
        key=lambda box: box.x0,
    )
    return any(a.x1 + MIN_LABEL_GAP_PX > b.x0 for a, b in itertools.pairwise(boxes))


def test_fig5_tick_labels_do_not_collide() -> None:
    from hvacflex.report.plots import HALF_WIDTH_MAX_TICKS

    assert _tick_labels_overlap(None)  # matplotlib's own choice: "Mar-0406:00"
    assert not _tick_labels_overlap(HALF_WIDTH_MAX_TICKS)


def test_the_power_panel_names_the_hvac_and_draws_the_metered_facility(
    make_results: Factory,
) -> None:
    import matplotlib.pyplot as plt

    frame = make_results(days=1.0)
    figure, ax = plt.subplots()
    plots.power_panel(ax, frame, "rc")
    labels = ax.get_legend_handles_labels()[1]
    assert "HVAC power drawn" in labels and "facility power (metered)" not in labels
    assert ax.get_ylabel().startswith("HVAC power")
    frame["facility_power_kw"] = frame["power_kw"] + 20.0
    figure2, ax2 = plt.subplots()
    plots.power_panel(ax2, frame, "energyplus")
    assert "facility power (metered)" in ax2.get_legend_handles_labels()[1]
    plt.close(figure)
    plt.close(figure2)
