"""HVAC electric power (paper eq. 10): fan + cooling coil + heating coil, exact and affine.

One VAV air-handling unit serves every zone with supply air at T_s. With S = Σṁ the total
supply flow [kg/s], m_oa the outdoor air (a fixed share f_oa · S, or the ventilation need
min(V_oa, S), while the damper is open — occupied periods and the pre-occupancy purge —
and 0 while it is closed: :mod:`hvacflex.building.air_handler`) and T_ret = Σ ṁ_i T_r,i / S::

    Q_sens  = c_p [Σ_i ṁ_i (T_r,i − T_s) + m_oa (T_out − T_ret)]              [W]
    Q_lat   = m_oa h_fg (W_out − W_s)⁺ + (1 − m_oa / S) L                       [W]
    P_cool  = plant(Q_sens⁺ + Q_lat, T_out),   P_heat = Q_sens⁻ / η_heat / 1000   [kW]
    P_fan   = fan(S)                                                            [kW]

``plant`` is Q / COP / 1000 (constant COP), or EnergyPlus's EIR chiller with part-load and
outdoor-temperature curves (:mod:`hvacflex.building.chiller`) where the system has one; the
fan is a power law or EnergyPlus's VAV part-load curve with its static-pressure floor.

Latent load. The coil leaves the supply air saturated at T_s (W_s = W_sat(T_s), unless the
file sets ``supply_humidity_ratio_kg_per_kg``). Assumption for the return air: at steady state
the zones' moisture balance gives S (W_return − W_s) = L / h_fg, with L the occupants' latent
gain [W]; the recirculated share (1 − m_oa/S) of that moisture reaches the coil, the rest
leaves with the relief air. L is an optional argument (default 0: return air at the supply
humidity ratio, i.e. only the outdoor air's moisture is removed); the controller's affine
model takes the term's secant over the step's flow range (it vanishes when the fan is off).

Affine model for the controller (docs/explanation/model.md §1): the coil heat is linear in ṁ at
T_r = T_ref with the outdoor air replaced by its secant a + b S over the step's flow range
[S_min, S_max] (a = 0, b = f_oa for the fixed share); the plant's power by its secant over
the coil heat of that range (the chiller's power is concave: the secant lies below it); the
fan by its secant over [S_min, S_max], above the convex curve (an upper bound, never
negative); the occupants' latent term likewise. Every secant is exact at both ends; p_k
changes every step (re-linearised along the forecast, as before).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.air_handler import (
    fan_marginal_kw_per_kg_s,
    fan_power_kw,
    fan_secant_from,
    outdoor_air_kg_s,
    outdoor_air_secant,
)
from hvacflex.building.chiller import chiller_marginal_kw_per_w, chiller_power_kw, chiller_secant
from hvacflex.building.model import HvacSystem
from hvacflex.units import CP_AIR_J_PER_KG_K, H_FG_J_PER_KG, W_PER_KW

FloatArray = NDArray[np.float64]

STANDARD_PRESSURE_PA = 101_325.0
"""Sea-level atmospheric pressure [Pa]."""

_MOLAR_MASS_RATIO = 0.621945
"""Molar mass of water over that of dry air [-]."""


def saturation_vapour_pressure_pa(temp_degc: ArrayLike) -> FloatArray:
    """Saturation vapour pressure over water, Magnus form (Alduchov & Eskridge 1996) [Pa]."""
    t = np.asarray(temp_degc, dtype=np.float64)
    out: FloatArray = 610.94 * np.exp(17.625 * t / (t + 243.04))
    return out


def saturation_humidity_ratio_kg_per_kg(
    temp_degc: ArrayLike, pressure_pa: float = STANDARD_PRESSURE_PA
) -> FloatArray:
    """Humidity ratio of saturated air [kg water / kg dry air] at ``temp_degc`` [°C]."""
    p_ws = saturation_vapour_pressure_pa(temp_degc)
    out: FloatArray = _MOLAR_MASS_RATIO * p_ws / (pressure_pa - p_ws)
    return out


def supply_humidity_ratio_kg_per_kg(hvac: HvacSystem) -> float:
    """Humidity ratio leaving the cooling coil [kg/kg]: configured, else saturated at T_s."""
    if hvac.supply_humidity_ratio_kg_per_kg is not None:
        return hvac.supply_humidity_ratio_kg_per_kg
    return float(saturation_humidity_ratio_kg_per_kg(hvac.supply_temp_degc))


@dataclass(frozen=True)
class HvacPower:
    """Components of HVAC power; every field has the broadcast time shape (...).

    Attributes
    ----------
    fan_kw, cooling_kw, heating_kw, total_kw : electric power [kW].
    coil_sensible_w, coil_latent_w : coil heat removed [W] (sensible negative = heating).
    """

    fan_kw: FloatArray
    cooling_kw: FloatArray
    heating_kw: FloatArray
    total_kw: FloatArray
    coil_sensible_w: FloatArray
    coil_latent_w: FloatArray


def plant_power_kw(
    hvac: HvacSystem, coil_heat_w: ArrayLike, outdoor_temp_degc: ArrayLike
) -> FloatArray:
    """Cooling-plant electric power [kW] for coil heat Q ≥ 0 (...) [W] at the outdoor dry
    bulb (...) [°C]: the chiller model where the system has one, else Q / COP."""
    q = np.maximum(np.asarray(coil_heat_w, dtype=np.float64), 0.0)
    if hvac.chiller is not None:
        return chiller_power_kw(hvac.chiller, q, outdoor_temp_degc)
    out: FloatArray = q / hvac.cop / W_PER_KW
    return out


def hvac_power(
    hvac: HvacSystem,
    flow_kg_s: ArrayLike,
    zone_temp_degc: ArrayLike,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    *,
    latent_gain_w: ArrayLike = 0.0,
    damper_open: ArrayLike = True,
) -> HvacPower:
    """Exact HVAC power, by component.

    Parameters
    ----------
    hvac : the air-handling system.
    flow_kg_s : (..., m) supply-air flow per zone [kg/s].
    zone_temp_degc : (..., m) zone (return) air temperatures [°C].
    outdoor_temp_degc : (...) outdoor dry-bulb temperature [°C].
    outdoor_humidity_ratio_kg_per_kg : (...) outdoor humidity ratio [kg/kg].
    latent_gain_w : (...) occupants' latent gain, all zones [W] (see module docstring).
    damper_open : (...) bool, the outdoor-air damper open (default: always; the schedule is
        :meth:`hvacflex.building.model.HvacSystem.outdoor_air_open_at`).

    Returns
    -------
    :class:`HvacPower` with arrays of shape (...).
    """
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    t_zone = np.asarray(zone_temp_degc, dtype=np.float64)
    t_out = np.asarray(outdoor_temp_degc, dtype=np.float64)
    w_out = np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64)
    total_flow = flow.sum(axis=-1)
    running = total_flow > 0.0
    safe_total = np.where(running, total_flow, 1.0)
    zone_heat = (flow * t_zone).sum(axis=-1)
    return_temp = np.where(running, zone_heat / safe_total, t_zone.mean(axis=-1))
    outdoor_air = outdoor_air_kg_s(hvac, total_flow, damper_open)
    coil_sensible = CP_AIR_J_PER_KG_K * (
        zone_heat - total_flow * hvac.supply_temp_degc + outdoor_air * (t_out - return_temp)
    )
    recirculated = np.where(running, 1.0 - outdoor_air / safe_total, 0.0)
    w_supply = supply_humidity_ratio_kg_per_kg(hvac)
    coil_latent = outdoor_air * H_FG_J_PER_KG * np.maximum(
        w_out - w_supply, 0.0
    ) + recirculated * np.asarray(latent_gain_w, dtype=np.float64)
    fan = fan_power_kw(hvac, total_flow)
    cooling = plant_power_kw(hvac, np.maximum(coil_sensible, 0.0) + coil_latent, t_out)
    heating = np.maximum(-coil_sensible, 0.0) / hvac.heating_efficiency / W_PER_KW
    return HvacPower(
        fan_kw=fan,
        cooling_kw=cooling,
        heating_kw=heating,
        total_kw=fan + cooling + heating,
        coil_sensible_w=coil_sensible,
        coil_latent_w=coil_latent,
    )


def hvac_power_kw(
    hvac: HvacSystem,
    flow_kg_s: ArrayLike,
    zone_temp_degc: ArrayLike,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    *,
    latent_gain_w: ArrayLike = 0.0,
    damper_open: ArrayLike = True,
) -> FloatArray:
    """Exact HVAC electric power P_fan + P_cool + P_heat [kW], shape (...).

    Shapes as :func:`hvac_power`: flows and zone temperatures (..., m), outdoor values and
    ``damper_open`` (...).
    """
    return hvac_power(
        hvac,
        flow_kg_s,
        zone_temp_degc,
        outdoor_temp_degc,
        outdoor_humidity_ratio_kg_per_kg,
        latent_gain_w=latent_gain_w,
        damper_open=damper_open,
    ).total_kw


def fan_secant(hvac: HvacSystem) -> tuple[float, float]:
    """Secant of P_fan over [Σṁ_min, Σṁ_max]: (intercept [kW], slope [kW per kg/s]).

    P_fan ≈ intercept + slope · S is exact at both ends and above the curve in between.
    """
    intercept, slope = fan_secant_from(hvac, float(sum(hvac.flow_min_kg_s)))
    return float(intercept), float(slope)


@dataclass(frozen=True)
class CoilHeatModel:
    """Coil heat affine in the zone flows per step, Q_k(u) = q0_k + q_k · u [W].

    Attributes
    ----------
    constant_w : (N,) q0 [W]: outdoor air's fixed part and the occupants' recirculated latent.
    cooling_w_per_kg_s : (N, m) q [W per kg/s] of cooling heat (sensible ≥ 0 + latent).
    heating_kw_per_kg_s : (N, m) heating-coil power per kg/s where the supply heats [kW].
    """

    constant_w: FloatArray
    cooling_w_per_kg_s: FloatArray
    heating_kw_per_kg_s: FloatArray


def coil_heat_model(
    hvac: HvacSystem,
    t_out: FloatArray,
    w_out: FloatArray,
    zone_temp_degc: FloatArray,
    total_flow_min_kg_s: FloatArray,
    latent_gain_w: FloatArray,
    damper_open: ArrayLike = True,
) -> CoilHeatModel:
    """:class:`CoilHeatModel` with return air of zone i at ``zone_temp_degc`` (N, m), outdoor
    air at (N,) ``t_out`` [°C], ``w_out`` [kg/kg], the outdoor-air secant over [S_min, S_max]
    with (N,) S_min ``total_flow_min_kg_s`` [kg/s] (none where (N,) ``damper_open`` is
    False) and (N,) occupants' latent gain [W]."""
    is_open = np.broadcast_to(np.asarray(damper_open, dtype=bool), t_out.shape)
    a, b = outdoor_air_secant(hvac, total_flow_min_kg_s, is_open)
    mean_zone = zone_temp_degc.mean(axis=1)
    sensible = CP_AIR_J_PER_KG_K * (
        zone_temp_degc - hvac.supply_temp_degc + b[:, None] * (t_out[:, None] - zone_temp_degc)
    )
    moisture = H_FG_J_PER_KG * np.maximum(w_out - supply_humidity_ratio_kg_per_kg(hvac), 0.0)
    # occupants' latent: the recirculated share (1 − m_oa/S) L, 0 when off, as its secant
    low, high = total_flow_min_kg_s, sum(hvac.flow_max_kg_s)
    share_low = np.where(
        low > 0.0, 1.0 - outdoor_air_kg_s(hvac, low, is_open) / np.where(low > 0, low, 1.0), 0.0
    )
    share_high = 1.0 - outdoor_air_kg_s(hvac, high, is_open) / high
    latent_slope = np.where(
        high > low, (share_high - share_low) * latent_gain_w / np.maximum(high - low, 1e-12), 0.0
    )
    latent_constant = share_low * latent_gain_w - latent_slope * low
    constant = CP_AIR_J_PER_KG_K * a * (t_out - mean_zone) + a * moisture + latent_constant
    return CoilHeatModel(
        constant_w=constant,
        cooling_w_per_kg_s=np.maximum(sensible, 0.0) + (b * moisture + latent_slope)[:, None],
        heating_kw_per_kg_s=np.maximum(-sensible, 0.0) / hvac.heating_efficiency / W_PER_KW,
    )


def _plant_secant(
    hvac: HvacSystem, coil_low_w: FloatArray, coil_high_w: FloatArray, t_out: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(intercept [kW], slope [kW per W]) of the plant's power over [Q_low, Q_high]."""
    if hvac.chiller is None:
        return np.zeros_like(t_out), np.full_like(t_out, 1.0 / hvac.cop / W_PER_KW)
    return chiller_secant(hvac.chiller, coil_low_w, coil_high_w, t_out)


def affine_power_model(
    hvac: HvacSystem,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    zone_temp_ref_degc: float | ArrayLike,
    *,
    latent_gain_w: ArrayLike = 0.0,
    flow_min_kg_s: ArrayLike | None = None,
    damper_open: ArrayLike = True,
) -> tuple[FloatArray, FloatArray]:
    """Per-step affine power model P_k ≈ p0_k + p_k · u_k.

    Parameters
    ----------
    hvac : the air-handling system.
    outdoor_temp_degc : (N,) forecast outdoor temperature [°C].
    outdoor_humidity_ratio_kg_per_kg : (N,) forecast outdoor humidity ratio [kg/kg].
    zone_temp_ref_degc : scalar, (m,) or (N, m) zone temperature the coil term is evaluated
        at [°C] (the linearisation temperature T₀, or each step's own).
    latent_gain_w : scalar or (N,) occupants' latent gain [W] (its recirculated share).
    flow_min_kg_s : (N, m) lower flow bound of each step [kg/s] (e.g. ventilation while
        occupied, the minimum otherwise); the secants of step k span [flow_min_k, ṁ_max],
        the flows the step can take. ``None``: ``hvac.flow_min_kg_s`` every step.
    damper_open : scalar or (N,) bool, the outdoor-air damper open in step k (default:
        always); closed, the coil sees no outdoor air (the same rule as the plant's).

    Returns
    -------
    p0_kw : (N,) [kW]; p_kw_per_kg_s : (N,m) [kW per kg/s]. At T_r = T_ref exact at both
    ends of the flow range; in between the fan secant lies above the exact power and the
    chiller's and the outdoor-air secants below it.
    """
    t_out = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    w_out = np.atleast_1d(np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64))
    m = len(hvac.flow_min_kg_s)
    t_ref = np.broadcast_to(np.asarray(zone_temp_ref_degc, dtype=np.float64), (t_out.size, m))
    if flow_min_kg_s is None:
        low: FloatArray = np.broadcast_to(np.asarray(hvac.flow_min_kg_s), (t_out.size, m))
    else:
        low = np.asarray(flow_min_kg_s, dtype=np.float64).reshape(-1, m)
        low = np.broadcast_to(low, (t_out.size, m))
    latent = np.broadcast_to(np.asarray(latent_gain_w, dtype=np.float64), t_out.shape)
    coil = coil_heat_model(
        hvac,
        t_out,
        w_out,
        t_ref,
        low.sum(axis=1),
        latent,
        damper_open,
    )
    high = np.asarray(hvac.flow_max_kg_s, dtype=np.float64)
    q_low = coil.constant_w + (coil.cooling_w_per_kg_s * low).sum(axis=1)
    q_high = coil.constant_w + coil.cooling_w_per_kg_s @ high
    plant_intercept, plant_slope = _plant_secant(hvac, q_low, q_high, t_out)
    fan_intercept, fan_slope = fan_secant_from(hvac, low.sum(axis=1))
    p = plant_slope[:, None] * coil.cooling_w_per_kg_s + coil.heating_kw_per_kg_s
    p = p + fan_slope[:, None]
    p0 = plant_intercept + plant_slope * coil.constant_w + fan_intercept
    return p0, p


def reserve_power_coeff(
    hvac: HvacSystem,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    zone_temp_degc: ArrayLike,
    total_flow_curtailed_kg_s: ArrayLike,
    damper_open: ArrayLike = True,
) -> FloatArray:
    """(N, m) power reduction per kg/s of flow shed that curtailment surely achieves [kW per
    kg/s]: a lower bound of the exact reduction P(u) − P(u − r) per unit of r.

    The fan power is convex in the total flow S, so shedding r from S gives at least the
    tangent at the reduced flow (S − Σr) per kg/s; the coil's heat per kg/s grows with the
    return-air temperature, so it is taken at the coolest return air the curtailed period may
    see; outdoor air by ventilation need does not shrink with the flow (only a fixed share
    does); the chiller's power is concave in its load, so each W of coil heat shed saves at
    least its slope at the full-flow load.

    Parameters
    ----------
    outdoor_temp_degc, outdoor_humidity_ratio_kg_per_kg : (N,) [°C], [kg/kg].
    zone_temp_degc : (N, m) return-air (zone) temperature the coil term is evaluated at [°C],
        e.g. the lower comfort bound.
    total_flow_curtailed_kg_s : (N,) total supply flow after curtailment S − Σr [kg/s] (a
        lower estimate makes the bound safer).
    damper_open : scalar or (N,) bool, the outdoor-air damper open in step k.
    """
    t_out = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    w_out = np.atleast_1d(np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64))
    m = len(hvac.flow_min_kg_s)
    zone = np.broadcast_to(np.asarray(zone_temp_degc, dtype=np.float64), (t_out.size, m))
    flow = np.maximum(np.asarray(total_flow_curtailed_kg_s, dtype=np.float64), 0.0)
    flow = np.broadcast_to(flow, t_out.shape)
    # the outdoor-air secant with S_min = S_max: the share shed with the flow (0 for the need)
    coil = coil_heat_model(
        hvac,
        t_out,
        w_out,
        zone,
        np.full(t_out.shape, sum(hvac.flow_max_kg_s)),
        np.zeros_like(t_out),
        damper_open,
    )
    if hvac.chiller is None:
        plant_slope = np.full_like(t_out, 1.0 / hvac.cop / W_PER_KW)
    else:
        full_load = coil.constant_w + coil.cooling_w_per_kg_s @ np.asarray(hvac.flow_max_kg_s)
        plant_slope = chiller_marginal_kw_per_w(hvac.chiller, full_load, t_out)
    tangent = fan_marginal_kw_per_kg_s(hvac, flow)
    coeff: FloatArray = (
        plant_slope[:, None] * coil.cooling_w_per_kg_s + coil.heating_kw_per_kg_s + tangent[:, None]
    )
    return coeff


@dataclass(frozen=True)
class AffinePowerError:
    """Error of the affine power model against the exact one on a grid of flows.

    Attributes
    ----------
    max_abs_kw : max |affine − exact| [kW].
    max_rel : max |affine − exact| / exact [-].
    max_fan_abs_kw : max error of the fan secant alone [kW] (analytic for n = 2: κ ΔS²/4).
    max_underestimate_kw : max (exact − affine), ≤ 0 when the affine model is an upper bound
        [kW].
    """

    max_abs_kw: float
    max_rel: float
    max_fan_abs_kw: float
    max_underestimate_kw: float


def affine_power_error(
    hvac: HvacSystem,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    zone_temp_ref_degc: float,
    *,
    zone_temp_degc: float | None = None,
    samples: int = 400,
    seed: int = 0,
    flow_min_kg_s: ArrayLike | None = None,
) -> AffinePowerError:
    """Approximation error of :func:`affine_power_model` over the flow range.

    Parameters
    ----------
    hvac : the air-handling system.
    outdoor_temp_degc, outdoor_humidity_ratio_kg_per_kg : (N,) outdoor conditions.
    zone_temp_ref_degc : T_ref used by the affine model [°C].
    zone_temp_degc : zone temperature used by the exact model (default T_ref; a different
        value adds the coil's linearisation error (1 − f_oa) c_p Σṁ (T_r − T_ref)/COP).
    samples : flow vectors drawn uniformly in [ṁ_min, ṁ_max] (seeded), plus the corners
        ṁ_min, ṁ_max and the midpoint.
    flow_min_kg_s : (m,) lower end of the flow range the affine model serves (e.g. the
        ventilation flow of occupied steps); default ``hvac.flow_min_kg_s``.

    Returns
    -------
    :class:`AffinePowerError`.
    """
    t_out = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    w_out = np.atleast_1d(np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64))
    low = np.asarray(hvac.flow_min_kg_s if flow_min_kg_s is None else flow_min_kg_s, dtype=float)
    high = np.asarray(hvac.flow_max_kg_s)
    rng = np.random.default_rng(seed)
    fractions = np.vstack([np.zeros_like(low), np.ones_like(low), np.full_like(low, 0.5)])
    fractions = np.vstack([fractions, rng.uniform(size=(samples, low.size))])
    flows = low + fractions * (high - low)  # (S, m)
    step_low = np.broadcast_to(low, (t_out.size, low.size))
    p0, p = affine_power_model(hvac, t_out, w_out, zone_temp_ref_degc, flow_min_kg_s=step_low)
    affine = p0[:, None] + p @ flows.T  # (N, S)
    t_zone = zone_temp_ref_degc if zone_temp_degc is None else zone_temp_degc
    exact = hvac_power_kw(
        hvac,
        flows[None, :, :],
        np.full(flows.shape, t_zone)[None, :, :],
        t_out[:, None],
        w_out[:, None],
    )
    error = affine - exact
    intercept, slope = fan_secant_from(hvac, float(low.sum()))
    total = flows.sum(axis=1)
    fan_error = intercept + slope * total - fan_power_kw(hvac, total)
    return AffinePowerError(
        max_abs_kw=float(np.max(np.abs(error))),
        max_rel=float(np.max(np.abs(error) / np.maximum(np.abs(exact), math.ulp(1.0)))),
        max_fan_abs_kw=float(np.max(np.abs(fan_error))),
        max_underestimate_kw=float(np.max(-error)),
    )
