"""The "does it pay?" table on hand-made frames whose answers are computed by hand."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hvacflex.errors import InputError
from hvacflex.report.does_it_pay import COLUMNS, CSV_NAME, does_it_pay, write_does_it_pay

DAYS_IN_MARCH = 31
PHI_SGD_PER_KW = 2.0
AREA_M2 = 100.0


def _frame(
    power_kw: float,
    *,
    reserve_kw: float = 0.0,
    temp_degc: float = 24.0,
    planned_peak_price: float = 0.0,
) -> pd.DataFrame:
    """One day (48 periods) of March 2014 at constant power, USEP 100 SGD/MWh, reserve price
    50 SGD/MWh, two zones at ``temp_degc`` in a 23–26 °C band."""
    index = pd.date_range("2014-03-03", periods=48, freq="30min", tz="Asia/Singapore")
    columns: dict[str, float | bool] = {
        "power_kw": power_kw,
        "energy_price_sgd_per_mwh": 100.0,
        "reserve_kw": reserve_kw,
        "reserve_price_sgd_per_mwh": 50.0,
        "peak_price_sgd_per_kw": planned_peak_price,
        "il_curtailed": False,
    }
    for zone in ("north", "core"):
        columns[f"temp_{zone}_degc"] = temp_degc
        columns[f"temp_end_{zone}_degc"] = temp_degc
        columns[f"comfort_lower_{zone}_degc"] = 23.0
        columns[f"comfort_upper_{zone}_degc"] = 26.0
    return pd.DataFrame(columns, index=index.rename("time"))


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
    assert m["reserve_revenue_sgd_per_month"] == pytest.approx(_month(2.0 * 24 * 0.05))  # 74.4
    assert m["il_penalty_sgd_per_month"] == 0.0
    assert m["tariff_cost_sgd_per_month"] == pytest.approx(669.6 + 18.0 - 74.4)
    assert m["tariff_cost_sgd_per_m2_month"] == pytest.approx((669.6 + 18.0 - 74.4) / AREA_M2)
    assert table.loc["baseline-a", "tariff_cost_sgd_per_month"] == pytest.approx(744.0 + 20.0)
    assert table.loc["mpc-n", "peak_power_kw"] == 12.0


def test_the_reference_is_the_cheapest_baseline_that_keeps_comfort(table: pd.DataFrame) -> None:
    assert set(table["reference"]) == {"baseline-a"}
    b = table.loc["baseline-b"]
    assert b["discomfort_kelvin_hours_per_month"] == pytest.approx(_month(2 * 48 * 1.0 * 0.5))
    assert b["saving_vs_reference_sgd_per_month"] > 0 and not b["pays"]  # bought by discomfort


def test_savings_ranks_and_whether_it_pays(table: pd.DataFrame) -> None:
    assert list(table.index) == ["baseline-b", "mpc-m", "baseline-a", "mpc-n"]
    assert list(table["rank"]) == [1, 2, 3, 4]
    m = table.loc["mpc-m"]
    saving = 764.0 - 613.2
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
    with pytest.raises(InputError, match="floor area"):
        does_it_pay({"a": _frame(9.0)}, {"a"}, peak_price_sgd_per_kw=1.0, floor_area_m2=0.0)


def test_the_csv_reads_back(table: pd.DataFrame, tmp_path: Path) -> None:
    path = write_does_it_pay(table.reset_index()[list(COLUMNS)], tmp_path)
    assert path.name == CSV_NAME
    back = pd.read_csv(path)
    assert list(back.columns) == list(COLUMNS)
    assert back.loc[back["controller"] == "mpc-m", "pays"].item()
