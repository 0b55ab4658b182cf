"""Reserve offers sized to what the settlement would see (docs/explanation/il_events.md).

An MPC plan's reserve flows r_j become offers here: the plan's flows snapped onto the
physical limits, each step's capacity q_j·r_j cut to what the settlement baselines would
see of it (:class:`~hvacflex.opt.OfferBaselines`, the LP's own formula), the offer committed
g periods ahead and the event plan an activation starting now locks. An
:class:`OfferSizer` is made per period from the period's inputs (the driver's baselines, ρ)
and the plan the period before made; it holds no state across periods.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hvacflex.control.base import EventPlan, FloatArray, PeriodInputs, ReserveOffer
from hvacflex.control.problem_builder import PlanContract
from hvacflex.opt import OfferBaselines, RMPCProblem, RMPCSolution
from hvacflex.opt.problem import BoolArray

RESERVE_FLOW_TOLERANCE_KG_S = 1e-6
"""Reserve flows below this are zero up to the solver's tolerance and are not offered."""

FLOW_SNAP_TOLERANCE_KG_S = 1e-9
"""A planned flow this close to a limit is the limit (the LP's round-off; a flow of 1e-13
kg/s above an unoccupied zero would start the fan)."""

BASELINE_TOLERANCE_KW = 1e-6
"""An offer that exceeds what the baseline would see by no more than this is kept [kW]."""


def snapped_flows_kg_s(
    problem: RMPCProblem, solution: RMPCSolution, steps: int, flow_max_kg_s: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(steps, m) each: the plan's u and r of the first ``steps`` steps snapped onto the
    physical limits (u_min ≤ u − r, u ≤ u_max = ``flow_max_kg_s`` (m,) [kg/s]; u within
    ``FLOW_SNAP_TOLERANCE_KG_S`` of a limit is the limit; r below the solver tolerance is
    0)."""
    low = np.asarray(problem.u_min, dtype=float)[:steps]
    high = np.broadcast_to(flow_max_kg_s, low.shape)
    flow = np.clip(solution.u[:steps], low, high)
    flow = np.where(flow - low < FLOW_SNAP_TOLERANCE_KG_S, low, flow)
    flow = np.where(high - flow < FLOW_SNAP_TOLERANCE_KG_S, high, flow)
    reserve = np.clip(solution.r[:steps], 0.0, flow - low)
    reserve[reserve < RESERVE_FLOW_TOLERANCE_KG_S] = 0.0
    return flow, reserve


def offer_steps(contract: PlanContract) -> int:
    """J: the plan's steps 0 … J − 1 an offer may be sized for — now (g = 0), the committed
    one g and, under the event model, the event plan's D + R."""
    reserve = contract.reserve
    events = reserve.event_max_steps
    event_steps = 1 if events is None else events + reserve.event_recovery_steps
    return min(max(contract.commit_ahead + 1, event_steps), contract.config.horizon_steps)


@dataclass(frozen=True)
class OfferSizer:
    """The period's offers from its plan (see the module docstring).

    Attributes
    ----------
    contract : the building's plan contract (mask, IL contract, g).
    baseline_kw : the metered baseline of an activation starting now [kW] (NaN: none;
        None: unknown to the driver).
    baseline_ahead_kw : (J,) the ``similar-days`` baselines of the coming periods (None:
        ``pre-event`` or unknown).
    previous_planned_kw : the power the plan made the period before planned for now [kW]
        (None: no such fresh plan).
    meter_ratio : ρ the offers are sized with (NaN: not scaled).
    """

    contract: PlanContract
    baseline_kw: float | None
    baseline_ahead_kw: FloatArray | None
    previous_planned_kw: float | None
    meter_ratio: float

    @classmethod
    def of(
        cls, contract: PlanContract, inputs: PeriodInputs, previous_planned_kw: float | None
    ) -> OfferSizer:
        ahead = inputs.baseline_ahead_kw
        return cls(
            contract,
            inputs.baseline_power_kw,
            None if ahead is None else np.asarray(ahead, dtype=float),
            previous_planned_kw,
            float(inputs.meter_ratio),
        )

    @property
    def scale(self) -> float:
        """ρ, or 1 where the period has none."""
        return 1.0 if math.isnan(self.meter_ratio) else self.meter_ratio

    def baselines(self, horizon: int, paid_steps: BoolArray | None = None) -> OfferBaselines:
        """The settlement baselines of the horizon's offers (event model), as the driver
        told them: its similar-days baseline where it has one, else the plan's own powers
        P̂_{s−1} and, for the starts s = 0, :meth:`baseline_now`. The LP pays only what
        they see at ``paid_steps`` (``[reserve] plan_visible_offers``) and
        :meth:`visible_offers_kw` sizes the offers to them."""
        reserve = self.contract.reserve
        assert reserve.event_max_steps is not None
        fixed = np.full(horizon, np.nan)
        on_plan = np.zeros(horizon, dtype=bool)
        planned = np.ones(horizon, dtype=bool)
        ahead = self.baseline_ahead_kw
        known = 0 if ahead is None else min(len(ahead), horizon)
        if ahead is not None:
            similar = np.isfinite(ahead[:known])
            fixed[:known][similar] = ahead[:known][similar]
            planned[:known][similar] = False
        now = self.baseline_now()
        if now is not None:
            kind, value = now
            starts_now = np.arange(horizon) < reserve.event_max_steps
            starts_now &= planned  # a similar-days baseline replaces the pre-event ones
            fixed[starts_now] = value
            on_plan[starts_now] = kind == "planned"
        return OfferBaselines(
            meter_ratio=self.scale,
            fixed_baseline_kw=fixed,
            fixed_on_plan_scale=on_plan,
            planned_baselines=planned,
            offer_steps=paid_steps,
            tolerance_kw=BASELINE_TOLERANCE_KW,
        )

    def baseline_now(self) -> tuple[str, float] | None:
        """The baseline of an activation starting now: ``("planned", P̂)``, the plan made for
        the period before, where that is known and at least the metered B (the affine model
        runs above the metered power: the fan secant, so the plan's own power is the
        baseline on the scale of the curtailed power it is compared with); else
        ``("metered", B)`` (−inf where B is NaN, the run's first period: nothing is seen);
        None: unknown to the driver (that start is skipped)."""
        baseline = self.baseline_kw
        if baseline is None:
            return None
        if not np.isfinite(baseline):
            return ("metered", -np.inf)
        previous = self.previous_planned_kw
        if previous is not None and previous >= baseline:
            return ("planned", previous)
        return ("metered", baseline)

    def seen_kw(self, problem: RMPCProblem, solution: RMPCSolution) -> FloatArray | None:
        """(N,) how far below every baseline of the problem's offer baselines the plan's
        power would fall if each step shed all it could, u − u_min on the reserve zones
        [kW]: negative where no offer could be seen (None without offer baselines)."""
        baselines = problem.offer_baselines
        max_steps = self.contract.reserve.event_max_steps
        if baselines is None or max_steps is None:
            return None
        room = np.where(
            self.contract.reserve_mask, np.maximum(solution.u - problem.u_min, 0.0), 0.0
        )
        return baselines.seen_kw(
            solution.power_kw,
            np.einsum("km,km->k", problem.power_coeff_kw_per_kg_s, room),
            np.full(problem.horizon, np.inf),
            min(max_steps, problem.horizon),
        )

    def visible_offers_kw(
        self, problem: RMPCProblem, served_kw: FloatArray, reserve_flow_kg_s: FloatArray
    ) -> FloatArray:
        """(J,) the capacity offered for each step j < J with reserve flows r_j
        (``reserve_flow_kg_s`` (J, m)) [kg/s]: q_j·r_j, but no more than the settlement
        baselines would see of it [kW], at least 0.

        An activation covering step j starts at some s ∈ [j − D + 1, j] (s ≥ 0) and is settled
        against the power of the period before s (``pre-event``): the plan's served power
        P̂_{s−1} for s ≥ 1, and :meth:`baseline_now` for s = 0 (skipped where unknown).
        Under ``similar-days`` the baseline of step j is the driver's (the metered power of
        earlier similar days, whenever the activation starts), and the pre-event ones apply
        only where it has none (no similar day yet, as in the settlement). The curtailed
        power must show the offer below every such baseline
        (:meth:`~hvacflex.opt.problem.OfferBaselines.seen_kw` of :meth:`baselines`):
        a period whose air handler was off before, a rising morning load, show less. ρ ∈
        [0, 1] is the meter's response to the plan's power (the problem's q carries it
        too): a change of the plan's power shows as ρ times it on the meter, so the gap to
        a baseline of the plan's own is ρ·(P̂_{s−1} − P̂_j), and to a metered baseline B (its
        level against the plan's level, as without ρ) B − P̂_j. ``served_kw`` (N,) is the
        plan's P̂ [kW]. The whole-horizon model (the paper's) offers q_j·r_j unchecked."""
        served = np.asarray(served_kw, dtype=float)
        steps = reserve_flow_kg_s.shape[0]
        offer_kw = np.einsum("km,km->k", problem.reserve_kw_per_kg_s[:steps], reserve_flow_kg_s)
        max_steps = self.contract.reserve.event_max_steps
        if max_steps is None:
            visible: FloatArray = np.maximum(offer_kw, 0.0)
            return visible
        horizon = problem.horizon
        shed_kw = np.zeros(horizon)
        shed_kw[:steps] = np.einsum(
            "km,km->k", problem.power_coeff_kw_per_kg_s[:steps], reserve_flow_kg_s
        )
        offers_kw = np.zeros(horizon)
        offers_kw[:steps] = offer_kw
        seen = self.baselines(horizon).seen_kw(served, shed_kw, offers_kw, min(max_steps, horizon))
        visible = np.maximum(seen[:steps], 0.0)
        return visible

    def offer_ahead(self, reserves: FloatArray, visible_kw: FloatArray) -> ReserveOffer | None:
        """The offer committed now for the period g steps ahead: the plan's snapped r_g
        (``reserves`` (J, m)), sized to what the baseline would see (``visible_kw`` (J,),
        :meth:`visible_offers_kw`); None without commitments."""
        g = self.contract.commit_ahead
        if not g:
            return None
        offer_kw = float(visible_kw[g])
        flow = reserves[g] if offer_kw > 0.0 else np.zeros_like(reserves[g])
        return ReserveOffer(flow_kg_s=flow, reserve_kw=offer_kw, meter_ratio=self.meter_ratio)

    def event_plan(
        self,
        problem: RMPCProblem,
        solution: RMPCSolution,
        flows: FloatArray,
        reserves: FloatArray,
        visible_kw: FloatArray,
    ) -> EventPlan | None:
        """The first D + R steps of an optimal plan, for an IL event starting now, from its
        snapped flows and reserve flows (J, m) and their visible offers (J,)
        (:meth:`visible_offers_kw`). ``None`` under the whole-horizon model (an activation
        then curtails each period's fresh plan).
        """
        reserve, g = self.contract.reserve, self.contract.commit_ahead
        if reserve.event_max_steps is None:
            return None
        steps = min(reserve.event_max_steps + reserve.event_recovery_steps, solution.u.shape[0])
        flow, flow_reserve = flows[:steps], reserves[:steps].copy()
        reserve_coeff = np.asarray(problem.reserve_kw_per_kg_s, dtype=float)[:steps]
        offer_kw = np.einsum("km,km->k", reserve_coeff, flow_reserve)
        # committed steps (< g) were offered before; the others are offered from this plan
        end = steps if g else min(reserve.event_max_steps, steps)
        checked = slice(g, end)
        offer_kw[checked] = visible_kw[checked]
        flow_reserve[checked][visible_kw[checked] <= 0.0] = 0.0
        coeff = np.asarray(problem.power_coeff_kw_per_kg_s, dtype=float)[:steps]
        offset = np.asarray(problem.power_offset_kw, dtype=float)[:steps]
        c = self.contract.model.c
        return EventPlan(
            flow_kg_s=flow,
            reserve_flow_kg_s=flow_reserve,
            served_power_kw=offset + np.einsum("km,km->k", coeff, flow),
            reserve_kw=offer_kw,
            predicted_served_degc=solution.x_served[1 : steps + 1] @ c.T,
            predicted_curtailed_degc=solution.x_curtailed[1 : steps + 1] @ c.T,
            meter_ratio=self.meter_ratio,
        )


def seen_steps(seen_kw: FloatArray | None, shift: int, horizon: int) -> BoolArray | None:
    """(N,) bool: the steps at which the last plan could have shown an offer — shedding
    all it could (u − u_min) would have reached every baseline (``seen_kw`` ≥ 0,
    :meth:`OfferSizer.seen_kw` of that plan, moved on by ``shift`` periods, its last step
    repeated); None (every step) without such a plan. The others — an air handler off
    before, a start-up steeper than any shed — are not paid at all, rather than charged
    for a rise no offer could show."""
    if seen_kw is None:
        return None
    moved = np.concatenate([seen_kw[shift:], np.repeat(seen_kw[-1:], min(shift, seen_kw.size))])
    steps: BoolArray = moved[:horizon] >= 0.0
    return steps
