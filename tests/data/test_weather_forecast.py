"""The statistical weather forecaster: fit on synthetic data, and it never reads the future."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
import pytest

from hvacflex.building.channels import internal_gain_channel, outdoor_temp_channel, solar_channel
from hvacflex.data.forecast import Exogenous, Forecaster, default_weather_file, load_exogenous
from hvacflex.data.weather_forecast import (
    ClimatologyAR1,
    fit_climatology_ar1,
    fit_weather_forecaster,
    period_of_day,
)
from hvacflex.errors import ConfigError, DataError

CHANNELS = (outdoor_temp_channel(), solar_channel(90, 90), internal_gain_channel("east"))


@dataclass(frozen=True)
class Gains:
    occupancy_m2_per_person: float = 10.0
    sensible_w_per_person: float = 75.0
    latent_w_per_person: float = 55.0
    lighting_w_per_m2: float = 10.0
    equipment_w_per_m2: float = 12.0


@pytest.fixture(scope="module")
def days() -> Exogenous:
    return load_exogenous(CHANNELS, [100.0], Gains(), start="2014-03-17", steps=3 * 48)


@pytest.fixture(scope="module")
def statistical(days: Exogenous) -> Forecaster:
    weather = fit_weather_forecaster(
        CHANNELS, days.index[0], train_days=14, weather_file=default_weather_file()
    )
    return Forecaster(days, weather=weather)


def test_fit_recovers_a_known_climatology_and_ar1_coefficient() -> None:
    rng = np.random.default_rng(7)
    t = 48 * 400
    periods = np.arange(t) % 48
    profile = 27.0 + 3.0 * np.sin(2 * np.pi * np.arange(48) / 48)
    anomaly = np.zeros(t)
    for i in range(1, t):
        anomaly[i] = 0.8 * anomaly[i - 1] + rng.normal(0.0, 0.3)
    fit = fit_climatology_ar1((profile[periods] + anomaly)[:, None], periods, np.array([False]))
    assert fit.ar1_coefficient[0] == pytest.approx(0.8, abs=0.02)
    np.testing.assert_allclose(fit.climatology[:, 0], profile, atol=0.1)


def test_predict_decays_the_last_anomaly_towards_the_climatology() -> None:
    climatology = np.zeros((48, 2))
    climatology[:, 0] = 20.0
    fit = ClimatologyAR1(climatology, np.array([0.5, 0.5]), np.array([False, True]))
    forecast = fit.predict(np.array([24.0, -8.0]), 47, np.array([0, 1, 2]))
    np.testing.assert_allclose(forecast[:, 0], [22.0, 21.0, 20.5])  # 20 + 0.5^(i+1) · 4
    np.testing.assert_array_equal(forecast[:, 1], [0.0, 0.0, 0.0])  # irradiance ≥ 0


def test_fit_needs_every_period_of_the_day() -> None:
    with pytest.raises(DataError, match="every 30-min period"):
        fit_climatology_ar1(np.ones((10, 1)), np.arange(10), np.array([False]))


def test_training_window_ends_before_the_forecast(days: Exogenous) -> None:
    weather = fit_weather_forecaster(
        CHANNELS, days.index[0], train_days=14, weather_file=default_weather_file()
    )
    assert weather.train_end == days.index[0] - pd.Timedelta(minutes=30)
    assert weather.train_start == days.index[0] - pd.Timedelta(days=14)
    assert weather.columns == (0, 1)  # the gain channel is not weather
    with pytest.raises(ConfigError, match="training day"):
        fit_weather_forecaster(CHANNELS, days.index[0], train_days=0, weather_file="x.epw")


def test_forecast_at_k_does_not_read_the_data_of_k_or_later(
    days: Exogenous, statistical: Forecaster
) -> None:
    k = 60
    changed = np.array(days.disturbances)
    changed[k:, :2] += 5.0  # a different future: hotter, sunnier
    humidity = np.array(days.outdoor_humidity_ratio_kg_per_kg)
    humidity[k:] *= 1.5
    other = replace(days, disturbances=changed, outdoor_humidity_ratio_kg_per_kg=humidity)
    assert statistical.weather is not None
    forecaster = Forecaster(other, weather=statistical.weather)
    before, after = statistical.forecast(k, 48), forecaster.forecast(k, 48)
    np.testing.assert_array_equal(before.disturbances, after.disturbances)
    np.testing.assert_array_equal(
        before.outdoor_humidity_ratio_kg_per_kg, after.outdoor_humidity_ratio_kg_per_kg
    )
    # ... while the forecast of the next step sees the changed period k
    assert not np.array_equal(
        statistical.forecast(k + 1, 48).disturbances, forecaster.forecast(k + 1, 48).disturbances
    )


def test_statistical_forecast_is_not_the_data_but_close(
    days: Exogenous, statistical: Forecaster
) -> None:
    forecast = statistical.forecast(20, 48)
    truth = days.disturbances[20:68]
    error = np.abs(forecast.disturbances[:, 0] - truth[:, 0])
    assert error.max() > 0.1  # not perfect foresight
    assert error.mean() < 2.0  # but a forecast of Singapore's outdoor temperature [K]
    np.testing.assert_array_equal(forecast.disturbances[:, 2], truth[:, 2])  # gains: schedule
    assert (forecast.disturbances[:, 1] >= 0).all()


def test_expected_disturbances_replace_the_gains(days: Exogenous) -> None:
    expected = np.array(days.disturbances)
    expected[:, 2] = 123.0
    forecast = Forecaster(days, expected_disturbances=expected).forecast(5, 10)
    np.testing.assert_array_equal(forecast.disturbances[:, 2], 123.0)
    np.testing.assert_array_equal(forecast.disturbances[:, 0], days.disturbances[5:15, 0])
    with pytest.raises(DataError, match="shape"):
        Forecaster(days, expected_disturbances=expected[:, :2])
    with pytest.raises(ConfigError, match="AR"):
        Forecaster(days, disturbance_error="ar1", expected_disturbances=expected)


def test_period_of_day_is_local_time() -> None:
    index = pd.date_range("2014-03-17 00:00", periods=3, freq="30min", tz="Asia/Singapore")
    np.testing.assert_array_equal(period_of_day(index.tz_convert("UTC")), [0, 1, 2])
