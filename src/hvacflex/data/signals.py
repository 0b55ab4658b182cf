"""Operator signals as data: what a grid operator or aggregator changes while a building runs.

Prices for given periods, an outdoor-temperature forecast, the peak-power price φ and a
feeder limit arrive as one
:class:`OperatorSignals` value, which :meth:`OperatorSignals.apply` lays over a controller's
:class:`~hvacflex.data.forecast.Forecast`. A controller reads φ from the forecast
(:func:`effective_peak_price`), so a new φ changes the next plan without rebuilding the
controller, and the results record the φ the plan was made with.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from hvacflex.data.forecast import Forecast
from hvacflex.errors import InputError


def _no_prices() -> Mapping[pd.Timestamp, float]:
    return {}


@dataclass(frozen=True)
class OperatorSignals:
    """Signals in force for a building.

    Attributes
    ----------
    energy_price_sgd_per_mwh : energy price [SGD/MWh] by period start (tz-aware), replacing
        the forecast's price for those periods.
    reserve_price_sgd_per_mwh : reserve price [SGD/MWh] by period start (tz-aware).
    outdoor_temp_degc : a posted outdoor-temperature forecast [°C] by period start
        (tz-aware), replacing every ``outdoor_temp`` channel of the forecast there (the
        typical-year weather of a live building, docs/guide/service.md).
    outdoor_humidity_ratio_kg_per_kg : a posted outdoor humidity-ratio forecast [kg/kg] by
        period start (tz-aware), replacing the forecast's there (the coil's latent load and
        a metered power model's moisture term read it).
    peak_price_sgd_per_kw : φ [SGD/kW]; None keeps the scenario's.
    feeder_limit_kw : the feeder's power limit [kW] (None: none); read by a fleet coordinator.
    """

    energy_price_sgd_per_mwh: Mapping[pd.Timestamp, float] = field(default_factory=_no_prices)
    reserve_price_sgd_per_mwh: Mapping[pd.Timestamp, float] = field(default_factory=_no_prices)
    outdoor_temp_degc: Mapping[pd.Timestamp, float] = field(default_factory=_no_prices)
    outdoor_humidity_ratio_kg_per_kg: Mapping[pd.Timestamp, float] = field(
        default_factory=_no_prices
    )
    peak_price_sgd_per_kw: float | None = None
    feeder_limit_kw: float | None = None

    def __post_init__(self) -> None:
        phi = self.peak_price_sgd_per_kw
        if phi is not None and not (math.isfinite(phi) and phi >= 0):
            raise InputError("must be a finite price ≥ 0", field="peak_price_sgd_per_kw", value=phi)

    def apply(self, forecast: Forecast) -> Forecast:
        """``forecast`` with these signals laid over it (the same object when none applies)."""
        changes: dict[str, object] = {}
        if self.peak_price_sgd_per_kw is not None:
            changes["peak_price_sgd_per_kw"] = float(self.peak_price_sgd_per_kw)
        for name, prices in (
            ("energy_price_sgd_per_mwh", self.energy_price_sgd_per_mwh),
            ("reserve_price_sgd_per_mwh", self.reserve_price_sgd_per_mwh),
            ("outdoor_humidity_ratio_kg_per_kg", self.outdoor_humidity_ratio_kg_per_kg),
        ):
            if not prices:
                continue
            utc = {pd.Timestamp(t).tz_convert("UTC"): float(v) for t, v in prices.items()}
            series = np.array(getattr(forecast, name), dtype=float)
            for i, stamp in enumerate(forecast.index.tz_convert("UTC")):
                series[i] = utc.get(stamp, series[i])
            changes[name] = series
        columns = forecast.channel_index("outdoor_temp")
        if self.outdoor_temp_degc and columns:
            utc = {
                pd.Timestamp(t).tz_convert("UTC"): float(v)
                for t, v in self.outdoor_temp_degc.items()
            }
            disturbances = np.array(forecast.disturbances, dtype=float)
            for i, stamp in enumerate(forecast.index.tz_convert("UTC")):
                if stamp in utc:
                    disturbances[i, columns] = utc[stamp]
            changes["disturbances"] = disturbances
        return dataclasses.replace(forecast, **changes) if changes else forecast  # type: ignore[arg-type]


def effective_peak_price(forecast: Forecast, configured_sgd_per_kw: float) -> float:
    """φ [SGD/kW] a plan made from ``forecast`` uses: the signalled one, else the configured."""
    signalled = forecast.peak_price_sgd_per_kw
    return configured_sgd_per_kw if signalled is None else float(signalled)
