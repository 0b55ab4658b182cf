r"""The feature blocks of an :class:`~hvacflex.opt.problem.RMPCProblem` (docs/explanation/model.md
§3).

The problem's core holds what every robust mode reads (model, forecast, prices, power model,
bounds, peak term, slack, reserve mask and coefficient). Each feature that only some problems
have is one frozen dataclass here, a field of the problem that is ``None`` when the feature is
off, validated on its own in ``__post_init__`` and against the core in ``check`` (the problem
calls it), and built into the LP by its own ``add_…`` family (:data:`FEATURE_BLOCKS` names it):

* ``events``: :class:`ILEventModel` → :func:`hvacflex.opt.lp.add_il_event_comfort`;
* ``commitments``: :class:`ReserveCommitment` → :func:`hvacflex.opt.lp.add_committed_reserve`;
* ``offer_baselines``: :class:`OfferBaselines` → :func:`hvacflex.opt.lp.add_visible_offers`;
* ``power_cap``: :class:`PowerCap` → :func:`hvacflex.opt.lp.add_power_cap`;
* ``comfort_knee``: :class:`ComfortKnee` → :func:`hvacflex.opt.lp.add_comfort_knee`;
* ``step_linearisation``: :class:`StepLinearisation` →
  :func:`hvacflex.opt.lp.add_input_coefficients`;
* ``feedback``: :class:`~hvacflex.opt.options.FeedbackOptions` →
  :func:`hvacflex.opt.feedback.build_feedback_lp` (its own LP).

A new feature is one more block here, one more ``add_…`` family, one more entry in
:data:`FEATURE_BLOCKS` — never a field on the core.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hvacflex.errors import ProblemError
from hvacflex.opt.checks import check_nonnegative, float_array, integer_in_range
from hvacflex.opt.options import FeedbackOptions

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: A committed reserve flow may exceed the room u_max − u_min by this much (round-off) [kg/s].
FIXED_RESERVE_TOLERANCE_KG_S = 1e-9

_SOURCE = "RMPCProblem"


def _matrix(field: str, value: object, shape: str, hint: str) -> FloatArray:
    """``value`` as a float array of two dimensions (``shape`` names them in the error),
    finite (:func:`~hvacflex.opt.checks.float_array`)."""
    array = np.asarray(value)
    if array.ndim != 2:
        raise ProblemError(
            f"wrong shape: expected {shape}, got {array.shape}",
            source=_SOURCE,
            field=field,
            hint=hint,
        )
    return float_array(field, array, (array.shape,))


@dataclass(frozen=True, kw_only=True)
class ILEventModel:
    """The IL event model (:mod:`hvacflex.opt.events`): at most one event of ≤ D curtailed
    steps, with an allowance α on the upper comfort bound during it and R steps after it.
    Without it (``RMPCProblem.events`` None) the problem has the paper's whole-horizon model
    (curtailed trajectory for all N steps, strict band).

    Parameters
    ----------
    max_steps : D ≥ 1, the longest IL event [steps] (≤ N, checked against the problem)
    allowance_kelvin : α ≥ 0 [K] added to the upper comfort bound during an event and R steps
        after it
    recovery_steps : R ≥ 0 [steps]
    carry_steps : c ≥ 0 (≤ N): outputs 1..c are the recovery from a real curtailment and get
        the decaying allowance α·min(1, (c − t + 1)/(R + 1)) under every pattern, the served
        plan included
    """

    max_steps: int
    allowance_kelvin: float = 0.0
    recovery_steps: int = 0
    carry_steps: int = 0

    def __post_init__(self) -> None:
        integer_in_range(
            "events.max_steps",
            self.max_steps,
            1,
            None,
            "D is the longest event in steps, 1 ≤ D ≤ N; events=None = whole-horizon model",
        )
        alpha = self.allowance_kelvin
        if not isinstance(alpha, int | float) or isinstance(alpha, bool) or not np.isfinite(alpha):
            raise ProblemError(
                "must be a finite number of kelvin",
                source=_SOURCE,
                field="events.allowance_kelvin",
                value=alpha,
            )
        if alpha < 0:
            raise ProblemError(
                "the event allowance α must be ≥ 0 K",
                source=_SOURCE,
                field="events.allowance_kelvin",
                value=alpha,
                hint="α widens the upper comfort bound during an event and its recovery",
            )
        integer_in_range(
            "events.recovery_steps",
            self.recovery_steps,
            0,
            None,
            "R steps after an event keep the allowance α",
        )
        integer_in_range(
            "events.carry_steps",
            self.carry_steps,
            0,
            None,
            "outputs 1..c keep α under every pattern (recovery of an event that just ended)",
        )

    def check(self, *, horizon: int, robust: str, b_reserve: FloatArray) -> None:
        """Refuse D or c beyond the horizon N, the dual and feedback forms, and heating
        reserve (``b_reserve`` (n, m_r), the reserve-carrying columns of B)."""
        integer_in_range(
            "events.max_steps",
            self.max_steps,
            1,
            horizon,
            f"D is the longest event in steps, 1 ≤ D ≤ N = {horizon}; events=None = "
            "whole-horizon model",
        )
        integer_in_range(
            "events.carry_steps",
            self.carry_steps,
            0,
            horizon,
            "outputs 1..c keep α under every pattern (recovery of an event that just ended)",
        )
        if robust == "dual":
            raise ProblemError(
                "the event model is not offered in the dual form (≈ N² event rows, each with "
                "its own λ's: too large)",
                source=_SOURCE,
                field="robust",
                value=robust,
                hint="use robust='tightening' (same optimum)",
            )
        if robust == "feedback":
            raise ProblemError(
                "the event model is not supported with affine disturbance feedback yet",
                source=_SOURCE,
                field="robust",
                value=robust,
                hint="use robust='tightening', or events=None for feedback",
            )
        if (b_reserve > 0).any():
            raise ProblemError(
                "the event model covers cooling reserve only (reserve-carrying columns of B ≤ 0)",
                source=_SOURCE,
                field="b_matrix",
                hint="offer reserve on cooling inputs, or use events=None",
            )


@dataclass(frozen=True, eq=False, kw_only=True)
class ReserveCommitment:
    """The reserve flows already committed to the market (offers are firm g periods ahead,
    docs/explanation/il_events.md); the LP takes r_0 … r_{g−1} as fixed (column bounds r_k = value).

    Parameters
    ----------
    reserve_kg_s : (g, m), 0 ≤ g < N, the committed reserve flows [kg/s]: ≥ 0, 0 outside the
        problem's ``reserve_mask``, ≤ u_max − u_min (checked against the problem)
    """

    reserve_kg_s: FloatArray

    def __post_init__(self) -> None:
        array = _matrix(
            "commitments.reserve_kg_s",
            self.reserve_kg_s,
            "(g, m)",
            "one row of committed reserve flows per committed step",
        )
        check_nonnegative("commitments.reserve_kg_s", array, "committed reserve flows")
        object.__setattr__(self, "reserve_kg_s", array)

    @property
    def steps(self) -> int:
        """g, the number of leading steps whose reserve is committed."""
        return int(self.reserve_kg_s.shape[0])

    def check(
        self, *, horizon: int, u_min: FloatArray, u_max: FloatArray, reserve_mask: BoolArray
    ) -> None:
        """Refuse g ≥ N, a wrong number of inputs, and flows that cannot be shed (``u_min``,
        ``u_max`` (N, m) [kg/s], ``reserve_mask`` (m,) bool)."""
        m = reserve_mask.size
        float_array(
            "commitments.reserve_kg_s", self.reserve_kg_s, tuple((g, m) for g in range(horizon))
        )
        array = self.reserve_kg_s
        room = (u_max - u_min)[: array.shape[0]]
        bad = (array > room + FIXED_RESERVE_TOLERANCE_KG_S) | ((array > 0) & ~reserve_mask)
        if bad.any():
            index = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ProblemError(
                f"committed reserve flow {float(array[index])!r} kg/s at (step, input) "
                f"{index} cannot be shed (room {float(room[index])!r} kg/s, reserve allowed: "
                f"{bool(reserve_mask[index[1]])})",
                source=_SOURCE,
                field="commitments.reserve_kg_s",
                hint="commit only reserve the zone can shed: 0 ≤ r ≤ u_max − u_min, 0 where masked",
            )


@dataclass(frozen=True, eq=False, kw_only=True)
class PowerCap:
    """A cap on the plan's power P_k [kW] (a column bound), e.g. a feeder's share
    (:mod:`hvacflex.fleet`). Open loop only.

    Parameters
    ----------
    power_max_kw : scalar or (N,) [kW]; +inf = no cap in that step. The problem stores it
        broadcast to (N,).
    """

    power_max_kw: float | FloatArray

    def __post_init__(self) -> None:
        value = np.asarray(self.power_max_kw)
        cap = float_array("power_cap.power_max_kw", value, (value.shape,), allow_pos_inf=True)
        if cap.ndim > 1:
            raise ProblemError(
                f"wrong shape: expected () or (N,), got {cap.shape}",
                source=_SOURCE,
                field="power_cap.power_max_kw",
                hint="one cap for all steps, or one per step",
            )
        object.__setattr__(self, "power_max_kw", cap)

    def over(self, horizon: int) -> PowerCap:
        """This cap broadcast to (N,) = ``horizon`` steps (refused if it has another length)."""
        cap = float_array(
            "power_cap.power_max_kw",
            self.power_max_kw,
            ((), (horizon,)),
            target=(horizon,),
            allow_pos_inf=True,
        )
        return PowerCap(power_max_kw=cap)

    def check(self, *, robust: str) -> None:
        """A finite cap applies only to the open-loop problem."""
        if robust == "feedback" and np.isfinite(self.power_max_kw).any():
            raise ProblemError(
                "a power cap applies only to the open-loop problem",
                source=_SOURCE,
                field="power_cap",
                hint="leave power_cap None with robust='feedback'",
            )

    @property
    def kw(self) -> FloatArray:
        """The cap as a float array [kW] ((N,) once checked by the problem)."""
        return np.asarray(self.power_max_kw, dtype=np.float64)


@dataclass(frozen=True, kw_only=True)
class ComfortKnee:
    """A comfort penalty that grows with the excursion: each zone's slack ε_k [K] costs the
    problem's ρ up to ``knee_kelvin`` and ``penalty_beyond_sgd_per_kelvin_hour`` beyond it
    (piecewise linear and convex, so the plan spreads a violation over zones and periods
    rather than putting it all where a kW buys least). None on the problem: ρ on all of ε.

    Parameters
    ----------
    knee_kelvin : δ ≥ 0 [K], the excursion priced at ρ
    penalty_beyond_sgd_per_kelvin_hour : ρ₂ ≥ ρ [SGD per K·h], the price of ε beyond δ
    """

    knee_kelvin: float
    penalty_beyond_sgd_per_kelvin_hour: float

    def __post_init__(self) -> None:
        for name, hint in (
            ("knee_kelvin", "the excursion [K] priced at ρ, e.g. 0.5"),
            ("penalty_beyond_sgd_per_kelvin_hour", "ρ₂ [SGD per K·h] ≥ ρ, e.g. 1000"),
        ):
            value = getattr(self, name)
            number = float(value) if isinstance(value, numbers.Real) else math.nan
            if isinstance(value, bool) or not math.isfinite(number) or number < 0:
                raise ProblemError(
                    "must be a finite number ≥ 0",
                    source=_SOURCE,
                    field=f"comfort_knee.{name}",
                    value=value,
                    hint=hint,
                )
            object.__setattr__(self, name, number)

    def check(self, *, rho: float) -> None:
        """ρ₂ ≥ ρ (the problem's comfort penalty [SGD per K·h]): a cheaper price beyond the
        knee would not be convex (the LP would fill the slack beyond it first)."""
        if self.penalty_beyond_sgd_per_kelvin_hour < rho:
            raise ProblemError(
                f"must be ≥ the comfort penalty ρ = {rho:g} SGD per K·h (convex)",
                source=_SOURCE,
                field="comfort_knee.penalty_beyond_sgd_per_kelvin_hour",
                value=self.penalty_beyond_sgd_per_kelvin_hour,
                hint="raise it to at least ρ, or lower the comfort penalty",
            )

    def surcharge_sgd_per_kelvin_hour(self, rho: float) -> float:
        """ρ₂ − ρ: what a kelvin-hour of slack beyond the knee costs on top of ρ."""
        return self.penalty_beyond_sgd_per_kelvin_hour - rho


@dataclass(frozen=True, eq=False, kw_only=True)
class OfferBaselines:
    """The settlement baselines that each step's reserve offer is measured against.

    An activation covering step k starts at some s ∈ [k − D + 1, k] and is settled against
    the power of the period before s (docs/explanation/il_events.md, "Offers that can be
    delivered"). For s ≥ 1 that is the plan's own power P_{s−1}, which the LP decides; for s = 0, or
    under a similar-days rule, a baseline the plan does not decide. The LP pays the reserve
    of step k for ``R_k = min(q_k·r_k, what every such baseline sees)`` only
    (:func:`hvacflex.opt.lp.add_visible_offers`), so the plan may shape its load to be
    seen, at the cost of the energy that takes.

    Parameters
    ----------
    meter_ratio : ρ ∈ [0, 1], the meter's change per kW of the plan's change
        (:mod:`hvacflex.control.meter_response`; 1 = the plan's own scale)
    fixed_baseline_kw : (N,) the baseline of step k that the plan does not decide [kW]: on
        the plan's scale (``fixed_on_plan_scale``: the plan made for the period before,
        compared as a change, ρ·(B − P_k + p_k·r_k)) or metered (a level against the plan's
        level, B − P_k + ρ·p_k·r_k); NaN = none, −inf = nothing can be seen (R_k = 0)
    fixed_on_plan_scale : (N,) bool, see ``fixed_baseline_kw``
    planned_baselines : (N,) bool, whether the plan's powers P_{s−1} of the starts
        s ∈ [max(1, k − D + 1), k] are baselines of step k (False where a similar-days
        baseline replaces them)
    offer_steps : (N,) bool, the steps that may be paid at all: elsewhere R_k = 0 and the
        baselines do not enter the LP (the controller leaves out the steps whose load the
        previous plan could not show, e.g. the morning start-up; default every step)
    tolerance_kw : added to every baseline [kW] (round-off)
    """

    meter_ratio: float
    fixed_baseline_kw: FloatArray
    fixed_on_plan_scale: BoolArray
    planned_baselines: BoolArray
    offer_steps: BoolArray | None = None
    tolerance_kw: float = 0.0

    def __post_init__(self) -> None:
        ratio = float(self.meter_ratio)
        if not 0.0 <= ratio <= 1.0:
            raise ProblemError(
                "the meter ratio ρ must lie in [0, 1]",
                source=_SOURCE,
                field="offer_baselines.meter_ratio",
                value=ratio,
                hint="pass the clipped slope of hvacflex.control.meter_response",
            )
        fixed = np.array(self.fixed_baseline_kw, dtype=float)
        horizon = fixed.size
        shapes = ((horizon,),)
        if fixed.ndim != 1 or np.isposinf(fixed).any():
            raise ProblemError(
                "fixed baselines must be a 1-D series of finite values, NaN or −inf",
                source=_SOURCE,
                field="offer_baselines.fixed_baseline_kw",
                hint="NaN where step k has no such baseline, −inf where nothing is seen",
            )
        if self.offer_steps is None:
            object.__setattr__(self, "offer_steps", np.ones(horizon, dtype=bool))
        for name in ("fixed_on_plan_scale", "planned_baselines", "offer_steps"):
            flags = np.array(getattr(self, name), dtype=bool)
            if flags.shape not in shapes:
                raise ProblemError(
                    f"{name} has shape {flags.shape}, expected {(horizon,)}",
                    source=_SOURCE,
                    field=f"offer_baselines.{name}",
                    hint="one flag per step",
                )
            flags.setflags(write=False)
            object.__setattr__(self, name, flags)
        fixed.setflags(write=False)
        object.__setattr__(self, "fixed_baseline_kw", fixed)
        object.__setattr__(self, "meter_ratio", ratio)

    @property
    def horizon(self) -> int:
        """N, the number of steps."""
        return int(self.fixed_baseline_kw.size)

    def check(self, *, horizon: int, events: ILEventModel | None, robust: str) -> None:
        """Offer baselines need the open-loop event model and one entry per step."""
        if events is None or robust == "feedback":
            raise ProblemError(
                "offer baselines need the IL event model and the open-loop LP",
                source=_SOURCE,
                field="offer_baselines",
                hint="set events (and not robust='feedback'), or pass None",
            )
        if self.horizon != horizon:
            raise ProblemError(
                f"offer baselines cover {self.horizon} steps, the horizon is {horizon}",
                source=_SOURCE,
                field="offer_baselines",
                hint="one fixed baseline and one planned-baseline flag per step",
            )

    def seen_kw(
        self, power_kw: FloatArray, shed_kw: FloatArray, offer_kw: FloatArray, max_steps: int
    ) -> FloatArray:
        """(N,) what the baselines see of each step's offer, ``min(offer, every baseline's
        gap + ρ·shed)`` [kW] — negative where even the shed does not reach the lowest
        baseline (the rows of :func:`hvacflex.opt.lp.add_visible_offers` at a plan).

        ``power_kw`` (N,) the plan's served power P̂, ``shed_kw`` (N,) its p_k·r_k, ``offer_kw``
        (N,) q_k·r_k (already on the meter's scale), D = ``max_steps``.
        """
        rho = self.meter_ratio
        power = np.asarray(power_kw, dtype=float)
        shed = rho * np.asarray(shed_kw, dtype=float)  # what the meter shows of the shed
        gaps = np.full(power.shape, np.inf)
        fixed = self.fixed_baseline_kw
        known = ~np.isnan(fixed)
        level = np.where(self.fixed_on_plan_scale, rho, 1.0)
        with np.errstate(invalid="ignore"):  # −inf baselines: nothing is seen
            gaps[known] = (level * (fixed - power) + shed)[known]
        for lag in range(1, max_steps + 1):
            steps = np.flatnonzero(self.planned_baselines[lag:]) + lag
            own = rho * (power[steps - lag] - power[steps]) + shed[steps]
            gaps[steps] = np.minimum(gaps[steps], own)
        seen: FloatArray = np.minimum(np.asarray(offer_kw, dtype=float), gaps + self.tolerance_kw)
        return seen


@dataclass(frozen=True, eq=False, kw_only=True)
class StepLinearisation:
    """Each step's supply-air term linearised at its own zone temperature T_k
    (``[controller] linearisation = "plan"``): the dynamics' input matrix of step k is
    B diag(s_k), for u_k in the served and u_k − r_k in the curtailed trajectory and the IL
    events, with s_k = (T_k − T_s) / (T₀ − T_s) the supply air's cooling per kg/s at T_k
    relative to B's at T₀ (:func:`hvacflex.control.problem_builder.plan_input_scale`). A is
    unchanged (the same ṁ_ref), so the margins are the problem's. Open loop only: the
    feedback LP's responses assume one B. Its LP family is the input coefficients of the
    dynamics (:func:`hvacflex.opt.lp.add_input_coefficients`).

    Parameters
    ----------
    input_scale : (N, m) s_k > 0 [-]
    """

    input_scale: FloatArray

    def __post_init__(self) -> None:
        scale = _matrix(
            "step_linearisation.input_scale", self.input_scale, "(N, m)", "one per step and input"
        )
        if not np.all(scale > 0.0):
            raise ProblemError(
                "must be > 0 (the supply air cools at every step)",
                source=_SOURCE,
                field="step_linearisation.input_scale",
                value=float(scale.min()),
                hint="(T_k − T_s) / (T₀ − T_s) with each T_k above the supply air",
            )
        object.__setattr__(self, "input_scale", scale)

    def check(self, *, horizon: int, m: int, robust: str) -> None:
        """One scale per step and input of the problem; not with robust="feedback"."""
        if self.input_scale.shape != (horizon, m):
            raise ProblemError(
                f"wrong shape: expected ({horizon}, {m}), got {self.input_scale.shape}",
                source=_SOURCE,
                field="step_linearisation.input_scale",
                hint="one scale per step of the horizon and input",
            )
        if robust == "feedback":
            raise ProblemError(
                "a step-varying input scale is not supported by the affine-feedback LP",
                source=_SOURCE,
                field="step_linearisation",
                hint="leave step_linearisation None with robust='feedback' (one B)",
            )


FEATURE_BLOCKS: dict[str, type] = {
    "events": ILEventModel,
    "commitments": ReserveCommitment,
    "offer_baselines": OfferBaselines,
    "power_cap": PowerCap,
    "comfort_knee": ComfortKnee,
    "step_linearisation": StepLinearisation,
    "feedback": FeedbackOptions,
}
"""The problem's feature fields and their blocks (each ``None`` = the feature is off)."""
