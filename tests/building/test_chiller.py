"""EnergyPlus's EIR chiller: the DOE-2.1E curves by hand, cycling, secant, marginal slope."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.building.chiller import (
    ChillerPerformance,
    chiller_marginal_kw_per_w,
    chiller_power_kw,
    chiller_secant,
)


def _by_hand_kw(q_w: float, t_cond: float, chiller: ChillerPerformance) -> float:
    """The Engineering Reference's formulas with the coefficients as ExpandObjects writes
    them (RecipCapFT, RecipEIRFT, RecipEIRFPLR), x = 6.67 °C, y clamped to 24–35 °C."""
    x, y = 6.67, min(max(t_cond, 24.0), 35.0)
    cap_ft = (0.507883 + 0.145228 * x - 0.00625644 * x * x - 0.0011178 * y
              - 0.0001296 * y * y - 0.00028188 * x * y)  # fmt: skip
    eir_ft = (1.03076 - 0.103536 * x + 0.00710208 * x * x + 0.0093186 * y
              + 0.00031752 * y * y - 0.00104328 * x * y)  # fmt: skip
    available = chiller.capacity_kw * 1000.0 * cap_ft
    plr = q_w / available
    cycling = min(plr / chiller.min_part_load_ratio, 1.0)
    p = max(plr, chiller.min_part_load_ratio)
    eir_plr = 0.088065 + 1.137742 * p - 0.225806 * p * p
    compressor = available / chiller.reference_cop * eir_ft * eir_plr * cycling
    fans = chiller.condenser_fan_kw_per_kw * available * cycling
    pump = chiller.pump_design_kw * 1000.0 * min(plr, 1.0) ** 2
    return (compressor + fans + pump) / 1000.0


CHILLER = ChillerPerformance(capacity_kw=180.0, reference_cop=4.2, pump_design_kw=1.64)


@pytest.mark.parametrize(
    ("q_kw", "t_cond"), [(20.0, 27.0), (90.0, 30.0), (170.0, 34.0), (90.0, 38.0)]
)
def test_power_is_the_engineering_reference_formula(q_kw: float, t_cond: float) -> None:
    got = float(chiller_power_kw(CHILLER, q_kw * 1000.0, t_cond))
    assert got == pytest.approx(_by_hand_kw(q_kw * 1000.0, t_cond, CHILLER), rel=1e-12)


def test_reference_point_and_part_load() -> None:
    # the DOE-2 curves are normalised at 6.67 °C / 29.4 °C: CAPFT ≈ EIRFT ≈ 1 there
    assert float(CHILLER.available_capacity_w(29.4)) == pytest.approx(180e3, rel=0.01)
    plain = ChillerPerformance(capacity_kw=100.0, reference_cop=4.0, condenser_fan_kw_per_kw=0.0)
    full = float(chiller_power_kw(plain, plain.available_capacity_w(29.4), 29.4))
    assert full == pytest.approx(100.0 / 4.0, rel=0.02)
    # part load costs more per kW of cooling, and a hotter condenser costs more
    q = np.array([50e3, 90e3, 140e3, 175e3])  # above the minimum part load (45 kW)
    cop = q / 1000.0 / chiller_power_kw(CHILLER, q, 30.0)
    assert np.all(np.diff(cop) > 0)
    assert chiller_power_kw(CHILLER, 90e3, 34.0) > chiller_power_kw(CHILLER, 90e3, 27.0)


def test_below_the_minimum_part_load_the_chiller_cycles() -> None:
    edge = float(CHILLER.available_capacity_w(30.0)) * CHILLER.min_part_load_ratio
    p_edge = float(chiller_power_kw(CHILLER, edge, 30.0))
    pump_edge = CHILLER.pump_design_kw * CHILLER.min_part_load_ratio**2
    for share in (0.1, 0.5, 0.9):  # power ∝ load (pump ∝ PLR², no false loading)
        p = float(chiller_power_kw(CHILLER, share * edge, 30.0))
        pump = CHILLER.pump_design_kw * (share * CHILLER.min_part_load_ratio) ** 2
        assert p - pump == pytest.approx(share * (p_edge - pump_edge), rel=1e-12)
    assert float(chiller_power_kw(CHILLER, 0.0, 30.0)) == 0.0


def test_secant_is_exact_at_the_ends_and_below_the_concave_curve() -> None:
    no_pump = ChillerPerformance(capacity_kw=180.0, reference_cop=4.2)
    low, high = np.array([0.0, 30e3, 60e3]), np.array([160e3, 160e3, 61e3])
    t = np.array([29.0, 31.0, 33.0])
    intercept, slope = chiller_secant(no_pump, low, high, t)
    for k in range(3):
        q = np.linspace(low[k], high[k], 101)
        exact = chiller_power_kw(no_pump, q, t[k])
        line = intercept[k] + slope[k] * q
        assert line[0] == pytest.approx(exact[0], abs=1e-9)
        assert line[-1] == pytest.approx(exact[-1], abs=1e-9)
        assert np.all(line <= exact + 1e-9)
    # the smallest slope on [0, Q] is the one just below Q
    marginal = chiller_marginal_kw_per_w(no_pump, 160e3, 29.0)
    assert marginal <= slope[0] and marginal > 0.0


def test_invalid_chiller_is_refused() -> None:
    with pytest.raises(ValueError, match="capacity"):
        ChillerPerformance(capacity_kw=0.0, reference_cop=4.0)
    with pytest.raises(ValueError, match="min_part_load_ratio"):
        ChillerPerformance(capacity_kw=10.0, reference_cop=4.0, min_part_load_ratio=0.0)
