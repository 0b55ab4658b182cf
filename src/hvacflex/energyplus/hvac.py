"""What an IDF's HVAC offers a supervisory controller: per-zone sensors and actuators.

Read from the IDF objects (:mod:`hvacflex.energyplus.idf`), case-insensitively as EnergyPlus
reads references:

* supply flow of a zone: the ``System Node Mass Flow Rate`` of its air inlet node(s)
  (``ZoneHVAC:EquipmentConnections``, a ``NodeList`` resolved);
* the heating setpoint a zone's thermostat schedules (``ZoneControl:Thermostat`` →
  ``ThermostatSetpoint:DualSetpoint`` or ``:SingleHeating`` → its schedule), read as the
  schedule's ``Schedule Value`` so that the actuated setpoint can stay below it;
* the air-side availability schedules — ``AvailabilityManager:Scheduled`` /
  ``:ScheduledOn`` of every ``AirLoopHVAC`` and the availability schedules of its fans and
  cooling coils — which the setpoint actuation forces on when a zone needs cooling outside
  the IDF's hours (pre-cooling);
* the flow actuator of a zone: ``ZoneHVAC:IdealLoadsAirSystem`` ("Ideal Loads Air System" /
  "Air Mass Flow Rate"). ``AirTerminal:SingleDuct:VAV:Reheat`` has none (a scheduled
  minimum flow can only raise the flow), so flow actuation needs ideal loads.
"""

from __future__ import annotations

from pathlib import Path

from hvacflex.energyplus.idf import IdfObject, objects_of
from hvacflex.errors import InputError

SCHEDULE_CLASSES = ("Schedule:Compact", "Schedule:Constant", "Schedule:Year", "Schedule:File")
"""Schedule classes EnergyPlus offers a "Schedule Value" actuator for (component type =
the class name)."""

FAN_CLASSES = ("Fan:VariableVolume", "Fan:ConstantVolume", "Fan:OnOff", "Fan:SystemModel")
COOLING_COIL_CLASSES = (
    "Coil:Cooling:Water",
    "Coil:Cooling:Water:DetailedGeometry",
    "Coil:Cooling:DX:SingleSpeed",
    "Coil:Cooling:DX:TwoSpeed",
)
"""Components whose second field is an availability schedule (forced on for pre-cooling)."""
AIR_TERMINAL_CLASSES = (
    "AirTerminal:SingleDuct:VAV:Reheat",
    "AirTerminal:SingleDuct:VAV:NoReheat",
    "AirTerminal:SingleDuct:ConstantVolume:Reheat",
    "AirTerminal:SingleDuct:ConstantVolume:NoReheat",
)
"""Zone air terminals whose second field is an availability schedule: a terminal that is
unavailable sends no air to its zone even while the air loop runs (5ZoneAirCooled's VAV boxes
are off at night and at weekends from April), so they are forced on with the loop."""

IDEAL_LOADS_CLASS = "ZoneHVAC:IdealLoadsAirSystem"


def _by_name(objects: tuple[IdfObject, ...], class_name: str) -> dict[str, IdfObject]:
    return {obj.field(0).lower(): obj for obj in objects_of(objects, class_name)}


def _connections(objects: tuple[IdfObject, ...], zone: str, source: str | Path) -> IdfObject:
    connections = _by_name(objects, "ZoneHVAC:EquipmentConnections")
    if zone.lower() not in connections:
        raise InputError(
            "the zone has no ZoneHVAC:EquipmentConnections (it is not conditioned)",
            source=source,
            field="ZoneHVAC:EquipmentConnections",
            value=zone,
            hint="map the hvacflex zone to a conditioned IDF zone (energyplus_zone)",
        )
    return connections[zone.lower()]


def zone_inlet_nodes(
    objects: tuple[IdfObject, ...], zone: str, source: str | Path
) -> tuple[str, ...]:
    """The air inlet node names of ``zone`` (a ``NodeList`` expanded)."""
    inlet = _connections(objects, zone, source).field(2)
    node_lists = _by_name(objects, "NodeList")
    if inlet.lower() in node_lists:
        return tuple(n for n in node_lists[inlet.lower()].fields[1:] if n)
    return (inlet,) if inlet else ()


def heating_setpoint_schedule(objects: tuple[IdfObject, ...], zone: str) -> str | None:
    """The heating setpoint schedule of ``zone``'s thermostat (dual or single heating), or
    None when the thermostat has none."""
    thermostats = [
        t
        for t in objects_of(objects, "ZoneControl:Thermostat")
        if t.field(1).lower() == zone.lower()
    ]
    if not thermostats:
        return None
    controls = thermostats[0].fields[3:]
    pairs = [(controls[i].lower(), controls[i + 1].lower()) for i in range(0, len(controls) - 1, 2)]
    dual = _by_name(objects, "ThermostatSetpoint:DualSetpoint")
    single = _by_name(objects, "ThermostatSetpoint:SingleHeating")
    for kind, name in pairs:
        if kind == "thermostatsetpoint:dualsetpoint" and name in dual:
            return dual[name].field(1) or None
    for kind, name in pairs:
        if kind == "thermostatsetpoint:singleheating" and name in single:
            return single[name].field(1) or None
    return None


def has_thermostat(objects: tuple[IdfObject, ...], zone: str) -> bool:
    return any(
        t.field(1).lower() == zone.lower() for t in objects_of(objects, "ZoneControl:Thermostat")
    )


def schedule_class(objects: tuple[IdfObject, ...], name: str) -> str | None:
    """The class of the schedule called ``name`` (one of :data:`SCHEDULE_CLASSES`), if any."""
    for class_name in SCHEDULE_CLASSES:
        if name.lower() in _by_name(objects, class_name):
            return class_name
    return None


def availability_schedules(objects: tuple[IdfObject, ...]) -> tuple[tuple[str, str], ...]:
    """(schedule class, schedule name) of every air-side availability schedule: the
    scheduled availability managers of the air loops and the fans', cooling coils' and zone
    air terminals' availability schedules (deduplicated, file order)."""
    names: list[str] = []
    lists = _by_name(objects, "AvailabilityManagerAssignmentList")
    managers = {
        **_by_name(objects, "AvailabilityManager:Scheduled"),
        **_by_name(objects, "AvailabilityManager:ScheduledOn"),
    }
    for loop in objects_of(objects, "AirLoopHVAC"):
        assignment = lists.get(loop.field(2).lower())
        if assignment is None:
            continue
        for manager in assignment.fields[2::2]:
            if manager.lower() in managers:
                names.append(managers[manager.lower()].field(1))
    for class_name in (*FAN_CLASSES, *COOLING_COIL_CLASSES, *AIR_TERMINAL_CLASSES):
        names += [obj.field(1) for obj in objects_of(objects, class_name)]
    found: dict[str, tuple[str, str]] = {}
    for name in names:
        kind = schedule_class(objects, name) if name else None
        if kind is not None and name.lower() not in found:
            found[name.lower()] = (kind, name)
    return tuple(found.values())


def ideal_loads_name(objects: tuple[IdfObject, ...], zone: str, source: str | Path) -> str:
    """The ``ZoneHVAC:IdealLoadsAirSystem`` serving ``zone`` (its flow is actuatable).

    Raises
    ------
    InputError
        when the zone's equipment has no ideal loads system (flow actuation impossible).
    """
    equipment_list = _connections(objects, zone, source).field(1).lower()
    lists = _by_name(objects, "ZoneHVAC:EquipmentList")
    entry = lists.get(equipment_list)
    fields = entry.fields[2:] if entry is not None else ()
    for i in range(0, len(fields) - 1, 6):
        if fields[i].lower() == IDEAL_LOADS_CLASS.lower():
            return fields[i + 1]
    kinds = sorted({fields[i] for i in range(0, len(fields), 6) if fields[i]})
    raise InputError(
        "flow actuation needs a zone supply flow EnergyPlus can actuate, and this zone's "
        f"equipment ({', '.join(kinds) or 'none'}) has none",
        source=source,
        field="plant.actuation",
        value="flow",
        hint=f"zone {zone!r}: AirTerminal:SingleDuct:VAV:Reheat has no flow actuator; use "
        "actuation = 'setpoint', or an IDF with ZoneHVAC:IdealLoadsAirSystem per zone (the "
        "'ideal' export)",
    )
