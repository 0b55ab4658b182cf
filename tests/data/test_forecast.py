"""load_exogenous alignment and Forecaster slicing, persistence and AR(1) error."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.building.channels import (
    ground_temp_channel,
    internal_gain_channel,
    outdoor_temp_channel,
    solar_channel,
)
from hvacflex.data.forecast import Exogenous, Forecaster, load_exogenous
from hvacflex.data.gains import zone_internal_gains_w
from hvacflex.data.market import load_usep
from hvacflex.errors import ConfigError, DataError

TZ = "Asia/Singapore"
CHANNELS = (
    outdoor_temp_channel(),
    solar_channel(90, 90),
    solar_channel(270, 90),
    internal_gain_channel("east"),
    internal_gain_channel("west"),
    ground_temp_channel(),
)


@dataclass(frozen=True)
class Gains:
    occupancy_m2_per_person: float = 10.0
    sensible_w_per_person: float = 75.0
    latent_w_per_person: float = 55.0
    lighting_w_per_m2: float = 10.0
    equipment_w_per_m2: float = 12.0


@pytest.fixture(scope="module")
def week() -> Exogenous:
    return load_exogenous(CHANNELS, [100.0, 200.0], Gains(), start="2014-03-17", steps=7 * 48)


def test_exogenous_shapes_and_alignment(week: Exogenous, shared_data_dir: Path) -> None:
    t = 7 * 48 + 48
    assert week.steps == t and str(week.index.tz) == TZ
    assert week.index[0] == pd.Timestamp("2014-03-17", tz=TZ)
    assert week.disturbances.shape == (t, 6)
    assert week.comfort_lower_degc.shape == week.comfort_upper_degc.shape == (t, 2)
    usep = load_usep(shared_data_dir / "nems_usep_2014")["energy_price_sgd_per_mwh"]
    np.testing.assert_array_equal(week.energy_price_sgd_per_mwh, usep.loc[week.index].to_numpy())
    assert week.reserve_price_synthetic and not week.energy_price_extrapolated.any()
    gains_east = zone_internal_gains_w(week.index, 100.0, 10.0, 75.0, 10.0, 12.0)
    np.testing.assert_allclose(week.disturbances[:, 3], gains_east)
    np.testing.assert_allclose(week.disturbances[:, 4], 2 * gains_east)
    assert 20 < week.outdoor_temp_degc.min() and week.outdoor_temp_degc.max() < 35
    assert 26 < week.disturbances[:, 5].mean() < 29  # ground
    assert 0.01 < week.outdoor_humidity_ratio_kg_per_kg.mean() < 0.025
    with pytest.raises(ValueError):
        week.energy_price_sgd_per_mwh[0] = 0.0  # read-only


def test_beyond_price_data_repeats_last_day_and_weather_wraps() -> None:
    x = load_exogenous(CHANNELS, [100.0, 100.0], Gains(), start="2014-12-31", steps=48)
    assert x.energy_price_extrapolated[:48].sum() == 0 and x.energy_price_extrapolated[48:].all()
    np.testing.assert_array_equal(x.energy_price_sgd_per_mwh[48:], x.energy_price_sgd_per_mwh[:48])
    assert not x.occupied[48:].any()  # 1 Jan 2015 is a holiday
    assert np.isfinite(x.disturbances).all()


def test_bad_arguments() -> None:
    with pytest.raises(ConfigError, match="30-min boundary"):
        load_exogenous(CHANNELS, [1.0, 1.0], Gains(), start="2014-01-01 00:10", steps=1)
    with pytest.raises(ConfigError, match="one internal_gain channel per zone"):
        load_exogenous(CHANNELS, [1.0], Gains(), start="2014-01-01", steps=1)
    with pytest.raises(ConfigError, match="without floor area"):
        load_exogenous(CHANNELS, {"east": 1.0}, Gains(), start="2014-01-01", steps=1)


def test_perfect_forecast_is_a_slice(week: Exogenous) -> None:
    forecaster = Forecaster(week)
    f = forecaster.forecast(10, 48)
    assert f.horizon == 48 and f.step == 10
    assert f.index[0] == week.index[10] and len(f.index) == 48
    np.testing.assert_array_equal(f.energy_price_sgd_per_mwh, week.energy_price_sgd_per_mwh[10:58])
    np.testing.assert_array_equal(f.disturbances, week.disturbances[10:58])
    np.testing.assert_array_equal(f.comfort_upper_degc, week.comfort_upper_degc[10:58])
    np.testing.assert_array_equal(f.outdoor_temp_degc, week.outdoor_temp_degc[10:58])
    assert f.reserve_price_synthetic
    last = forecaster.forecast(7 * 48 - 1, 48)
    assert last.horizon == 48
    with pytest.raises(DataError, match="outside the loaded data"):
        forecaster.forecast(7 * 48 + 1, 48)


def test_price_persistence_is_yesterdays_same_period(week: Exogenous) -> None:
    f = Forecaster(week, mode="persistence").forecast(100, 48)
    np.testing.assert_array_equal(f.energy_price_sgd_per_mwh, week.energy_price_sgd_per_mwh[52:100])
    np.testing.assert_array_equal(
        f.reserve_price_sgd_per_mwh, week.reserve_price_sgd_per_mwh[52:100]
    )
    long = Forecaster(week, mode="persistence").forecast(100, 96)
    np.testing.assert_array_equal(
        long.energy_price_sgd_per_mwh[48:], week.energy_price_sgd_per_mwh[52:100]
    )
    first_day = Forecaster(week, mode="persistence").forecast(0, 48)
    np.testing.assert_array_equal(
        first_day.energy_price_sgd_per_mwh, week.energy_price_sgd_per_mwh[:48]
    )


def test_ar1_disturbance_error(week: Exogenous) -> None:
    forecaster = Forecaster(week, disturbance_error="ar1", seed=3)
    f = forecaster.forecast(20, 48)
    truth = week.disturbances[20:68]
    np.testing.assert_array_equal(f.disturbances[0], truth[0])  # current period known
    assert not np.array_equal(f.disturbances, truth)
    assert (f.disturbances[:, 1:5] >= 0).all()
    again = Forecaster(week, disturbance_error="ar1", seed=3)
    again.forecast(5, 48)
    np.testing.assert_array_equal(again.forecast(20, 48).disturbances, f.disturbances)
    # error grows with lead time: mean |error| over many forecasts, outdoor temperature
    errors = np.array(
        [forecaster.forecast(k, 48).disturbances[:, 0] - week.disturbances[k : k + 48, 0]
         for k in range(0, 300, 3)]
    )  # fmt: skip
    spread = np.abs(errors).mean(axis=0)
    assert spread[1] < spread[10] < spread[40] + 0.05
    assert 0.2 < spread[40] < 0.6  # → σ = 0.5 K, mean |N(0, σ)| ≈ 0.4 K


@pytest.mark.parametrize(
    ("start", "steps", "field", "partly"),
    [("2016-03-03", 48, "start", False), ("2013-12-31", 48, "start", False),
     ("2014-12-30", 3 * 48, "days", True)],
)  # fmt: skip
def test_a_run_outside_the_price_data_is_refused(
    start: str, steps: int, field: str, partly: bool
) -> None:
    with pytest.raises(DataError, match="outside the USEP price data") as info:
        load_exogenous(CHANNELS, [100.0, 100.0], Gains(), start=start, steps=steps)
    text = str(info.value)
    assert info.value.field == field and ("partly outside" in text) == partly
    assert "covers 2014-01-01 … 2014-12-31 (2014)" in text
    assert "data.usep_source" in text and "HVACFLEX_DATA_DIR" in text


def test_the_last_simulated_period_may_be_the_last_period_of_the_data() -> None:
    x = load_exogenous(CHANNELS, [100.0, 100.0], Gains(), start="2014-12-31 23:30", steps=1)
    assert not x.energy_price_extrapolated[0] and x.energy_price_extrapolated[1:].all()
    with pytest.raises(DataError, match="partly outside"):
        load_exogenous(CHANNELS, [100.0, 100.0], Gains(), start="2014-12-31 23:30", steps=2)


def test_price_gap_fill_reaches_the_loader(tmp_path: Path, shared_data_dir: Path) -> None:
    source = shared_data_dir / "nems_usep_2014" / "USEP_Mar-2014.csv"
    lines = source.read_text().splitlines()
    del lines[1 + 48 * 16 + 20]  # 17 March, period 21
    gappy = tmp_path / "USEP_Mar-2014.csv"
    gappy.write_text("\n".join(lines) + "\n")
    kwargs = {"start": "2014-03-17", "steps": 48, "usep_source": gappy}
    with pytest.raises(DataError, match="1 missing period"):
        load_exogenous(CHANNELS, [100.0, 100.0], Gains(), **kwargs)  # type: ignore[arg-type]
    x = load_exogenous(CHANNELS, [100.0, 100.0], Gains(), price_gap_fill="previous-day", **kwargs)  # type: ignore[arg-type]
    full = load_usep(source)["energy_price_sgd_per_mwh"]
    assert x.energy_price_sgd_per_mwh[20] == full.loc["2014-03-16 10:00+08:00"]
    assert x.energy_price_sgd_per_mwh[21] == full.loc["2014-03-17 10:30+08:00"]


def test_the_live_calendar_plans_real_dates_on_the_mapped_prices_and_the_typical_year(
    shared_data_dir: Path,
) -> None:
    # Wed 2026-12-02 takes the prices of Wed 2014-12-03 (hvacflex.data.calendar); the weather
    # is the typical year's 2 December, as in any year; the schedule is 2026's
    live = load_exogenous(
        CHANNELS, [100.0, 100.0], Gains(), start="2026-12-02", steps=48, calendar="live"
    )
    assert live.index[0] == pd.Timestamp("2026-12-02", tz=TZ)
    usep = load_usep(shared_data_dir / "nems_usep_2014")["energy_price_sgd_per_mwh"]
    np.testing.assert_array_equal(
        live.energy_price_sgd_per_mwh[:48], usep.loc["2014-12-03"].to_numpy()
    )
    assert live.energy_price_extrapolated.all()
    same_date = load_exogenous(CHANNELS, [100.0, 100.0], Gains(), start="2014-12-02", steps=48)
    np.testing.assert_array_equal(live.outdoor_temp_degc[:48], same_date.outdoor_temp_degc[:48])
    assert live.occupied[:48].any()  # a Wednesday, a working day
    # the same date under the data calendar is refused
    with pytest.raises(DataError, match="outside the USEP price data"):
        load_exogenous(CHANNELS, [100.0, 100.0], Gains(), start="2026-12-02", steps=48)


@pytest.mark.parametrize("phi", [0.0, 0.3, 0.9, -0.5])
def test_ar1_filter_is_scipys_lfilter_bit_for_bit(phi: float) -> None:
    """The forecast error's AR(1) recursion equals scipy.signal.lfilter's (which it replaces
    to spare start-up the import), bit for bit, and e_k = w_k + φ·e_{k−1} by hand."""
    from scipy.signal import lfilter

    from hvacflex.data.forecast import ar1_filter

    w = np.random.default_rng(7).standard_normal((49, 6)) * 2.5
    ours = ar1_filter(w, phi)
    assert np.array_equal(ours, lfilter([1.0], [1.0, -phi], w, axis=0))
    assert ours[0].tolist() == w[0].tolist()
    assert ours[3, 2] == w[3, 2] + phi * (w[2, 2] + phi * (w[1, 2] + phi * w[0, 2]))
    assert np.array_equal(ar1_filter(w[:, 0], phi), ours[:, 0])
