"""HVAC electric power (paper eq. 10): fan + cooling coil + heating coil, exact and affine.

One VAV air-handling unit serves every zone with supply air at T_s; a fixed share f_oa of the
supply air is outdoor air. With Σṁ the total supply flow [kg/s]::

    P_fan   = κ_f (Σṁ)^n                                              [kW]
    Q_sens  = Σ_i ṁ_i c_p (T_mix,i − T_s),   T_mix,i = (1 − f_oa) T_r,i + f_oa T_out   [W]
    Q_lat   = Σṁ f_oa h_fg (W_out − W_s)⁺ + (1 − f_oa) L                [W]
    P_cool  = (Q_sens⁺ + Q_lat) / COP / 1000,   P_heat = Q_sens⁻ / η_heat / 1000

Latent load. The coil leaves the supply air saturated at T_s (W_s = W_sat(T_s), unless the
file sets ``supply_humidity_ratio_kg_per_kg``). Assumption for the return air: at steady state
the zones' moisture balance gives ṁ (W_return − W_s) = L / h_fg, with L the occupants' latent
gain [W]; the recirculated share (1 − f_oa) of that moisture reaches the coil, the rest leaves
with the relief air. L is an optional argument (default 0: return air at the supply humidity
ratio, i.e. only the outdoor air's moisture is removed); it does not depend on the flows, so it
enters p0 only.

Affine model for the controller (docs/model.md §1): coil terms are linear in ṁ at T_r = T_ref; the
fan is replaced by the secant of κ_f S^n over [S_min, S_max] = [Σṁ_min, Σṁ_max], which lies
above the convex curve on that interval (an upper bound, never negative).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

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


def hvac_power(
    hvac: HvacSystem,
    flow_kg_s: ArrayLike,
    zone_temp_degc: ArrayLike,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    *,
    latent_gain_w: ArrayLike = 0.0,
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

    Returns
    -------
    :class:`HvacPower` with arrays of shape (...).
    """
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    t_zone = np.asarray(zone_temp_degc, dtype=np.float64)
    t_out = np.asarray(outdoor_temp_degc, dtype=np.float64)
    w_out = np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64)
    f_oa = hvac.outdoor_air_fraction
    total_flow = flow.sum(axis=-1)
    coil_sensible = CP_AIR_J_PER_KG_K * (
        (1.0 - f_oa) * (flow * t_zone).sum(axis=-1)
        + total_flow * (f_oa * t_out - hvac.supply_temp_degc)
    )
    w_supply = supply_humidity_ratio_kg_per_kg(hvac)
    coil_latent = total_flow * f_oa * H_FG_J_PER_KG * np.maximum(w_out - w_supply, 0.0) + (
        1.0 - f_oa
    ) * np.asarray(latent_gain_w, dtype=np.float64)
    fan = hvac.fan_coeff_kw * total_flow**hvac.fan_exponent
    cooling = (np.maximum(coil_sensible, 0.0) + coil_latent) / hvac.cop / W_PER_KW
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
) -> FloatArray:
    """Exact HVAC electric power P_fan + P_cool + P_heat [kW], shape (...).

    Shapes as :func:`hvac_power`: flows and zone temperatures (..., m), outdoor values (...).
    """
    return hvac_power(
        hvac,
        flow_kg_s,
        zone_temp_degc,
        outdoor_temp_degc,
        outdoor_humidity_ratio_kg_per_kg,
        latent_gain_w=latent_gain_w,
    ).total_kw


def fan_secant(hvac: HvacSystem) -> tuple[float, float]:
    """Secant of κ_f S^n over [Σṁ_min, Σṁ_max]: (intercept [kW], slope [kW per kg/s]).

    P_fan ≈ intercept + slope · S is exact at both ends and above the curve in between.
    """
    intercept, slope = fan_secant_from(hvac, float(sum(hvac.flow_min_kg_s)))
    return float(intercept), float(slope)


def fan_secant_from(
    hvac: HvacSystem, total_flow_min_kg_s: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Secant of κ_f S^n over [S_min, Σṁ_max] for each given S_min (vectorised).

    Parameters
    ----------
    total_flow_min_kg_s : (N,) or scalar lower end S_min of the flow range [kg/s].

    Returns
    -------
    intercept [kW], slope [kW per kg/s], each shaped like ``total_flow_min_kg_s``.
    """
    s_min = np.asarray(total_flow_min_kg_s, dtype=np.float64)
    s_max = float(sum(hvac.flow_max_kg_s))
    kappa, n = hvac.fan_coeff_kw, hvac.fan_exponent
    width = s_max - s_min
    tangent = n * kappa * s_max ** (n - 1.0)
    safe = np.where(width > 0.0, width, 1.0)
    slope = np.where(width > 0.0, kappa * (s_max**n - s_min**n) / safe, tangent)
    intercept: FloatArray = kappa * s_min**n - slope * s_min
    return intercept, np.asarray(slope, dtype=np.float64)


def affine_power_model(
    hvac: HvacSystem,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    zone_temp_ref_degc: float | ArrayLike,
    *,
    latent_gain_w: ArrayLike = 0.0,
    flow_min_kg_s: ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Per-step affine power model P_k ≈ p0_k + p_k · u_k.

    Parameters
    ----------
    hvac : the air-handling system.
    outdoor_temp_degc : (N,) forecast outdoor temperature [°C].
    outdoor_humidity_ratio_kg_per_kg : (N,) forecast outdoor humidity ratio [kg/kg].
    zone_temp_ref_degc : scalar or (m,) zone temperature the coil term is evaluated at [°C]
        (the linearisation temperature T₀).
    latent_gain_w : scalar or (N,) occupants' latent gain [W], enters p0 only.
    flow_min_kg_s : (N, m) lower flow bound of each step [kg/s] (e.g. ventilation while
        occupied, the minimum otherwise); the fan secant of step k spans [Σ flow_min_k,
        Σṁ_max], the flows the step can take. ``None``: ``hvac.flow_min_kg_s`` every step.

    Returns
    -------
    p0_kw : (N,) [kW]; p_kw_per_kg_s : (N,m) [kW per kg/s]. Exact at T_r = T_ref whenever
    Σu is Σṁ_min or Σṁ_max; above the exact power in between (fan secant).
    """
    t_out = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    w_out = np.atleast_1d(np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64))
    m = len(hvac.flow_min_kg_s)
    t_ref = np.broadcast_to(np.asarray(zone_temp_ref_degc, dtype=np.float64), (m,))
    f_oa = hvac.outdoor_air_fraction
    coil = _coil_kw_per_kg_s(hvac, t_out, w_out, np.broadcast_to(t_ref, (t_out.size, m)))
    if flow_min_kg_s is None:
        low_total: FloatArray = np.full(t_out.shape, float(sum(hvac.flow_min_kg_s)))
    else:
        low_total = np.asarray(flow_min_kg_s, dtype=np.float64).reshape(-1, m).sum(axis=1)
    intercept, slope = fan_secant_from(hvac, np.broadcast_to(low_total, t_out.shape))
    p = coil + slope[:, None]
    p0 = (
        intercept
        + (1.0 - f_oa)
        * np.broadcast_to(np.asarray(latent_gain_w, dtype=np.float64), t_out.shape)
        / hvac.cop
        / W_PER_KW
    )
    return p0, p


def _coil_kw_per_kg_s(
    hvac: HvacSystem, t_out: FloatArray, w_out: FloatArray, zone_temp_degc: FloatArray
) -> FloatArray:
    """(N, m) coil electric power per kg/s of each zone's supply flow [kW per kg/s], with the
    return air of zone i at ``zone_temp_degc`` (N, m) and outdoor air at (N,) t_out, w_out."""
    f_oa = hvac.outdoor_air_fraction
    # sensible coil heat per kg/s of each zone's flow [W per kg/s], (N, m)
    sensible = CP_AIR_J_PER_KG_K * (
        (1.0 - f_oa) * zone_temp_degc + f_oa * t_out[:, None] - hvac.supply_temp_degc
    )
    latent = f_oa * H_FG_J_PER_KG * np.maximum(w_out - supply_humidity_ratio_kg_per_kg(hvac), 0.0)
    coil: FloatArray = (
        (np.maximum(sensible, 0.0) + latent[:, None]) / hvac.cop
        + np.maximum(-sensible, 0.0) / hvac.heating_efficiency
    ) / W_PER_KW
    return coil


def reserve_power_coeff(
    hvac: HvacSystem,
    outdoor_temp_degc: ArrayLike,
    outdoor_humidity_ratio_kg_per_kg: ArrayLike,
    zone_temp_degc: ArrayLike,
    total_flow_curtailed_kg_s: ArrayLike,
) -> FloatArray:
    """(N, m) power reduction per kg/s of flow shed that curtailment surely achieves [kW per
    kg/s]: a lower bound of the exact reduction P(u) − P(u − r) per unit of r.

    The fan power κ S^n is convex in the total flow S, so shedding r from S gives at least
    the tangent at the reduced flow, n κ (S − Σr)^(n−1) per kg/s (the LP's secant over the
    whole range gives more); the coil's power per kg/s grows with the return-air temperature,
    so it is taken at the coolest return air the curtailed period may see.

    Parameters
    ----------
    outdoor_temp_degc, outdoor_humidity_ratio_kg_per_kg : (N,) [°C], [kg/kg].
    zone_temp_degc : (N, m) return-air (zone) temperature the coil term is evaluated at [°C],
        e.g. the lower comfort bound.
    total_flow_curtailed_kg_s : (N,) total supply flow after curtailment S − Σr [kg/s] (a
        lower estimate makes the bound safer).
    """
    t_out = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    w_out = np.atleast_1d(np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64))
    m = len(hvac.flow_min_kg_s)
    zone = np.broadcast_to(np.asarray(zone_temp_degc, dtype=np.float64), (t_out.size, m))
    flow = np.maximum(np.asarray(total_flow_curtailed_kg_s, dtype=np.float64), 0.0)
    kappa, n = hvac.fan_coeff_kw, hvac.fan_exponent
    tangent = n * kappa * np.broadcast_to(flow, t_out.shape) ** (n - 1.0)
    coeff: FloatArray = _coil_kw_per_kg_s(hvac, t_out, w_out, zone) + tangent[:, None]
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
    fan_error = intercept + slope * total - hvac.fan_coeff_kw * total**hvac.fan_exponent
    return AffinePowerError(
        max_abs_kw=float(np.max(np.abs(error))),
        max_rel=float(np.max(np.abs(error) / np.maximum(np.abs(exact), math.ulp(1.0)))),
        max_fan_abs_kw=float(np.max(np.abs(fan_error))),
        max_underestimate_kw=float(np.max(-error)),
    )
