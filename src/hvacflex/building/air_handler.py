"""The air-handling unit's supply fan and outdoor-air damper, exact and as secants.

Fan, with S = Σṁ the total supply flow [kg/s] and f = S / S_max::

    power law (default)   P_fan = κ_f S^n
    part-load curve       P_fan = κ_f S_max^n · (c1 + c2 f + c3 f² + c4 f³)  for S > 0, 0 when off

The part-load curve is EnergyPlus's ``Fan:VariableVolume`` form; the coefficients of its
``VariableSpeedMotorPressureReset`` option, which ``ExpandObjects`` writes for the ``vav``
export, are (0.040759894, 0.08804497, −0.07292612, 0.943739823): a VAV fan whose duct static
pressure is reset still draws 4 % of its design power near zero flow and ≈ 11 % at 30 %
flow, where the pure power law with n = 2.5 gives 5 % — the static-pressure floor.

Outdoor air [kg/s]: a fixed share f_oa of the supply (default), or the ventilation need
V_oa (``HvacSystem.outdoor_air_kg_s``): the damper admits min(V_oa, S) while it is open, as a
building management system runs it: in the occupied periods and the pre-occupancy purge
(``HvacSystem.outdoor_air_open_at``); closed otherwise, so a fan running at night
recirculates return air only (outdoor air 0).

For the controller both are replaced per step by their secant over [S_low, S_max], the flows
the step can take: exact at both ends. The fan curve is convex on the operating range, so its
secant lies above it (an upper bound); min(V_oa, S) is concave, its secant below it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.building.model import HvacSystem

FloatArray = NDArray[np.float64]

PRESSURE_RESET_FAN_COEFFICIENTS = (0.040759894, 0.08804497, -0.07292612, 0.943739823)
"""EnergyPlus's VAV fan curve with static-pressure reset (``VariableSpeedMotorPressureReset``
of ``HVACTemplate:System:VAV``, as ``ExpandObjects`` 25.2 writes it)."""


def max_total_flow_kg_s(hvac: HvacSystem) -> float:
    """S_max = Σṁ_max [kg/s]."""
    return float(sum(hvac.flow_max_kg_s))


def fan_power_kw(hvac: HvacSystem, total_flow_kg_s: ArrayLike) -> FloatArray:
    """Supply-fan power [kW] at total flow S (...) [kg/s]; 0 where S = 0."""
    s = np.asarray(total_flow_kg_s, dtype=np.float64)
    curve = hvac.fan_part_load_coefficients
    if curve is None:
        power: FloatArray = hvac.fan_coeff_kw * np.maximum(s, 0.0) ** hvac.fan_exponent
        return power
    s_max = max_total_flow_kg_s(hvac)
    design_kw = hvac.fan_coeff_kw * s_max**hvac.fan_exponent
    f = s / s_max
    fraction = curve[0] + curve[1] * f + curve[2] * f**2 + curve[3] * f**3
    out: FloatArray = np.where(s > 0.0, design_kw * fraction, 0.0)
    return out


def fan_marginal_kw_per_kg_s(hvac: HvacSystem, total_flow_kg_s: ArrayLike) -> FloatArray:
    """dP_fan/dS [kW per kg/s] at S (...) [kg/s] (the tangent's slope)."""
    s = np.maximum(np.asarray(total_flow_kg_s, dtype=np.float64), 0.0)
    curve = hvac.fan_part_load_coefficients
    kappa, n = hvac.fan_coeff_kw, hvac.fan_exponent
    if curve is None:
        slope: FloatArray = n * kappa * s ** (n - 1.0)
        return slope
    s_max = max_total_flow_kg_s(hvac)
    f = s / s_max
    out: FloatArray = (
        kappa * s_max ** (n - 1.0) * (curve[1] + 2.0 * curve[2] * f + 3.0 * curve[3] * f**2)
    )
    return out


def fan_secant_from(
    hvac: HvacSystem, total_flow_min_kg_s: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Secant of P_fan over [S_min, S_max] for each given S_min (vectorised).

    Parameters
    ----------
    total_flow_min_kg_s : (N,) or scalar lower end S_min of the flow range [kg/s].

    Returns
    -------
    intercept [kW], slope [kW per kg/s], each shaped like ``total_flow_min_kg_s``; where the
    range is a point, the tangent there.
    """
    s_min = np.asarray(total_flow_min_kg_s, dtype=np.float64)
    s_max = max_total_flow_kg_s(hvac)
    width = s_max - s_min
    safe = np.where(width > 0.0, width, 1.0)
    p_min = fan_power_kw(hvac, s_min)
    slope = np.where(
        width > 0.0,
        (fan_power_kw(hvac, s_max) - p_min) / safe,
        fan_marginal_kw_per_kg_s(hvac, s_max),
    )
    intercept: FloatArray = p_min - slope * s_min
    return intercept, np.asarray(slope, dtype=np.float64)


def outdoor_air_kg_s(
    hvac: HvacSystem, total_flow_kg_s: ArrayLike, damper_open: ArrayLike = True
) -> FloatArray:
    """Outdoor air through the damper [kg/s] at total supply S (...) [kg/s]; 0 where
    ``damper_open`` (bool, broadcast with S) is False."""
    s = np.maximum(np.asarray(total_flow_kg_s, dtype=np.float64), 0.0)
    is_open = np.asarray(damper_open, dtype=bool)
    if hvac.outdoor_air_kg_s is None:
        share: FloatArray = np.where(is_open, hvac.outdoor_air_fraction * s, 0.0)
        return share
    need: FloatArray = np.where(is_open, np.minimum(hvac.outdoor_air_kg_s, s), 0.0)
    return need


def outdoor_air_secant(
    hvac: HvacSystem, total_flow_min_kg_s: ArrayLike, damper_open: ArrayLike = True
) -> tuple[FloatArray, FloatArray]:
    """Outdoor air ≈ a + b · S over [S_min, S_max] per step: (a [kg/s], b [-]).

    Exact at both ends (the fixed share: a = 0, b = f_oa exactly; the ventilation need V:
    a = V, b = 0 once S_min ≥ V); a = b = 0 in steps whose damper is closed
    (``damper_open``, bool broadcast with S_min).
    """
    s_min = np.maximum(np.asarray(total_flow_min_kg_s, dtype=np.float64), 0.0)
    is_open = np.broadcast_to(np.asarray(damper_open, dtype=bool), s_min.shape)
    if hvac.outdoor_air_kg_s is None:
        return np.zeros_like(s_min), np.where(is_open, hvac.outdoor_air_fraction, 0.0)
    s_max = max_total_flow_kg_s(hvac)
    width = np.maximum(s_max - s_min, 1e-12)
    low, high = outdoor_air_kg_s(hvac, s_min), outdoor_air_kg_s(hvac, s_max)
    slope: FloatArray = np.where(is_open & (s_max > s_min), (high - low) / width, 0.0)
    intercept: FloatArray = np.where(is_open, low - slope * s_min, 0.0)
    return intercept, slope
