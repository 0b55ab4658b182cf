"""The plant interface: what the closed loop drives, one 30-min period at a time.

A plant is anything that turns an :class:`Actuation` (what the building's actuators are told
for the period) and the period's realised :class:`Disturbance` into an :class:`Observation`
(what the meters and sensors read at the end of the period). The closed loop talks to the
plant only through :class:`Plant`; the first implementation is :class:`RCPlant`, hvacflex's
exact nonlinear RC network (:class:`hvacflex.building.plant.NonlinearPlant`) with the exact
HVAC power model (:func:`hvacflex.building.hvac.hvac_power_kw`; a building identified from
data: its fitted power model).

A plant that reads its meter within a period (``reads_meter_in_period``: the RC plant, as
below; EnergyPlus at its zone time step, :mod:`hvacflex.sim.energyplus_plant`) runs
the in-period **peak guard** an :class:`Actuation` may carry (:class:`PeakGuard`): at each of
``substeps`` instants of the period it reads the power the meter would show at the actuated
flows and, where that exceeds the committed cap, sheds flow within the comfort band
(:func:`shed_flows_kg_s`) for that substep; it releases at the next reading that fits.

A plant that can snapshot its state (``can_snapshot``) lets the closed loop compute the
counterfactual of an IL activation (the same period with and without curtailment) by
``get_state`` → ``step`` → ``set_state`` → ``step``. An external emulator that cannot (an
EnergyPlus run cannot be copied mid-simulation) says so, and the closed loop resumes it by
replaying the recorded actuations instead.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from hvacflex.building.hvac import hvac_power_kw
from hvacflex.building.identified import identified_occupied_share, identified_power_kw
from hvacflex.building.model import Building
from hvacflex.building.plant import NonlinearPlant

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PeakGuard:
    """The committed peak a period's meter must keep, and the room the guard may use.

    Attributes
    ----------
    cap_kw : the committed peak [kW] (``committed_peak_kw``).
    comfort_upper_degc : (m,) the upper comfort bound at the period's end [°C] (the tighter of
        the bands of this period and the next, as the plan's); a zone at or above it is
        not shed.
    flow_floor_kg_s : (m,) the lowest flow the guard may shed to [kg/s] (the ventilation flow
        while occupied, the minimum otherwise).
    substeps : meter readings per period (≥ 1) on the RC plant (EnergyPlus reads its meter at
        its zone time step).
    """

    cap_kw: float
    comfort_upper_degc: FloatArray
    flow_floor_kg_s: FloatArray
    substeps: int = 6

    def __post_init__(self) -> None:
        if self.substeps < 1:
            raise ValueError(f"the peak guard needs ≥ 1 substep, got {self.substeps}")


@dataclass(frozen=True)
class Actuation:
    """What the plant is told for one period (held over the period).

    Exactly one of ``flow_kg_s``, ``setpoint_degc`` and ``cooling_kw`` is given: the way the
    plant is actuated (supply-flow control, supervisory setpoints, or delivered sensible
    cooling for identified models of packaged units).

    Attributes
    ----------
    flow_kg_s : (m,) supply air mass flow per zone [kg/s], or None.
    setpoint_degc : (m,) zone cooling setpoint [°C], or None.
    cooling_kw : (m,) delivered sensible cooling per zone [kW] (≥ 0), or None.
    supply_temp_degc : supply-air temperature [°C]; None: the plant's own (design) value.
    peak_guard : the in-period peak guard of the period (on a plant that
        ``reads_meter_in_period``), or None.
    limit_degc : (m,) with ``setpoint_degc``, each zone's comfort limit for the period [°C]
        (the band's upper bound at its end): a plant that starts its own loop (EnergyPlus)
        starts it a time step early when a zone rising at its last step's rate would pass
        it; None: no such anticipation.
    """

    flow_kg_s: FloatArray | None = None
    setpoint_degc: FloatArray | None = None
    cooling_kw: FloatArray | None = None
    supply_temp_degc: float | None = None
    peak_guard: PeakGuard | None = None
    limit_degc: FloatArray | None = None

    def __post_init__(self) -> None:
        given = [
            name
            for name in ("flow_kg_s", "setpoint_degc", "cooling_kw")
            if getattr(self, name) is not None
        ]
        if len(given) != 1:
            raise ValueError(
                "an Actuation carries exactly one of flow_kg_s, setpoint_degc, cooling_kw; "
                f"got {given or 'none'}"
            )

    @property
    def kind(self) -> str:
        """``"flow"``, ``"setpoint"`` or ``"cooling"``."""
        if self.flow_kg_s is not None:
            return "flow"
        if self.setpoint_degc is not None:
            return "setpoint"
        return "cooling"


@dataclass(frozen=True)
class Disturbance:
    """The realised outside world over one period, as the plant's model needs it.

    Attributes
    ----------
    d : (nd,) disturbance channels in the building's channel order (outdoor temperature [°C],
        solar [W/m²], internal gains [W]; :mod:`hvacflex.building.channels`).
    outdoor_temp_degc : outdoor dry-bulb temperature [°C].
    outdoor_humidity_ratio_kg_per_kg : outdoor humidity ratio [kg/kg].
    latent_gain_w : the occupants' latent gain, all zones [W] (a coil load, not in ``d``).
    damper_open : the outdoor-air damper is open this period (occupied, or the pre-occupancy
        purge: ``HvacSystem.outdoor_air_open_at``); closed, the air handler recirculates.

    A plant with its own weather (EnergyPlus reads the EPW) may ignore these.
    """

    d: FloatArray
    outdoor_temp_degc: float
    outdoor_humidity_ratio_kg_per_kg: float
    latent_gain_w: float = 0.0
    damper_open: bool = True


@dataclass(frozen=True)
class Observation:
    """What the plant's sensors and meters read over one period.

    Attributes
    ----------
    zone_temp_degc : (m,) zone air temperature at the end of the period [°C].
    zone_mean_temp_degc : (m,) mean zone air temperature over the period [°C].
    node_temp_degc : (n,) every node temperature the plant can show at the end of the period
        [°C] (the RC plant: its full state), or None.
    supply_flow_kg_s : (m,) mean supply air mass flow per zone over the period [kg/s].
    power_kw : mean HVAC electric power over the period (fans + cooling plant) [kW].
    facility_power_kw : mean whole-facility electric power [kW] (NaN where not metered).
    outdoor_temp_degc : mean outdoor dry-bulb temperature over the period [°C].
    boundary_temp_degc : (nb,) air temperature at the end of the period of the unconditioned
        zones the controller's model carries as boundary nodes (an identified model's plenum)
        [°C], or None where the plant does not read them.
    supply_temp_degc : (m,) mean supply air temperature at the zone inlets over the period
        (weighted across a zone's inlets by their flows) [°C], or None where the plant's
        supply air is the model's own (the RC plants); with it the observer feeds the model
        the cooling delivered, not the flow (``closed_loop``: a coil off out of hours
        delivers none).
    peak_guard_active : True when the peak guard shed load in some substep (EnergyPlus: zone
        time step) of the period.
    """

    zone_temp_degc: FloatArray
    zone_mean_temp_degc: FloatArray
    node_temp_degc: FloatArray | None
    supply_flow_kg_s: FloatArray
    power_kw: float
    facility_power_kw: float
    outdoor_temp_degc: float
    boundary_temp_degc: FloatArray | None = None
    supply_temp_degc: FloatArray | None = None
    peak_guard_active: bool = False


def reads_meter_in_period(plant: object) -> bool:
    """Whether ``plant`` reads its meter within a period (can run a :class:`PeakGuard`): its
    ``reads_meter_in_period`` attribute, False where it has none."""
    return bool(getattr(plant, "reads_meter_in_period", False))


def shed_flows_kg_s(
    flow_kg_s: FloatArray,
    guard: PeakGuard,
    zone_temp_degc: FloatArray,
    power_kw: Callable[[FloatArray], float],
    iterations: int = 40,
) -> FloatArray:
    """(m,) the flows [kg/s] the guard runs while the meter exceeds ``guard.cap_kw``.

    Rule: the zones below their upper comfort bound are moved together towards their floor,
    u' = u_floor + s (u − u_floor), with the largest s ∈ [0, 1] at which the metered power
    ``power_kw(u')`` [kW] is at most the cap (bisection; power grows with flow); s = 0 where
    even the floor exceeds it. Zones at or above their upper bound keep u; where u ≤ the cap
    already, u is returned unchanged.

    Parameters
    ----------
    flow_kg_s : (m,) the actuated flows [kg/s].
    zone_temp_degc : (m,) zone temperatures now [°C].
    power_kw : the meter's power at given flows (m,) [kg/s] → [kW], at the present state.
    """
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    if power_kw(flow) <= guard.cap_kw:
        return flow
    floor = np.minimum(np.asarray(guard.flow_floor_kg_s, dtype=np.float64), flow)
    may_shed = np.asarray(zone_temp_degc) < np.asarray(guard.comfort_upper_degc)

    def at(s: float) -> FloatArray:
        out: FloatArray = np.where(may_shed, floor + s * (flow - floor), flow)
        return out

    if power_kw(at(0.0)) > guard.cap_kw:
        return at(0.0)
    low, high = 0.0, 1.0
    for _ in range(iterations):
        mid = 0.5 * (low + high)
        if power_kw(at(mid)) <= guard.cap_kw:
            low = mid
        else:
            high = mid
    return at(low)


@runtime_checkable
class Plant(Protocol):
    """A building the closed loop drives period by period.

    Attributes
    ----------
    zone_names : the zones, in the order of every (m,) array.
    can_snapshot : True when :meth:`get_state` / :meth:`set_state` copy the whole plant (so a
        period can be stepped twice from the same state); False for an external emulator.
    actuations : the :attr:`Actuation.kind` values the plant accepts.
    """

    zone_names: tuple[str, ...]
    can_snapshot: bool
    actuations: tuple[str, ...]

    def reset(self, initial_temp_degc: float) -> Observation:
        """Start (again) with every temperature at ``initial_temp_degc`` [°C]; the
        observation of the state before the first period."""
        ...

    def step(self, actuation: Actuation, disturbance: Disturbance, dt_s: float) -> Observation:
        """Advance one period of ``dt_s`` [s] under ``actuation`` and ``disturbance``."""
        ...

    def get_state(self) -> dict[str, Any]:
        """The plant's state as data (JSON values and numpy arrays)."""
        ...

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`get_state` (only where ``can_snapshot``)."""
        ...


class RCPlant:
    """hvacflex's exact nonlinear RC network as a :class:`Plant` (flow actuation only).

    Parameters
    ----------
    building : the building.
    plant : its nonlinear plant, if already built (shares the step-matrix cache).
    """

    can_snapshot = True
    reads_meter_in_period = True
    actuations: tuple[str, ...] = ("flow",)

    def __init__(self, building: Building, plant: NonlinearPlant | None = None) -> None:
        self.building = building
        self.plant = plant if plant is not None else NonlinearPlant(building)
        self.zone_names = tuple(building.zone_names)
        self._zones = np.asarray(self.plant.network.zone_node_index)
        self.x = np.full(self.plant.n, np.nan)

    def reset(self, initial_temp_degc: float) -> Observation:
        self.x = np.full(self.plant.n, float(initial_temp_degc))
        zones = self.x[self._zones]
        return Observation(
            zone_temp_degc=zones.copy(),
            zone_mean_temp_degc=zones.copy(),
            node_temp_degc=self.x.copy(),
            supply_flow_kg_s=np.zeros(len(self.zone_names)),
            power_kw=float("nan"),
            facility_power_kw=float("nan"),
            outdoor_temp_degc=float("nan"),
        )

    def _power_kw(
        self, flow: FloatArray, zone_temp_degc: FloatArray, disturbance: Disturbance
    ) -> float:
        """The meter's HVAC power [kW] at flows (m,) [kg/s] and zone (return-air)
        temperatures (m,) [°C] under the period's disturbance."""
        identified = self.building.identified
        if identified is not None:
            return identified_power_kw(
                identified,
                flow,
                zone_temp_degc,
                disturbance.outdoor_temp_degc,
                identified_occupied_share(self.plant.network.channel_names, disturbance.d),
                disturbance.outdoor_humidity_ratio_kg_per_kg,
            )
        return float(
            hvac_power_kw(
                self.building.hvac,
                flow,
                zone_temp_degc,
                disturbance.outdoor_temp_degc,
                disturbance.outdoor_humidity_ratio_kg_per_kg,
                latent_gain_w=disturbance.latent_gain_w,
                damper_open=disturbance.damper_open,
            )
        )

    def step(self, actuation: Actuation, disturbance: Disturbance, dt_s: float) -> Observation:
        if actuation.flow_kg_s is None:
            raise ValueError(f"the RC plant is flow-actuated; got a {actuation.kind} actuation")
        flow = np.asarray(actuation.flow_kg_s, dtype=np.float64)
        if actuation.peak_guard is not None:
            guarded = self._guarded_step(flow, disturbance, dt_s, actuation.peak_guard)
            if guarded is not None:
                return guarded
        start = self.x[self._zones]
        x_next = self.plant.step(self.x, flow, disturbance.d, dt_s)
        end = x_next[self._zones]
        mean = 0.5 * (start + end)
        power = self._power_kw(flow, mean, disturbance)
        self.x = x_next
        return Observation(
            zone_temp_degc=end.copy(),
            zone_mean_temp_degc=mean,
            node_temp_degc=x_next.copy(),
            supply_flow_kg_s=flow.copy(),
            power_kw=power,
            facility_power_kw=float("nan"),
            outdoor_temp_degc=float(disturbance.outdoor_temp_degc),
        )

    def _guarded_step(
        self, flow: FloatArray, disturbance: Disturbance, dt_s: float, guard: PeakGuard
    ) -> Observation | None:
        """The period in ``guard.substeps`` exact substeps, the meter read at the start of
        each (the actuated flows at the present zone temperatures) and flow shed by
        :func:`shed_flows_kg_s` while it exceeds the cap; None (state untouched) when the
        guard never sheds, so the period is stepped whole as without a guard."""
        h = dt_s / guard.substeps
        x = self.x
        flows, powers, means = [], [], []
        active = False
        for _ in range(guard.substeps):
            zones = x[self._zones]
            meter = partial(self._power_kw, zone_temp_degc=zones, disturbance=disturbance)
            applied = shed_flows_kg_s(flow, guard, zones, meter)
            active = active or bool(np.any(applied < flow))
            x_sub = self.plant.step(x, applied, disturbance.d, h)
            mean = 0.5 * (zones + x_sub[self._zones])
            flows.append(applied)
            means.append(mean)
            powers.append(self._power_kw(applied, mean, disturbance))
            x = x_sub
        if not active:
            return None
        self.x = x
        end = x[self._zones]
        return Observation(
            zone_temp_degc=end.copy(),
            zone_mean_temp_degc=np.mean(means, axis=0),
            node_temp_degc=x.copy(),
            supply_flow_kg_s=np.mean(flows, axis=0),
            power_kw=float(np.mean(powers)),
            facility_power_kw=float("nan"),
            outdoor_temp_degc=float(disturbance.outdoor_temp_degc),
            peak_guard_active=True,
        )

    def get_state(self) -> dict[str, Any]:
        return {"x_degc": self.x.copy()}

    def set_state(self, state: dict[str, Any]) -> None:
        self.x = np.asarray(state["x_degc"], dtype=np.float64).copy()
