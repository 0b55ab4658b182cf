"""Trend data from an EnergyPlus model: the building under its own control plus an excitation.

``hvacflex identify collect`` runs an IDF as the :class:`~hvacflex.sim.energyplus_plant.
EnergyPlusPlant` (setpoint actuation, docs/guide/energyplus.md) for ``days`` days and writes what a
BMS export would give (:mod:`hvacflex.identify.trend`). The excitation is on the zones'
cooling setpoints (docs/guide/identify.md):

* ``range`` (default): the operating range a controller uses — in the occupied periods (the
  office schedule's: working days 08:00–18:00) the ``prbs`` below (set-point steps, flow
  steps); outside them each zone alternates **float-ups** (set-point
  :data:`RANGE_FLOAT_DEGC`, the unoccupied comfort bound: the zone's unit idles and the zone
  floats up, as a controller lets it at night and at weekends) of a random
  :data:`RANGE_FLOAT_PERIODS` and **pull-downs** (the ``prbs`` levels, the lower one first: a
  pre-cool from the floated state) of a random :data:`RANGE_PULL_DOWN_PERIODS`, drawn per zone
  from ``numpy.random.default_rng(seed)``;
* ``prbs``: each zone independently switches between :data:`EXCITATION_CENTER_DEGC` ±
  :data:`EXCITATION_AMPLITUDE_K`, holding each level for a random 1…4 h (2…8 periods, uniform)
  drawn from ``numpy.random.default_rng(seed)``, around the clock;
* ``steps``: each zone cycles through center − amplitude, center, center + amplitude, center,
  :data:`STEP_HOLD_PERIODS` periods each, zone ``i`` shifted by ``i`` levels;
* ``none``: the IDF's own schedules (no actuation), as plain BMS data is.

Readings per 30-min period: each zone's mean air temperature; a controlled zone's supply flow
(inlet nodes, summed) and supply temperature (inlet node temperatures, flow-weighted; the
plain mean when no air flows); the site's outdoor dry bulb and humidity ratio, direct normal
and diffuse horizontal irradiance and GHI = DHI + DNI · sin(solar altitude); ``occupied`` = 1
when the IDF's ``People`` objects count anyone in the collected zones (``Zone People Occupant
Count``, period mean > 0), else 0 (0 throughout, with a warning, for an IDF without People);
HVAC and facility electricity as the plant meters them.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from hvacflex.constants import PERIOD_FREQ, PERIOD_S, PERIODS_PER_DAY, TIMEZONE
from hvacflex.data.gains import occupied_mask
from hvacflex.energyplus.hvac import has_thermostat
from hvacflex.energyplus.idf import IdfObject, match_zones, objects_of, parse_idf, read_idf
from hvacflex.energyplus.idf import zone_names as idf_zone_names
from hvacflex.energyplus.runner import Variable, expand_hvac_templates
from hvacflex.errors import InputError
from hvacflex.identify import trend
from hvacflex.identify.trend import FloatArray, zone_column
from hvacflex.paths import resolve_idf
from hvacflex.sim.energyplus_plant import EnergyPlusPlant
from hvacflex.sim.plant import Actuation, Disturbance

Excitation = Literal["range", "prbs", "steps", "none"]
EXCITATIONS: tuple[str, ...] = ("range", "prbs", "steps", "none")
DEFAULT_EXCITATION = "range"

EXCITATION_CENTER_DEGC = 24.5
"""Middle of the excited cooling setpoints [°C] (hvacflex's default occupied band 22–26 °C)."""
EXCITATION_AMPLITUDE_K = 1.0
"""Half the span of the excited setpoints [K]."""
PRBS_HOLD_PERIODS = (2, 8)
"""Shortest and longest hold of a PRBS level [30-min periods] (1…4 h)."""
STEP_HOLD_PERIODS = 6
"""Hold of each ``steps`` level [30-min periods] (3 h)."""
RANGE_FLOAT_DEGC = 30.0
"""The ``range`` float-up set-point [°C]: hvacflex's unoccupied comfort bound (20–30 °C), the
temperature an MPC floats the zones towards outside office hours."""
RANGE_FLOAT_PERIODS = (8, 32)
"""Shortest and longest float-up [30-min periods] (4…16 h)."""
RANGE_PULL_DOWN_PERIODS = (4, 12)
"""Shortest and longest pull-down between float-ups [30-min periods] (2…6 h)."""


def excitation_setpoints_degc(
    kind: str, steps: int, zones: int, seed: int = 0, occupied: np.ndarray | None = None
) -> FloatArray | None:
    """The excited cooling setpoints (module docstring); ``occupied`` (steps,) bool: the
    office schedule's occupied periods (``range`` only; None: none occupied).

    Returns
    -------
    (steps, zones) setpoints [°C], or None for ``"none"``.
    """
    if kind not in EXCITATIONS:
        raise InputError(
            "unknown excitation",
            field="--excitation",
            value=kind,
            hint="use range, prbs, steps or none",
        )
    if kind == "range":
        mask = np.zeros(steps, dtype=bool) if occupied is None else np.asarray(occupied, bool)
        return _range_setpoints_degc(mask, zones, seed)
    if kind == "none":
        return None
    low = EXCITATION_CENTER_DEGC - EXCITATION_AMPLITUDE_K
    high = EXCITATION_CENTER_DEGC + EXCITATION_AMPLITUDE_K
    out = np.empty((steps, zones))
    if kind == "steps":
        levels = np.array([low, EXCITATION_CENTER_DEGC, high, EXCITATION_CENTER_DEGC])
        for i in range(zones):
            out[:, i] = levels[(np.arange(steps) // STEP_HOLD_PERIODS + i) % len(levels)]
        return out
    rng = np.random.default_rng(seed)
    shortest, longest = PRBS_HOLD_PERIODS
    for i in range(zones):
        k, level = 0, bool(rng.integers(2))
        while k < steps:
            hold = int(rng.integers(shortest, longest + 1))
            out[k : k + hold, i] = high if level else low
            k += hold
            level = not level
    return out


def _range_setpoints_degc(occupied: np.ndarray, zones: int, seed: int) -> FloatArray:
    """``range``: the PRBS (seeded with ``seed``) where ``occupied``, float-ups and pull-downs
    outside (module docstring; their draws seeded with ``seed + 1``)."""
    out = excitation_setpoints_degc("prbs", occupied.size, zones, seed)
    assert out is not None
    rng = np.random.default_rng(seed + 1)
    low = EXCITATION_CENTER_DEGC - EXCITATION_AMPLITUDE_K
    for i in range(zones):
        k, floating = 0, bool(rng.integers(2))
        while k < occupied.size:
            bounds = RANGE_FLOAT_PERIODS if floating else RANGE_PULL_DOWN_PERIODS
            segment = slice(k, k + int(rng.integers(bounds[0], bounds[1] + 1)))
            free = ~occupied[segment]
            if floating:
                out[segment, i] = np.where(free, RANGE_FLOAT_DEGC, out[segment, i])
            elif free.any():
                first = k + int(np.argmax(free))  # the pull-down starts at the lower level
                out[first : min(first + PRBS_HOLD_PERIODS[0], segment.stop), i] = low
            k = segment.stop
            floating = not floating
    return out


@dataclass(frozen=True)
class _Layout:
    """Where each reading sits in the plant's extra variables."""

    controlled: tuple[str, ...]
    boundary: tuple[str, ...]
    boundary_start: int
    solar_start: int
    people_start: int
    people_count: int
    variables: tuple[Variable, ...]


def _people_zones(objects: tuple[IdfObject, ...], zones: tuple[str, ...]) -> tuple[str, ...]:
    """The zones (of ``zones``) that a ``People`` object names, directly or by ZoneList."""
    lists = {
        o.field(0).lower(): [f.lower() for f in o.fields[1:]]
        for o in objects_of(objects, "ZoneList")
    }
    named: set[str] = set()
    for people in objects_of(objects, "People"):
        target = people.field(1).lower()
        named |= set(lists.get(target, [target]))
    return tuple(z for z in zones if z.lower() in named)


def _layout(objects: tuple[IdfObject, ...], controlled: tuple[str, ...]) -> _Layout:
    variables: list[Variable] = []
    wanted = {z.lower() for z in controlled}
    boundary = tuple(z for z in idf_zone_names(objects) if z.lower() not in wanted)
    boundary_start = len(variables)
    variables += [Variable("Zone Mean Air Temperature", z) for z in boundary]
    solar_start = len(variables)
    variables += [
        Variable("Site Direct Solar Radiation Rate per Area", "Environment"),
        Variable("Site Diffuse Solar Radiation Rate per Area", "Environment"),
        Variable("Site Solar Altitude Angle", "Environment"),
        Variable("Site Outdoor Air Humidity Ratio", "Environment"),
    ]
    people = _people_zones(objects, controlled)
    people_start = len(variables)
    variables += [Variable("Zone People Occupant Count", z) for z in people]
    return _Layout(
        controlled=controlled,
        boundary=boundary,
        boundary_start=boundary_start,
        solar_start=solar_start,
        people_start=people_start,
        people_count=len(people),
        variables=tuple(variables),
    )


def _trend_row(plant_obs: object, extra: FloatArray, layout: _Layout) -> dict[str, float]:
    from hvacflex.sim.plant import Observation

    assert isinstance(plant_obs, Observation)
    row: dict[str, float] = {}
    assert plant_obs.zone_mean_temp_degc is not None and plant_obs.supply_temp_degc is not None
    for i, zone in enumerate(layout.controlled):
        row[zone_column("temp", zone)] = float(plant_obs.zone_mean_temp_degc[i])
        row[zone_column("supply_flow", zone)] = float(plant_obs.supply_flow_kg_s[i])
        row[zone_column("supply_temp", zone)] = float(plant_obs.supply_temp_degc[i])
    for j, zone in enumerate(layout.boundary):
        row[zone_column("temp", zone)] = float(extra[layout.boundary_start + j])
    dni, dhi, altitude_deg, humidity = extra[layout.solar_start : layout.solar_start + 4]
    row[trend.OUTDOOR_TEMP] = float(plant_obs.outdoor_temp_degc)
    row[trend.DNI] = max(float(dni), 0.0)
    row[trend.DHI] = max(float(dhi), 0.0)
    row[trend.GHI] = max(float(dhi + dni * np.sin(np.radians(max(altitude_deg, 0.0)))), 0.0)
    row[trend.OUTDOOR_HUMIDITY] = max(float(humidity), 0.0)
    people = extra[layout.people_start : layout.people_start + layout.people_count]
    row[trend.OCCUPIED] = float(people.sum() > 0.0)
    row[trend.HVAC_POWER] = float(plant_obs.power_kw)
    row[trend.FACILITY_POWER] = float(np.nan_to_num(plant_obs.facility_power_kw, nan=0.0))
    return row


def collect_trend(
    idf_path: str | Path,
    *,
    start: str,
    days: int,
    epw_path: str | Path,
    excitation: str = DEFAULT_EXCITATION,
    zones: tuple[str, ...] | None = None,
    seed: int = 0,
    timesteps_per_hour: int = 6,
    on_day: Callable[[], None] | None = None,
) -> pd.DataFrame:
    """Run the IDF under its own control plus the excitation and return the trend frame;
    ``on_day`` is called as each day of the run is collected (progress).

    Parameters
    ----------
    idf_path : the EnergyPlus 25.2 model.
    start : first day, ``YYYY-MM-DD`` (local time, :data:`TIMEZONE`).
    days : number of days.
    epw_path : the weather EnergyPlus reads.
    excitation : ``range`` (default), ``prbs``, ``steps`` or ``none`` (module docstring).
    zones : the IDF zones to excite and record with supply air (any case); None: every zone
        with a thermostat. The IDF's other zones are recorded as temperatures only.
    seed : the PRBS's seed.

    Returns
    -------
    (days · 48, columns) the trend frame of :mod:`hvacflex.identify.trend` (period starts).
    """
    idf_file = resolve_idf(idf_path, "--idf")
    source = str(idf_file)
    try:
        first = pd.Timestamp(start)
    except ValueError:
        raise InputError(
            "not a date", field="--start", value=start, hint="write YYYY-MM-DD"
        ) from None
    if days < 1:
        raise InputError("needs at least one day", field="--days", value=days)
    text = read_idf(idf_file)
    objects = parse_idf(text, source)
    if any(o.class_name.lower().startswith("hvactemplate:") for o in objects):
        objects = parse_idf(expand_hvac_templates(text, source), source)
    available = idf_zone_names(objects)
    if zones is None:
        controlled = tuple(z for z in available if has_thermostat(objects, z))
    else:
        controlled = match_zones(zones, available, source, "--zones")
    if not controlled:
        raise InputError(
            "no zone to collect", source=source, field="--zones", hint="name the IDF's zones"
        )
    layout = _layout(objects, controlled)
    if layout.people_count == 0:
        warnings.warn(
            f"{source}: no People object in the collected zones; occupied is 0 throughout",
            stacklevel=2,
        )
    steps = days * PERIODS_PER_DAY
    begin = first.tz_localize(TIMEZONE) if first.tzinfo is None else first
    occupied = occupied_mask(pd.date_range(begin, periods=steps, freq=PERIOD_FREQ))
    setpoints = excitation_setpoints_degc(excitation, steps, len(controlled), seed, occupied)
    plant = EnergyPlusPlant(
        text,
        source,
        tuple(z.lower() for z in controlled),
        idf_zone_names=controlled,
        start=first.tz_localize(TIMEZONE) if first.tzinfo is None else first,
        steps=steps,
        epw_path=epw_path,
        actuation="setpoint",
        timesteps_per_hour=timesteps_per_hour,
        extra_variables=layout.variables,
    )
    rows = []
    index = pd.date_range(plant.start, periods=steps, freq=PERIOD_FREQ)
    no_disturbance = Disturbance(  # EnergyPlus reads its own weather
        d=np.zeros(0), outdoor_temp_degc=np.nan, outdoor_humidity_ratio_kg_per_kg=np.nan
    )
    try:
        plant.reset(float("nan"))
        for k in range(steps):
            sent = np.full(len(controlled), np.nan) if setpoints is None else setpoints[k]
            observation = plant.step(Actuation(setpoint_degc=sent), no_disturbance, PERIOD_S)
            row = _trend_row(observation, plant.extra_mean, layout)
            if setpoints is not None:
                for i, zone in enumerate(controlled):
                    row[zone_column("setpoint", zone)] = float(setpoints[k, i])
            rows.append(row)
            if on_day is not None and (k + 1) % PERIODS_PER_DAY == 0:
                on_day()
    finally:
        plant.close()
    return pd.DataFrame(rows, index=index)
