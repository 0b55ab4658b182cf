"""Operator signals laid over a forecast: prices by period, φ, refused bad values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacflex.config import preset
from hvacflex.data.signals import OperatorSignals, effective_peak_price
from hvacflex.errors import InputError
from hvacflex.sim.setup import prepare


@pytest.fixture(scope="module")
def forecast():  # type: ignore[no-untyped-def]
    setup = prepare(preset("rmpc", start="2014-03-03", days=0.5))
    return setup.forecaster.forecast(4, 6)


def test_no_signal_leaves_the_forecast_as_it_is(forecast) -> None:  # type: ignore[no-untyped-def]
    assert OperatorSignals().apply(forecast) is forecast
    assert effective_peak_price(forecast, 1.5) == 1.5


def test_prices_replace_their_periods_and_phi_is_carried(forecast) -> None:  # type: ignore[no-untyped-def]
    second = forecast.index[1]
    utc_third = forecast.index[2].tz_convert("UTC")  # any tz names the same period
    signals = OperatorSignals(
        energy_price_sgd_per_mwh={second: 999.0, utc_third: 888.0},
        reserve_price_sgd_per_mwh={second: 7.0},
        peak_price_sgd_per_kw=2.5,
    )
    out = signals.apply(forecast)
    expected = np.array(forecast.energy_price_sgd_per_mwh, dtype=float)
    expected[1:3] = [999.0, 888.0]
    np.testing.assert_array_equal(out.energy_price_sgd_per_mwh, expected)
    assert out.reserve_price_sgd_per_mwh[1] == 7.0
    assert out.reserve_price_sgd_per_mwh[0] == forecast.reserve_price_sgd_per_mwh[0]
    assert effective_peak_price(out, 1.5) == 2.5
    # a period outside the horizon changes nothing
    later = OperatorSignals(energy_price_sgd_per_mwh={pd.Timestamp("2014-06-01", tz="UTC"): 1.0})
    np.testing.assert_array_equal(
        later.apply(forecast).energy_price_sgd_per_mwh, forecast.energy_price_sgd_per_mwh
    )


def test_a_posted_outdoor_temperature_replaces_the_outdoor_channel_there(forecast) -> None:  # type: ignore[no-untyped-def]
    column = forecast.channel_index("outdoor_temp")
    assert column  # office5 has one
    out = OperatorSignals(outdoor_temp_degc={forecast.index[2]: 35.5}).apply(forecast)
    expected = np.array(forecast.disturbances, dtype=float)
    expected[2, column] = 35.5
    np.testing.assert_array_equal(out.disturbances, expected)  # the other channels kept
    assert out.outdoor_temp_degc[2] == 35.5 and out.outdoor_temp_degc[1] != 35.5
    np.testing.assert_array_equal(out.energy_price_sgd_per_mwh, forecast.energy_price_sgd_per_mwh)


def test_a_posted_outdoor_humidity_replaces_the_forecast_s_there(forecast) -> None:  # type: ignore[no-untyped-def]
    stamp = forecast.index[3].tz_convert("UTC")  # any zone of time names the period
    out = OperatorSignals(outdoor_humidity_ratio_kg_per_kg={stamp: 0.0265}).apply(forecast)
    expected = np.array(forecast.outdoor_humidity_ratio_kg_per_kg, dtype=float)
    assert expected[3] != 0.0265
    expected[3] = 0.0265
    np.testing.assert_array_equal(out.outdoor_humidity_ratio_kg_per_kg, expected)
    np.testing.assert_array_equal(out.disturbances, forecast.disturbances)


@pytest.mark.parametrize("phi", [-1.0, float("nan"), float("inf")])
def test_an_impossible_peak_price_is_refused(phi: float) -> None:
    with pytest.raises(InputError, match="peak_price_sgd_per_kw"):
        OperatorSignals(peak_price_sgd_per_kw=phi)
