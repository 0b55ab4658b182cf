"""A power model from the meter: HVAC electricity fitted to a trend's ``hvac_power_kw``.

The model (:class:`~hvacflex.building.identified.IdentifiedPower`, docs/guide/identify.md §3) is
linear in its coefficients, so it is a bounded least-squares fit on the training periods of
the regressors :func:`power_regressors` builds from the trend's zone flows, zone and supply
temperatures, the outdoor temperature and the occupied share:

======================================  =========================================  ==========
coefficient                             regressor                                  bound
======================================  =========================================  ==========
``base_kw``                             1                                          free
``kw_per_kw_cooling``                   ΣQ [kW]                                    ≥ 0
``kw_per_k_outdoor``                    To [°C]                                    free
``occupied_kw``                         occ [–]                                    free
``kw_per_kg_s_k_outdoor_occupied``      occ · Σṁ (To − Ta) [kg/s·K]                ≥ 0
``running_kw``                          run (S > 1 g/s) [–]                        ≥ 0
``fan_kw_per_kg_s``                     S [kg/s]                                   ≥ 0
``fan_kw_per_kg2_s2``                   S² [(kg/s)²]                               ≥ 0
``kw_per_kw_cooling_k_outdoor``         ΣQ (To − 30 °C) [kW·K]                     ≥ 0
``kw_per_kw2_cooling``                  (ΣQ)² [kW²]                                ≤ 0
``kw_per_kg_s_occupied``                occ · S [kg/s]                             ≥ 0
``kw_per_humidity_ratio_occupied``      occ · (Wo − 0.018) [kg/kg]                 ≥ 0
======================================  =========================================  ==========

(Q = ṁ c_p (Ta − T_s) per zone with its measured supply temperature, S = Σṁ, Wo the outdoor
humidity ratio, a trend's or a run's results' optional ``outdoor_humidity_ratio_kg_per_kg``:
without it the term is left out.) A regressor
that does not vary in the training periods (no unoccupied period, a loop that never stops)
is left out: its coefficient is 0 and the intercept carries it.

:func:`evaluate_power` grades the model on the test days against the meter, per day and
over all test days, for all, occupied and unoccupied periods (``power_report.csv``).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import numpy.typing as npt
import pandas as pd
import scipy.optimize

from hvacflex.building.identified import (
    MIN_RUNNING_PERIODS,
    PLANT_REFERENCE_OUTDOOR_DEGC,
    RUNNING_FLOW_KG_S,
    IdentifiedPower,
    sensible_cooling_kw,
)
from hvacflex.building.identified import (
    REFERENCE_HUMIDITY_KG_PER_KG as REFERENCE_HUMIDITY,
)
from hvacflex.constants import PERIODS_PER_DAY
from hvacflex.data.gains import occupied_mask
from hvacflex.errors import InputError
from hvacflex.identify.trend import (
    HVAC_POWER,
    OUTDOOR_HUMIDITY,
    OUTDOOR_TEMP,
    RANGES,
    TrendData,
    first_out_of_range,
    zone_column,
)

FloatArray = npt.NDArray[np.float64]

FREE, POSITIVE, NEGATIVE = (-np.inf, np.inf), (0.0, np.inf), (-np.inf, 0.0)
POWER_TERMS: tuple[tuple[str, tuple[float, float]], ...] = (
    ("base_kw", FREE),
    ("kw_per_kw_cooling", POSITIVE),
    ("kw_per_k_outdoor", FREE),
    ("occupied_kw", FREE),
    ("kw_per_kg_s_k_outdoor_occupied", POSITIVE),
    ("running_kw", POSITIVE),
    ("fan_kw_per_kg_s", POSITIVE),
    ("fan_kw_per_kg2_s2", POSITIVE),
    ("kw_per_kw_cooling_k_outdoor", POSITIVE),
    ("kw_per_kw2_cooling", NEGATIVE),
    ("kw_per_kg_s_occupied", POSITIVE),
    ("kw_per_humidity_ratio_occupied", POSITIVE),
)
"""The fitted coefficients in regressor order, each with its (lower, upper) bound: the signs
physics gives (a plant's power per kW grows with the outdoor temperature and falls with its
part load — concave, as EnergyPlus's DX and EIR chiller curves; a fan's is convex)."""
PERIOD_H = 0.5
"""A trend period [h]."""
RIDGE = 1e-8
"""Relative ridge on the scaled regressors: keeps nearly collinear terms (fan flow and
cooling) bounded without moving a well-determined fit."""


@dataclass(frozen=True)
class PowerInputs:
    """The trend's series the power model reads, on the 30-min grid.

    Attributes
    ----------
    index : (T,) period starts; flow_kg_s, zone_temp_degc, supply_temp_degc : (T, m) per
    zone; outdoor_temp_degc : (T,) [°C]; occupied : (T,) 1 in the office schedule's occupied
    periods (those whose comfort band is the occupied one: where the damper opens and the LP
    counts the outdoor air), else 0 — not the trend's people count, which an IDF's People
    schedule may spread over the evening; metered_kw : (T,) the meter [kW];
    outdoor_humidity_ratio_kg_per_kg : (T,) [kg/kg], or None when the data has none (the
    moisture term is then left out of the fit).
    """

    index: pd.DatetimeIndex
    flow_kg_s: FloatArray
    zone_temp_degc: FloatArray
    supply_temp_degc: FloatArray
    outdoor_temp_degc: FloatArray
    occupied: FloatArray
    metered_kw: FloatArray
    outdoor_humidity_ratio_kg_per_kg: FloatArray | None = None


def power_inputs(data: TrendData, zones: tuple[str, ...] | None = None) -> PowerInputs:
    """The power model's inputs from a trend: the zones ``zones`` (default: every zone with
    a supply flow) and the meter.

    Raises
    ------
    InputError
        when the trend has no ``hvac_power_kw`` column, or no zone with supply air.
    """
    if not data.has(HVAC_POWER):
        raise InputError(
            "the trend has no metered HVAC power: a power model is fitted to the meter",
            source=data.source,
            field=HVAC_POWER,
            hint="export the HVAC electricity meter as hvac_power_kw (kW, period means)",
        )
    chosen = zones
    if chosen is None:
        chosen = tuple(z for z in data.zones if data.has(zone_column("supply_flow", z)))
    flow = data.zone_series("supply_flow", chosen) if chosen else None
    temp = data.zone_series("temp", chosen) if chosen else None
    supply = data.zone_series("supply_temp", chosen) if chosen else None
    if flow is None or temp is None or supply is None:
        raise InputError(
            "the power model needs every zone's supply flow and supply temperature",
            source=data.source,
            field="supply_flow_<zone>_kg_s",
            value=list(chosen or ()),
            hint="export each zone's supply air flow and temperature",
        )
    return PowerInputs(
        index=pd.DatetimeIndex(data.frame.index),
        flow_kg_s=flow,
        zone_temp_degc=temp,
        supply_temp_degc=supply,
        outdoor_temp_degc=data.column(OUTDOOR_TEMP),
        occupied=occupied_mask(pd.DatetimeIndex(data.frame.index)).astype(np.float64),
        metered_kw=data.column(HVAC_POWER),
        outdoor_humidity_ratio_kg_per_kg=(
            data.column(OUTDOOR_HUMIDITY) if data.has(OUTDOOR_HUMIDITY) else None
        ),
    )


def power_inputs_from_results(
    results: pd.DataFrame, zones: tuple[str, ...], supply_temp_degc: float
) -> PowerInputs:
    """The power model's inputs from a run's results (``results.parquet`` of ``hvacflex
    simulate``: its plant's meter ``power_kw``, the flows ``flow_<zone>_kg_s``, the zone
    temperatures at the period's start and end — their mean is the period's — and
    ``d_outdoor_temp_degc``, and ``outdoor_humidity_ratio_kg_per_kg`` where the results have
    it — older ones do not, and their fit leaves the moisture term out), the supply air at
    ``supply_temp_degc`` [°C].

    The flows are the ones the controller applied, in its own model's units: a power model
    fitted to them maps the plan to the meter, which a trend's flows (the plant's delivered
    air) do not where the controller's thermal model needs other flows than the plant for
    the same temperatures (docs/guide/identify.md §3.2).

    Raises
    ------
    InputError
        when a column is missing (a results file of another building or version).
    """
    columns = [f"flow_{z}_kg_s" for z in zones] + [f"temp_{z}_degc" for z in zones]
    columns += [f"temp_end_{z}_degc" for z in zones] + ["d_outdoor_temp_degc", "power_kw"]
    missing = [c for c in columns if c not in results.columns]
    if missing:
        raise InputError(
            "the results lack the columns the power model reads",
            source="results",
            field=missing[0],
            value=missing,
            hint="give the results of a run of this building (hvacflex simulate)",
        )
    humidity = _results_humidity(results)
    start = results[[f"temp_{z}_degc" for z in zones]].to_numpy(dtype=np.float64)
    end = results[[f"temp_end_{z}_degc" for z in zones]].to_numpy(dtype=np.float64)
    flow = results[[f"flow_{z}_kg_s" for z in zones]].to_numpy(dtype=np.float64)
    index = pd.DatetimeIndex(results.index)
    return PowerInputs(
        index=index,
        flow_kg_s=flow,
        zone_temp_degc=0.5 * (start + end),
        supply_temp_degc=np.full_like(flow, supply_temp_degc),
        outdoor_temp_degc=results["d_outdoor_temp_degc"].to_numpy(dtype=np.float64),
        occupied=occupied_mask(index).astype(np.float64),
        metered_kw=results["power_kw"].to_numpy(dtype=np.float64),
        outdoor_humidity_ratio_kg_per_kg=humidity,
    )


def _results_humidity(results: pd.DataFrame) -> FloatArray | None:
    """(T,) a run's outdoor humidity ratio [kg/kg], or None where its results have none (an
    older run's).

    Raises
    ------
    InputError
        when a value is not finite or outside the trend's range (:data:`RANGES`): a g/kg slip.
    """
    if OUTDOOR_HUMIDITY not in results.columns:
        return None
    humidity = results[OUTDOOR_HUMIDITY].to_numpy(dtype=np.float64)
    first = first_out_of_range(humidity, OUTDOOR_HUMIDITY)
    if first is not None:
        low, high = RANGES[OUTDOOR_HUMIDITY]
        raise InputError(
            f"the results' outdoor humidity ratio is {humidity[first]!r} at "
            f"{results.index[first]}, outside {low:g} … {high:g} kg/kg",
            source="results",
            field=OUTDOOR_HUMIDITY,
            value=float(humidity[first]),
            hint="the column is in kg of water per kg of dry air (not g/kg), every period set",
        )
    return humidity


def power_regressors(inputs: PowerInputs) -> FloatArray:
    """(T, 12) the regressors of :data:`POWER_TERMS` (module docstring's table; the moisture
    column 0 without the outdoor humidity)."""
    flow, outdoor, occ = inputs.flow_kg_s, inputs.outdoor_temp_degc, inputs.occupied
    humidity = inputs.outdoor_humidity_ratio_kg_per_kg
    total = flow.sum(axis=1)
    cooling = sensible_cooling_kw(flow, inputs.zone_temp_degc, inputs.supply_temp_degc).sum(axis=1)
    outdoor_air = (flow * (outdoor[:, None] - inputs.zone_temp_degc)).sum(axis=1)
    return np.column_stack(
        [
            np.ones_like(total),
            cooling,
            outdoor,
            occ,
            occ * outdoor_air,
            (total > RUNNING_FLOW_KG_S).astype(np.float64),
            total,
            total**2,
            cooling * (outdoor - PLANT_REFERENCE_OUTDOOR_DEGC),
            cooling**2,
            occ * total,
            np.zeros_like(total) if humidity is None else occ * (humidity - REFERENCE_HUMIDITY),
        ]
    )


def running_periods(inputs: PowerInputs, first: int, end: int) -> int:
    """The periods ``first`` … ``end − 1`` in which the air loop ran (S > 1 g/s)."""
    return int((inputs.flow_kg_s[first:end].sum(axis=1) > RUNNING_FLOW_KG_S).sum())


def fit_power_model(
    inputs: PowerInputs, train: tuple[int, int], source: str = "the trend"
) -> IdentifiedPower:
    """Bounded least-squares fit of the power model on the periods ``train`` = (first, end).

    Raises
    ------
    InputError
        when fewer than :data:`~hvacflex.building.identified.MIN_RUNNING_PERIODS` training
        periods have the air loop running (the fan, the coil and the plant are not
        identifiable from a few).
    """
    first, end = train
    running = running_periods(inputs, first, end)
    if running < MIN_RUNNING_PERIODS:
        raise InputError(
            f"the power model would be fitted on {running} periods with the air loop running, "
            f"fewer than {MIN_RUNNING_PERIODS}",
            source=source,
            field="--train",
            value=running,
            hint=f"train on more days when the HVAC ran (at least {MIN_RUNNING_PERIODS} "
            "running 30-min periods: about two working days)",
        )
    x = power_regressors(inputs)[first:end]
    y = inputs.metered_kw[first:end]
    scale = np.sqrt((x**2).mean(axis=0))
    varies = x.std(axis=0) > 1e-9 * np.maximum(scale, 1.0)
    varies[0] = True  # the intercept
    kept = np.flatnonzero(varies & (scale > 0))
    scaled = x[:, kept] / scale[kept]
    ridge = np.sqrt(RIDGE * len(y)) * np.eye(kept.size)
    ridge[0, 0] = 0.0  # no shrinking of the intercept
    lower = np.array([POWER_TERMS[j][1][0] for j in kept])
    upper = np.array([POWER_TERMS[j][1][1] for j in kept])
    solution = scipy.optimize.lsq_linear(
        np.vstack([scaled, ridge]),
        np.concatenate([y, np.zeros(kept.size)]),
        bounds=(lower, upper),
        method="bvls",
    )
    coefficients = np.zeros(len(POWER_TERMS))
    coefficients[kept] = solution.x / scale[kept]
    values = {name: float(c) for (name, _), c in zip(POWER_TERMS, coefficients, strict=True)}
    return IdentifiedPower(**values, running_periods=float(running))


def metered_power_model(
    data: TrendData, zones: tuple[str, ...], train: tuple[int, int]
) -> IdentifiedPower | None:
    """``identify fit``'s power model: fitted to the meter on the training periods
    (:func:`fit_power_model`, which refuses too few running periods), or None when the trend
    has no ``hvac_power_kw`` or it is 0 throughout the training (ideal loads: no meter)."""
    first, end = train
    if not data.has(HVAC_POWER) or not np.any(data.column(HVAC_POWER)[first:end]):
        return None
    return fit_power_model(power_inputs(data, zones), train, source=data.source)


def power_kw(power: IdentifiedPower, inputs: PowerInputs) -> FloatArray:
    """(T,) the power model's HVAC electricity [kW] on the trend's inputs."""
    coefficients = np.array([getattr(power, name) for name, _ in POWER_TERMS])
    result: FloatArray = power_regressors(inputs) @ coefficients
    return result


def evaluate_power(
    power: IdentifiedPower, inputs: PowerInputs, test: tuple[int, int]
) -> pd.DataFrame:
    """The power model against the meter on the whole test days within ``test``.

    Returns
    -------
    One row per test day and per ``hours`` (``all``, ``occupied``: the office schedule's
    occupied periods, ``unoccupied``), then the same three rows with ``day`` = ``test days``
    (every test day): ``day``, ``hours``, ``periods``, ``measured_kwh``, ``predicted_kwh``,
    ``error_pct`` (predicted − measured, % of measured; NaN at 0), ``power_rmse_kw`` and
    ``power_bias_kw`` (RMS and mean of predicted − measured power [kW]).
    """
    first, last = test
    k = np.flatnonzero((inputs.index.hour == 0) & (inputs.index.minute == 0))
    starts = k[(k >= first) & (k + PERIODS_PER_DAY <= last)]
    predicted = power_kw(power, inputs)
    rows: list[dict[str, object]] = []
    days = [(inputs.index[s].date().isoformat(), [s]) for s in starts]
    for day, day_starts in [*days, ("test days", list(starts))]:
        rows.extend(_power_rows(day, day_starts, inputs, predicted))
    return pd.DataFrame(rows)


def _power_rows(
    day: str, starts: list[int], inputs: PowerInputs, predicted: FloatArray
) -> list[dict[str, object]]:
    """The ``all``, ``occupied`` and ``unoccupied`` rows of the days starting at ``starts``."""
    periods = (np.asarray(starts, dtype=np.int64)[:, None] + np.arange(PERIODS_PER_DAY)).ravel()
    occupied = inputs.occupied[periods] > 0.0
    masks = (("all", np.ones_like(occupied)), ("occupied", occupied), ("unoccupied", ~occupied))
    return [
        _power_row(day, hours, periods[mask], inputs.metered_kw, predicted) for hours, mask in masks
    ]


def _power_row(
    day: str, hours: str, periods: np.ndarray, measured: FloatArray, predicted: FloatArray
) -> dict[str, object]:
    """One row of :func:`evaluate_power` over ``periods``."""
    error = predicted[periods] - measured[periods]
    m_kwh = float(measured[periods].sum() * PERIOD_H)
    p_kwh = float(predicted[periods].sum() * PERIOD_H)
    return {
        "day": day,
        "hours": hours,
        "periods": int(periods.size),
        "measured_kwh": m_kwh,
        "predicted_kwh": p_kwh,
        "error_pct": 100.0 * (p_kwh - m_kwh) / m_kwh if m_kwh > 0 else np.nan,
        "power_rmse_kw": float(np.sqrt((error**2).mean())) if error.size else np.nan,
        "power_bias_kw": float(error.mean()) if error.size else np.nan,
    }


def power_model_table(power: IdentifiedPower) -> dict[str, float]:
    """The model's coefficients as a TOML table's keys (``running_periods`` when known)."""
    return {
        f.name: float(getattr(power, f.name))
        for f in fields(power)
        if getattr(power, f.name) is not None
    }
