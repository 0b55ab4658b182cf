"""ASHRAE Standard 140-2020 (BESTEST) Cases 600, 900, 600FF and 900FF on the Denver TMY3 year.

Inputs (package data ``hvacflex/resources/bestest/``, ``resources/PROVENANCE.md`` §4):
``725650TYCST.epw`` and the six example programs' results
``std140_2020_example_results_600_900.csv``; buildings ``resources/buildings/bestest600.toml``
and ``bestest900.toml`` (FF = the same file in free float).

Procedure
---------
* Weather: :func:`hvacflex.data.weather.weather_30min` on the file's local standard time
  (UTC−7, ``Etc/GMT+7``; no daylight saving), a non-leap year. Dry bulb linearly
  interpolated, irradiance hour totals kept. Irradiance on every orientation including the
  roof with :mod:`hvacflex.data.solar` (Hay–Davies on period-integrated sun geometry),
  ground reflectance 0.2. Sky long-wave
  ``σ T_out⁴ − L↓`` with ``L↓`` the EPW horizontal infrared radiation (field 13, held over
  its hour). Internal gain 200 W constant.
* Time stepping: exact ZOH of the linear network at ``DT_S`` = 10 min, the 30-min
  disturbances held (:mod:`hvacflex.validation.ideal_loads`). One year of warm-up
  (the year is run twice, the second pass starting from the end of the first) so that the
  reported year is periodic.
* Ideal loads: heating below 20 °C, cooling above 27 °C, ideal convective air system.
  Annual heating/cooling [MWh]; peaks are the largest hourly-integrated loads [kW].
* Free float: maximum, minimum and mean of the hourly-integrated zone air temperature.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from hvacflex.building.io import load_building
from hvacflex.building.model import Building
from hvacflex.building.rc import ThermalNetwork, build_network
from hvacflex.constants import PERIOD_S
from hvacflex.data.weather import read_epw, weather_30min
from hvacflex.data.weather_channels import weather_channel_values
from hvacflex.validation.ideal_loads import simulate_zone_loads

FloatArray = NDArray[np.float64]

EPW_NAME = "725650TYCST.epw"
REFERENCE_CSV_NAME = "std140_2020_example_results_600_900.csv"
TIMEZONE = "Etc/GMT+7"
"""Denver local standard time, UTC−7 all year (Standard 140 uses standard time)."""
YEAR = 2019
"""Any non-leap year: the TMY calendar is mapped onto it (no weekday schedules here)."""
DT_S = 600.0
"""Simulation step [s] (three per 30-min weather period)."""
HEATING_SETPOINT_DEGC = 20.0
COOLING_SETPOINT_DEGC = 27.0
INTERNAL_GAIN_W = 200.0
"""Constant sensible internal gain (its radiative share is in the building file) [W]."""
WINTER_DAY = (1, 4)
SUMMER_DAY = (7, 27)
"""(month, day) of the hourly free-float plots: Standard 140's Jan 4 and Jul 27 (neither
``resources/bestest/SPEC.md`` nor the results CSV names days; these are the days the
standard's reports plot)."""
PROGRAMS = ("BSIMAC", "CSE", "DeST", "EnergyPlus", "ESP-r", "TRNSYS")


@dataclass(frozen=True)
class Quantity:
    """One of the 14 compared quantities.

    Attributes
    ----------
    key : e.g. ``"600 annual heating"``.
    case : ``"600"``, ``"900"``, ``"600FF"``, ``"900FF"``.
    label, unit : for tables and plots.
    csv_quantity : the ``quantity`` column of the reference CSV.
    """

    key: str
    case: str
    label: str
    unit: str
    csv_quantity: str


_HEAT = "Annual Heating Loads (MWh)"
_COOL = "Annual Sensible Cooling Loads (MWh)"
_PEAK_HEAT = "Annual Hourly Integrated Peak Heating Loads"
_PEAK_COOL = "Annual Hourly Integrated Peak Sensible Cooling Loads"
_TMAX = "MAXIMUM ANNUAL HOURLY INTEGRATED ZONE TEMPERATURE"
_TMIN = "MINIMUM ANNUAL HOURLY INTEGRATED ZONE TEMPERATURE"
_TMEAN = "AVERAGE ANNUAL HOURLY INTEGRATED ZONE TEMPERATURE"

QUANTITIES: tuple[Quantity, ...] = (
    Quantity("600 annual heating", "600", "annual heating", "MWh", _HEAT),
    Quantity("900 annual heating", "900", "annual heating", "MWh", _HEAT),
    Quantity("600 annual cooling", "600", "annual sensible cooling", "MWh", _COOL),
    Quantity("900 annual cooling", "900", "annual sensible cooling", "MWh", _COOL),
    Quantity("600 peak heating", "600", "peak heating", "kW", _PEAK_HEAT),
    Quantity("900 peak heating", "900", "peak heating", "kW", _PEAK_HEAT),
    Quantity("600 peak cooling", "600", "peak sensible cooling", "kW", _PEAK_COOL),
    Quantity("900 peak cooling", "900", "peak sensible cooling", "kW", _PEAK_COOL),
    Quantity("600FF max temperature", "600FF", "max zone temperature", "°C", _TMAX),
    Quantity("900FF max temperature", "900FF", "max zone temperature", "°C", _TMAX),
    Quantity("600FF min temperature", "600FF", "min zone temperature", "°C", _TMIN),
    Quantity("900FF min temperature", "900FF", "min zone temperature", "°C", _TMIN),
    Quantity("600FF mean temperature", "600FF", "mean zone temperature", "°C", _TMEAN),
    Quantity("900FF mean temperature", "900FF", "mean zone temperature", "°C", _TMEAN),
)

CASES: dict[str, tuple[str, bool]] = {
    "600": ("bestest600", False),
    "900": ("bestest900", False),
    "600FF": ("bestest600", True),
    "900FF": ("bestest900", True),
}
"""Case → (building name, free float)."""


@dataclass(frozen=True)
class CaseResult:
    """Hourly results of one case over the year (8,760 hours, local standard time).

    Attributes
    ----------
    case : ``"600"`` …
    hourly : DataFrame with ``zone_temp_degc`` (hour mean), ``heating_w``, ``cooling_w``
        (hour means) and ``outdoor_temp_degc`` on the hour starts.
    """

    case: str
    hourly: pd.DataFrame

    def quantities(self) -> dict[str, float]:
        """This case's compared quantities by :attr:`Quantity.key`."""
        h = self.hourly
        if self.case.endswith("FF"):
            t = h["zone_temp_degc"]
            return {
                f"{self.case} max temperature": float(t.max()),
                f"{self.case} min temperature": float(t.min()),
                f"{self.case} mean temperature": float(t.mean()),
            }
        return {
            f"{self.case} annual heating": float(h["heating_w"].sum() / 1e6),
            f"{self.case} annual cooling": float(h["cooling_w"].sum() / 1e6),
            f"{self.case} peak heating": float(h["heating_w"].max() / 1e3),
            f"{self.case} peak cooling": float(h["cooling_w"].max() / 1e3),
        }


@dataclass(frozen=True)
class BestestResult:
    """Outcome of :func:`run_bestest`.

    Attributes
    ----------
    table : one row per quantity (14): ``quantity``, ``case``, ``unit``, ``hvacflex``, the
        six programs, ``ref_min``, ``ref_max``, ``ref_mean``, ``in_range`` (bool),
        ``deviation_pct`` (0 inside the band, else the signed distance to the nearer bound
        in % of that bound), ``deviation_from_mean_pct``.
    cases : hourly results per case.
    """

    table: pd.DataFrame
    cases: dict[str, CaseResult]

    @property
    def n_in_range(self) -> int:
        return int(self.table["in_range"].sum())


def bestest_disturbances(net: ThermalNetwork, epw_path: Path) -> pd.DataFrame:
    """Disturbances of a BESTEST building on 30-min periods of the Denver year.

    Parameters
    ----------
    net : the building's network (its channels fix the columns; a window channel carries
        the window's angular SHGC).
    epw_path : the Denver TMY3 EPW.

    Returns
    -------
    (17520, nd) DataFrame on 30-min period starts (``Etc/GMT+7``), one column per channel
    (channel names, ``channels.py`` units): the weather's channels from
    :func:`hvacflex.data.weather_channels.weather_channel_values`, the internal gain the
    constant :data:`INTERNAL_GAIN_W`.
    """
    epw, location = read_epw(epw_path)
    weather = weather_30min(epw, location, YEAR, tz=TIMEZONE)
    values = weather_channel_values(net.channels, weather, location, source=epw_path)
    columns = {
        ch.name: values[i] if i in values else np.full(len(weather), INTERNAL_GAIN_W)
        for i, ch in enumerate(net.channels)
    }
    return pd.DataFrame(columns, index=weather.index)


def run_case(
    case: str, building: Building, disturbances_30min: pd.DataFrame, *, dt_s: float = DT_S
) -> CaseResult:
    """Simulate one case over the year (after a one-year warm-up) → hourly results.

    Parameters
    ----------
    case : ``"600"``, ``"900"``, ``"600FF"`` or ``"900FF"`` (FF: free float).
    building : its building.
    disturbances_30min : from :func:`bestest_disturbances`.
    dt_s : simulation step, a divisor of 30 min [s].
    """
    free_float = case.endswith("FF")
    net = build_network(building)
    substeps = round(PERIOD_S / dt_s)
    if substeps < 1 or abs(substeps * dt_s - PERIOD_S) > 1e-9:
        raise ValueError(f"dt_s must divide {PERIOD_S:g} s, got {dt_s}")
    d = np.repeat(disturbances_30min.to_numpy(dtype=float), substeps, axis=0)
    setpoints: dict[str, float | None] = {
        "heating_setpoint_degc": None if free_float else HEATING_SETPOINT_DEGC,
        "cooling_setpoint_degc": None if free_float else COOLING_SETPOINT_DEGC,
    }
    warm_up = simulate_zone_loads(net, d, dt_s, **setpoints)
    year = simulate_zone_loads(
        net, d, dt_s, initial_state_degc=warm_up.final_state_degc, **setpoints
    )
    per_hour = 2 * substeps
    hours = len(d) // per_hour

    def hourly(values: FloatArray) -> FloatArray:
        result: FloatArray = values[: hours * per_hour].reshape(hours, per_hour).mean(axis=1)
        return result

    index = disturbances_30min.index[::2]
    outdoor = disturbances_30min["outdoor_temp_degc"].to_numpy(dtype=float)
    frame = pd.DataFrame(
        {
            "zone_temp_degc": hourly(year.step_mean_zone_temp_degc()[:, 0]),
            "heating_w": hourly(year.heating_w[:, 0]),
            "cooling_w": hourly(year.cooling_w[:, 0]),
            "outdoor_temp_degc": outdoor.reshape(-1, 2).mean(axis=1),
        },
        index=index,
    )
    return CaseResult(case, frame)


def load_reference(csv_path: Path) -> pd.DataFrame:
    """The example programs' results: one row per quantity key, columns the six programs
    and ``ref_min``, ``ref_max``, ``ref_mean``."""
    raw = pd.read_csv(csv_path, dtype={"case": str})
    rows = {}
    for q in QUANTITIES:
        sel = raw[(raw["quantity"] == q.csv_quantity) & (raw["case"] == q.case)]
        values = dict(zip(sel["program_or_stat"], sel["value"].astype(float), strict=True))
        rows[q.key] = {
            **{p: values[p] for p in PROGRAMS},
            "ref_min": values["stat_min"],
            "ref_max": values["stat_max"],
            "ref_mean": values["stat_mean"],
        }
    return pd.DataFrame.from_dict(rows, orient="index")


def comparison_table(values: dict[str, float], reference: pd.DataFrame) -> pd.DataFrame:
    """The 14-row table (see :class:`BestestResult`) from hvacflex's values and the
    reference."""
    records = []
    for q in QUANTITIES:
        row = reference.to_dict(orient="index")[q.key]
        ref: dict[str, float] = {str(k): float(v) for k, v in row.items()}
        value = values[q.key]
        low, high = float(ref["ref_min"]), float(ref["ref_max"])
        if value < low:
            deviation = (value - low) / abs(low) * 100.0
        elif value > high:
            deviation = (value - high) / abs(high) * 100.0
        else:
            deviation = 0.0
        records.append(
            {
                "quantity": q.key,
                "case": q.case,
                "unit": q.unit,
                "hvacflex": value,
                **{p: float(ref[p]) for p in PROGRAMS},
                "ref_min": low,
                "ref_max": high,
                "ref_mean": float(ref["ref_mean"]),
                "in_range": low <= value <= high,
                "deviation_pct": deviation,
                "deviation_from_mean_pct": (value - float(ref["ref_mean"]))
                / abs(float(ref["ref_mean"]))
                * 100.0,
            }
        )
    return pd.DataFrame.from_records(records)


def stage_count() -> int:
    """Stages :func:`run_bestest` announces through ``progress``: weather and solar once per
    building, then one per case."""
    return len({name for name, _ in CASES.values()}) + len(CASES)


def run_bestest(
    bestest_dir: Path,
    buildings_dir: Path,
    *,
    dt_s: float = DT_S,
    progress: Callable[[str], None] | None = None,
) -> BestestResult:
    """Run Cases 600, 900, 600FF and 900FF and compare with the reference programs.

    Parameters
    ----------
    bestest_dir : folder with ``725650TYCST.epw`` and the results CSV.
    buildings_dir : folder with ``bestest600.toml`` and ``bestest900.toml``.
    dt_s : simulation step [s].
    progress : called with a short message before each stage.
    """
    say = progress or (lambda _message: None)
    epw_path = bestest_dir / EPW_NAME
    buildings: dict[str, Building] = {}
    disturbances: dict[str, pd.DataFrame] = {}
    cases: dict[str, CaseResult] = {}
    values: dict[str, float] = {}
    for case, (name, _) in CASES.items():
        if name not in buildings:
            say(f"weather and solar for {name}")
            buildings[name] = load_building(buildings_dir / f"{name}.toml")
            disturbances[name] = bestest_disturbances(build_network(buildings[name]), epw_path)
        say(f"case {case}")
        cases[case] = run_case(case, buildings[name], disturbances[name], dt_s=dt_s)
        values.update(cases[case].quantities())
    reference = load_reference(bestest_dir / REFERENCE_CSV_NAME)
    return BestestResult(comparison_table(values, reference), cases)


def table_markdown(table: pd.DataFrame) -> str:
    """The comparison as a Markdown table (hvacflex, the reference band, in/out, deviation)."""
    lines = [
        "| quantity | unit | hvacflex | ref. min | ref. max | ref. mean | in range | "
        "outside band by |",
        "|---|---|---:|---:|---:|---:|---|---:|",
    ]
    for row in table.itertuples(index=False):
        outside = "" if row.in_range else f"{row.deviation_pct:+.1f} %"
        lines.append(
            f"| {row.quantity} | {row.unit} | {row.hvacflex:.3f} | {row.ref_min:.3f} | "
            f"{row.ref_max:.3f} | {row.ref_mean:.3f} | {'yes' if row.in_range else 'NO'} | "
            f"{outside} |"
        )
    n_in = int(table["in_range"].sum())
    lines.append("")
    lines.append(f"{n_in} of {len(table)} quantities inside the example programs' min–max range.")
    return "\n".join(lines) + "\n"
