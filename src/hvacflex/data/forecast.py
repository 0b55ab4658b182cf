"""Exogenous inputs aligned on one time grid, and the forecasts a controller sees.

:func:`load_exogenous` builds an :class:`Exogenous`: prices, disturbances (in the building's
channel order, see ``hvacflex.building.channels``), outdoor humidity, comfort band and
occupancy on a 30-min, tz-aware (``Asia/Singapore``) index of period starts. It covers
``steps + horizon_steps`` periods so that a forecast at the last simulated step still has a
full horizon.

* Energy prices: NEMS USEP (2014 shipped). Every simulated period must lie inside the price
  data (a run outside it is refused, naming the dates the data covers); only the look-ahead
  periods of the last steps' forecasts may fall after its end: they take the same period of
  the nearest available day and are flagged in ``energy_price_extrapolated``. Under the live
  calendar (``calendar="live"``, :mod:`hvacflex.data.calendar`) any date may be planned: a
  day outside the price data takes the prices of the data's day of the same weekday nearest
  its date, flagged in ``energy_price_extrapolated`` as well.
* Reserve prices: a user CSV (``reserve_source``) or, by default, the seeded synthetic series
  (``reserve_price_synthetic = True``).
* Weather: an EPW typical year (the Singapore Changi TMYx file by default) mapped onto each
  calendar year the index touches, so it wraps around the year end.
* Internal gains and comfort: office schedule with Singapore public holidays.

:class:`Forecaster` serves ``forecast(k, horizon)`` from precomputed arrays: perfect
foresight, or price persistence (yesterday's same period) and/or an AR(1) disturbance
forecast error that grows with lead time (as BOPTEST's forecast-uncertainty emulator), or a
forecaster that does not know the future: the weather from a statistical model fitted on the
days before the run (:mod:`hvacflex.data.weather_forecast`)
and the internal gains from the schedule while the plant sees stochastic occupancy
(:mod:`hvacflex.data.occupancy`); docs/explanation/forecast.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, Protocol, get_args

import numpy as np
import pandas as pd

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.constants import HORIZON_STEPS, PERIOD, PERIODS_PER_DAY, TIMEZONE
from hvacflex.data.calendar import Calendar, live_price_index
from hvacflex.data.gains import (
    DEFAULT_OFFICE_SCHEDULE,
    ComfortBand,
    OfficeSchedule,
    comfort_bounds_degc,
    occupied_mask,
    office_schedule,
    zone_internal_gains_w,
)
from hvacflex.data.market import (
    RESERVE_PRICE_CORRELATION,
    RESERVE_PRICE_SCALE,
    FillMode,
    load_reserve_prices,
    load_usep,
    synthetic_reserve_prices,
)
from hvacflex.data.uncertainty import (
    AR1_COEFFICIENT,
    DEFAULT_UNCERTAINTY,
    UncertaintyBox,
    check_ar1_coefficient,
)
from hvacflex.data.weather import EpwLocation, weather_on
from hvacflex.data.weather_channels import HEAT_GAIN_KINDS, weather_channel_values
from hvacflex.data.weather_forecast import StatisticalWeather, period_of_day
from hvacflex.errors import ConfigError, DataError
from hvacflex.paths import DATA_DIR_ENV, data_dir

DEFAULT_WEATHER_FILE = "SGP_SG_Singapore-Changi.Intl.AP.486980_TMYx.2009-2023.epw"
"""Default EPW in ``<data_dir>/weather``: the TMYx typical year of Singapore Changi (2009–2023,
NOAA ISD + ERA5). The ASHRAE IWEC file is not redistributed; point ``[data] weather_file`` at a
copy to use it."""

DEFAULT_USEP_FOLDER = "nems_usep_2014"
"""Default USEP folder in ``<data_dir>`` (real NEMS prices, 2014)."""

PriceMode = Literal["perfect", "persistence"]
DisturbanceErrorMode = Literal["none", "ar1"]


def ar1_filter(innovation: np.ndarray, phi: float) -> np.ndarray:
    """The AR(1) process driven by ``innovation`` along axis 0: ``e_0 = w_0``,
    ``e_k = w_k + φ·e_{k−1}`` (what ``scipy.signal.lfilter([1], [1, −φ], w, axis=0)``
    computes, bit for bit, without importing ``scipy.signal`` — half a second of start-up).

    Parameters
    ----------
    innovation : (T, ...) innovations w_k.
    phi : the AR(1) coefficient φ.

    Returns
    -------
    (T, ...) float64 array e_k.
    """
    error = np.array(innovation, dtype=float, copy=True)
    for k in range(1, error.shape[0]):
        error[k] += phi * error[k - 1]
    return error


class InternalGainDensities(Protocol):
    """What :func:`load_exogenous` reads from a building's ``gains`` (``InternalGains``)."""

    @property
    def occupancy_m2_per_person(self) -> float: ...
    @property
    def sensible_w_per_person(self) -> float: ...
    @property
    def latent_w_per_person(self) -> float: ...
    @property
    def lighting_w_per_m2(self) -> float: ...
    @property
    def equipment_w_per_m2(self) -> float: ...


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class ExogenousSeries:
    """The series from outside the building over consecutive 30-min periods: the fields that
    :class:`Exogenous` (the data, T periods) and :class:`Forecast` (a controller's view of N
    periods) share.

    Attributes
    ----------
    index : (T,) tz-aware (``Asia/Singapore``) period starts, 30 min apart.
    energy_price_sgd_per_mwh : (T,) USEP [SGD/MWh].
    reserve_price_sgd_per_mwh : (T,) reserve (IL) price [SGD/MWh].
    reserve_price_synthetic : True if the reserve price is the synthetic series.
    disturbances : (T, nd) disturbance vector d per period, in ``channels`` order and units.
    channels : (nd,) the building's disturbance channels.
    outdoor_humidity_ratio_kg_per_kg : (T,) [kg/kg].
    comfort_lower_degc, comfort_upper_degc : (T, m) band in force from the start of period k.
    occupied : (T,) bool, occupied comfort band in force.
    energy_price_extrapolated : (T,) bool, the price was copied from the nearest day with data
        (all False if not given).
    occupant_latent_w : (T,) the occupants' latent gain, all zones together [W]: people (the
        schedule's people fraction × floor area / m² per person) × latent W per person; it
        loads the cooling coil, not the zone air (zeros if not given).
    """

    index: pd.DatetimeIndex
    energy_price_sgd_per_mwh: np.ndarray
    reserve_price_sgd_per_mwh: np.ndarray
    reserve_price_synthetic: bool
    disturbances: np.ndarray
    channels: tuple[DisturbanceChannel, ...]
    outdoor_humidity_ratio_kg_per_kg: np.ndarray
    comfort_lower_degc: np.ndarray
    comfort_upper_degc: np.ndarray
    occupied: np.ndarray
    energy_price_extrapolated: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    occupant_latent_w: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def channel_index(self, kind: str) -> list[int]:
        """Positions of the channels of one kind in ``disturbances``."""
        return [i for i, ch in enumerate(self.channels) if ch.kind == kind]

    @property
    def outdoor_temp_degc(self) -> np.ndarray:
        """(T,) outdoor dry-bulb temperature [°C] (the first ``outdoor_temp`` channel)."""
        for i, ch in enumerate(self.channels):
            if ch.kind == "outdoor_temp":
                column: np.ndarray = self.disturbances[:, i]
                return column
        raise DataError(
            "no outdoor_temp channel", field="channels", value=[c.name for c in self.channels]
        )


@dataclass(frozen=True)
class Exogenous(ExogenousSeries):
    """Everything from outside the building, on one 30-min grid of T period starts
    (the fields of :class:`ExogenousSeries`, validated: shapes checked, arrays read-only)."""

    def __post_init__(self) -> None:
        t = len(self.index)
        if self.energy_price_extrapolated.size == 0 and t:
            object.__setattr__(self, "energy_price_extrapolated", np.zeros(t, dtype=bool))
        if self.occupant_latent_w.size == 0 and t:
            object.__setattr__(self, "occupant_latent_w", np.zeros(t))
        object.__setattr__(self, "channels", tuple(self.channels))
        shapes = {
            "energy_price_sgd_per_mwh": (t,),
            "reserve_price_sgd_per_mwh": (t,),
            "disturbances": (t, len(self.channels)),
            "outdoor_humidity_ratio_kg_per_kg": (t,),
            "occupied": (t,),
            "energy_price_extrapolated": (t,),
            "occupant_latent_w": (t,),
        }
        for name, shape in shapes.items():
            value = np.asarray(getattr(self, name))
            if value.shape != shape:
                raise DataError(
                    "array has the wrong shape", source="Exogenous", field=name, value=value.shape,
                    hint=f"expected {shape}",
                )  # fmt: skip
        lower = np.asarray(self.comfort_lower_degc)
        upper = np.asarray(self.comfort_upper_degc)
        if lower.ndim != 2 or lower.shape[0] != t or lower.shape != upper.shape:
            raise DataError(
                "comfort bounds must both be (T, m)",
                source="Exogenous",
                field="comfort_lower_degc",
                value=(lower.shape, upper.shape),
                hint=f"T = {t}",
            )
        for name in (*shapes, "comfort_lower_degc", "comfort_upper_degc"):
            object.__setattr__(self, name, _readonly(np.asarray(getattr(self, name))))

    @property
    def steps(self) -> int:
        """Number of periods T."""
        return len(self.index)

    def frame(self) -> pd.DataFrame:
        """All series as one DataFrame (disturbances named by channel), for inspection."""
        data: dict[str, np.ndarray] = {
            "energy_price_sgd_per_mwh": self.energy_price_sgd_per_mwh,
            "reserve_price_sgd_per_mwh": self.reserve_price_sgd_per_mwh,
            "energy_price_extrapolated": self.energy_price_extrapolated,
            "outdoor_humidity_ratio_kg_per_kg": self.outdoor_humidity_ratio_kg_per_kg,
            "occupied": self.occupied,
        }
        for i, ch in enumerate(self.channels):
            data[ch.name] = self.disturbances[:, i]
        for j in range(self.comfort_lower_degc.shape[1]):
            data[f"comfort_lower_{j}_degc"] = self.comfort_lower_degc[:, j]
            data[f"comfort_upper_{j}_degc"] = self.comfort_upper_degc[:, j]
        out = pd.DataFrame(data, index=self.index)
        out.attrs["reserve_price_synthetic"] = self.reserve_price_synthetic
        return out


@dataclass(frozen=True)
class Forecast(ExogenousSeries):
    """What the controller knows at step k about periods k … k+N−1: the fields of
    :class:`ExogenousSeries` over N = horizon periods, and the step ``step`` = k.

    ``disturbances`` is the forecast d̂ (the data itself under perfect foresight); prices are
    the data or their persistence forecast. ``peak_price_sgd_per_kw`` is the peak-power price
    φ [SGD/kW] an operator signalled (:class:`hvacflex.data.signals.OperatorSignals`), or
    None: the controller's configured φ.
    """

    step: int = field(kw_only=True)
    peak_price_sgd_per_kw: float | None = field(default=None, kw_only=True)

    @property
    def horizon(self) -> int:
        """N."""
        return len(self.energy_price_sgd_per_mwh)


class Forecaster:
    """Forecasts from an :class:`Exogenous`, sliced from precomputed arrays.

    Parameters
    ----------
    exogenous : the data (truth).
    mode : ``"perfect"`` (prices known) or ``"persistence"`` (energy and reserve price of
        period j forecast as those of period j − 48 · ⌈(j − k + 1)/48⌉, i.e. yesterday's same
        period for a one-day horizon; on the first day of the data, where there is no
        yesterday, the data itself is used).
    disturbance_error : ``"none"`` (d̂ = d) or ``"ar1"``: d̂_{k+i|k} = d_{k+i} + e_i with
        e_0 = 0 (the current period is known) and e_i = φ e_{i−1} + √(1−φ²) σ_{k+i} ε_i,
        σ from ``error_box`` applied to the data — a BOPTEST-style error that grows with lead
        time towards standard deviation σ. Solar and internal gains stay ≥ 0. The draw is
        seeded by (seed, k), so a forecast does not depend on the call order (resumable).
    seed : random seed of the AR(1) error.
    error_box : standard deviations of the AR(1) error (default ``DEFAULT_UNCERTAINTY``).
    ar1_coefficient : φ per 30-min step.
    weather : a :class:`StatisticalWeather` fitted before the data: the weather channels and
        the outdoor humidity of the forecast at k come from it and from the data of periods
        before k only (never the data of k or later); None: the data (perfect foresight).
    expected_disturbances : (T, nd) what the controller expects of the non-weather channels
        (internal gains: the schedule, while the plant sees stochastic occupancy); None: the
        data.

    ``forecast(k, horizon)`` returns read-only views of the data in the default mode (no
    copies).
    """

    def __init__(
        self,
        exogenous: Exogenous,
        mode: PriceMode = "perfect",
        disturbance_error: DisturbanceErrorMode = "none",
        seed: int = 2014,
        *,
        error_box: UncertaintyBox = DEFAULT_UNCERTAINTY,
        ar1_coefficient: float = AR1_COEFFICIENT,
        weather: StatisticalWeather | None = None,
        expected_disturbances: np.ndarray | None = None,
    ) -> None:
        if mode not in get_args(PriceMode):
            raise ConfigError(
                "unknown price forecast mode", field="mode", value=mode,
                hint=f"use one of {list(get_args(PriceMode))}",
            )  # fmt: skip
        if disturbance_error not in get_args(DisturbanceErrorMode):
            raise ConfigError(
                "unknown disturbance forecast error",
                field="disturbance_error",
                value=disturbance_error,
                hint=f"use one of {list(get_args(DisturbanceErrorMode))}",
            )
        check_ar1_coefficient(ar1_coefficient)
        self.exogenous = exogenous
        self.mode: PriceMode = mode
        self.disturbance_error: DisturbanceErrorMode = disturbance_error
        self.seed = seed
        self.ar1_coefficient = ar1_coefficient
        x = exogenous
        self._t = x.steps
        self._index = x.index
        self._energy = x.energy_price_sgd_per_mwh
        self._reserve = x.reserve_price_sgd_per_mwh
        self._lagged: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._channels = x.channels
        self._rel, self._abs = error_box.coefficients(x.channels)
        self._nonnegative = np.array(
            [ch.kind in (*HEAT_GAIN_KINDS, "internal_gain") for ch in x.channels], dtype=bool
        )
        self._init_realistic(weather, expected_disturbances)

    def _init_realistic(
        self, weather: StatisticalWeather | None, expected: np.ndarray | None
    ) -> None:
        """Precompute the inputs of a forecaster that does not know the future."""
        x = self.exogenous
        if (weather is not None or expected is not None) and self.disturbance_error != "none":
            raise ConfigError(
                "the AR(1) forecast error is for a perfect forecast",
                field="disturbance_error",
                value=self.disturbance_error,
                hint="use disturbance_error='none' with a statistical weather forecast or "
                "expected disturbances",
            )
        self.weather = weather
        self._expected = x.disturbances if expected is None else _readonly(expected)
        if self._expected.shape != x.disturbances.shape:
            raise DataError(
                "expected disturbances must have the data's shape",
                source="Forecaster",
                field="expected_disturbances",
                value=self._expected.shape,
                hint=f"expected {x.disturbances.shape}",
            )
        if weather is None:
            return
        columns = list(weather.columns)
        self._observed = np.column_stack(
            [x.disturbances[:, columns], x.outdoor_humidity_ratio_kg_per_kg]
        )
        self._periods = period_of_day(x.index)

    def _lag(self, days: int) -> tuple[np.ndarray, np.ndarray]:
        if days not in self._lagged:
            lag = days * PERIODS_PER_DAY
            pos = np.arange(self._t) - lag
            pos = np.where(pos < 0, np.arange(self._t) % PERIODS_PER_DAY, pos)
            self._lagged[days] = (_readonly(self._energy[pos]), _readonly(self._reserve[pos]))
        return self._lagged[days]

    def _prices(self, k: int, horizon: int) -> tuple[np.ndarray, np.ndarray]:
        if self.mode == "perfect":
            return self._energy[k : k + horizon], self._reserve[k : k + horizon]
        if horizon <= PERIODS_PER_DAY:
            energy, reserve = self._lag(1)
            return energy[k : k + horizon], reserve[k : k + horizon]
        energy_parts, reserve_parts = [], []
        for start in range(0, horizon, PERIODS_PER_DAY):
            stop = min(start + PERIODS_PER_DAY, horizon)
            energy, reserve = self._lag(start // PERIODS_PER_DAY + 1)
            energy_parts.append(energy[k + start : k + stop])
            reserve_parts.append(reserve[k + start : k + stop])
        return _readonly(np.concatenate(energy_parts)), _readonly(np.concatenate(reserve_parts))

    def _statistical(self, k: int, horizon: int) -> tuple[np.ndarray, np.ndarray]:
        """(horizon, nd) disturbances and (horizon,) humidity of the realistic forecast:
        the expected (scheduled) gains, the weather from the model and periods < k."""
        disturbances = np.array(self._expected[k : k + horizon], dtype=float)
        weather = self.weather
        if weather is None:
            humidity = self.exogenous.outdoor_humidity_ratio_kg_per_kg[k : k + horizon]
            return _readonly(disturbances), humidity
        last = weather.last_value if k == 0 else self._observed[k - 1]
        last_period = int(self._periods[k] - 1) % PERIODS_PER_DAY
        predicted = weather.model.predict(last, last_period, self._periods[k : k + horizon])
        disturbances[:, list(weather.columns)] = predicted[:, :-1]
        return _readonly(disturbances), _readonly(predicted[:, -1])

    def _disturbances(self, k: int, horizon: int) -> np.ndarray:
        truth = self.exogenous.disturbances[k : k + horizon]
        if self.disturbance_error == "none" or horizon == 0:
            return truth
        rng = np.random.default_rng([self.seed, k])
        sigma = self._rel * np.abs(truth) + self._abs
        phi = self.ar1_coefficient
        innovation = rng.standard_normal(truth.shape) * sigma * np.sqrt(1.0 - phi * phi)
        innovation[0] = 0.0  # the current period is known
        error = ar1_filter(innovation, phi)
        forecast = truth + error
        forecast[:, self._nonnegative] = np.maximum(forecast[:, self._nonnegative], 0.0)
        return _readonly(forecast)

    def forecast(self, k: int, horizon: int = HORIZON_STEPS) -> Forecast:
        """The forecast made at step k for periods k … k+horizon−1.

        Raises
        ------
        DataError
            if ``k + horizon`` exceeds the data (load ``steps + horizon_steps`` periods).
        """
        if k < 0 or horizon < 0 or k + horizon > self._t:
            raise DataError(
                "forecast window outside the loaded data",
                source="Forecaster",
                field="k",
                value=(k, horizon),
                hint=f"the data has {self._t} periods; load_exogenous(steps=..., "
                "horizon_steps=...) covers steps + horizon_steps",
            )
        x = self.exogenous
        end = k + horizon
        energy, reserve = self._prices(k, horizon)
        if self.weather is None and self._expected is x.disturbances:
            disturbances = self._disturbances(k, horizon)
            humidity = x.outdoor_humidity_ratio_kg_per_kg[k:end]
        else:
            disturbances, humidity = self._statistical(k, horizon)
        return Forecast(
            self._index[k:end],
            energy,
            reserve,
            x.reserve_price_synthetic,
            disturbances,
            self._channels,
            humidity,
            x.comfort_lower_degc[k:end],
            x.comfort_upper_degc[k:end],
            x.occupied[k:end],
            x.energy_price_extrapolated[k:end],
            x.occupant_latent_w[k:end],
            step=k,
        )


def default_weather_file() -> Path:
    """The shipped EPW (:data:`DEFAULT_WEATHER_FILE` in ``<data_dir>/weather``)."""
    return data_dir() / "weather" / DEFAULT_WEATHER_FILE


def _check_coverage(
    data_index: pd.Index, run: pd.DatetimeIndex, what: str, source: object, setting: str
) -> None:
    """Refuse a run whose simulated periods ``run`` are not all inside the data's days."""
    if not isinstance(data_index, pd.DatetimeIndex) or len(data_index) == 0 or len(run) == 0:
        return
    first_day = data_index.min().normalize()
    end = data_index.max().normalize() + pd.Timedelta(days=1)
    local = run.tz_convert(data_index.tz)
    if local[0] >= first_day and local[-1] < end:
        return
    years = sorted(set(data_index.year))
    span = f"{years[0]}" if len(years) == 1 else f"{years[0]}–{years[-1]}"
    last = local[-1] + PERIOD
    starts_inside = first_day <= local[0] < end
    or_data_dir = (
        f" (or point {DATA_DIR_ENV} at a data folder whose {DEFAULT_USEP_FOLDER}/ holds them)"
        if setting == "usep_source"
        else ""
    )
    raise DataError(
        f"the run {local[0]:%Y-%m-%d %H:%M} … {last:%Y-%m-%d %H:%M} is "
        f"{'partly ' if starts_inside else ''}outside the {what} data, which covers "
        f"{first_day:%Y-%m-%d} … {end - pd.Timedelta(days=1):%Y-%m-%d} ({span})",
        source=str(source)[:300],
        field="days" if starts_inside else "start",
        value=f"{local[0]:%Y-%m-%d}" if not starts_inside else f"{last:%Y-%m-%d %H:%M}",
        hint=f"choose --start/--days (scenario keys start, days) inside those dates, or supply "
        f"{what} CSV files covering the run: set data.{setting} in the scenario TOML to a "
        f"CSV file or folder{or_data_dir}",
    )


def _align_prices(
    series: pd.Series, index: pd.DatetimeIndex, what: str
) -> tuple[np.ndarray, np.ndarray]:
    """Values of ``series`` at ``index``; outside its days, the same period of the nearest day."""
    data_index = series.index
    if not isinstance(data_index, pd.DatetimeIndex) or len(series) == 0:
        raise DataError(f"{what} series is empty", field=what)
    first_day = data_index[0].normalize()
    last_day = data_index[-1].normalize()
    local = index.tz_convert(data_index.tz)
    day = local.normalize()
    time_of_day = local - day
    source_day = day.where(day <= last_day, last_day).where(day >= first_day, first_day)
    lookup = source_day + time_of_day
    outside = np.asarray(source_day != day)
    values = series.reindex(lookup).to_numpy(dtype=float)
    if np.isnan(values).any():
        bad = lookup[np.isnan(values)]
        raise DataError(
            f"{what} has no value for {len(bad)} period(s)",
            field=what,
            value=[str(t) for t in bad[:5]],
            hint="the price series must be complete (see load_usep fill=...)",
        )
    return values, outside


def load_exogenous(
    channels: Sequence[DisturbanceChannel],
    zone_floor_areas_m2: Sequence[float] | Mapping[str, float],
    gains: InternalGainDensities,
    *,
    start: str | pd.Timestamp,
    steps: int,
    horizon_steps: int = HORIZON_STEPS,
    weather_file: str | Path | None = None,
    usep_source: str | Path | Sequence[str | Path] | None = None,
    reserve_source: str | Path | Sequence[str | Path] | None = None,
    comfort: ComfortBand | None = None,
    seed: int = 2014,
    reserve_scale_sgd_per_mwh: float = RESERVE_PRICE_SCALE,
    reserve_correlation: float = RESERVE_PRICE_CORRELATION,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
    price_gap_fill: FillMode = "none",
    calendar: Calendar = "data",
) -> Exogenous:
    """Load and align all exogenous inputs for a simulation.

    Parameters
    ----------
    channels : (nd,) the building's disturbance channels, in its order.
    zone_floor_areas_m2 : (m,) floor area per zone [m²], in zone order (the i-th
        ``internal_gain`` channel belongs to the i-th zone), or a mapping zone name → area
        (matched to ``channel.zone``; its order is the zone order of the comfort arrays).
    gains : the building's internal-gain densities (``occupancy_m2_per_person``,
        ``sensible_w_per_person``, ``lighting_w_per_m2``, ``equipment_w_per_m2``).
    start : first period start (local Singapore time if naive), on a 30-min boundary.
    steps : number of simulated steps; ``horizon_steps`` more periods are loaded.
    weather_file : EPW (default: TMYx Singapore Changi in ``<data_dir>/weather``).
    usep_source : USEP CSV file(s) or folder (default: ``<data_dir>/nems_usep_2014``).
    reserve_source : reserve-price CSV(s); default: synthetic prices (flagged).
    comfort : occupied/unoccupied bands (default 23–26 / 20–30 °C).
    seed : seed of the synthetic reserve prices.
    reserve_scale_sgd_per_mwh : scale of the synthetic reserve prices.
    reserve_correlation : weight ρ of their USEP-driven part (1: the calibrated series).
    schedule : office schedule for gains and occupancy.
    price_gap_fill : ``fill`` of :func:`~hvacflex.data.market.load_usep` for gaps in the
        price files: ``"none"`` (a gap is an error) or ``"previous-day"``.
    calendar : ``"data"`` (the simulated periods must lie inside the price data) or
        ``"live"`` (real dates; days outside the price data take the prices of the mapped
        day, :mod:`hvacflex.data.calendar`).

    Returns
    -------
    :class:`Exogenous` over ``steps + horizon_steps`` periods.

    Raises
    ------
    DataError
        if a simulated period (the first ``steps``) lies outside the price data (calendar
        ``"data"``), naming the dates it covers; and for any error of the loaders.
    """
    channels = tuple(channels)
    index = _run_index(channels, start, steps, horizon_steps)
    gain_areas, n_zones = _internal_gain_areas_m2(channels, zone_floor_areas_m2)
    usep_from = usep_source if usep_source is not None else data_dir() / DEFAULT_USEP_FOLDER
    usep = load_usep(usep_from, fill=price_gap_fill)
    if calendar == "live":
        lookup, extrapolated = live_price_index(index, pd.DatetimeIndex(usep.index))
        energy, _ = _align_prices(usep["energy_price_sgd_per_mwh"], lookup, "USEP")
    else:
        _check_coverage(usep.index, index[:steps], "USEP price", usep_from, "usep_source")
        energy, extrapolated = _align_prices(usep["energy_price_sgd_per_mwh"], index, "USEP")
    reserve, synthetic = _reserve_prices(
        index,
        steps,
        energy,
        reserve_source,
        seed,
        reserve_scale_sgd_per_mwh,
        price_gap_fill,
        calendar,
        reserve_correlation,
    )
    weather_path = Path(weather_file) if weather_file is not None else default_weather_file()
    weather, location = weather_on(index, weather_path)
    d = _disturbance_matrix(
        channels, index, weather, location, gains, gain_areas, schedule, weather_path
    )
    band = comfort or ComfortBand()
    lower, upper = comfort_bounds_degc(
        index, n_zones, band.occupied_degc, band.unoccupied_degc, schedule
    )
    return Exogenous(
        index=index,
        energy_price_sgd_per_mwh=energy,
        reserve_price_sgd_per_mwh=reserve,
        reserve_price_synthetic=synthetic,
        disturbances=d,
        channels=channels,
        outdoor_humidity_ratio_kg_per_kg=weather["humidity_ratio_kg_per_kg"].to_numpy(),
        comfort_lower_degc=lower,
        comfort_upper_degc=upper,
        occupied=occupied_mask(index, schedule),
        energy_price_extrapolated=extrapolated,
        occupant_latent_w=occupant_latent_w(index, sum(gain_areas), gains, schedule),
    )


def occupant_latent_w(
    index: pd.DatetimeIndex,
    floor_area_m2: float,
    gains: InternalGainDensities,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
) -> np.ndarray:
    """(T,) the occupants' latent gain on ``index`` [W]: the schedule's people fraction ×
    ``floor_area_m2`` / ``occupancy_m2_per_person`` × ``latent_w_per_person``."""
    people = floor_area_m2 / gains.occupancy_m2_per_person
    fraction = office_schedule(index, schedule)["people_fraction"].to_numpy(dtype=float)
    out: np.ndarray = people * gains.latent_w_per_person * fraction
    return out


def _run_index(
    channels: tuple[DisturbanceChannel, ...],
    start: str | pd.Timestamp,
    steps: int,
    horizon_steps: int,
) -> pd.DatetimeIndex:
    """The ``steps + horizon_steps`` period starts of a run; checks the arguments."""
    if steps < 1 or horizon_steps < 0:
        raise ConfigError(
            "need steps ≥ 1 and horizon_steps ≥ 0",
            field="steps",
            value=(steps, horizon_steps),
        )
    names = [ch.name for ch in channels]
    if len(set(names)) != len(names):
        raise ConfigError("disturbance channel names must be unique", field="channels", value=names)
    try:
        first = pd.Timestamp(start)
    except ValueError:
        raise ConfigError(
            "unparseable start time", field="start", value=start, hint="e.g. '2014-01-01'"
        ) from None
    first = first.tz_localize(TIMEZONE) if first.tz is None else first.tz_convert(TIMEZONE)
    if first != first.floor(PERIOD):
        raise ConfigError(
            "start must be on a 30-min boundary", field="start", value=str(first),
            hint="NEMS periods start at :00 and :30",
        )  # fmt: skip
    return pd.date_range(first, periods=steps + horizon_steps, freq=PERIOD, name="time")


def _internal_gain_areas_m2(
    channels: tuple[DisturbanceChannel, ...],
    zone_floor_areas_m2: Sequence[float] | Mapping[str, float],
) -> tuple[list[float], int]:
    """Floor area behind each ``internal_gain`` channel [m²], in channel order, and the
    number of zones m."""
    gain_channels = [ch for ch in channels if ch.kind == "internal_gain"]
    if isinstance(zone_floor_areas_m2, Mapping):
        areas = dict(zone_floor_areas_m2)
        missing = [ch.zone for ch in gain_channels if ch.zone not in areas]
        if missing:
            raise ConfigError(
                "internal-gain channel for a zone without floor area",
                field="zone_floor_areas_m2",
                value=missing,
                hint=f"zones given: {sorted(areas)}",
            )
        gain_areas = [areas[str(ch.zone)] for ch in gain_channels]
        n_zones = len(areas)
    else:
        area_list = [float(a) for a in zone_floor_areas_m2]
        if len(gain_channels) not in (0, len(area_list)):
            raise ConfigError(
                "one internal_gain channel per zone expected",
                field="zone_floor_areas_m2",
                value=(len(area_list), len(gain_channels)),
                hint="give the floor areas in the zone order of the internal_gain channels",
            )
        gain_areas = area_list if gain_channels else []
        n_zones = len(area_list)
    if n_zones < 1:
        raise ConfigError("need at least one zone", field="zone_floor_areas_m2", value=n_zones)
    return gain_areas, n_zones


def _reserve_prices(
    index: pd.DatetimeIndex,
    steps: int,
    energy_sgd_per_mwh: np.ndarray,
    reserve_source: str | Path | Sequence[str | Path] | None,
    seed: int,
    reserve_scale_sgd_per_mwh: float,
    price_gap_fill: FillMode,
    calendar: Calendar = "data",
    reserve_correlation: float = RESERVE_PRICE_CORRELATION,
) -> tuple[np.ndarray, bool]:
    """(T,) reserve price on ``index`` [SGD/MWh] and whether it is the synthetic series
    (``reserve_source`` None) rather than the user's CSV files (on the days of the live
    calendar where ``calendar`` is ``"live"``)."""
    if reserve_source is None:
        reserve_series = synthetic_reserve_prices(
            pd.Series(energy_sgd_per_mwh, index=index),
            seed=seed,
            scale_sgd_per_mwh=reserve_scale_sgd_per_mwh,
            correlation=reserve_correlation,
        )
        return reserve_series.to_numpy(), True
    reserve_series = load_reserve_prices(reserve_source, fill=price_gap_fill)
    if calendar == "live":
        lookup, _ = live_price_index(index, pd.DatetimeIndex(reserve_series.index))
        reserve, _ = _align_prices(reserve_series, lookup, "reserve price")
        return reserve, False
    _check_coverage(
        reserve_series.index, index[:steps], "reserve price", reserve_source, "reserve_source"
    )
    reserve, _ = _align_prices(reserve_series, index, "reserve price")
    return reserve, False


def _disturbance_matrix(
    channels: tuple[DisturbanceChannel, ...],
    index: pd.DatetimeIndex,
    weather: pd.DataFrame,
    location: EpwLocation,
    gains: InternalGainDensities,
    gain_areas_m2: Sequence[float],
    schedule: OfficeSchedule,
    weather_path: Path,
) -> np.ndarray:
    """(T, nd) disturbances d in ``channels`` order and units, from the weather on ``index``
    (:func:`~hvacflex.data.weather_channels.weather_channel_values`) and the office
    schedule's internal gains."""
    values = weather_channel_values(channels, weather, location, source=weather_path)
    per_m2 = zone_internal_gains_w(
        index,
        1.0,
        gains.occupancy_m2_per_person,
        gains.sensible_w_per_person,
        gains.lighting_w_per_m2,
        gains.equipment_w_per_m2,
        schedule,
    )
    d = np.empty((len(index), len(channels)))
    gain_i = 0
    for i, ch in enumerate(channels):
        if i in values:
            d[:, i] = values[i]
        elif ch.kind == "internal_gain":
            d[:, i] = per_m2 * gain_areas_m2[gain_i]
            gain_i += 1
        elif ch.kind == "constant":
            d[:, i] = 1.0
        else:
            raise ConfigError("unknown channel kind", field=ch.name, value=ch.kind)
    return d
