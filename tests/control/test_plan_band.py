"""The band a plan keeps: the bounds at period ends, the night and lower margins, by hand."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.config import ControllerConfig, preset
from hvacflex.control.plan_band import comfort_bounds_at_period_ends, controller_band, plan_band
from hvacflex.data.forecast import Forecast
from hvacflex.sim.setup import prepare


@pytest.fixture(scope="module")
def forecast() -> Forecast:
    """07:00 of a weekday: occupancy starts at 08:00, the horizon holds the night after."""
    return prepare(preset("rmpc-ppp", start="2014-03-03", days=1.0)).forecaster.forecast(14, 49)


def test_bounds_at_period_ends_are_the_tighter_of_two_periods_by_hand(forecast: Forecast) -> None:
    lower, upper = comfort_bounds_at_period_ends(forecast, 48)
    band_lower, band_upper = forecast.comfort_lower_degc, forecast.comfort_upper_degc
    for k in range(47):
        np.testing.assert_array_equal(lower[k], np.maximum(band_lower[k], band_lower[k + 1]))
        np.testing.assert_array_equal(upper[k], np.minimum(band_upper[k], band_upper[k + 1]))
    assert (upper[1] < band_upper[1]).all()  # the end of 07:30 is 08:00: occupied band


def test_the_plan_band_takes_its_margins_inside_the_band_by_hand(forecast: Forecast) -> None:
    """A 20 … 30 °C band: the night ends' upper bound 0.5 K lower, every lower bound 0.3 K
    higher; a night margin wider than the band stops at the lower bound, a lower margin
    that would pass the upper bound stops at the middle; zero margins give the band back,
    a crossed band stays crossed (for the problem to refuse)."""
    horizon = 48
    occupied = forecast.occupied
    night = np.array([not occupied[k] and not occupied[k + 1] for k in range(horizon)])
    assert night.any() and not night.all()
    y_min, y_max = np.full((horizon, 2), 20.0), np.full((horizon, 2), 30.0)

    def band(unoccupied_k: float, lower_k: float, top: np.ndarray = y_max) -> tuple:
        return plan_band(
            forecast, y_min, top, unoccupied_plan_margin_k=unoccupied_k, lower_plan_margin_k=lower_k
        )

    lower, upper = band(0.5, 0.3)
    np.testing.assert_array_equal(upper[night], 29.5)
    np.testing.assert_array_equal(upper[~night], 30.0)
    np.testing.assert_array_equal(lower, 20.3)
    lower, upper = band(50.0, 0.0)  # the night stops at y_min
    np.testing.assert_array_equal(upper[night], 20.0)
    lower, upper = band(0.5, 50.0)  # the lower bound stops half-way to the upper
    np.testing.assert_array_equal(lower[night], 24.75)
    np.testing.assert_array_equal(lower[~night], 25.0)
    lower, upper = band(0.0, 0.0)
    np.testing.assert_array_equal(lower, y_min)
    np.testing.assert_array_equal(upper, y_max)
    crossed = np.full((horizon, 2), 19.0)  # y_max below y_min: left for the problem to refuse
    for lower_k in (0.0, 0.3):
        lower, upper = band(0.0, lower_k, crossed)
        np.testing.assert_array_equal(lower, y_min)
        np.testing.assert_array_equal(upper[~night], 19.0)


def test_a_controller_s_band_takes_its_configured_margins(forecast: Forecast) -> None:
    config = ControllerConfig(unoccupied_plan_margin_k=0.7, lower_plan_margin_k=0.3)
    got = controller_band(forecast, 48, config)
    want = plan_band(
        forecast,
        *comfort_bounds_at_period_ends(forecast, 48),
        unoccupied_plan_margin_k=0.7,
        lower_plan_margin_k=0.3,
    )
    for a, b in zip(got, want, strict=True):
        np.testing.assert_array_equal(a, b)
    band = comfort_bounds_at_period_ends(forecast, 48)
    assert np.any(got[0] > band[0]) and np.any(got[1] < band[1])  # both margins taken
