r"""Each step of the horizon linearised at the previous plan's zone temperature
(``[controller] linearisation = "plan"``, docs/explanation/estimation.md §3).

The model's bilinear supply-air term ṁ c_p (T_s − T_r) is linearised about (ṁ_ref, T₀)
(:func:`hvacflex.building.discretize.linearize`). About (ṁ_ref, T_k) instead, A stays (the
same ṁ_ref), B's zone column c_p (T_s − T₀) / C becomes c_p (T_s − T_k) / C through the same
ZOH integral, and the affine term moves with ṁ_ref::

    B_k = B diag(s_k),   s_k = (T_k − T_s) / (T₀ − T_s),   g_k = g − B diag(s_k − 1) ṁ_ref

T_k is the previous plan's zone temperature over step k, one step on
(:func:`~hvacflex.control.trajectory.shifted_operating_points`); the problem takes B_k as
the :class:`~hvacflex.opt.StepLinearisation` block and the design curves' power rows at
T_k (:mod:`hvacflex.control.problem_builder`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hvacflex.building.discretize import LinearModel
from hvacflex.control.base import FloatArray
from hvacflex.control.estimation import StepModel
from hvacflex.control.trajectory import (
    MIN_SUPPLY_DIFFERENCE_K,
    StepMatrices,
    shifted_operating_points,
)
from hvacflex.opt import RMPCProblem, RMPCSolution, StepLinearisation


@dataclass(frozen=True)
class PlanLinearisation:
    """A problem's steps linearised along a plan: the zone temperatures (N, m) [°C], the
    LP block B diag(s_k), and g_k − g (N, n) [K] (None where ṁ_ref = 0: g unchanged)."""

    zone_temps_degc: FloatArray
    block: StepLinearisation
    affine_shift: FloatArray | None


def plan_linearisation(
    model: LinearModel, plan: RMPCSolution | None, x_degc: FloatArray, horizon: int
) -> PlanLinearisation | None:
    """The N = ``horizon`` steps linearised along ``plan`` (the previous period's, fresh)
    from the state ``x_degc`` (n,) [°C] now; None without a plan of this horizon."""
    temps = plan_zone_temps_degc(model, plan, x_degc, horizon)
    if temps is None:
        return None
    scale = plan_input_scale(model, temps)
    shift = plan_affine_shift(model, scale) if np.any(model.flow_ref_kg_s) else None
    return PlanLinearisation(temps, StepLinearisation(input_scale=scale), shift)


def plan_zone_temps_degc(
    model: LinearModel, plan: RMPCSolution | None, x_degc: FloatArray, horizon: int
) -> FloatArray | None:
    """(N, m) zone temperatures each step is linearised at [°C]: ``plan``'s served zone
    temperatures over each step (the mean of its start and end), one step on — the first
    step from the state ``x_degc`` (n,) now, the last step's end repeated
    (:func:`~hvacflex.control.trajectory.shifted_operating_points`); None without a plan of
    this horizon."""
    if plan is None or plan.x_served.shape[0] != horizon + 1:
        return None
    served_degc = plan.x_served @ model.c.T  # (N + 1, m): the start, then each step's end
    now_degc = model.c @ np.asarray(x_degc, dtype=float)
    _, temps_degc = shifted_operating_points(plan.u, served_degc, now_degc, horizon)
    return temps_degc


def plan_input_scale(model: LinearModel, zone_temps_degc: FloatArray) -> FloatArray:
    """(N, m) s_k = (T_k − T_s) / (T₀ − T_s): the supply air's cooling per kg/s at each
    step's zone temperature ``zone_temps_degc`` (N, m) [°C] relative to the model's at its
    T₀; zone temperatures are raised to :data:`MIN_SUPPLY_DIFFERENCE_K` above the supply
    air (the supply air always cools)."""
    supply = model.supply_temp_degc
    temps = np.maximum(zone_temps_degc, supply + MIN_SUPPLY_DIFFERENCE_K)
    scale: FloatArray = (temps - supply) / (model.linearisation_temp_degc - supply)
    return scale


def plan_affine_shift(model: LinearModel, scale: FloatArray) -> FloatArray:
    """(N, n) g_k − g [K] for the scale ``scale`` (N, m): −B diag(s_k − 1) ṁ_ref, so that
    x_{k+1} = A x_k + B ṁ_ref + B diag(s_k) (u_k − ṁ_ref) + E d_k + g (zero where
    ṁ_ref = 0)."""
    shift: FloatArray = -((scale - 1.0) * model.flow_ref_kg_s) @ model.b.T
    return shift


def planned_first_step(problem: RMPCProblem, model: StepModel) -> StepModel:
    """The one-step model ``problem``'s plan makes its first step with: ``model`` (the fixed
    model or a re-linearisation), with B diag(s_0) and g + (g_0 − g) where the problem has
    a step linearisation (``model`` then the fixed :class:`LinearModel`): what the
    prediction error, the filter and a fleet's comfort floor step with."""
    if problem.input_scale is None or not isinstance(model, LinearModel):
        return model
    scale = problem.input_scale[0]
    return StepMatrices(
        a=model.a,
        b=model.b * scale,
        e=model.e,
        g=model.g + plan_affine_shift(model, scale[None])[0],
        c=model.c,
    )
