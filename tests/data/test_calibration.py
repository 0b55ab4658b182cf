"""The calibrated box: known quantiles of synthetic errors, and coverage counted right."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.building.channels import internal_gain_channel, outdoor_temp_channel, solar_channel
from hvacflex.data.calibration import (
    calibrate_box,
    coverage,
    forecast_errors,
    model_error_coverage,
)
from hvacflex.data.forecast import Forecast
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import ConfigError, DataError

CHANNELS = (outdoor_temp_channel(), solar_channel(90, 90), internal_gain_channel("east"))


def test_half_widths_are_the_quantiles_of_synthetic_errors() -> None:
    rng = np.random.default_rng(11)
    s = 200_000
    forecasts = np.column_stack(
        [np.full(s, 28.0), rng.uniform(100.0, 500.0, s), rng.uniform(1000.0, 3000.0, s)]
    )
    low = np.arange(s) < s // 4
    forecasts[low, 1] = rng.uniform(0.0, 50.0, low.sum())  # sunrise: below 20 % of the peak
    errors = np.column_stack(
        [
            rng.uniform(-2.0, 2.0, s),  # |e| ~ U(0, 2): Q_0.9 = 1.8 K
            np.where(
                low,
                rng.uniform(-30.0, 30.0, s),  # low forecasts: |e| ~ U(0, 30), Q_0.9 = 27 W/m²
                forecasts[:, 1] * rng.uniform(-0.5, 0.5, s),  # |e|/d̂ ~ U(0, 0.5)
            ),
            forecasts[:, 2] * rng.normal(0.0, 0.1, s),  # |e|/d̂ half-normal: Q_0.9 = 0.1645
        ]
    )
    cal = calibrate_box(errors, forecasts, CHANNELS, 0.9)
    assert cal.box.channel_absolute["outdoor_temp_degc"] == pytest.approx(1.8, abs=0.01)
    solar = CHANNELS[1].name
    assert cal.box.channel_absolute[solar] == pytest.approx(27.0, abs=0.3)
    # high forecasts: Q_0.9 of max(|e| − 27, 0)/d̂ with |e| = u·d̂, u ~ U(0, 0.5), d̂ ~ U(100, 500)
    u = rng.uniform(0.0, 0.5, s)
    d = rng.uniform(100.0, 500.0, s)
    expected = np.quantile(np.maximum(u * d - cal.box.channel_absolute[solar], 0.0) / d, 0.9)
    assert cal.box.channel_relative[solar] == pytest.approx(expected, abs=0.005)
    assert cal.box.channel_relative[CHANNELS[2].name] == pytest.approx(0.1645, abs=0.002)
    assert cal.box.channel_absolute[CHANNELS[2].name] == 0.0  # these forecasts are never low
    assert cal.samples == s and cal.quantile == 0.9
    inside = coverage(errors, forecasts, cal.box, CHANNELS)
    np.testing.assert_array_less(0.9 - 1e-9, inside)  # at least q in sample


def test_a_channel_forecast_at_zero_throughout_is_sized_absolutely() -> None:
    errors = np.column_stack([np.zeros(4), np.array([0.0, 1.0, 2.0, 3.0]), np.zeros(4)])
    cal = calibrate_box(errors, np.zeros((4, 3)), CHANNELS, 0.5)
    assert cal.box.channel_absolute[CHANNELS[1].name] == 2.0  # next-higher of the median
    assert cal.box.channel_relative[CHANNELS[1].name] == 0.0


def test_coverage_on_hand_made_errors() -> None:
    box = UncertaintyBox(channel_absolute={"outdoor_temp_degc": 1.0})
    channel = (outdoor_temp_channel(),)
    errors = np.array([[0.5], [-1.0], [1.5], [-2.0]])
    forecasts = np.full((4, 1), 30.0)
    assert coverage(errors, forecasts, box, channel)[0] == 0.5  # 0.5 and −1.0 (the edge)
    relative = UncertaintyBox(relative={"solar": 0.1})
    solar = (solar_channel(0, 90),)
    covered = coverage(np.array([[5.0], [15.0]]), np.array([[100.0], [100.0]]), relative, solar)
    assert covered[0] == 0.5
    assert np.isnan(coverage(np.zeros((0, 1)), np.zeros((0, 1)), box, channel)[0])


def test_per_channel_values_override_the_kind() -> None:
    channels = (solar_channel(0, 90), solar_channel(90, 90))
    box = UncertaintyBox(relative={"solar": 0.2}, channel_absolute={channels[1].name: 7.0})
    sigma = box.sigma(np.array([[100.0, 100.0]]), channels)
    np.testing.assert_allclose(sigma, [[20.0, 7.0]])
    assert "±7" in box.describe() and not box.is_zero
    np.testing.assert_allclose(
        box.scaled(2.0).sigma(np.array([[100.0, 100.0]]), channels), [[40.0, 14.0]]
    )


def test_model_error_term_and_its_coverage() -> None:
    rng = np.random.default_rng(3)
    errors = {"north": rng.uniform(-0.4, 0.4, 100_000), "core": np.array([0.1, np.nan, -0.3])}
    cal = calibrate_box(
        np.zeros((1, 3)), np.ones((1, 3)), CHANNELS, 0.95, prediction_error_k=errors
    )
    assert cal.model_error_k["north"] == pytest.approx(0.38, abs=0.005)
    assert cal.model_error_k["core"] == pytest.approx(0.3)  # NaN ignored; next-higher sample
    held_out = {"north": np.array([0.1, 0.5, -0.2, np.nan])}
    assert model_error_coverage(held_out, cal.model_error_k)["north"] == pytest.approx(2 / 3)


def test_forecast_errors_stack_every_lead() -> None:
    class Shifted:
        """A forecast that is the truth minus one."""

        def __init__(self, truth: np.ndarray) -> None:
            self.truth = truth

        def forecast(self, k: int, horizon: int) -> Forecast:
            class View:
                disturbances = self.truth[k : k + horizon] - 1.0

            return View()  # type: ignore[return-value]

    truth = np.arange(30.0).reshape(10, 3)
    errors, forecasts = forecast_errors(Shifted(truth), truth, range(3), 4)
    assert errors.shape == forecasts.shape == (12, 3)
    np.testing.assert_array_equal(errors, 1.0)
    np.testing.assert_array_equal(forecasts[4], truth[1] - 1.0)  # step 1, lead 0


def test_bad_input() -> None:
    with pytest.raises(ConfigError, match="quantile"):
        calibrate_box(np.zeros((2, 3)), np.zeros((2, 3)), CHANNELS, 1.0)
    with pytest.raises(DataError, match="S, nd"):
        calibrate_box(np.zeros((2, 3)), np.zeros((3, 3)), CHANNELS, 0.9)
