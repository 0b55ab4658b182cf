"""What every controller returns each step, and the interface the simulator drives."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from hvacflex.control.estimation import StepModel
from hvacflex.data.forecast import Forecast

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ReserveOffer:
    """Reserve offered for one future period (committed g periods ahead,
    docs/explanation/il_events.md).

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
    plan : the optimal plan over the horizon this decision made (an ``RMPCSolution``);
        None for a rule, a fallback or a locked period.
    step_model : the model (a, b, e, g, c) the decision was planned with (its first step);
        None: the scenario's fixed model (a rule, a stand-in).
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
    plan: Any = None
    step_model: StepModel | None = None

    @classmethod
    def unoptimised(
        cls,
        flow_kg_s: FloatArray,
        reserve_flow_kg_s: FloatArray,
        planned_power_kw: float,
        predicted_served_degc: FloatArray,
        predicted_curtailed_degc: FloatArray,
        *,
        status: str,
        reserve_kw: float = 0.0,
        fallback: bool = False,
        offer_meter_ratio: float = math.nan,
    ) -> Action:
        """An action nobody optimised this period (a locked or replayed plan, or none): no
        solve time, no plan's slack or margin (NaN)."""
        return cls(
            flow_kg_s=flow_kg_s,
            reserve_flow_kg_s=reserve_flow_kg_s,
            reserve_kw=reserve_kw,
            planned_power_kw=planned_power_kw,
            status=status,
            fallback=fallback,
            solve_time_s=0.0,
            planned_slack_max_k=math.nan,
            delta_max_k=math.nan,
            predicted_served_degc=predicted_served_degc,
            predicted_curtailed_degc=predicted_curtailed_degc,
            offer_meter_ratio=offer_meter_ratio,
        )

    def applied_flow_kg_s(self, *, curtailed: bool) -> FloatArray:
        """(m,) the flow the plant runs [kg/s]: u₀ − r₀ when the period is curtailed (IL
        activated), else u₀."""
        flow = self.flow_kg_s - self.reserve_flow_kg_s if curtailed else self.flow_kg_s
        return np.asarray(flow, dtype=float)


@dataclass(frozen=True)
class PeriodInputs:
    """Everything a controller gets to decide the period starting now (:meth:`Controller.act`).

    The driver's part (the state, the forecast with the operator's signals, the peak so far,
    the settlement baselines, the meter of the period before) is built once, by
    :func:`hvacflex.sim.history.period_inputs` from the driver's
    :class:`~hvacflex.sim.history.PeriodHistory`; the control step's part (the recovery
    carried from an event, the commitments, ρ, the filter's input of the period before, a
    locked event period) is laid over it by :meth:`hvacflex.sim.step.ControlStep.decide`.

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
    baseline_power_kw : the metered baseline an activation starting now would be settled
        against [kW] (:mod:`hvacflex.settlement`; NaN: none, e.g. the run's first metered
        period; None: unknown to the driver). A controller that offers reserve offers only
        what the baseline would see.
    baseline_ahead_kw : (J,) the baselines of the periods k … k + J − 1 where the rule fixes
        them whenever the activation starts (``similar-days``; NaN: no similar day yet;
        None: the ``pre-event`` rule or unknown).
    previous_power_kw : the metered power of period k − 1 [kW] (None: not metered), which the
        control step's meter history reads (:mod:`hvacflex.control.meter_response`).
    delivered_flow_kg_s : (m,) the plant's report of period k − 1: the air system's input as
        the model takes it (the cooling the air delivered, as a flow at the model's supply
        temperature) [kg/s]; None where the plant reports none.
    committed_reserve_kg_s : (g, m) reserve flows committed for the coming g periods, this
        one first, which the plan keeps [kg/s] (None: no commitments).
    meter_ratio : ρ ∈ [0, 1], the meter's response to the plan in the building's recent
        periods; offers are sized on the meter's scale with it (NaN: not scaled).
    meter_offset_kw : (N,) the meter's offset from the power model for the periods of the
        horizon [kW] (at the same time of day over the building's recent occupied periods),
        added to the LP's power rows in occupied periods under ``[controller] power_level =
        "meter"``; None: none.
    previous_flow_kg_s : (m,) the input of the filter's last step, period k − 1 (the flow the
        plant ran: u − r when curtailed, or what the air delivered) [kg/s]; None: keep the
        decided one.
    locked : the action of an IL event period that runs a locked plan: the controller does
        not decide (a filter still measures) and returns it unchanged; None: decide.
    """

    x_degc: FloatArray
    forecast: Forecast
    peak_floor_kw: float
    allowance_carry_steps: int = 0
    measured_zone_temp_degc: FloatArray | None = None
    plan: Any = None
    baseline_power_kw: float | None = None
    baseline_ahead_kw: FloatArray | None = None
    previous_power_kw: float | None = None
    delivered_flow_kg_s: FloatArray | None = None
    committed_reserve_kg_s: FloatArray | None = None
    meter_ratio: float = math.nan
    meter_offset_kw: FloatArray | None = None
    previous_flow_kg_s: FloatArray | None = None
    locked: Action | None = None


class Controller(Protocol):
    """A controller the closed loop, the service and the fleet drive through one
    :class:`hvacflex.sim.step.ControlStep`, and checkpoint: :meth:`act`, :meth:`get_state`,
    :meth:`set_state`.

    Everything a period needs arrives in its :class:`PeriodInputs`; everything a decision
    made (its plan, the model it planned with) leaves in its :class:`Action`. Two attributes
    describe a controller to its driver: :attr:`takes_measurements` and
    :attr:`commits_ahead`. A rule-based controller subclasses it and writes :meth:`act`
    (its action from :func:`hvacflex.control.baselines.rule_action`) and the state pair.
    """

    takes_measurements: bool = False
    """True when :meth:`act` needs ``measured_zone_temp_degc`` (a filter)."""

    commits_ahead: int = 0
    """g: the controller offers the reserve of a period g periods ahead
    (``Action.offer_ahead``) and plans with the commitments of the next g periods fixed
    (``PeriodInputs.committed_reserve_kg_s``); 0: each period's offer is decided at its
    start."""

    def act(self, inputs: PeriodInputs) -> Action:
        """Decide the action for the period starting now from its :class:`PeriodInputs`
        (or, for a locked IL event period, ``inputs.locked``: measure and return it)."""
        ...

    def get_state(self) -> dict[str, Any]:
        """State needed to resume identically, as data (:mod:`hvacflex.state`)."""
        ...

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore the state returned by :meth:`get_state`."""
        ...


@runtime_checkable
class WarmRestart(Protocol):
    """A controller that keeps live solver state beyond what :meth:`Controller.get_state`
    returns (the MPC's HiGHS handle)."""

    def restart_warm(self) -> None:
        """Continue as a run resumed from ``get_state`` would: drop the live solver state and
        keep what restarts it (the closed loop calls this at every checkpoint, so a resumed
        run equals an uninterrupted one bit for bit)."""
        ...
