"""Part-load and outdoor-temperature performance of the cooling plant: EnergyPlus's EIR chiller.

The model of EnergyPlus's ``Chiller:Electric:EIR`` (Engineering Reference, "Electric Chiller
Model Based on Condenser Entering Temperature"), with the curves that EnergyPlus 25.2's
``ExpandObjects`` writes for ``HVACTemplate:Plant:Chiller`` of type
``ElectricReciprocatingChiller`` — the DOE-2.1E reciprocating-chiller curves, also in the
wheel's ``DataSets/Chillers.idf`` — so that hvacflex's plant and its ``vav`` export share one
chiller. With Q the coil heat [W], T_lchw the leaving chilled-water temperature and T_cond the
condenser's entering temperature (the outdoor dry bulb for an air-cooled chiller)::

    Q_avail = Q_ref · CAPFT(T_lchw, T_cond)                   available capacity [W]
    PLR     = Q / Q_avail
    P_comp  = Q_avail / COP_ref · EIRFT(T_lchw, T_cond) · EIRFPLR(max(PLR, PLR_min)) · c
    P_cfan  = r · Q_avail · c                                 condenser fans (air cooled)
    P_pump  = P_pump,design · min(PLR, 1)²                     variable-speed chilled-water pump
    c       = min(PLR / PLR_min, 1)                           cycling ratio below PLR_min

CAPFT and EIRFT are biquadratics in (T_lchw, T_cond), their inputs clamped to the curves'
limits as EnergyPlus does; EIRFPLR is a quadratic in PLR. Below ``min_part_load_ratio`` the
chiller cycles (power ∝ load) instead of false-loading. The pump's curve is the one
``ExpandObjects`` writes for the template's ``Pump:VariableSpeed`` (coefficients 0, 0, 1, 0).
Above PLR = 1 the power is extended linearly with the full-load slope (hvacflex's coil has
no capacity limit; EnergyPlus would leave the load unmet).

Without the pump P(Q) is concave in Q (EIRFPLR's PLR² coefficient is negative, the condenser
fans are a constant once the chiller runs, and the cycling slope exceeds the part-load
slope), so its secant over a range lies below the curve inside it; the pump's PLR² is a
small convex term (≈ 1 % of the plant's power at full load).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hvacflex.units import W_PER_KW

FloatArray = NDArray[np.float64]

Biquadratic = tuple[float, float, float, float, float, float]
"""(c1 … c6) of c1 + c2 x + c3 x² + c4 y + c5 y² + c6 x y."""

RECIP_CAP_FT: Biquadratic = (0.507883, 0.145228, -0.00625644, -0.0011178, -0.0001296, -0.00028188)
"""``RecipCapFT`` (DOE-2.1E HERM-REC-CAP-FT), x = T_lchw, y = T_cond [°C]."""

RECIP_EIR_FT: Biquadratic = (1.03076, -0.103536, 0.00710208, 0.0093186, 0.00031752, -0.00104328)
"""``RecipEIRFT`` (DOE-2.1E HERM-REC-EIR-FT), x = T_lchw, y = T_cond [°C]."""

RECIP_EIR_FPLR: tuple[float, float, float] = (0.088065, 1.137742, -0.225806)
"""``RecipEIRFPLR`` (DOE-2.1E HERM-REC-EIR-FPLR), quadratic in PLR on [0, 1]."""

CURVE_LCHW_LIMITS_DEGC = (5.0, 10.0)
"""Limits of the curves' x (leaving chilled water) [°C]."""

CURVE_CONDENSER_LIMITS_DEGC = (24.0, 35.0)
"""Limits of the curves' y (condenser entering temperature) [°C]."""

REFERENCE_LCHW_DEGC = 6.67
"""Leaving chilled-water temperature of the template's chiller [°C]."""

CONDENSER_FAN_KW_PER_KW = 0.035
"""Condenser fan power per unit of available capacity, the template's air-cooled value."""

FINITE_DIFFERENCE_W = 1.0
"""Load step for the slope of P(Q) where the range collapses to a point [W]."""


def _biquadratic(c: Biquadratic, x: FloatArray, y: FloatArray) -> FloatArray:
    x = np.clip(x, *CURVE_LCHW_LIMITS_DEGC)
    y = np.clip(y, *CURVE_CONDENSER_LIMITS_DEGC)
    out: FloatArray = c[0] + c[1] * x + c[2] * x**2 + c[3] * y + c[4] * y**2 + c[5] * x * y
    return out


@dataclass(frozen=True)
class ChillerPerformance:
    """The cooling plant's chiller and chilled-water pump (see the module docstring).

    Attributes
    ----------
    capacity_kw : reference capacity Q_ref [kW] (at T_lchw and the curves' reference).
    reference_cop : COP_ref, compressor only, at the reference conditions [-].
    min_part_load_ratio : PLR_min, below it the chiller cycles [-].
    condenser_fan_kw_per_kw : r, condenser fan power per kW of available capacity [-].
    pump_design_kw : chilled-water pump power at full load [kW].
    leaving_chilled_water_degc : T_lchw [°C].
    cap_ft, eir_ft : biquadratics in (T_lchw, T_cond); eir_fplr : quadratic in PLR.
    """

    capacity_kw: float
    reference_cop: float
    min_part_load_ratio: float = 0.25
    condenser_fan_kw_per_kw: float = CONDENSER_FAN_KW_PER_KW
    pump_design_kw: float = 0.0
    leaving_chilled_water_degc: float = REFERENCE_LCHW_DEGC
    cap_ft: Biquadratic = RECIP_CAP_FT
    eir_ft: Biquadratic = RECIP_EIR_FT
    eir_fplr: tuple[float, float, float] = RECIP_EIR_FPLR

    def __post_init__(self) -> None:
        if self.capacity_kw <= 0 or self.reference_cop <= 0:
            raise ValueError("chiller capacity and COP must be > 0")
        if not 0.0 < self.min_part_load_ratio <= 1.0:
            raise ValueError("min_part_load_ratio must be in (0, 1]")

    def available_capacity_w(self, condenser_temp_degc: ArrayLike) -> FloatArray:
        """Q_avail [W] at the condenser entering temperature [°C], shape of the input."""
        t_cond = np.asarray(condenser_temp_degc, dtype=np.float64)
        t_lchw = np.full_like(t_cond, self.leaving_chilled_water_degc)
        out: FloatArray = self.capacity_kw * W_PER_KW * _biquadratic(self.cap_ft, t_lchw, t_cond)
        return out

    def _eir_fplr(self, plr: FloatArray) -> FloatArray:
        a, b, c = self.eir_fplr
        out: FloatArray = a + b * plr + c * plr**2
        return out


def chiller_power_kw(
    chiller: ChillerPerformance, coil_heat_w: ArrayLike, condenser_temp_degc: ArrayLike
) -> FloatArray:
    """Electric power of chiller, condenser fans and chilled-water pump [kW].

    Parameters
    ----------
    chiller : the plant.
    coil_heat_w : (...) coil heat removed Q ≥ 0 [W] (negative values count as 0).
    condenser_temp_degc : (...) condenser entering temperature (outdoor dry bulb) [°C].

    Returns
    -------
    (...) power [kW]; 0 where Q = 0.
    """
    q = np.maximum(np.asarray(coil_heat_w, dtype=np.float64), 0.0)
    t_cond = np.broadcast_to(np.asarray(condenser_temp_degc, dtype=np.float64), q.shape)
    available = chiller.available_capacity_w(t_cond)
    t_lchw = np.full_like(t_cond, chiller.leaving_chilled_water_degc)
    eir_ft = _biquadratic(chiller.eir_ft, t_lchw, t_cond)
    plr = q / available
    plr_min = chiller.min_part_load_ratio
    cycling = np.minimum(plr / plr_min, 1.0)
    operating = np.clip(plr, plr_min, 1.0)
    full_slope = chiller.eir_fplr[1] + 2.0 * chiller.eir_fplr[2]  # d EIRFPLR / d PLR at 1
    eir_plr = chiller._eir_fplr(operating) + full_slope * np.maximum(plr - 1.0, 0.0)
    compressor = available / chiller.reference_cop * eir_ft * eir_plr * cycling
    condenser_fan = chiller.condenser_fan_kw_per_kw * available * cycling
    pump = chiller.pump_design_kw * W_PER_KW * np.minimum(plr, 1.0) ** 2
    out: FloatArray = (compressor + condenser_fan + pump) / W_PER_KW
    return out


def chiller_secant(
    chiller: ChillerPerformance,
    coil_low_w: ArrayLike,
    coil_high_w: ArrayLike,
    condenser_temp_degc: ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    """Secant of P(Q) over [Q_low, Q_high] per step: (intercept [kW], slope [kW per W]).

    Exact at both ends; below the (concave) curve in between. Where the range is a point,
    the slope is the backward difference at it.

    Parameters
    ----------
    coil_low_w, coil_high_w : (N,) ends of the coil-heat range [W].
    condenser_temp_degc : (N,) [°C].
    """
    low = np.maximum(np.asarray(coil_low_w, dtype=np.float64), 0.0)
    high = np.maximum(np.asarray(coil_high_w, dtype=np.float64), low + FINITE_DIFFERENCE_W)
    t_cond = np.broadcast_to(np.asarray(condenser_temp_degc, dtype=np.float64), low.shape)
    p_low = chiller_power_kw(chiller, low, t_cond)
    slope: FloatArray = (chiller_power_kw(chiller, high, t_cond) - p_low) / (high - low)
    intercept: FloatArray = p_low - slope * low
    return intercept, slope


def chiller_marginal_kw_per_w(
    chiller: ChillerPerformance, coil_heat_w: ArrayLike, condenser_temp_degc: ArrayLike
) -> FloatArray:
    """dP/dQ just below Q [kW per W]: for a concave P(Q) the smallest slope on [0, Q], so
    shedding ΔQ from Q saves at least this · ΔQ."""
    q = np.maximum(np.asarray(coil_heat_w, dtype=np.float64), FINITE_DIFFERENCE_W)
    upper = chiller_power_kw(chiller, q, condenser_temp_degc)
    lower = chiller_power_kw(chiller, q - FINITE_DIFFERENCE_W, condenser_temp_degc)
    out: FloatArray = (upper - lower) / FINITE_DIFFERENCE_W
    return out
