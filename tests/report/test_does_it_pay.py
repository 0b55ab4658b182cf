"""The "does it pay?" table on hand-made frames whose answers are computed by hand."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.report.does_it_pay import (
    COLUMNS,
    CSV_NAME,
    DECIDING_COLUMNS,
    does_it_pay,
    write_does_it_pay,
)

DAYS_IN_MARCH = 31
PHI_SGD_PER_KW = 2.0
AREA_M2 = 100.0


def _frame(
    power_kw: float,
    *,
    reserve_kw: float = 0.0,
    temp_degc: float = 24.0,
    planned_peak_price: float = 0.0,
    night_temp_degc: float | None = None,
    activated_periods: int = 0,
) -> pd.DataFrame:
    """One day (48 periods) of March 2014 at constant power, USEP 100 SGD/MWh, reserve price
    50 SGD/MWh, two zones at ``temp_degc`` in a 23–26 °C band; with ``night_temp_degc`` the
    first 16 periods (00:00–08:00) are unoccupied (20–30 °C band) at that temperature. The
    first ``activated_periods`` periods are IL-activated."""
    index = pd.date_range("2014-03-03", periods=48, freq="30min", tz="Asia/Singapore")
    columns: dict[str, float | bool] = {
        "power_kw": power_kw,
        "energy_price_sgd_per_mwh": 100.0,
        "reserve_kw": reserve_kw,
        "reserve_price_sgd_per_mwh": 50.0,
        "peak_price_sgd_per_kw": planned_peak_price,
        "il_curtailed": False,
    }
    frame = pd.DataFrame(columns, index=index.rename("time"))
    frame["il_activated"] = [k < activated_periods for k in range(48)]
    night = [k < 16 and night_temp_degc is not None for k in range(48)]
    for zone in ("north", "core"):
        frame[f"temp_{zone}_degc"] = [night_temp_degc if n else temp_degc for n in night]
        frame[f"temp_end_{zone}_degc"] = frame[f"temp_{zone}_degc"]
        frame[f"comfort_lower_{zone}_degc"] = [20.0 if n else 23.0 for n in night]
        frame[f"comfort_upper_{zone}_degc"] = [30.0 if n else 26.0 for n in night]
    return frame


def _month(per_day_sgd: float) -> float:
    """A day's sum scaled to the month (one day covers 1/31 of March)."""
    return per_day_sgd * DAYS_IN_MARCH


@pytest.fixture
def table() -> pd.DataFrame:
    frames = {
        "baseline-a": _frame(10.0),
        "baseline-b": _frame(8.0, temp_degc=27.0),  # cheaper, but 1 K too warm all day
        "mpc-m": _frame(9.0, reserve_kw=2.0, planned_peak_price=5.0),
        "mpc-n": _frame(12.0),
    }
    return does_it_pay(
        frames,
        {"baseline-a", "baseline-b"},
        peak_price_sgd_per_kw=PHI_SGD_PER_KW,
        floor_area_m2=AREA_M2,
    ).set_index("controller")


def test_every_run_is_priced_with_the_one_tariff(table: pd.DataFrame) -> None:
    # energy per day: P × 24 h × 100 SGD/MWh; peak: φ × P whatever φ the run planned with
    m = table.loc["mpc-m"]
    assert m["energy_cost_sgd_per_month"] == pytest.approx(_month(9.0 * 24 * 0.1))  # 669.6
    assert m["peak_charge_sgd_per_month"] == pytest.approx(2.0 * 9.0)
    # no activation: the reserve revenue is availability payments no meter settled; beside
    # the tariff cost, not in it
    assert m["reserve_unsettled_sgd_per_month"] == pytest.approx(_month(2.0 * 24 * 0.05))  # 74.4
    assert m["reserve_settled_sgd_per_month"] == 0.0
    assert m["il_penalty_sgd_per_month"] == 0.0
    assert m["tariff_cost_sgd_per_month"] == pytest.approx(669.6 + 18.0)
    assert m["tariff_cost_sgd_per_m2_month"] == pytest.approx((669.6 + 18.0) / AREA_M2)
    assert table.loc["baseline-a", "tariff_cost_sgd_per_month"] == pytest.approx(744.0 + 20.0)
    assert table.loc["mpc-n", "peak_power_kw"] == 12.0


def test_the_reference_is_the_cheapest_baseline_that_keeps_comfort(table: pd.DataFrame) -> None:
    assert set(table["reference"]) == {"baseline-a"}
    b = table.loc["baseline-b"]
    assert b["discomfort_occupied_kelvin_hours_per_month"] == pytest.approx(
        _month(2 * 48 * 1.0 * 0.5)
    )
    assert b["saving_vs_reference_sgd_per_month"] > 0 and not b["pays"]  # bought by discomfort


def test_savings_ranks_and_whether_it_pays(table: pd.DataFrame) -> None:
    assert list(table.index) == ["baseline-b", "mpc-m", "baseline-a", "mpc-n"]
    assert list(table["rank"]) == [1, 2, 3, 4]
    m = table.loc["mpc-m"]
    saving = 764.0 - 687.6
    assert m["saving_vs_reference_sgd_per_month"] == pytest.approx(saving)
    assert m["saving_vs_reference_sgd_per_m2_month"] == pytest.approx(saving / AREA_M2)
    assert m["saving_vs_reference_pct"] == pytest.approx(100 * saving / 764.0)
    assert m["pays"] and not table.loc["mpc-n", "pays"] and not table.loc["baseline-a", "pays"]
    assert table.loc["mpc-n", "saving_vs_reference_sgd_per_month"] == pytest.approx(
        764.0 - (892.8 + 24.0)
    )
    assert sorted(table.reset_index().columns) == sorted(COLUMNS)
    assert table["rule_based"].to_dict() == {
        "baseline-b": True,
        "mpc-m": False,
        "baseline-a": True,
        "mpc-n": False,
    }


def test_without_a_comfortable_baseline_the_cheapest_baseline_is_the_reference() -> None:
    frames = {"hot": _frame(8.0, temp_degc=27.0), "mpc": _frame(9.0)}
    table = does_it_pay(frames, {"hot"}, peak_price_sgd_per_kw=1.0, floor_area_m2=1.0)
    assert set(table["reference"]) == {"hot"}


def test_bad_inputs_raise_input_errors() -> None:
    with pytest.raises(InputError, match="rule-based baseline"):
        does_it_pay(
            {"mpc": _frame(9.0)}, {"thermostat"}, peak_price_sgd_per_kw=1.0, floor_area_m2=1.0
        )


@pytest.mark.parametrize("area_m2", [float("nan"), 0.0, float("inf")])
def test_per_m2_is_not_available_without_a_floor_area(area_m2: float) -> None:
    table = does_it_pay(
        {"a": _frame(9.0), "m": _frame(8.0)},
        {"a"},
        peak_price_sgd_per_kw=1.0,
        floor_area_m2=area_m2,
    )
    assert table["tariff_cost_sgd_per_m2_month"].isna().all()
    assert table["saving_vs_reference_sgd_per_m2_month"].isna().all()
    assert table["tariff_cost_sgd_per_month"].notna().all()


def test_settled_reserve_ranks_and_unsettled_stands_beside_it() -> None:
    # the baseline "gta" offers 2 kW all day and is activated in 4 periods: those 4 periods'
    # payments are settled (2 kW × 50 SGD/MWh × 0.5 h each); the other 44 are not
    frames = {"thermostat": _frame(10.0), "gta": _frame(10.0, reserve_kw=2.0, activated_periods=4)}
    table = does_it_pay(
        frames, {"thermostat", "gta"}, peak_price_sgd_per_kw=2.0, floor_area_m2=AREA_M2
    ).set_index("controller")
    gta = table.loc["gta"]
    # metered power does not fall in the activations: a 2 kW shortfall, but these frames
    # have no penalty price column (no penalty), so only the settled payment counts
    assert gta["reserve_settled_sgd_per_month"] == pytest.approx(_month(4 * 2.0 * 0.05 * 0.5))
    assert gta["reserve_unsettled_sgd_per_month"] == pytest.approx(_month(44 * 2.0 * 0.05 * 0.5))
    assert gta["tariff_cost_sgd_per_month"] == pytest.approx(
        744.0 + 20.0 - _month(4 * 2.0 * 0.05 * 0.5)
    )
    assert table.index[0] == "gta" and set(table["reference"]) == {"gta"}
    # the same revenue without any activation ties with the thermostat: the reference is
    # then chosen on settled money alone, never on the availability payments
    frames["gta"] = _frame(10.0, reserve_kw=2.0)
    tied = does_it_pay(frames, {"thermostat", "gta"}, peak_price_sgd_per_kw=2.0, floor_area_m2=1)
    assert list(tied["tariff_cost_sgd_per_month"]) == pytest.approx([764.0, 764.0])
    assert list(tied["controller"]) == ["thermostat", "gta"]  # stable: the first given wins


def test_pays_grades_occupied_comfort_and_shows_night_excursions_beside_it() -> None:
    # the MPC is cheaper and rides 0.5 K above the 30 °C night bound for 8 h in both zones:
    # unoccupied discomfort 2 × 16 × 0.5 K × 0.5 h = 8 K·h; occupied discomfort 0
    frames = {"thermostat": _frame(10.0), "mpc": _frame(9.0, night_temp_degc=30.5)}
    table = does_it_pay(
        frames, {"thermostat"}, peak_price_sgd_per_kw=2.0, floor_area_m2=AREA_M2
    ).set_index("controller")
    mpc = table.loc["mpc"]
    assert mpc["discomfort_occupied_kelvin_hours_per_month"] == 0.0
    assert mpc["discomfort_unoccupied_kelvin_hours_per_month"] == pytest.approx(_month(8.0))
    assert mpc["pays"]
    assert list(
        does_it_pay(frames, {"thermostat"}, peak_price_sgd_per_kw=2.0, floor_area_m2=1).columns[:6]
    ) == list(DECIDING_COLUMNS)


def test_the_csv_reads_back(table: pd.DataFrame, tmp_path: Path) -> None:
    path = write_does_it_pay(table.reset_index()[list(COLUMNS)], tmp_path)
    assert path.name == CSV_NAME
    back = pd.read_csv(path)
    assert list(back.columns) == list(COLUMNS)
    assert back.loc[back["controller"] == "mpc-m", "pays"].item()
