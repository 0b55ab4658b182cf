"""A statistical weather forecaster: diurnal climatology plus a decaying AR(1) anomaly.

The controller of a real building does not know tomorrow's weather. This module gives it a
forecast it could make itself, from the weather it has seen:

Model
-----
For each weather series ``v`` (outdoor and ground temperature, the solar channels, the sky's
long-wave loss, outdoor humidity), fitted on *training* periods that are not forecast (by
default the 28 days before the run, :data:`WEATHER_TRAIN_DAYS`):

* climatology ``c(p)``: the mean of ``v`` over the training days for each of the 48
  periods of the day ``p``;
* anomaly ``a_t = v_t − c(p_t)`` follows an AR(1), ``a_t = φ a_{t−1} + ε_t``, with ``φ``
  the least-squares estimate ``Σ a_t a_{t−1} / Σ a_{t−1}²`` on the training anomalies,
  clipped to [0, :data:`MAX_AR1_COEFFICIENT`].

At step k the last period whose weather is known is k − 1 (measured), so the forecast of
period k + i (i = 0 … N − 1) is::

    v̂_{k+i|k} = c(p_{k+i}) + φ^{i+1} · a_{k−1}

— persistence of the current anomaly that decays towards the climatology (the diurnal
cycle of recent days) with lead time. Heat gains (solar) stay ≥ 0. The forecast reads only
periods before k: changing the data from period k on leaves it unchanged
(``tests/data/test_weather_forecast.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.constants import PERIOD, PERIODS_PER_DAY, TIMEZONE
from hvacflex.data.weather import weather_on
from hvacflex.data.weather_channels import (
    HEAT_GAIN_KINDS,
    WEATHER_CHANNEL_KINDS,
    weather_channel_values,
)
from hvacflex.errors import ConfigError, DataError

MAX_AR1_COEFFICIENT = 0.999
"""Largest AR(1) coefficient of the anomaly (keeps the forecast mean-reverting)."""

WEATHER_KINDS = WEATHER_CHANNEL_KINDS
"""Channel kinds that are weather (forecast by :class:`StatisticalWeather`); the others
(``internal_gain``, ``constant``) come from the schedule."""

WEATHER_TRAIN_DAYS = 28
"""Default training window of the statistical weather forecaster: the days before the run."""


def period_of_day(index: pd.DatetimeIndex) -> np.ndarray:
    """(T,) int, 0 … 47: the 30-min period of the (Singapore local) day each start lies in."""
    local = index.tz_convert(TIMEZONE) if index.tz is not None else index
    result: np.ndarray = np.asarray(local.hour) * 2 + np.asarray(local.minute) // 30
    return result


@dataclass(frozen=True)
class ClimatologyAR1:
    """A fitted climatology + AR(1)-anomaly forecaster of ``c`` series (module docstring).

    Attributes
    ----------
    climatology : (48, c) mean value per period of the day [series units].
    ar1_coefficient : (c,) φ of each series' anomaly per 30-min step, in [0, 1).
    nonnegative : (c,) bool, series clipped at 0 (irradiance).
    """

    climatology: np.ndarray
    ar1_coefficient: np.ndarray
    nonnegative: np.ndarray

    def __post_init__(self) -> None:
        c = self.ar1_coefficient.shape[0]
        if self.climatology.shape != (PERIODS_PER_DAY, c) or self.nonnegative.shape != (c,):
            raise DataError(
                "climatology, coefficients and flags disagree",
                source="ClimatologyAR1",
                field="climatology",
                value=(self.climatology.shape, self.ar1_coefficient.shape),
                hint=f"expected (48, c), (c,), (c,) with c = {c}",
            )

    def anomaly(self, value: np.ndarray, period: int) -> np.ndarray:
        """(c,) anomaly ``v − c(p)`` of the values (c,) of one period of the day ``p``."""
        result: np.ndarray = (
            np.asarray(value, dtype=float) - self.climatology[period % PERIODS_PER_DAY]
        )
        return result

    def predict(self, last_value: np.ndarray, last_period: int, periods: np.ndarray) -> np.ndarray:
        """The forecast of the periods after a known one.

        Parameters
        ----------
        last_value : (c,) the values of the last known period (step k − 1).
        last_period : its period of the day (0 … 47).
        periods : (N,) periods of the day of the forecast steps k … k + N − 1.

        Returns
        -------
        (N, c) ``c(p_{k+i}) + φ^{i+1} a_{k−1}``, clipped at 0 where ``nonnegative``.
        """
        anomaly = self.anomaly(last_value, last_period)
        leads = np.arange(1, len(periods) + 1)[:, None]
        climatology = self.climatology[np.asarray(periods) % PERIODS_PER_DAY]
        forecast = climatology + self.ar1_coefficient**leads * anomaly
        forecast[:, self.nonnegative] = np.maximum(forecast[:, self.nonnegative], 0.0)
        result: np.ndarray = forecast
        return result


def fit_climatology_ar1(
    values: np.ndarray, periods: np.ndarray, nonnegative: np.ndarray
) -> ClimatologyAR1:
    """Fit the climatology and the anomalies' AR(1) coefficient on training data.

    Parameters
    ----------
    values : (T, c) training series on consecutive 30-min periods [series units].
    periods : (T,) their periods of the day (0 … 47; :func:`period_of_day`).
    nonnegative : (c,) bool, series clipped at 0 in the forecast.

    Returns
    -------
    The fitted :class:`ClimatologyAR1`.

    Raises
    ------
    DataError
        if the data do not cover every period of the day, or hold NaN.
    """
    values = np.asarray(values, dtype=float)
    periods = np.asarray(periods, dtype=int)
    if values.ndim != 2 or values.shape[0] != periods.shape[0] or not np.isfinite(values).all():
        raise DataError(
            "training weather must be a finite (T, c) array with one period of day per row",
            source="fit_climatology_ar1",
            field="values",
            value=values.shape,
        )
    frame = pd.DataFrame(values).groupby(periods).mean()
    if len(frame) != PERIODS_PER_DAY:
        raise DataError(
            "training weather must cover every 30-min period of the day",
            source="fit_climatology_ar1",
            field="periods",
            value=len(frame),
            hint="train on at least one whole day",
        )
    climatology = frame.sort_index().to_numpy()
    anomaly = values - climatology[periods]
    numerator = np.sum(anomaly[1:] * anomaly[:-1], axis=0)
    denominator = np.sum(anomaly[:-1] ** 2, axis=0)
    phi = np.divide(numerator, denominator, out=np.zeros_like(numerator), where=denominator > 0)
    return ClimatologyAR1(
        climatology=climatology,
        ar1_coefficient=np.clip(phi, 0.0, MAX_AR1_COEFFICIENT),
        nonnegative=np.asarray(nonnegative, dtype=bool),
    )


@dataclass(frozen=True)
class StatisticalWeather:
    """A weather forecaster fitted on days before the data it forecasts.

    Attributes
    ----------
    model : the fitted climatology + AR(1) anomaly (:mod:`hvacflex.data.weather_forecast`)
        of the c = (number of weather channels + 1) series: the weather channels in channel
        order, then the outdoor humidity ratio.
    columns : (c − 1,) positions of the weather channels in the disturbance vector.
    last_value : (c,) the series in the last training period, the one just before the first
        forecast period (what is known at step 0).
    train_start, train_end : first and last training period start (tz-aware).
    """

    model: ClimatologyAR1
    columns: tuple[int, ...]
    last_value: np.ndarray
    train_start: pd.Timestamp
    train_end: pd.Timestamp


def weather_series(
    channels: Sequence[DisturbanceChannel], index: pd.DatetimeIndex, weather_file: str | Path
) -> tuple[np.ndarray, tuple[int, ...]]:
    """The weather series of ``channels`` on ``index``, as :class:`StatisticalWeather` models
    them.

    Returns
    -------
    values : (T, c) the weather channels (kinds :data:`WEATHER_KINDS`, channel order and
        units), then the outdoor humidity ratio [kg/kg].
    columns : (c − 1,) the weather channels' positions in the disturbance vector.
    """
    channels = tuple(channels)
    weather, location = weather_on(index, Path(weather_file))
    values = weather_channel_values(channels, weather, location, source=weather_file)
    columns = sorted(values)
    parts = [values[i] for i in columns]
    parts.append(weather["humidity_ratio_kg_per_kg"].to_numpy())
    return np.column_stack(parts), tuple(columns)


def fit_weather_forecaster(
    channels: Sequence[DisturbanceChannel],
    start: str | pd.Timestamp,
    *,
    train_days: int = WEATHER_TRAIN_DAYS,
    weather_file: str | Path,
) -> StatisticalWeather:
    """Fit the statistical weather forecaster on the ``train_days`` days before ``start``.

    Parameters
    ----------
    channels : (nd,) the building's disturbance channels.
    start : first forecast period (local Singapore time if naive); the training periods are
        ``[start − train_days, start)``, so none of them is forecast.
    train_days : length of the training window [days], ≥ 1.
    weather_file : the EPW (``hvacflex.data.forecast.default_weather_file()`` is the shipped
        one).

    Returns
    -------
    :class:`StatisticalWeather`.
    """
    if train_days < 1:
        raise ConfigError(
            "the weather forecaster needs at least one training day",
            field="forecast.train_days",
            value=train_days,
        )
    first = pd.Timestamp(start)
    first = first.tz_localize(TIMEZONE) if first.tz is None else first.tz_convert(TIMEZONE)
    index = pd.date_range(
        end=first - PERIOD, periods=train_days * PERIODS_PER_DAY, freq=PERIOD, name="time"
    )
    values, columns = weather_series(channels, index, Path(weather_file))
    nonnegative = np.array([channels[i].kind in HEAT_GAIN_KINDS for i in columns] + [False])
    model = fit_climatology_ar1(values, period_of_day(index), nonnegative)
    return StatisticalWeather(model, columns, values[-1].copy(), index[0], index[-1])
