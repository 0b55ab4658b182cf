"""A hvacflex building as an EnergyPlus 25.2 model (IDF text).

:func:`export_idf` writes the building description of :mod:`hvacflex.building.model` as an
EnergyPlus input file, so that EnergyPlus — a model hvacflex's own equations never see — can
simulate the same building under the same weather and gains.

What is mapped, and how
-----------------------
* **Zones**: one ``Zone`` per hvacflex zone, same name (hvacflex names are lower-case; EnergyPlus
  matches names case-insensitively), with the floor area, the ceiling height and the volume
  ``A · h`` given explicitly (so they do not depend on the placeholder geometry below);
  ``capacitance_multiplier`` becomes ``ZoneCapacitanceMultiplier:ResearchSpecial``.
* **Walls**: one ``BuildingSurface:Detailed`` per hvacflex wall, same name, area, azimuth and
  tilt (type ``Wall`` for tilts 60–120°, ``Roof``/``Ceiling`` below, ``Floor`` above). The far
  side: ``outside`` → ``Outdoors`` (sun and wind exposed), ``ground`` → ``Ground`` (with the
  EPW's monthly ground temperatures at the shallowest depth, as hvacflex uses them),
  ``adiabatic`` → ``Adiabatic``, another zone → ``Surface``: hvacflex's one partition becomes
  a pair, the wall in its zone and a mirror ``<wall> reverse`` in the adjacent zone with the
  layers reversed (so each face sees its own zone).
* **Windows**: ``FenestrationSurface:Detailed`` with ``WindowMaterial:SimpleGlazingSystem``
  (U-value incl. films, SHGC: ``shgc_normal`` where given, since EnergyPlus applies its own
  angular dependence, else the constant ``shgc``). A window sits in the exterior wall of its
  zone with the same azimuth and tilt; the wall's gross area is its opaque area plus its
  windows, so the opaque areas stay the building's. Several windows in one wall split it into
  one host surface per window (opaque area shared by window area).
* **Constructions**: the same layers, outside → inside (``Material``, or ``Material:NoMass``
  for a layer without heat capacity); a homogeneous R/C construction is its one 1-m layer,
  written with c = 1000 J/(kg K) and ρ = C / 1000 (the product ρ c d is what matters). The
  outer layer of an exterior wall carries the wall's solar absorptance and thermal emissivity
  (0.9 where the file gives none).
  A wall on an ``adiabatic`` plane is written mirrored about that plane (layers inside →
  outside → inside): EnergyPlus's ``Adiabatic`` boundary sets the far face's temperature to
  the inside face's rather than its heat flux to zero, so only a symmetric construction
  keeps hvacflex's half slab (:func:`hvacflex.energyplus.envelope.wall_variant`).
* **Internal gains**: ``People`` (people per m² = 1/``occupancy_m2_per_person``, activity =
  sensible + latent W per person, sensible fraction = sensible / total), ``Lights`` and
  ``ElectricEquipment`` (W/m²), all with the hvacflex office schedule
  (:data:`hvacflex.data.gains.DEFAULT_OFFICE_SCHEDULE`: entry h of a profile is the value
  ``Until: h+1:00``; weekdays use the working-day profile, weekends and holidays the off-day
  one), radiant fraction = the zone's ``internal_gain_radiative_fraction``. Singapore public
  holidays of :data:`EXPORT_YEAR` (``holidays`` package, as hvacflex) are
  ``RunPeriodControl:SpecialDays``; the run period ignores the weather file's holidays and
  daylight saving.
* **Infiltration**: ``ZoneInfiltration:DesignFlowRate`` at the zone's constant ACH.
* **HVAC** ``"vav"`` (default): ``HVACTemplate`` objects that EnergyPlus's ``ExpandObjects``
  turns into a VAV air loop (no reheat, no heating coil) with a chilled-water coil, a
  chilled-water loop and an air-cooled electric chiller. Sized like the ``HvacSystem``: supply
  air at ``supply_temp_degc``; per-zone maximum flow ``flow_max_kg_s``; per-zone minimum flow
  as a schedule (``<zone> minimum flow fraction``: ventilation flow / max while occupied,
  ``flow_min`` / max otherwise); outdoor air the ventilation need ``outdoor_air_kg_s`` as a
  fixed minimum = maximum, or else a fixed ``outdoor_air_fraction`` of the supply
  (proportional minimum = maximum outdoor air = f_oa · Σ max flow), no economiser, the
  damper open only from ``outdoor_air_purge_h`` before the occupied hours of working days to
  their end (the ``outdoor air damper`` schedule, the rule of the RC plant and the LP); the fan's
  design pressure so that its design power equals κ_f (Σ ṁ_max)^n at 70 % total efficiency;
  chiller COP = ``cop``, and where the building has a ``chiller`` model its capacity and its
  minimum part load (also as the minimum unloading ratio: it cycles, no false loading; the
  template writes the same DOE-2.1E curves as :mod:`hvacflex.building.chiller`), else
  autosized with EnergyPlus's defaults. The air handler is available in the occupied hours
  of working days and cycles on at night when a zone passes its set-point.
  ``"ideal"``: ``ZoneHVAC:IdealLoadsAirSystem`` per zone (through its template) supplying at
  ``supply_temp_degc`` and the supply humidity ratio of :mod:`hvacflex.building.hvac`, flow
  limited to ``flow_max_kg_s``, heating off, outdoor air f_oa × the ventilation flow.
  ``"none"``: no HVAC at all, the zones float freely (for validation).
  ``vav`` and ``ideal`` use one thermostat: cooling at :data:`THERMOSTAT_SETPOINT_DEGC` while
  occupied and 1 K inside the unoccupied upper bound otherwise (hvacflex's
  ``ThermostatController`` rule), heating set-point at the lowest comfort bound (no heating
  equipment exists).
* **Site**: ``Site:Location`` and the ground temperatures from the EPW (default: the shipped
  TMYx Singapore Changi file); a cooling and a heating ``SizingPeriod:DesignDay`` from the
  EPW header's ASHRAE design conditions (cooling 0.4 % dry bulb with its mean coincident wet
  bulb and daily range; heating 99.6 %), or from the hourly data where the header has none.
  A ``RunPeriod`` of the whole :data:`EXPORT_YEAR` (a co-simulation sets its own).

What is approximated
--------------------
* Geometry: hvacflex has areas and orientations, no coordinates. Each surface is a rectangle
  of the right area, azimuth and tilt (walls as tall as the zone), placed side by side, their
  lower edges at the building's ``height_above_ground_m`` (default 0);
  ``MinimalShadowing`` (no self-shading, as hvacflex) makes their positions irrelevant to the
  solar gains. Interior long-wave exchange then uses EnergyPlus's area-weighted view factors.
* Surface heat transfer: EnergyPlus's own convection algorithms (TARP inside, DOE-2 outside,
  the wind at the surfaces' centroids, ``height_above_ground_m`` plus half a wall: office5's
  18 m, a mid-rise floor), explicit long-wave radiation and
  wet façades in the weather file's rain replace hvacflex's constant combined film
  coefficients (``inside_film_w_per_m2k``, ``outside_film_w_per_m2k``) and its optional sky
  term; ``surfaces="hvacflex"`` writes those films instead (:data:`SURFACE_MODELS`).
* Solar: EnergyPlus distributes the transmitted solar over the zone's surfaces (beam on the
  floor); hvacflex puts it on the air node unless ``interior_solar_fraction`` says otherwise
  (neither that nor ``solar_lost_fraction`` is exported).
* HVAC: the fan's part-load curve is EnergyPlus's ``VariableSpeedMotorPressureReset`` (a
  cubic; hvacflex uses the same curve where ``fan_part_load_coefficients`` says so, else the
  power law (Σṁ)^n); the chiller has EnergyPlus's part-load and outdoor-temperature curves
  (hvacflex's ``chiller`` model uses the same ones; without it a constant ``cop``); EnergyPlus
  sizes its own chilled-water pump (office5: 1.78 kW, hvacflex 1.64 kW). Flows in m³/s are
  mass flows over ρ = 1.2 kg/m³.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import date
from pathlib import Path

import holidays
import numpy as np

from hvacflex.building.hvac import supply_humidity_ratio_kg_per_kg
from hvacflex.building.model import Building
from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
from hvacflex.data.gains import DEFAULT_OFFICE_SCHEDULE, ComfortBand, OfficeSchedule
from hvacflex.data.weather import EpwLocation, read_epw
from hvacflex.energyplus.envelope import (
    check_films,
    construction_objects,
    idf_object,
    surface_objects,
    zone_objects,
)
from hvacflex.errors import InputError
from hvacflex.paths import data_dir
from hvacflex.units import RHO_AIR_KG_PER_M3, W_PER_KW

ENERGYPLUS_VERSION = "25.2"
"""The EnergyPlus input syntax written (``Version`` object)."""

SURFACE_MODELS = ("energyplus", "hvacflex")
"""``--surfaces`` choices: how the exported surfaces exchange heat with the air and each other.
``"energyplus"`` (default): EnergyPlus's own convection algorithms (TARP inside, DOE-2
outside), explicit long-wave exchange inside and with the sky, and wet façades in the
weather file's rain — the independent model. ``"hvacflex"``: the building's own constant
combined films as convection coefficients, no long-wave exchange where hvacflex models none
(every face of an opaque layer at :data:`~hvacflex.energyplus.envelope.NO_LONGWAVE_ABSORPTANCE`
unless the wall gives ``thermal_emissivity``), rain and snow ignored — EnergyPlus solving
hvacflex's equations with its own conduction, solar and zone heat balance, the station's air
temperature at every height (:data:`STATION_AIR_HEIGHT_VARIATION`) (a verification of
the implementation, not of the film model; what stays EnergyPlus's: the windows' angular
solar and their long-wave to the sky, ε 0.84; a window's inside film is hvacflex's default,
7.69 W/m²K). Only for buildings with combined films and convective gains
(:func:`~hvacflex.energyplus.envelope.check_films`)."""

HVAC_KINDS = ("vav", "ideal", "none")
"""``--hvac`` choices: a VAV air loop with a chiller, ideal loads per zone, or no HVAC (the
zones float freely: the free-float validation case)."""

EXPORT_YEAR = 2014
"""Calendar year of the run period and the public holidays (the year of the market data)."""

MAX_WARMUP_DAYS = 50
"""EnergyPlus's limit on repeating the first day until the zones converge (its default 25
is too few for office5's free-floating core, whose half slabs hold 225 MJ/K)."""

TIMESTEPS_PER_HOUR = 6
"""Zone time steps per hour (10 min: three per 30-min control period)."""

THERMOSTAT_SETPOINT_DEGC = 24.0
"""Occupied cooling set-point [°C] (the default of hvacflex's ``ThermostatController``)."""

UNOCCUPIED_MARGIN_K = 1.0
"""Unoccupied cooling set-point this far below the unoccupied upper comfort bound [K]."""

FAN_TOTAL_EFFICIENCY = 0.7
"""Supply fan total (fan × motor) efficiency used to turn the design fan power into a design
pressure rise [-]."""

FAN_MOTOR_EFFICIENCY = 0.9
"""Supply fan motor efficiency [-] (the HVACTemplate default)."""

SEA_LEVEL_PRESSURE_PA = 101325.0
"""Standard atmosphere at sea level [Pa]."""


def check_choice(value: str, choices: Sequence[str], *, what: str, field: str) -> None:
    """Refuse ``value`` unless it is one of ``choices``: ``unknown <what>``, naming ``field``.

    Raises
    ------
    InputError
        with the choices as the hint.
    """
    if value not in choices:
        raise InputError(
            f"unknown {what}", field=field, value=value, hint=f"choose one of {', '.join(choices)}"
        )


def export_idf(
    building: Building,
    *,
    hvac: str = "vav",
    epw_path: Path | None = None,
    surfaces: str = "energyplus",
) -> str:
    """The EnergyPlus 25.2 model of ``building`` (see the module docstring for the mapping).

    Parameters
    ----------
    building : the validated building.
    hvac : ``"vav"`` (HVACTemplate VAV air loop with a chiller; run EnergyPlus with ``-x``),
        ``"ideal"`` (ideal loads per zone) or ``"none"`` (free-floating zones).
    epw_path : weather file for the site and design days (default: the shipped TMYx
        Singapore Changi EPW).
    surfaces : ``"energyplus"`` (EnergyPlus's own surface heat transfer and rain) or
        ``"hvacflex"`` (the building's constant films; :data:`SURFACE_MODELS`).

    Returns
    -------
    IDF text, one object per paragraph.

    Raises
    ------
    InputError
        an unknown ``hvac`` kind or ``surfaces`` model, or a window without an exterior wall
        of its zone facing the same way.
    DataError
        an unreadable or malformed weather file.
    """
    check_choice(hvac, HVAC_KINDS, what="HVAC kind", field="hvac")
    check_choice(surfaces, SURFACE_MODELS, what="surface model", field="surfaces")
    films = surfaces == "hvacflex"
    if films:
        check_films(building)
    weather = (
        Path(epw_path) if epw_path is not None else data_dir() / "weather" / DEFAULT_WEATHER_FILE
    )
    location = read_epw(weather)[1]
    parts = [
        f"! {building.name}: exported by hvacflex for EnergyPlus {ENERGYPLUS_VERSION}",
        f"! weather for site and design days: {weather.name}",
        *_simulation_objects(hvac, rain=not films),
        *_site_objects(weather, location),
        *_height_objects(films),
        *_schedule_objects(building, DEFAULT_OFFICE_SCHEDULE),
        *construction_objects(building, films=films),
        *zone_objects(building),
        *surface_objects(building, films=films),
        *_gain_objects(building),
        *_HVAC_WRITERS[hvac](building),
        *_output_objects(hvac),
    ]
    return "\n\n".join(parts) + "\n"


# ---- simulation, site, calendar -----------------------------------------------------------


def _simulation_objects(hvac: str, *, rain: bool = True) -> list[str]:
    wet = "Yes" if rain else "No"
    sizing = "Yes" if hvac == "vav" else "No"
    return [
        idf_object("Version", ENERGYPLUS_VERSION),
        idf_object("SimulationControl", sizing, sizing, sizing, "No", "Yes", "No", 1),
        # MinimalShadowing: no self-shading, as hvacflex (and the placeholder geometry)
        idf_object(
            "Building", "hvacflex", 0.0, "City", 0.04, 0.4, "MinimalShadowing", MAX_WARMUP_DAYS, 6
        ),
        idf_object("Timestep", TIMESTEPS_PER_HOUR),
        idf_object("GlobalGeometryRules", "UpperLeftCorner", "Counterclockwise", "Relative"),
        idf_object(
            "RunPeriod",
            f"year {EXPORT_YEAR}",
            1,
            1,
            EXPORT_YEAR,
            12,
            31,
            EXPORT_YEAR,
            date(EXPORT_YEAR, 1, 1).strftime("%A"),
            "No",
            "No",
            "No",
            wet,
            wet,
        ),
        *_special_days(DEFAULT_OFFICE_SCHEDULE, EXPORT_YEAR),
    ]


def _special_days(schedule: OfficeSchedule, year: int) -> list[str]:
    """Public holidays of ``year`` as EnergyPlus ``Holiday`` days (the off-day profile)."""
    calendar = holidays.country_holidays(schedule.country, years=[year])
    return [
        idf_object("RunPeriodControl:SpecialDays", f"{name} {day.isoformat()}",
                   f"{day.month}/{day.day}", 1, "Holiday")
        for day, name in sorted(calendar.items())
    ]  # fmt: skip


def _site_pressure_pa(elevation_m: float) -> float:
    """Standard-atmosphere pressure at ``elevation_m`` [Pa] (ASHRAE Fundamentals ch. 1)."""
    return float(SEA_LEVEL_PRESSURE_PA * (1.0 - 2.25577e-5 * elevation_m) ** 5.2559)


@dataclass(frozen=True)
class DesignConditions:
    """Design-day weather of a site.

    Attributes
    ----------
    cooling_month, heating_month : month (1–12) of the hottest / coldest design day.
    cooling_dry_bulb_degc : 0.4 % annual dry bulb [°C].
    cooling_wet_bulb_degc : mean coincident wet bulb [°C]; ``None`` when only the dew point
        is known (then ``cooling_dewpoint_degc``).
    cooling_dewpoint_degc : mean coincident dew point [°C] (data-derived conditions only).
    cooling_daily_range_k : mean daily dry-bulb range of the hottest month [K].
    heating_dry_bulb_degc : 99.6 % annual dry bulb [°C].
    source : ``"header"`` (the EPW's DESIGN CONDITIONS line) or ``"data"`` (hourly rows).
    """

    cooling_month: int
    cooling_dry_bulb_degc: float
    cooling_wet_bulb_degc: float | None
    cooling_dewpoint_degc: float | None
    cooling_daily_range_k: float
    heating_month: int
    heating_dry_bulb_degc: float
    source: str


def design_conditions(epw_path: Path) -> DesignConditions:
    """Design conditions of an EPW: its header's ASHRAE line, else percentiles of the data.

    Header (ASHRAE Handbook of Fundamentals, ch. 14 layout, as EnergyPlus's weather converter
    writes it): after ``Heating``: coldest month, 99.6 % dry bulb; after ``Cooling``: hottest
    month, daily range, 0.4 % dry bulb, its mean coincident wet bulb. Data: the 99.6th and
    0.4th percentiles of the hourly dry bulb, the mean dew point of the hours at or above the
    99th, the hottest month's mean daily range.
    """
    with Path(epw_path).open(encoding="utf-8", errors="replace") as handle:
        header = [next(handle, "") for _ in range(8)]
    line = next((h for h in header if h.startswith("DESIGN CONDITIONS")), "")
    fields = [f.strip() for f in line.split(",")]
    try:
        heat = fields.index("Heating")
        cool = fields.index("Cooling")
        return DesignConditions(
            cooling_month=int(fields[cool + 1]),
            cooling_daily_range_k=float(fields[cool + 2]),
            cooling_dry_bulb_degc=float(fields[cool + 3]),
            cooling_wet_bulb_degc=float(fields[cool + 4]),
            cooling_dewpoint_degc=None,
            heating_month=int(fields[heat + 1]),
            heating_dry_bulb_degc=float(fields[heat + 2]),
            source="header",
        )
    except (ValueError, IndexError):
        return _design_conditions_from_data(epw_path)


def _design_conditions_from_data(epw_path: Path) -> DesignConditions:
    hourly = read_epw(epw_path)[0]
    temp = hourly["outdoor_temp_degc"].to_numpy()
    hot = temp >= np.percentile(temp, 99.0)
    daily = hourly.groupby(["month", "day"])["outdoor_temp_degc"].agg(["max", "min", "mean"])
    monthly_mean = daily["mean"].groupby(level="month").mean()
    hottest = int(monthly_mean.to_numpy().argmax()) + 1
    coldest = int(monthly_mean.to_numpy().argmin()) + 1
    day_range = (daily["max"] - daily["min"]).xs(hottest, level="month").mean()
    return DesignConditions(
        cooling_month=hottest,
        cooling_dry_bulb_degc=float(np.percentile(temp, 99.6)),
        cooling_wet_bulb_degc=None,
        cooling_dewpoint_degc=float(hourly["dewpoint_degc"].to_numpy()[hot].mean()),
        cooling_daily_range_k=float(day_range),
        heating_month=coldest,
        heating_dry_bulb_degc=float(np.percentile(temp, 0.4)),
        source="data",
    )


STATION_AIR_HEIGHT_VARIATION = (0.22, 370.0, 0.0)
"""``Site:HeightVariation`` of ``surfaces="hvacflex"``: EnergyPlus's default wind profile
(exponent 0.22, boundary layer 370 m) and **no** air-temperature lapse (its default
0.0065 K/m), so every surface sees the weather station's air temperature at any height, as
hvacflex's films do."""


def _height_objects(films: bool) -> list[str]:
    """With hvacflex's films, :data:`STATION_AIR_HEIGHT_VARIATION`; else none (EnergyPlus's
    defaults: the air 0.0065 K/m cooler and the wind faster with the surfaces' height)."""
    return [idf_object("Site:HeightVariation", *STATION_AIR_HEIGHT_VARIATION)] if films else []


def _site_objects(epw_path: Path, location: EpwLocation) -> list[str]:
    pressure_pa = _site_pressure_pa(location.elevation_m)
    design = design_conditions(epw_path)
    humidity: tuple[str, float | None] = ("WetBulb", design.cooling_wet_bulb_degc)
    if design.cooling_wet_bulb_degc is None:
        humidity = ("DewPoint", design.cooling_dewpoint_degc)
    ground = location.ground_temp_monthly_degc or _monthly_mean_temp(epw_path)
    return [
        idf_object(
            "Site:Location", location.name, location.latitude_deg, location.longitude_deg,
            location.tz_offset_h, location.elevation_m,
        ),
        idf_object(
            "SizingPeriod:DesignDay", f"cooling {design.source} 0.4%", design.cooling_month,
            21, "SummerDesignDay", design.cooling_dry_bulb_degc, design.cooling_daily_range_k,
            "DefaultMultipliers", None, humidity[0], humidity[1], None, None, None, None,
            pressure_pa, 0.0, 0.0, "No", "No", "No", "ASHRAEClearSky", None, None, None, None,
            1.0,
        ),
        idf_object(
            "SizingPeriod:DesignDay", f"heating {design.source} 99.6%", design.heating_month,
            21, "WinterDesignDay", design.heating_dry_bulb_degc, 0.0, "DefaultMultipliers",
            None, "WetBulb", design.heating_dry_bulb_degc, None, None, None, None,
            pressure_pa, 0.0, 0.0, "No", "No", "No", "ASHRAEClearSky", None, None, None, None,
            0.0,
        ),
        idf_object("Site:GroundTemperature:BuildingSurface", *ground),
    ]  # fmt: skip


def _monthly_mean_temp(epw_path: Path) -> tuple[float, ...]:
    hourly = read_epw(epw_path)[0]
    means = hourly.groupby("month")["outdoor_temp_degc"].mean()
    return tuple(float(v) for v in means.to_numpy())


# ---- schedules ----------------------------------------------------------------------------

ALWAYS_ON = "always on"
ALWAYS_OFF = "always off"
OCCUPIED = "occupied"
ACTIVITY = "activity level"
COOLING_SETPOINT = "cooling setpoint"
HEATING_SETPOINT = "heating setpoint"
SUPPLY_AIR_TEMP = "supply air temperature"
OUTDOOR_AIR = "outdoor air damper"
WORKDAY_TYPES = "Weekdays SummerDesignDay"
"""Day types that take the working-day profile (design days size for a working day)."""


def _until(hourly: Sequence[float]) -> list[str]:
    """``Until: HH:00, value`` fields of a (24,) hour-starting profile, runs merged."""
    fields: list[str] = []
    for hour, value in enumerate(hourly):
        if hour + 1 < len(hourly) and hourly[hour + 1] == value:
            continue
        fields += [f"Until: {hour + 1:02d}:00", f"{float(value):.10g}"]
    return fields


def _compact(name: str, limits: str, workday: Sequence[float], offday: Sequence[float]) -> str:
    return idf_object(
        "Schedule:Compact", name, limits, "Through: 12/31",
        f"For: {WORKDAY_TYPES}", *_until(workday), "For: AllOtherDays", *_until(offday),
    )  # fmt: skip


def _occupied_profile(schedule: OfficeSchedule, inside: float, outside: float) -> list[float]:
    start, end = schedule.occupied_hours
    return [inside if start <= h < end else outside for h in range(24)]


def _schedule_objects(b: Building, schedule: OfficeSchedule) -> list[str]:
    band = ComfortBand()
    per_person_w = b.gains.sensible_w_per_person + b.gains.latent_w_per_person
    cooling_occupied = float(np.clip(THERMOSTAT_SETPOINT_DEGC, *band.occupied_degc))
    cooling_unoccupied = max(band.unoccupied_degc[1] - UNOCCUPIED_MARGIN_K, band.unoccupied_degc[0])
    heating = min(band.occupied_degc[0], band.unoccupied_degc[0])
    cooling_work = _occupied_profile(schedule, cooling_occupied, cooling_unoccupied)
    objects = [
        idf_object("ScheduleTypeLimits", "fraction", 0.0, 1.0, "Continuous"),
        idf_object("ScheduleTypeLimits", "on/off", 0, 1, "Discrete"),
        idf_object("ScheduleTypeLimits", "temperature", -60.0, 200.0, "Continuous"),
        idf_object("ScheduleTypeLimits", "activity level", 0.0, None, "Continuous"),
        idf_object("Schedule:Constant", ALWAYS_ON, "on/off", 1),
        idf_object("Schedule:Constant", ALWAYS_OFF, "on/off", 0),
        idf_object("Schedule:Constant", ACTIVITY, "activity level", max(per_person_w, 1.0)),
        idf_object("Schedule:Constant", HEATING_SETPOINT, "temperature", heating),
        idf_object("Schedule:Constant", SUPPLY_AIR_TEMP, "temperature", b.hvac.supply_temp_degc),
        _compact(OCCUPIED, "on/off", _occupied_profile(schedule, 1, 0), [0] * 24),
        _compact(COOLING_SETPOINT, "temperature", cooling_work, [cooling_unoccupied] * 24),
        _outdoor_air_schedule(schedule, b.hvac.outdoor_air_purge_h),
    ]
    for name in ("people", "lighting", "equipment"):
        objects.append(
            _compact(
                f"{name} fraction", "fraction",
                getattr(schedule, f"{name}_workday"), getattr(schedule, f"{name}_offday"),
            )
        )  # fmt: skip
    for i, zone in enumerate(b.zones):
        flow_max = b.hvac.flow_max_kg_s[i]
        occupied = b.hvac.ventilation_flow_kg_s[i] / flow_max
        unoccupied = b.hvac.flow_min_kg_s[i] / flow_max
        objects.append(
            _compact(
                _minimum_flow_schedule(zone.name), "fraction",
                _occupied_profile(schedule, occupied, unoccupied), [unoccupied] * 24,
            )
        )  # fmt: skip
    return objects


def _outdoor_air_schedule(schedule: OfficeSchedule, purge_h: float) -> str:
    """The damper's schedule (the template's minimum outdoor air schedule): 1 from
    ``purge_h`` before the occupied hours of working days to their end, 0 otherwise — the
    rule of the RC plant and the LP (``HvacSystem.outdoor_air_open_at``)."""
    start, end = schedule.occupied_hours
    open_min = max(round((start - purge_h) * 60.0), 0)
    fields: list[str] = []
    if open_min > 0:
        fields += [f"Until: {open_min // 60:02d}:{open_min % 60:02d}", "0"]
    fields += [f"Until: {end:02d}:00", "1"]
    if end < 24:
        fields += ["Until: 24:00", "0"]
    return idf_object(
        "Schedule:Compact", OUTDOOR_AIR, "fraction", "Through: 12/31",
        f"For: {WORKDAY_TYPES}", *fields, "For: AllOtherDays", "Until: 24:00", "0",
    )  # fmt: skip


def _minimum_flow_schedule(zone: str) -> str:
    return f"{zone} minimum flow fraction"


# ---- internal gains and infiltration ------------------------------------------------------


def _gain_objects(b: Building) -> list[str]:
    g = b.gains
    per_person_w = g.sensible_w_per_person + g.latent_w_per_person
    objects: list[str] = []
    for zone in b.zones:
        radiant = zone.internal_gain_radiative_fraction
        if per_person_w > 0:
            objects.append(
                idf_object(
                    "People", f"{zone.name} people", zone.name, "people fraction",
                    "People/Area", None, 1.0 / g.occupancy_m2_per_person, None, radiant,
                    g.sensible_w_per_person / per_person_w, ACTIVITY,
                )
            )  # fmt: skip
        if g.lighting_w_per_m2 > 0:
            objects.append(
                idf_object(
                    "Lights", f"{zone.name} lights", zone.name, "lighting fraction",
                    "Watts/Area", None, g.lighting_w_per_m2, None, 0.0, radiant, 0.0, 0.0,
                )
            )  # fmt: skip
        if g.equipment_w_per_m2 > 0:
            objects.append(
                idf_object(
                    "ElectricEquipment", f"{zone.name} equipment", zone.name,
                    "equipment fraction", "Watts/Area", None, g.equipment_w_per_m2, None,
                    0.0, radiant, 0.0,
                )
            )  # fmt: skip
        if zone.infiltration_ach > 0:
            objects.append(
                idf_object(
                    "ZoneInfiltration:DesignFlowRate", f"{zone.name} infiltration", zone.name,
                    ALWAYS_ON, "AirChanges/Hour", None, None, None, zone.infiltration_ach,
                    1.0, 0.0, 0.0, 0.0,
                )
            )  # fmt: skip
    return objects


# ---- HVAC ---------------------------------------------------------------------------------

THERMOSTAT = "hvacflex thermostat"


def _thermostat() -> str:
    return idf_object("HVACTemplate:Thermostat", THERMOSTAT, HEATING_SETPOINT, None,
                      COOLING_SETPOINT, None)  # fmt: skip


def design_fan_pressure_pa(b: Building) -> float:
    """Fan pressure rise [Pa] at which the design power is hvacflex's κ_f (Σ ṁ_max)^n.

    P = V̇ Δp / η  ⇒  Δp = η · κ_f (Σ ṁ_max)^n · 1000 / (Σ ṁ_max / ρ).
    """
    flow_kg_s = sum(b.hvac.flow_max_kg_s)
    power_w = b.hvac.fan_coeff_kw * flow_kg_s**b.hvac.fan_exponent * W_PER_KW
    return float(FAN_TOTAL_EFFICIENCY * power_w / (flow_kg_s / RHO_AIR_KG_PER_M3))


def _vav_objects(b: Building) -> list[str]:
    h = b.hvac
    system = f"{b.name} air handler"
    supply_max_m3_s = sum(h.flow_max_kg_s) / RHO_AIR_KG_PER_M3
    outdoor_m3_s = h.outdoor_air_fraction * supply_max_m3_s
    outdoor_control = "ProportionalMinimum"
    if h.outdoor_air_kg_s is not None:  # the ventilation need, whatever the supply flow
        outdoor_m3_s, outdoor_control = h.outdoor_air_kg_s / RHO_AIR_KG_PER_M3, "FixedMinimum"
    objects = [
        _thermostat(),
        idf_object(
            "HVACTemplate:System:VAV", system, OCCUPIED, supply_max_m3_s,
            sum(h.flow_min_kg_s) / RHO_AIR_KG_PER_M3, FAN_TOTAL_EFFICIENCY,
            design_fan_pressure_pa(b), FAN_MOTOR_EFFICIENCY, 1.0,
            "ChilledWater", ALWAYS_ON, SUPPLY_AIR_TEMP, h.supply_temp_degc,
            "None", None, None, None, None, None,  # heating coil
            "None", None, None, None, None, None,  # preheat coil
            outdoor_m3_s, outdoor_m3_s, outdoor_control, OUTDOOR_AIR,
            "NoEconomizer", "NoLockout", None, None, None, None,
            None, None, "DrawThrough", "VariableSpeedMotorPressureReset", "CycleOnAny", None,
            "None", None, None, "None", "None", "None", None, None, "None",
        ),
        idf_object("HVACTemplate:Plant:ChilledWaterLoop", "chilled water loop", None,
                   "Intermittent", "Default", None, None, None, "VariablePrimaryNoSecondary"),
        _chiller_object(b),
    ]  # fmt: skip
    for i, zone in enumerate(b.zones):
        objects.append(
            idf_object(
                "HVACTemplate:Zone:VAV", zone.name, system, THERMOSTAT,
                h.flow_max_kg_s[i] / RHO_AIR_KG_PER_M3, None, None, "Scheduled",
                h.ventilation_flow_kg_s[i] / h.flow_max_kg_s[i], None,
                _minimum_flow_schedule(zone.name), "Flow/Zone", 0.0, 0.0,
                _zone_outdoor_air_m3_s(b, i), "None",
            )
        )  # fmt: skip
    return objects


def _zone_outdoor_air_m3_s(b: Building, i: int) -> float:
    """Zone i's share of the outdoor air [m³/s] (sizing): by floor area of the ventilation
    need, or f_oa × its ventilation flow."""
    h = b.hvac
    if h.outdoor_air_kg_s is not None:
        share = b.zones[i].floor_area_m2 / sum(z.floor_area_m2 for z in b.zones)
        return h.outdoor_air_kg_s * share / RHO_AIR_KG_PER_M3
    return h.outdoor_air_fraction * h.ventilation_flow_kg_s[i] / RHO_AIR_KG_PER_M3


def _chiller_object(b: Building) -> str:
    """The template's air-cooled chiller: hvacflex's capacity, reference COP and minimum part
    load (below it the chiller cycles, ``Minimum Unloading Ratio`` = ``Minimum Part Load
    Ratio``: no false loading) where the building has a chiller model; else autosized with
    EnergyPlus's defaults (false loading below 25 %)."""
    h = b.hvac
    if h.chiller is None:
        return idf_object("HVACTemplate:Plant:Chiller", "chiller", "ElectricReciprocatingChiller",
                          "autosize", h.cop, "AirCooled", 1)  # fmt: skip
    c = h.chiller
    return idf_object(
        "HVACTemplate:Plant:Chiller", "chiller", "ElectricReciprocatingChiller",
        c.capacity_kw * W_PER_KW, c.reference_cop, "AirCooled", 1, 1.0,
        c.min_part_load_ratio, 1.0, 1.0, c.min_part_load_ratio,
    )  # fmt: skip


def _ideal_objects(b: Building) -> list[str]:
    h = b.hvac
    supply_w_kg_per_kg = supply_humidity_ratio_kg_per_kg(h)
    objects = [_thermostat()]
    for i, zone in enumerate(b.zones):
        objects.append(
            idf_object(
                "HVACTemplate:Zone:IdealLoadsAirSystem", zone.name, THERMOSTAT, ALWAYS_ON,
                50.0, h.supply_temp_degc, 0.0156, supply_w_kg_per_kg,
                "NoLimit", None, None,
                "LimitFlowRate", h.flow_max_kg_s[i] / RHO_AIR_KG_PER_M3, None,
                ALWAYS_OFF, ALWAYS_ON, "ConstantSupplyHumidityRatio", None, None, "None", None,
                "Flow/Zone", 0.0, 0.0,
                h.outdoor_air_fraction * h.ventilation_flow_kg_s[i] / RHO_AIR_KG_PER_M3,
            )
        )  # fmt: skip
    return objects


def _no_hvac_objects(b: Building) -> list[str]:
    """Free-floating zones: no HVAC objects at all."""
    return []


_HVAC_WRITERS: dict[str, Callable[[Building], list[str]]] = {
    "vav": _vav_objects,
    "ideal": _ideal_objects,
    "none": _no_hvac_objects,
}


# ---- outputs ------------------------------------------------------------------------------

OUTPUT_VARIABLES = (
    "Zone Mean Air Temperature",
    "Zone Air System Sensible Cooling Rate",
    "Site Outdoor Air Drybulb Temperature",
)
"""Hourly report variables (all keys)."""

HVAC_OUTPUT_VARIABLES = {
    "vav": ("Cooling Coil Total Cooling Rate", "Cooling Coil Sensible Cooling Rate"),
    "ideal": ("Zone Ideal Loads Supply Air Total Cooling Rate",),
    "none": (),
}
"""Hourly report variables of the cooling equipment: coil total (sensible + latent,
outdoor air included) and sensible heat removed [W]."""

OUTPUT_METERS = ("Electricity:HVAC", "Electricity:Plant", "ElectricityPurchased:Facility")
"""Hourly meters: fans + cooling plant, and the whole site."""


def _output_objects(hvac: str) -> list[str]:
    meters = OUTPUT_METERS if hvac == "vav" else OUTPUT_METERS[-1:]  # ideal loads draw none
    return [
        idf_object("Output:VariableDictionary", "IDF"),
        *(
            idf_object("Output:Variable", "*", v, "Hourly")
            for v in (*OUTPUT_VARIABLES, *HVAC_OUTPUT_VARIABLES[hvac])
        ),
        *(idf_object("Output:Meter", m, "Hourly") for m in meters),
        idf_object("OutputControl:Table:Style", "Comma"),
        idf_object("Output:Table:SummaryReports", "AllSummary"),
    ]
