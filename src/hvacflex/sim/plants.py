"""The plant a scenario's ``[plant]`` table asks for: :func:`make_plant`.

``kind = "rc"`` → :class:`~hvacflex.sim.plant.RCPlant` (hvacflex's RC network, flow
actuation); ``kind = "energyplus"`` → :class:`~hvacflex.sim.energyplus_plant.EnergyPlusPlant`
on ``idf`` (a path, or ``"generated"``: the building's own IDF export with ``hvac="vav"``,
:func:`hvacflex.energyplus.export.export_idf`). hvacflex zones map to IDF zones by their
``energyplus_zone`` (default: the zone name), case-insensitively.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import pandas as pd

from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant
from hvacflex.config.model import PlantConfig
from hvacflex.data.forecast import DEFAULT_WEATHER_FILE
from hvacflex.errors import ConfigError
from hvacflex.paths import data_dir, resolve_idf
from hvacflex.sim.plant import Plant, RCPlant
from hvacflex.sim.setup import Setup

EXPORT_MODULE = "hvacflex.energyplus.export"
"""Where ``export_idf(building, *, hvac="vav", epw_path=None) -> str`` lives."""


def generated_idf(building: Building, epw_path: Path) -> str:
    """The building's own EnergyPlus model (``export_idf(building, hvac="vav")``).

    Raises
    ------
    ConfigError
        when this hvacflex has no IDF export (``hvacflex.energyplus.export``).
    """
    try:
        export = importlib.import_module(EXPORT_MODULE)
    except ModuleNotFoundError as error:
        if error.name != EXPORT_MODULE:
            raise
        raise ConfigError(
            "this hvacflex cannot generate an IDF (it has no hvacflex.energyplus.export)",
            field="plant.idf",
            value="generated",
            hint="give the path of an EnergyPlus 25.2 IDF in [plant] idf, e.g. the shipped "
            "resources/energyplus/5ZoneAirCooled.idf",
        ) from None
    text: str = export.export_idf(building, hvac="vav", epw_path=epw_path)
    return text


def make_plant(
    config: PlantConfig,
    building: Building,
    *,
    start: pd.Timestamp,
    steps: int,
    weather_file: str | Path | None = None,
    nonlinear_plant: NonlinearPlant | None = None,
    work_dir: Path | None = None,
    peak_guard_required: bool = False,
) -> Plant:
    """The plant of a scenario.

    Parameters
    ----------
    config : the scenario's ``[plant]`` table.
    building : the building (its zones name the plant's (m,) arrays).
    start : the first period's start (local, tz-aware or naive).
    steps : number of 30-min periods the run needs.
    weather_file : the EPW EnergyPlus reads (None: the shipped Singapore TMYx).
    nonlinear_plant : the RC plant's nonlinear model, if already built.
    work_dir : folder for EnergyPlus's files (None: a temporary folder).
    peak_guard_required : ``[controller] peak_guard = "on"``: an EnergyPlus IDF without an
        HVAC meter is refused when the plant starts (before the first period).

    Raises
    ------
    ConfigError
        for setpoint actuation on the RC plant, ``idf = "generated"`` without the export.
    InputError
        for a missing ``energyplus`` extra, a bad IDF, an unknown zone, a short weather file.
    """
    actuation = config.resolved_actuation
    if config.kind == "rc":
        if actuation != "flow":
            raise ConfigError(
                "the RC plant is flow-actuated",
                field="plant.actuation",
                value=actuation,
                hint="use actuation = 'flow' or kind = 'energyplus'",
            )
        return RCPlant(building, nonlinear_plant)
    from hvacflex.energyplus.api import engine_dir  # not imported by an RC run's start
    from hvacflex.energyplus.idf import read_idf
    from hvacflex.sim.energyplus_plant import EnergyPlusPlant

    engine_dir()  # a missing extra is the first thing to say
    epw = (
        Path(weather_file)
        if weather_file is not None
        else (data_dir() / "weather" / DEFAULT_WEATHER_FILE)
    )
    if config.idf == "generated":
        text, source = generated_idf(building, epw), f"generated IDF of {building.name}"
    else:
        idf_file = resolve_idf(config.idf)
        text, source = read_idf(idf_file), str(idf_file)
    zones = tuple(building.zone_names)
    idf_zones = tuple(z.energyplus_zone or z.name for z in building.zones)
    identified = building.identified
    boundaries = tuple(b.name for b in identified.boundaries) if identified is not None else ()
    return EnergyPlusPlant(
        text,
        source,
        zones,
        idf_zone_names=idf_zones,
        start=start,
        steps=steps,
        epw_path=epw,
        actuation=actuation,
        timesteps_per_hour=config.timesteps_per_hour,
        supply_temp_degc=building.hvac.supply_temp_degc,
        work_dir=work_dir,
        boundary_zone_names=boundaries,
        peak_guard_required=peak_guard_required,
    )


def scenario_plant(setup: Setup) -> Plant:
    """The plant of a prepared run: :func:`make_plant` of its ``[plant]`` table, over the
    run's periods and weather (sharing the RC model's step-matrix cache)."""
    config = setup.config
    return make_plant(
        config.plant,
        setup.building,
        start=config.start_timestamp,
        steps=config.steps,
        weather_file=config.data.weather_file,
        nonlinear_plant=setup.plant,
        peak_guard_required=config.controller.peak_guard == "on",
    )


def plant_summary(config: PlantConfig) -> dict[str, str]:
    """The summary keys that say what the run was graded on: ``plant`` (``"rc"`` or
    ``"energyplus"``), ``plant_idf`` (the IDF, ``""`` on the RC plant),
    ``plant_actuation`` and ``plant_curtailed_setpoint``."""
    return {
        "plant": config.kind,
        "plant_idf": config.idf if config.kind == "energyplus" else "",
        "plant_actuation": config.resolved_actuation,
        "plant_curtailed_setpoint": config.curtailed_setpoint,
    }
