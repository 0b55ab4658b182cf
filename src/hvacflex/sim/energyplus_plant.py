"""EnergyPlus as a :class:`~hvacflex.sim.plant.Plant`: an emulator hvacflex's model never saw.

One EnergyPlus 25.2 run (:class:`hvacflex.energyplus.runner.CoSimulation`) is advanced one
30-min period per :meth:`EnergyPlusPlant.step`. The IDF gets the run's dates, year and
time step, and Singapore's site (:func:`hvacflex.energyplus.idf.prepare_idf`); EnergyPlus
reads its own weather from the EPW, so the step's :class:`~hvacflex.sim.plant.Disturbance`
is not used (the internal gains are the IDF's schedules).

Actuation (docs/guide/energyplus.md):

* ``"setpoint"`` (supervisory, as MPCs are deployed on a BMS): each zone's cooling setpoint
  is the actuated value ("Zone Temperature Control" / "Cooling Setpoint"); its heating
  setpoint and the air loop's availability schedules (availability managers, fans, coils,
  terminals) follow :class:`~hvacflex.sim.zone_step_rules.SetpointRule` at every zone time
  step: the loop forced on while a zone is warmer than its setpoint (or, rising, about to
  pass its comfort limit), so pre-cooling works outside the IDF's hours; otherwise the IDF's
  schedules decide.
  An all-NaN setpoint actuation releases every zone to the IDF's own schedules for the
  period (the building's own control, e.g. ``hvacflex identify collect --excitation none``).
* ``"flow"``: each zone's ``ZoneHVAC:IdealLoadsAirSystem`` supply mass flow and supply
  temperature (the actuation's, else the plant's ``supply_temp_degc``); an IDF without ideal
  loads is refused.

Observations per period: zone mean air temperature at the end and mean over the period,
supply mass flow (the zone inlet nodes, period mean, summed) and supply air temperature (the
inlet node temperatures' period means, flow-weighted; their plain mean when no air flows),
outdoor dry bulb (mean),
``power_kw`` = (Electricity:HVAC + Electricity:Plant) period mean [kW] (a meter EnergyPlus
does not have, because nothing is on it, counts 0) and ``facility_power_kw`` =
ElectricityPurchased:Facility period mean [kW] (NaN when absent), and the air temperature at
the end of the period of each ``boundary_zone_names`` zone (an identified model's plenum).

An IDF with ``HVACTemplate:*`` objects is expanded by EnergyPlus's ExpandObjects when the plant
is built, so that its zones' equipment and thermostats can be found.

The in-period **peak guard** (an :class:`~hvacflex.sim.plant.PeakGuard` the actuation
carries; docs/explanation/model.md, the committed peak) reads the HVAC meters (``power_kw``'s) at
EnergyPlus's zone time step, through the API callback: at the start of each zone time step,
the mean power P of the step before [kW]. It holds a shed level s ∈ [0, 1], integral action
on the meter (:func:`~hvacflex.sim.zone_step_rules.next_shed_level`: deeper while the meter
exceeds the cap, released more slowly below it); s carries over to the next period while a
guard is in force, 0 without one. It sheds, within the comfort band, the zones whose air is below
their upper bound (the band at the period's end, the tighter of this period's and the next's, as the
plan's): under setpoint actuation the cooling setpoint moves the share s of the way from the
actuated one up to that bound, T' = T_sp + s (T_upper − T_sp) (the air loop then cools less); under
flow actuation the flow moves towards its floor, u' = u_floor + (1 − s)(u − u_floor), as on the RC
plant. A period in which some zone was shed has ``peak_guard_active``.

EnergyPlus cannot be copied mid-run (``can_snapshot = False``); :meth:`set_state` replays the
recorded actuations (with their peak guards and comfort limits) of :meth:`get_state` from a fresh
run, which reproduces the same readings (the engine is deterministic).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from hvacflex.constants import PERIOD_S
from hvacflex.energyplus.hvac import (
    availability_schedules,
    has_thermostat,
    heating_setpoint_schedule,
    ideal_loads_name,
    zone_inlet_nodes,
)
from hvacflex.energyplus.idf import (
    IdfObject,
    check_weather_covers,
    match_zones,
    parse_idf,
    prepare_idf,
    read_idf,
)
from hvacflex.energyplus.runner import (
    Actuator,
    CoSimSpec,
    CoSimulation,
    PeriodReading,
    Variable,
    expand_hvac_templates,
)
from hvacflex.errors import InputError
from hvacflex.sim.plant import Actuation, Disturbance, FloatArray, Observation, PeakGuard
from hvacflex.sim.zone_step_rules import SetpointRule, next_shed_level, shed_toward_band

PlantActuation = Literal["setpoint", "flow"]

HVAC_METERS = ("Electricity:HVAC", "Electricity:Plant")
"""Meters whose sum is the plant's ``power_kw`` (fans, pumps, chiller)."""
FACILITY_METER = "ElectricityPurchased:Facility"
"""The whole-facility meter (``Electricity:Facility`` has no API handle in 25.2)."""
FLOW_EPSILON_KG_S = 1e-6
"""Below this total inlet flow a zone's supply temperature is the plain mean of its inlets."""


class EnergyPlusPlant:
    """An EnergyPlus model driven period by period (see the module docstring).

    Parameters
    ----------
    idf_text : the model, EnergyPlus 25.2 IDF text.
    source : where it came from (named in errors; a path or "generated …").
    zone_names : (m,) the hvacflex zone names, the order of every (m,) array.
    idf_zone_names : (m,) the IDF zone for each (case-insensitive); None: ``zone_names``.
    start : the first period's start (local time, on the 30-min grid).
    steps : number of 30-min periods the run must offer.
    epw_path : the weather file EnergyPlus reads.
    actuation : ``"setpoint"`` or ``"flow"``.
    timesteps_per_hour : EnergyPlus zone time steps per hour (even).
    singapore_site : give the IDF Singapore's location, design days and ground temperature.
    supply_temp_degc : flow mode: the ideal loads' supply temperature [°C] when the
        actuation gives none (``make_plant``: the building's ``hvac.supply_temp_degc``);
        required in flow mode, unused in setpoint mode.
    work_dir : folder for EnergyPlus's files (None: a temporary folder per run).
    boundary_zone_names : (nb,) unconditioned IDF zones (case-insensitive) whose air
        temperatures each :class:`~hvacflex.sim.plant.Observation` carries as
        ``boundary_temp_degc`` (an identified model's boundary nodes: a BMS measures them).
    extra_variables : (ne,) further output variables read every period; their period means
        are :attr:`extra_mean` after each :meth:`reset` / :meth:`step` (the trend collection
        of ``hvacflex identify collect`` reads supply temperatures, solar and occupancy so).
    peak_guard_required : the run needs the peak guard (``[controller] peak_guard = "on"``):
        :meth:`reset` refuses an IDF without any of the :data:`HVAC_METERS` the guard reads.

    Raises
    ------
    InputError
        for a malformed IDF or one of another version, a zone the IDF lacks (naming it and the
        IDF's zones), flow actuation without an actuatable flow, a weather file that does not
        cover the run, or (on :meth:`reset`) a missing ``energyplus`` extra or, under
        ``peak_guard_required``, an IDF without an HVAC meter.
    """

    can_snapshot = False
    reads_meter_in_period = True
    """The HVAC meters are read at every zone time step: the peak guard runs here."""

    def __init__(
        self,
        idf_text: str,
        source: str | Path,
        zone_names: tuple[str, ...],
        *,
        start: pd.Timestamp,
        steps: int,
        epw_path: str | Path,
        idf_zone_names: tuple[str, ...] | None = None,
        actuation: PlantActuation = "setpoint",
        timesteps_per_hour: int = 6,
        singapore_site: bool = True,
        supply_temp_degc: float | None = None,
        work_dir: Path | None = None,
        boundary_zone_names: tuple[str, ...] = (),
        extra_variables: tuple[Variable, ...] = (),
        peak_guard_required: bool = False,
    ) -> None:
        if actuation not in ("setpoint", "flow"):
            raise InputError(
                "unknown plant actuation",
                field="plant.actuation",
                value=actuation,
                hint="use 'setpoint' or 'flow'",
            )
        if actuation == "flow" and supply_temp_degc is None:
            raise InputError(
                "flow actuation needs the supply air temperature",
                field="supply_temp_degc",
                hint="give the building's design supply temperature (hvac.supply_temp_degc)",
            )
        self.supply_temp_degc = supply_temp_degc
        self.peak_guard_required = peak_guard_required
        self.zone_names = tuple(zone_names)
        self.actuations: tuple[str, ...] = (actuation,)
        self.actuation = actuation
        self.source = str(source)
        self.start = pd.Timestamp(start)
        self.steps = int(steps)
        self.work_dir = work_dir
        naive = self.start.tz_localize(None) if self.start.tzinfo else self.start
        first_day = naive.normalize()
        last_day = (naive + pd.Timedelta(seconds=PERIOD_S) * max(self.steps - 1, 0)).normalize()
        prepared = prepare_idf(
            idf_text,
            source,
            start_date=first_day,
            end_date=last_day,
            timesteps_per_hour=timesteps_per_hour,
            singapore_site=singapore_site,
        )
        wanted = tuple(idf_zone_names) if idf_zone_names is not None else self.zone_names
        self.idf_zone_names = match_zones(
            wanted, prepared.zone_names, source, "zones.energyplus_zone"
        )
        doubled = sorted({z for z in self.idf_zone_names if self.idf_zone_names.count(z) > 1})
        if doubled:
            raise InputError(
                "two hvacflex zones name the same IDF zone",
                source=source,
                field="zones.energyplus_zone",
                value=doubled[0],
                hint="map each hvacflex zone to its own IDF zone",
            )
        self.boundary_zone_names = match_zones(
            tuple(boundary_zone_names),
            prepared.zone_names,
            source,
            "identified.boundaries",
            "the model's [[identified.boundaries]] names (fit on data of this IDF)",
        )
        self.epw_path = Path(epw_path)
        check_weather_covers(self.epw_path, first_day, last_day)
        self._skip_periods = int((naive - first_day) / pd.Timedelta(seconds=PERIOD_S))
        text, objects = prepared.text, prepared.objects
        if any(o.class_name.lower().startswith("hvactemplate:") for o in objects):
            text = expand_hvac_templates(text, self.source)
            objects = parse_idf(text, source)
        self._extra_variables = tuple(extra_variables)
        self._spec = self._co_sim_spec(text, objects, timesteps_per_hour)
        self.extra_mean: FloatArray = np.full(len(self._extra_variables), np.nan)
        """(ne,) period means of ``extra_variables`` in the last period read."""
        self._sim: CoSimulation | None = None
        self._history: list[FloatArray] = []
        self._guards: list[PeakGuard | None] = []
        self._guard: PeakGuard | None = None
        self._shed_level = 0.0
        self._period_shed = False
        self._limits: list[FloatArray | None] = []
        self.python_time_s = 0.0
        """Wall time of :meth:`step` outside the engine [s] (the plant's own overhead)."""

    @classmethod
    def from_file(
        cls, idf_path: str | Path, zone_names: tuple[str, ...], **kwargs: Any
    ) -> EnergyPlusPlant:
        """The plant of an IDF file (see the class for ``kwargs``)."""
        return cls(read_idf(idf_path), idf_path, zone_names, **kwargs)

    # ---- what is read and actuated -----------------------------------------------------

    def _co_sim_spec(
        self, text: str, objects: tuple[IdfObject, ...], timesteps_per_hour: int
    ) -> CoSimSpec:
        m = len(self.zone_names)
        variables = [Variable("Zone Mean Air Temperature", z) for z in self.idf_zone_names]
        self._inlets: list[tuple[list[int], list[int]]] = []  # (flows, temperatures)
        for zone in self.idf_zone_names:
            nodes = zone_inlet_nodes(objects, zone, self.source)
            first = len(variables)
            self._inlets.append(
                (
                    list(range(first, first + len(nodes))),
                    list(range(first + len(nodes), first + 2 * len(nodes))),
                )
            )
            variables += [Variable("System Node Mass Flow Rate", n) for n in nodes]
            variables += [Variable("System Node Temperature", n) for n in nodes]
        self._outdoor = len(variables)
        variables.append(Variable("Site Outdoor Air Drybulb Temperature", "Environment"))
        actuators: list[Actuator] = []
        self._rule = SetpointRule(m)
        if self.actuation == "setpoint":
            actuators = self._setpoint_actuators(objects, variables)
        else:
            names = [ideal_loads_name(objects, z, self.source) for z in self.idf_zone_names]
            actuators = [Actuator("Ideal Loads Air System", "Air Mass Flow Rate", n) for n in names]
            actuators += [Actuator("Ideal Loads Air System", "Air Temperature", n) for n in names]
        self._m = m
        self._boundary_start = len(variables)
        variables += [Variable("Zone Mean Air Temperature", z) for z in self.boundary_zone_names]
        self._extra_start = len(variables)
        variables += list(self._extra_variables)
        return CoSimSpec(
            idf_text=text,
            epw_path=self.epw_path,
            source=self.source,
            timesteps_per_hour=timesteps_per_hour,
            variables=tuple(variables),
            meters=(*HVAC_METERS, FACILITY_METER),
            actuators=tuple(actuators),
            timestep_rule=self._timestep_rule,
        )

    def _setpoint_actuators(
        self, objects: tuple[IdfObject, ...], variables: list[Variable]
    ) -> list[Actuator]:
        for zone in self.idf_zone_names:
            if not has_thermostat(objects, zone):
                raise InputError(
                    "setpoint actuation needs a ZoneControl:Thermostat for the zone",
                    source=self.source,
                    field="ZoneControl:Thermostat",
                    value=zone,
                    hint="give the zone a dual-setpoint thermostat in the IDF",
                )
        actuators = [
            Actuator("Zone Temperature Control", "Cooling Setpoint", z) for z in self.idf_zone_names
        ]
        actuators += [
            Actuator("Zone Temperature Control", "Heating Setpoint", z) for z in self.idf_zone_names
        ]
        for zone in self.idf_zone_names:
            schedule = heating_setpoint_schedule(objects, zone)
            if schedule is None:
                self._rule.heating_vars.append(None)
            else:
                self._rule.heating_vars.append(len(variables))
                variables.append(Variable("Schedule Value", schedule))
        self._availability = availability_schedules(objects)
        actuators += [Actuator(kind, "Schedule Value", name) for kind, name in self._availability]
        return actuators

    def _timestep_rule(
        self, now: FloatArray, commanded: FloatArray, meters_last_step_j: FloatArray
    ) -> FloatArray:
        """The peak guard (module docstring), then under setpoint actuation
        :meth:`_setpoint_rule`: the actuator values of a zone time step."""
        m = self._m
        values = commanded.copy()
        guard = self._guard
        if guard is not None:
            step_s = 3600.0 / self._spec.timesteps_per_hour
            hvac_j = meters_last_step_j[: len(HVAC_METERS)]
            if not np.all(np.isnan(hvac_j)):
                power_kw = float(np.nansum(hvac_j)) / step_s / 1000.0
                self._shed_level = next_shed_level(self._shed_level, power_kw, guard.cap_kw)
            if self._shed_level > 0.0:
                shed = shed_toward_band(
                    values[:m],
                    now[:m],
                    guard,
                    self._shed_level,
                    setpoint=self.actuation == "setpoint",
                )
                self._period_shed = self._period_shed or not np.array_equal(
                    shed, values[:m], equal_nan=True
                )
                values[:m] = shed
        if self.actuation == "setpoint":
            return self._rule.apply(now, values)
        return values

    # ---- the Plant protocol ------------------------------------------------------------

    def reset(self, initial_temp_degc: float) -> Observation:
        """Start EnergyPlus afresh (sizing and warm-up on the first day's weather: EnergyPlus
        sets its own initial state, ``initial_temp_degc`` is not used) and run, under the
        IDF's own control, the periods of the first day before ``start``.

        The observation is the state at ``start``: temperatures, flows and outdoor
        temperature as read then; ``power_kw`` and ``facility_power_kw`` NaN (no period has
        been metered), as on the RC plant."""
        self.close()
        self._history, self._guards, self._limits = [], [], []
        self._guard, self._shed_level, self._period_shed = None, 0.0, False
        self._rule.reset()
        self._sim = CoSimulation(self._spec, self.work_dir)
        reading = self._sim.start()
        refused = guard_meter_error(self.source, self._sim.missing_meters)
        if self.peak_guard_required and refused is not None:  # before the first period
            self.close()
            raise refused
        for _ in range(self._skip_periods):
            reading = self._sim.advance(np.full(len(self._spec.actuators), np.nan))
        return replace(self._observation(reading), power_kw=np.nan, facility_power_kw=np.nan)

    def step(self, actuation: Actuation, disturbance: Disturbance, dt_s: float) -> Observation:
        began = time.perf_counter()
        if dt_s != PERIOD_S:
            raise ValueError(f"the EnergyPlus plant steps {PERIOD_S:g} s periods, got {dt_s}")
        if actuation.kind != self.actuation:
            raise ValueError(
                f"this EnergyPlus plant is {self.actuation}-actuated; got a "
                f"{actuation.kind} actuation"
            )
        if self._sim is None:
            raise RuntimeError("call reset() before step()")
        values = self._actuator_values(actuation)
        engine_before = self._sim.engine_time_s
        reading = self._advance(values, actuation.peak_guard, actuation.limit_degc)
        observation = replace(self._observation(reading), peak_guard_active=self._period_shed)
        engine = self._sim.engine_time_s - engine_before
        self.python_time_s += time.perf_counter() - began - engine
        return observation

    def _advance(
        self, values: FloatArray, guard: PeakGuard | None, limit_degc: FloatArray | None = None
    ) -> PeriodReading:
        """One period of the engine under ``values`` (na,), ``guard`` and the comfort limits
        ``limit_degc`` (m,) [°C], recorded for replay."""
        assert self._sim is not None
        self._guard, self._period_shed = guard, False
        self._rule.limit_degc = None if limit_degc is None else np.asarray(limit_degc, np.float64)
        if guard is None:
            self._shed_level = 0.0
        reading = self._sim.advance(values)
        self._history.append(values.copy())
        self._guards.append(guard)
        self._limits.append(self._rule.limit_degc)
        return reading

    def _actuator_values(self, actuation: Actuation) -> FloatArray:
        m = self._m
        values = np.full(len(self._spec.actuators), np.nan)
        if actuation.setpoint_degc is not None:
            values[:m] = np.asarray(actuation.setpoint_degc, dtype=np.float64)
        else:
            assert actuation.flow_kg_s is not None
            values[:m] = np.maximum(np.asarray(actuation.flow_kg_s, dtype=np.float64), 0.0)
            supply = actuation.supply_temp_degc
            values[m : 2 * m] = self.supply_temp_degc if supply is None else supply
        released = self.actuation == "setpoint" and bool(np.isnan(values[:m]).all())
        if values[:m].shape != (m,) or not (released or np.isfinite(values[:m]).all()):
            raise ValueError(f"the actuation needs {m} finite values, got {values[:m]}")
        return values

    def _observation(self, reading: PeriodReading) -> Observation:
        m = self._m
        self.extra_mean = reading.variables_mean[self._extra_start :].copy()
        flow, supply = inlet_flow_and_temp(reading.variables_mean, self._inlets)
        hvac_j = np.nan_to_num(reading.meters_j[: len(HVAC_METERS)], nan=0.0).sum()
        return Observation(
            zone_temp_degc=reading.variables_end[:m].copy(),
            zone_mean_temp_degc=reading.variables_mean[:m].copy(),
            node_temp_degc=None,
            supply_flow_kg_s=flow,
            supply_temp_degc=supply,
            power_kw=float(hvac_j / PERIOD_S / 1000.0),
            facility_power_kw=float(reading.meters_j[len(HVAC_METERS)] / PERIOD_S / 1000.0),
            outdoor_temp_degc=float(reading.variables_mean[self._outdoor]),
            boundary_temp_degc=(
                reading.variables_end[self._boundary_start : self._extra_start].copy()
                if self.boundary_zone_names
                else None
            ),
        )

    def get_state(self) -> dict[str, Any]:
        """The actuations applied since :meth:`reset` ((k, na) array), the peak guards in
        force (``guard_cap_kw`` (k,), NaN without one; ``guard_upper_degc`` and
        ``guard_floor_kg_s`` (k, m)) and the comfort limits (``limit_degc`` (k, m), NaN
        without), for replay."""
        k, m = len(self._history), self._m
        cap, upper, floor = np.full(k, np.nan), np.full((k, m), np.nan), np.full((k, m), np.nan)
        for j, guard in enumerate(self._guards):
            if guard is not None:
                cap[j], upper[j], floor[j] = (
                    guard.cap_kw,
                    guard.comfort_upper_degc,
                    guard.flow_floor_kg_s,
                )
        limits = np.full((k, m), np.nan)
        for j, limit in enumerate(self._limits):
            if limit is not None:
                limits[j] = limit
        return {
            "actuator_values": np.array(self._history).reshape(k, -1),
            "guard_cap_kw": cap,
            "guard_upper_degc": upper,
            "guard_floor_kg_s": floor,
            "limit_degc": limits,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Replay :meth:`get_state`'s actuations and peak guards on a fresh run (the same
        readings follow). A state without guards (written before the guard ran here)
        replays without one."""
        history = np.asarray(state["actuator_values"], dtype=np.float64)
        k, m = len(history), self._m
        cap = np.asarray(state.get("guard_cap_kw", np.full(k, np.nan)), dtype=np.float64)
        upper = np.asarray(state.get("guard_upper_degc", np.full((k, m), np.nan)))
        floor = np.asarray(state.get("guard_floor_kg_s", np.full((k, m), np.nan)))
        limits = np.asarray(state.get("limit_degc", np.full((k, m), np.nan)), dtype=np.float64)
        self.reset(float("nan"))
        for j, values in enumerate(history):
            guard = (
                PeakGuard(float(cap[j]), upper[j].astype(np.float64), floor[j].astype(np.float64))
                if np.isfinite(cap[j])
                else None
            )
            limit = limits[j] if np.isfinite(limits[j]).all() else None
            self._advance(values, guard, limit)

    def close(self) -> None:
        """End the EnergyPlus run (also done by the next :meth:`reset`)."""
        if self._sim is not None:
            self._sim.close()
            self._sim = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass


def guard_meter_error(source: str, missing_meters: tuple[str, ...]) -> InputError | None:
    """The refusal of a required peak guard that could never act, None where it can: none
    of the :data:`HVAC_METERS` it reads exists in the IDF ``source`` (EnergyPlus's handles
    −1: ``missing_meters``)."""
    if all(m in missing_meters for m in HVAC_METERS):
        return InputError(
            "the peak guard reads the HVAC meters, and EnergyPlus has none of them for this "
            "IDF: a guard that could never act",
            source=source,
            field="controller.peak_guard",
            value=" + ".join(HVAC_METERS),
            hint="use an IDF whose HVAC draws electricity (fans, pumps, chiller), or set "
            "peak_guard = 'auto' or 'off'",
        )
    return None


def inlet_flow_and_temp(
    means: FloatArray, inlets: list[tuple[list[int], list[int]]]
) -> tuple[FloatArray, FloatArray]:
    """Per zone, the supply flow [kg/s] (its inlet nodes' mean flows summed) and supply
    temperature [°C] (each node's period-mean temperature weighted by its period-mean flow;
    their plain mean when less than :data:`FLOW_EPSILON_KG_S` flows; NaN for a zone without an
    inlet node), from the period means of the read variables. (Per node, the mean temperature
    stands for the flow-weighted one: exact while the flow is steady within the period.)

    Parameters
    ----------
    means : (nv,) period means of the plant's variables.
    inlets : per zone, the indices of its inlet nodes' flows and temperatures in ``means``.

    Returns
    -------
    flow (m,) [kg/s], supply temperature (m,) [°C].
    """
    flow = np.array([means[flows].sum() for flows, _ in inlets])
    supply = np.array(
        [
            means[flows] @ means[temps] / total
            if total > FLOW_EPSILON_KG_S
            else (means[temps].mean() if temps else np.nan)
            for (flows, temps), total in zip(inlets, flow, strict=True)
        ]
    )
    return flow, supply
