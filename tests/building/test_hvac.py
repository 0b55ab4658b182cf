"""HVAC power: hand calculation, psychrometrics, monotonicity, affine model error."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hvacflex.building.hvac import (
    affine_power_error,
    affine_power_model,
    fan_secant,
    hvac_power,
    hvac_power_kw,
    reserve_power_coeff,
    saturation_humidity_ratio_kg_per_kg,
)
from hvacflex.building.model import Building, HvacSystem
from hvacflex.units import H_FG_J_PER_KG


def _hvac(**changes: object) -> HvacSystem:
    base = HvacSystem(
        supply_temp_degc=13.0,
        flow_min_kg_s=(0.2, 0.3),
        flow_max_kg_s=(1.0, 1.5),
        outdoor_air_fraction=0.3,
        cop=4.0,
        fan_coeff_kw=0.5,
        fan_exponent=2.0,
        reserve_zones=("a", "b"),
        supply_humidity_ratio_kg_per_kg=0.009,
    )
    return dataclasses.replace(base, **changes)  # type: ignore[arg-type]


def test_saturation_humidity_ratio_matches_ashrae_table() -> None:
    # ASHRAE Handbook Fundamentals, psychrometric table at 101.325 kPa
    assert saturation_humidity_ratio_kg_per_kg(13.0) == pytest.approx(0.009370, rel=0.01)
    assert saturation_humidity_ratio_kg_per_kg(25.0) == pytest.approx(0.020170, rel=0.01)


def test_power_by_hand() -> None:
    hvac = _hvac()
    flow, t_zone, t_out, w_out = [0.6, 0.4], [24.0, 25.0], 30.0, 0.019
    # T_mix,a = 0.7·24 + 0.3·30 = 25.8, T_mix,b = 0.7·25 + 9 = 26.5
    sensible = 1006.0 * (0.6 * (25.8 - 13.0) + 0.4 * (26.5 - 13.0))
    latent = 1.0 * 0.3 * 2.501e6 * (0.019 - 0.009)
    fan = 0.5 * 1.0**2
    p = hvac_power(hvac, flow, t_zone, t_out, w_out)
    assert p.coil_sensible_w == pytest.approx(sensible)
    assert p.coil_latent_w == pytest.approx(latent)
    assert p.fan_kw == pytest.approx(fan)
    assert p.heating_kw == 0.0
    assert p.total_kw == pytest.approx(fan + (sensible + latent) / 4.0 / 1000.0)


def test_heating_kept_in_formula() -> None:
    hvac = _hvac(supply_temp_degc=18.0)
    p = hvac_power(hvac, [0.5, 0.5], [15.0, 15.0], 10.0, 0.005)
    assert p.heating_kw > 0 and p.coil_latent_w == 0.0
    assert p.cooling_kw == 0.0


def test_broadcasts_over_time() -> None:
    hvac = _hvac()
    n = 7
    flows = np.tile([0.5, 0.7], (n, 1))
    p = hvac_power_kw(hvac, flows, np.full((n, 2), 24.0), np.linspace(25, 33, n), np.full(n, 0.018))
    assert p.shape == (n,)
    assert np.all(np.diff(p) > 0)  # warmer outdoor air costs more


def test_exact_power_monotone_in_flow(office5: Building) -> None:
    hvac = office5.hvac
    low = np.asarray(hvac.flow_min_kg_s)
    high = np.asarray(hvac.flow_max_kg_s)
    fractions = np.linspace(0.0, 1.0, 51)
    for zone in range(len(low)):
        flows = np.tile(low, (fractions.size, 1))
        flows[:, zone] = low[zone] + fractions * (high[zone] - low[zone])
        power = hvac_power_kw(hvac, flows, np.full(flows.shape, 23.0), 27.0, 0.018)
        assert np.all(np.diff(power) > 0)


def test_fan_secant_exact_at_the_ends_and_above_the_curve() -> None:
    hvac = _hvac(fan_exponent=2.7)
    intercept, slope = fan_secant(hvac)
    s = np.linspace(0.5, 2.5, 201)
    curve = hvac.fan_coeff_kw * s**2.7
    secant = intercept + slope * s
    assert secant[0] == pytest.approx(curve[0]) and secant[-1] == pytest.approx(curve[-1])
    assert np.all(secant >= curve - 1e-12) and np.all(secant >= 0)


def test_affine_error_bounded_by_fan_secant_and_upper_bound() -> None:
    hvac = _hvac()  # n = 2: the secant's largest error is κ (ΔS)² / 4 at the midpoint
    t_out = np.array([26.0, 30.0, 33.0])
    w_out = np.array([0.017, 0.019, 0.021])
    error = affine_power_error(hvac, t_out, w_out, 23.0)
    bound = 0.5 * (2.5 - 0.5) ** 2 / 4.0
    assert error.max_fan_abs_kw == pytest.approx(bound)
    assert error.max_abs_kw == pytest.approx(bound, rel=1e-9)
    assert error.max_underestimate_kw <= 1e-12  # affine ≥ exact at T_r = T_ref
    p0, p = affine_power_model(hvac, t_out, w_out, 23.0)
    assert p0.shape == (3,) and p.shape == (3, 2)
    exact_min = hvac_power_kw(
        hvac, np.tile([0.2, 0.3], (3, 1)), np.full((3, 2), 23.0), t_out, w_out
    )
    np.testing.assert_allclose(p0 + p @ np.array([0.2, 0.3]), exact_min, atol=1e-12)


def test_affine_coil_error_when_zone_differs_from_reference() -> None:
    hvac = _hvac(fan_coeff_kw=0.0)
    error = affine_power_error(hvac, [30.0], [0.019], 23.0, zone_temp_degc=25.0)
    # (1 − f_oa) c_p Σṁ_max (T_r − T_ref) / COP
    assert error.max_abs_kw == pytest.approx(0.7 * 1006.0 * 2.5 * 2.0 / 4.0 / 1000.0)


def test_office5_affine_error_small(office5: Building) -> None:
    # occupied steps: flows between the ventilation minimum and the maximum
    error = affine_power_error(
        office5.hvac,
        np.linspace(25, 33, 5),
        np.full(5, 0.019),
        23.0,
        flow_min_kg_s=office5.hvac.ventilation_flow_kg_s,
    )
    assert error.max_underestimate_kw <= 1e-9
    assert error.max_rel < 0.10


def test_reserve_coefficient_is_a_lower_bound_of_the_exact_reduction() -> None:
    """q·r ≤ P(u, T_cut) − P(u − r, T_cut) for every curtailed state at least as warm and a
    reduced flow at least the one the tangent was taken at (seeded random draws)."""
    hvac = _hvac(fan_exponent=2.5)
    rng = np.random.default_rng(7)
    for _ in range(200):
        t_out, w_out = rng.uniform(24.0, 34.0), rng.uniform(0.012, 0.022)
        zone_low = rng.uniform(22.0, 26.0, 2)
        low = np.array(hvac.flow_min_kg_s)
        flow = rng.uniform(low, np.array(hvac.flow_max_kg_s))
        shed = rng.uniform(0.0, flow - low)
        q = reserve_power_coeff(
            hvac, [t_out], [w_out], zone_low[None], [float((flow - shed).sum())]
        )
        warmer = zone_low + rng.uniform(0.0, 2.0, 2)
        served = hvac_power_kw(hvac, flow, warmer, t_out, w_out)
        curtailed = hvac_power_kw(hvac, flow - shed, warmer, t_out, w_out)
        assert float(q[0] @ shed) <= served - curtailed + 1e-9
    # and below the LP's secant coefficient at the same state
    _, p = affine_power_model(hvac, [30.0], [0.018], 24.0)
    q = reserve_power_coeff(hvac, [30.0], [0.018], np.full((1, 2), 24.0), [0.5])
    assert (q < p).all()


def test_outdoor_air_by_need_and_occupant_latent_by_hand() -> None:
    """Outdoor air min(V, S) displaces return air; the recirculated share 1 − m_oa/S of the
    occupants' latent gain reaches the coil."""
    hvac = _hvac(outdoor_air_kg_s=0.6)
    flow, t_zone, t_out, w_out, latent = (
        np.array([0.8, 1.2]),
        np.array([24.0, 26.0]),
        32.0,
        0.019,
        5000.0,
    )
    power = hvac_power(hvac, flow, t_zone, t_out, w_out, latent_gain_w=latent)
    t_return = (0.8 * 24.0 + 1.2 * 26.0) / 2.0
    sensible = 1006.0 * (0.8 * 11.0 + 1.2 * 13.0 + 0.6 * (t_out - t_return))
    assert float(power.coil_sensible_w) == pytest.approx(sensible)
    moisture = 0.6 * H_FG_J_PER_KG * (w_out - 0.009)
    assert float(power.coil_latent_w) == pytest.approx(
        moisture + (1 - 0.6 / 2.0) * latent, rel=2e-3
    )
    # below the need the damper passes the whole supply; off, nothing reaches the coil
    small = hvac_power(hvac, np.array([0.2, 0.2]), t_zone, t_out, w_out, latent_gain_w=latent)
    assert float(small.coil_sensible_w) == pytest.approx(1006.0 * 0.4 * (t_out - 13.0))
    off = hvac_power(hvac, np.zeros(2), t_zone, t_out, w_out, latent_gain_w=latent)
    assert float(off.total_kw) == 0.0 and float(off.coil_latent_w) == 0.0


def test_affine_model_with_chiller_fan_curve_and_need_is_exact_at_both_ends(
    office5: Building,
) -> None:
    hvac = office5.hvac
    assert hvac.chiller is not None and hvac.outdoor_air_kg_s is not None
    t_out, w_out = np.array([26.0, 30.0, 33.0]), np.array([0.017, 0.019, 0.021])
    latent = np.array([0.0, 3000.0, 7000.0])
    for low in (np.asarray(hvac.ventilation_flow_kg_s), np.asarray(hvac.flow_min_kg_s)):
        p0, p = affine_power_model(
            hvac, t_out, w_out, 24.0, latent_gain_w=latent, flow_min_kg_s=np.tile(low, (3, 1))
        )
        for flows in (low, np.asarray(hvac.flow_max_kg_s)):
            exact = hvac_power_kw(
                hvac, np.tile(flows, (3, 1)), np.full((3, 5), 24.0), t_out, w_out,
                latent_gain_w=latent if flows.sum() > 0 else 0.0,
            )  # fmt: skip
            np.testing.assert_allclose(p0 + p @ flows, exact, rtol=1e-9, atol=1e-9)


def test_a_closed_damper_leaves_the_coil_only_the_return_air_by_hand() -> None:
    """Unoccupied, the fan recirculates: coil sensible c_p Σṁ(T_r − T_s), no outdoor latent;
    the affine model with the damper closed is exact at both ends of the flow range."""
    hvac = _hvac(outdoor_air_kg_s=0.6)
    flow, t_zone = np.array([0.2, 0.3]), np.array([27.0, 28.0])
    closed = hvac_power(hvac, flow, t_zone, 30.0, 0.02, damper_open=False)
    assert float(closed.coil_sensible_w) == pytest.approx(1006.0 * (0.2 * 14.0 + 0.3 * 15.0))
    assert float(closed.coil_latent_w) == 0.0
    opened = hvac_power(hvac, flow, t_zone, 30.0, 0.02)
    assert float(opened.total_kw) > float(closed.total_kw)
    t_out, w_out = np.array([30.0, 30.0]), np.array([0.02, 0.02])
    damper = np.array([False, True])
    p0, p = affine_power_model(hvac, t_out, w_out, 24.0, damper_open=damper)
    for flows in (np.asarray(hvac.flow_min_kg_s), np.asarray(hvac.flow_max_kg_s)):
        exact = hvac_power_kw(
            hvac, np.tile(flows, (2, 1)), np.full((2, 2), 24.0), t_out, w_out, damper_open=damper
        )
        np.testing.assert_allclose(p0 + p @ flows, exact, rtol=1e-9)
    assert p0[0] < p0[1]


def test_affine_power_model_takes_each_steps_own_zone_temperatures(office5: Building) -> None:
    """A (N, m) reference gives, row by row, the model of that row's (m,) temperatures."""
    hvac = office5.hvac
    m = len(hvac.flow_min_kg_s)
    outdoor = np.array([27.0, 30.0, 33.0])
    humidity = np.array([0.016, 0.018, 0.019])
    temps = np.array([np.linspace(23.0, 25.0, m), np.full(m, 24.0), np.linspace(26.0, 24.5, m)])
    p0, p = affine_power_model(hvac, outdoor, humidity, temps)
    for k in range(3):
        p0_k, p_k = affine_power_model(hvac, outdoor[k : k + 1], humidity[k : k + 1], temps[k])
        np.testing.assert_allclose(p0[k], p0_k[0], rtol=1e-13)
        np.testing.assert_allclose(p[k], p_k[0], rtol=1e-13)
    assert not np.allclose(p[0], p[1])
