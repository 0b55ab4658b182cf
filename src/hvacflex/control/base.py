"""What every controller returns each step, and the interface the simulator drives."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from hvacflex.control.estimation import StepModel
from hvacflex.data.forecast import Forecast

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ReserveOffer:
    """Reserve offered for one future period (committed g periods ahead, docs/il_events.md).

    Attributes
    ----------
    flow_kg_s : (m,) reserve flows r the building sheds if the period is activated [kg/s].
    reserve_kw : the capacity offered (and paid) [kW]: at most the power that r surely sheds,
        and no more than the settlement baseline would see.
    meter_ratio : ρ, the meter's response to the plan the offer was sized with
        (:mod:`hvacflex.control.meter_response`); NaN: not scaled.
    """

    flow_kg_s: FloatArray
    reserve_kw: float
    meter_ratio: float = math.nan


@dataclass(frozen=True)
class EventPlan:
    """The steps of a plan an interruptible-load event locks (made when the event starts).

    The closed loop applies ``flow_kg_s[j] − reserve_flow_kg_s[j]`` in the event's j-th
    period without re-optimising, and settles the delivery against ``served_power_kw[j]``.
    Covers D + R steps (the event and its recovery; fewer at the horizon's end).

    Attributes
    ----------
    flow_kg_s : (L, m) served flows u_j [kg/s].
    reserve_flow_kg_s : (L, m) reserve flows r_j [kg/s] (0 ≤ r_j ≤ u_j − u_min).
    served_power_kw : (L,) the plan's served power p0_j + p_jᵀ u_j [kW].
    reserve_kw : (L,) reserve capacity scheduled, q_jᵀ r_j, no more than the baseline would
        see [kW]; where reserve is committed ahead, step j's is the offer committed for it
        (steps < g: committed before the plan was made).
    predicted_served_degc, predicted_curtailed_degc : (L, m) predicted zone temperatures at
        the end of period j, without and with the event (from the start) [°C].
    meter_ratio : ρ the plan's offers were sized with (NaN: not scaled).
    """

    flow_kg_s: FloatArray
    reserve_flow_kg_s: FloatArray
    served_power_kw: FloatArray
    reserve_kw: FloatArray
    predicted_served_degc: FloatArray
    predicted_curtailed_degc: FloatArray
    meter_ratio: float = math.nan

    @property
    def steps(self) -> int:
        return int(self.served_power_kw.shape[0])


@dataclass(frozen=True)
class Action:
    """The decision applied in the current 30-min period.

    Attributes
    ----------
    flow_kg_s : (m,) supply air flow per zone when IL is not activated, u₀ [kg/s].
    reserve_flow_kg_s : (m,) flow reduction offered as IL reserve, r₀ [kg/s]; the plant runs
        u₀ − r₀ when activated.
    reserve_kw : reserve capacity offered, q₀ᵀ r₀ [kW] (what the reserve price pays for; q the
        problem's ``reserve_kw_per_kg_s``, p where it has none).
    planned_power_kw : the plan's first-step power p0₀ + p₀ᵀ u₀ [kW] (NaN without a plan).
    status : solver outcome (``"optimal"``, ``"infeasible"``, …, or ``"rule"`` for baselines).
    fallback : True when the plan could not be used and a safe rule decided instead.
    solve_time_s : wall time of the optimisation [s] (0 for rules).
    planned_slack_max_k : largest comfort slack in the plan [K].
    delta_max_k : largest robust margin δ in the plan [K].
    predicted_served_degc, predicted_curtailed_degc : (m,) one-step predicted zone
        temperatures without and with IL activation [°C] (NaN without a plan).
    event_plan : the plan's first D + R steps, which an IL activation starting now locks
        (``None`` without a plan, or under the whole-horizon reserve model).
    predicted_event_worst_degc : (m,) worst zone temperature at the end of this period over
        the plan's event set × the uncertainty box (``RMPCSolution.y_event_worst`` of output
        step 1) [°C]; ``None`` without a plan.
    supply_temp_degc : supply-air temperature set-point for the period [°C], handed to a
        flow-actuated plant that accepts one (``Actuation.supply_temp_degc``); ``None``: the
        plant's own (design) value.
    released : True when the controller leaves the period to the plant's own control (the
        ``plant-baseline``: a setpoint-actuated plant is told nothing, all-NaN setpoints).
    offer_ahead : the reserve offered for the period g periods from now
        (:attr:`Controller.commits_ahead`); ``None``: nothing (no plan, or no commitments).
    offer_meter_ratio : ρ, the meter's response to the plan that ``reserve_kw`` was sized
        with (:mod:`hvacflex.control.meter_response`; under commitments, the ρ of the
        decision that committed it); NaN: not scaled.
    """

    flow_kg_s: FloatArray
    reserve_flow_kg_s: FloatArray
    reserve_kw: float
    planned_power_kw: float
    status: str
    fallback: bool
    solve_time_s: float
    planned_slack_max_k: float
    delta_max_k: float
    predicted_served_degc: FloatArray
    predicted_curtailed_degc: FloatArray
    event_plan: EventPlan | None = None
    predicted_event_worst_degc: FloatArray | None = None
    supply_temp_degc: float | None = None
    released: bool = False
    offer_ahead: ReserveOffer | None = None
    offer_meter_ratio: float = math.nan

    def applied_flow_kg_s(self, *, curtailed: bool) -> FloatArray:
        """(m,) the flow the plant runs [kg/s]: u₀ − r₀ when the period is curtailed (IL
        activated), else u₀."""
        flow = self.flow_kg_s - self.reserve_flow_kg_s if curtailed else self.flow_kg_s
        return np.asarray(flow, dtype=float)


@dataclass(frozen=True)
class PeriodInputs:
    """What a controller gets to decide the period starting now (:meth:`Controller.act`).

    Built by the driver of the period (:meth:`hvacflex.sim.step.ControlStep.decide`, which
    sets :attr:`allowance_carry_steps` from its IL event tracker) and passed unchanged to
    the controller.

    Attributes
    ----------
    x_degc : (n,) node temperatures now [°C] (the plant's state, or the building's report).
    forecast : prices, φ, disturbances and comfort bounds over the horizon from now.
    peak_floor_kw : the peak already incurred in this billing period [kW] (billing-period
        PPP; 0 at a billing period's start).
    allowance_carry_steps : periods from now that still belong to the recovery of an IL
        event that just ended: their end temperatures may use the event allowance α (0:
        none).
    measured_zone_temp_degc : (m,) zone-air readings [°C] for a controller with a filter
        (:attr:`Controller.takes_measurements`); None: not measured.
    plan : a plan of this period decided elsewhere (the fleet coordinator's
        ``RMPCSolution``) to apply instead of solving; controllers that do not plan ignore it.
    """

    x_degc: FloatArray
    forecast: Forecast
    peak_floor_kw: float
    allowance_carry_steps: int = 0
    measured_zone_temp_degc: FloatArray | None = None
    plan: Any = None


class Controller(Protocol):
    """A controller the closed loop, the service and the fleet drive through one
    :class:`hvacflex.sim.step.ControlStep`, and checkpoint.

    Concrete controllers subclass it explicitly to inherit the no-op defaults: a rule-based
    controller implements :meth:`act`, :meth:`get_state` and :meth:`set_state` only; an MPC
    also takes measurements, holds through locked IL events, and shows its model and plan.
    """

    takes_measurements: bool = False
    """True when :meth:`act` and :meth:`hold` need ``measured_zone_temp_degc`` (a filter)."""

    def act(self, inputs: PeriodInputs) -> Action:
        """Decide the action for the period starting now from what the period's
        :class:`PeriodInputs` hold."""
        ...

    def hold(
        self,
        forecast: Forecast,
        flow_kg_s: FloatArray,
        measured_zone_temp_degc: FloatArray | None = None,
    ) -> None:
        """A period that runs a locked IL-event plan (flow (m,) [kg/s]) without a decision."""
        return None

    def note_applied_flow(self, flow_kg_s: FloatArray) -> None:
        """The flow (m,) [kg/s] the plant ran this period (u − r when curtailed)."""
        return None

    def note_baseline_power(
        self, baseline_power_kw: float | None, ahead_kw: FloatArray | None = None
    ) -> None:
        """The metered baseline an activation starting in the coming period would be settled
        against [kW] (:mod:`hvacflex.settlement`; NaN: none, e.g. the run's first period;
        None: unknown to the driver), and ``ahead_kw`` (J,) the baselines of the coming
        periods k … k + J − 1 where the rule fixes them whenever the activation starts
        (``similar-days``; NaN: no similar day yet; None: the ``pre-event`` rule or unknown).
        A controller that offers reserve uses them to offer only what the baseline would
        see."""
        return None

    def note_meter_response(self, ratio: float) -> None:
        """ρ ∈ [0, 1]: how much the metered power has moved per kW the plan's power moved in
        the building's recent periods (:mod:`hvacflex.control.meter_response`); a controller
        that offers reserve scales its offers by it, so that they are sized on the meter's
        scale, and says so in ``Action.offer_meter_ratio`` and its offers' ``meter_ratio``."""
        return None

    @property
    def commits_ahead(self) -> int:
        """g: the controller offers the reserve of a period g periods ahead
        (``Action.offer_ahead``) and plans with the commitments of the next g periods fixed
        (:meth:`note_commitments`); 0: each period's offer is decided at its start."""
        return 0

    def note_commitments(self, reserve_flow_kg_s: FloatArray) -> None:
        """(g, m) reserve flows [kg/s] committed for the coming g periods (this one first),
        which every plan from now on keeps (only a controller with :attr:`commits_ahead`)."""
        return None

    @property
    def step_model(self) -> StepModel | None:
        """The model the last decision was planned with (None: the controller has none)."""
        return None

    @property
    def last_plan(self) -> Any:
        """The last optimal plan over the horizon (an ``RMPCSolution``), or None."""
        return None

    def observe_problems(self, callback: Callable[[Any], None]) -> bool:
        """Call ``callback`` with every optimisation problem built from now on; False when
        the controller builds none."""
        return False

    def restart_warm(self) -> None:
        """Continue as a run resumed from :meth:`get_state` would: a controller that keeps
        live solver state beyond what :meth:`get_state` returns drops it here (the closed
        loop calls this at every checkpoint, so a resumed run equals an uninterrupted one
        bit for bit)."""
        return None

    def get_state(self) -> dict[str, Any]:
        """State needed to resume identically, as data (:mod:`hvacflex.state`)."""
        ...

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore the state returned by :meth:`get_state`."""
        ...
