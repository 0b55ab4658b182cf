"""An identified building: its network is the fitted grey-box model, its power model the
fitted one (checked against the fit's own discretisation and hand-computed values)."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import hvacflex
from hvacflex.building.discretize import linearize
from hvacflex.building.identified import (
    GAIN_CHANNEL_PEAK_W,
    IdentifiedIdleAir,
    IdentifiedPower,
    IdentifiedValidity,
    hours_text,
    identified_affine_power,
    identified_occupied_share,
    identified_power_kw,
    initial_node_temps_degc,
    metered_affine_power,
    metered_power_kw,
    metered_reserve_coeff,
    parse_hours,
    sensible_cooling_kw,
)
from hvacflex.building.io import building_from_dict, load_building
from hvacflex.building.rc import disturbance_channels as building_channels
from hvacflex.errors import BuildingConfigError
from hvacflex.identify.greybox import GreyBoxParameters, discretize
from hvacflex.identify.model_file import AirSystem, IdentifiedModel, write_identified_model
from hvacflex.paths import resources_dir
from hvacflex.sim.plant import Actuation, Disturbance, RCPlant
from hvacflex.units import CP_AIR_J_PER_KG_K

ZONES = np.array(
    [
        [800.0, 3.0e4, 0.05, 0.8, 0.03, 3.0, 6.0, 0.0, 2.0, 0.5, 0.0, 1.5, 0.4],
        [1200.0, 6.0e4, 0.08, 1.2, 0.05, 5.0, 8.0, 1.0, 0.0, 0.0, 3.0, 2.5, -0.2],
    ]
)
PARAMETERS = GreyBoxParameters(ZONES, np.array([[0, 1]], dtype=np.int64), np.array([0.3]))
SUPPLY_TEMP_DEGC = 13.0
POWER = IdentifiedPower(
    base_kw=1.2,
    kw_per_kw_cooling=0.35,
    kw_per_k_outdoor=0.04,
    occupied_kw=0.7,
    kw_per_kg_s_k_outdoor_occupied=0.15,
)


def _two_zone_model(validity: IdentifiedValidity | None = None) -> IdentifiedModel:
    """The two-zone model of these tests (with a validity range, if given)."""
    return IdentifiedModel(
        name="two zones",
        zones=("a", "b"),
        energyplus_zones=("Zone A", "ZONE-B"),
        parameters=PARAMETERS,
        power=POWER,
        provenance={},
        air=AirSystem(SUPPLY_TEMP_DEGC, (0.0, 0.0), (0.5, 0.8), (0.0, 0.0), (24.0, 24.0)),
        validity=validity,
    )


@pytest.fixture
def model_path(tmp_path: Path) -> Path:
    return write_identified_model(_two_zone_model(), tmp_path / "model.toml")


def test_the_linear_model_is_the_fitted_models_discretisation(model_path: Path) -> None:
    building = load_building(model_path)
    t0 = 24.0
    linear = linearize(building, 1800.0, t0)  # at zero reference flow: the pure network
    fitted = discretize(PARAMETERS)  # the fit's own (eigendecomposition) discretisation
    np.testing.assert_allclose(linear.a, fitted.a, atol=1e-12)
    # fit inputs [To, G kW/m², occ, 1, walls N E S W kW/m², Q_a, Q_b]; building channels
    # [To, G W/m², walls N E S W W/m², gain_a W, gain_b W (1 kW × people fraction),
    # constant]; building input: flow at T0
    assert [c.name for c in building_channels(building)][2:6] == [
        f"solar_az{azimuth:g}_tilt90_w_per_m2" for azimuth in (0, 90, 180, 270)
    ]
    np.testing.assert_allclose(linear.e[:, 0], fitted.b[:, 0], atol=1e-12)
    np.testing.assert_allclose(linear.e[:, 1] * 1000.0, fitted.b[:, 1], atol=1e-12)
    np.testing.assert_allclose(linear.e[:, 2:6] * 1000.0, fitted.b[:, 4:8], atol=1e-12)
    np.testing.assert_allclose((linear.e[:, 6] + linear.e[:, 7]) * 1000.0, fitted.b[:, 2])
    np.testing.assert_allclose(linear.e[:, 8], fitted.b[:, 3], atol=1e-12)
    per_kg_s = CP_AIR_J_PER_KG_K * (t0 - SUPPLY_TEMP_DEGC) / 1000.0  # kW of cooling
    np.testing.assert_allclose(linear.b, fitted.b[:, 8:10] * per_kg_s, atol=1e-12)
    assert np.all(linear.a >= -1e-12)  # Metzler network: the robust LP's condition


def test_the_power_model_in_the_lp_matches_the_plants_at_the_reference(model_path: Path) -> None:
    rc = load_building(model_path).identified
    assert rc is not None and rc.power == POWER
    flow = np.array([0.3, 0.5])
    t0, outdoor = 24.5, 31.0
    p0, p = identified_affine_power(rc, np.array([outdoor]), t0)
    cooling = flow * CP_AIR_J_PER_KG_K * (t0 - SUPPLY_TEMP_DEGC) / 1000.0
    by_hand = 1.2 + 0.35 * cooling.sum() + 0.04 * outdoor
    assert p0[0] + p[0] @ flow == pytest.approx(by_hand, rel=1e-12)
    assert identified_power_kw(rc, flow, np.full(2, t0), outdoor) == pytest.approx(by_hand)
    np.testing.assert_allclose(sensible_cooling_kw(flow, np.full(2, t0), SUPPLY_TEMP_DEGC), cooling)


def test_the_occupied_outdoor_air_term_is_in_the_lp_and_the_plant(model_path: Path) -> None:
    rc = load_building(model_path).identified
    assert rc is not None
    flow = np.array([0.3, 0.5])
    t0, outdoor = 24.5, 31.0
    p0, p = identified_affine_power(rc, np.array([outdoor, outdoor]), t0, np.array([0.0, 1.0]))
    cooling = flow * CP_AIR_J_PER_KG_K * (t0 - SUPPLY_TEMP_DEGC) / 1000.0
    vacant = 1.2 + 0.35 * cooling.sum() + 0.04 * outdoor
    occupied = vacant + 0.7 + 0.15 * (flow * (outdoor - t0)).sum()
    assert p0[0] + p[0] @ flow == pytest.approx(vacant, rel=1e-12)
    assert p0[1] + p[1] @ flow == pytest.approx(occupied, rel=1e-12)
    plant = identified_power_kw(rc, flow, np.full(2, t0), outdoor, occupied=1.0)
    assert plant == pytest.approx(occupied)
    channels = ("outdoor_temp_degc", "internal_gain_a_w", "internal_gain_b_w")
    assert identified_occupied_share(channels, np.array([30.0, 500.0, 500.0])) == 0.5


def test_the_outdoor_air_moisture_is_in_the_lp_and_the_plant_while_occupied(
    model_path: Path,
) -> None:
    rc = load_building(model_path).identified
    assert rc is not None
    moist = replace(POWER, kw_per_humidity_ratio_occupied=1000.0)
    wet = replace(rc, power=moist)
    lp0, lp = identified_affine_power(wet, [31.0], 24.5, [1.0], None, [0.025])
    dry0, _ = identified_affine_power(wet, [31.0], 24.5, [1.0], None, [0.018])
    assert lp0[0] - dry0[0] == pytest.approx(1000.0 * 0.007)
    plant_wet = identified_power_kw(wet, [0.3, 0.5], [24.5, 24.5], 31.0, 1.0, 0.025)
    assert plant_wet == pytest.approx(lp0[0] + lp[0] @ [0.3, 0.5], rel=1e-12)
    flow, t0, outdoor = np.array([0.3, 0.5]), 24.5, 31.0
    humidity = np.array([0.024, 0.024, 0.018])  # humid vacant, humid occupied, the reference
    occupied = np.array([0.0, 1.0, 1.0])
    p0, p = metered_affine_power(
        moist,
        SUPPLY_TEMP_DEGC,
        2,
        np.full(3, outdoor),
        t0,
        occupied,
        outdoor_humidity_ratio_kg_per_kg=humidity,
    )
    dry_p0, dry_p = metered_affine_power(
        POWER, SUPPLY_TEMP_DEGC, 2, np.full(3, outdoor), t0, occupied
    )
    np.testing.assert_allclose(p, dry_p)  # a constant of the period: the flows' slope is unchanged
    np.testing.assert_allclose(p0 - dry_p0, [0.0, 1000.0 * 0.006, 0.0], atol=1e-12)
    plant = metered_power_kw(moist, SUPPLY_TEMP_DEGC, flow, np.full(2, t0), outdoor, 1.0, 0.024)
    assert plant == pytest.approx(p0[1] + p[1] @ flow, rel=1e-12)


def test_an_identified_building_refuses_walls_and_mismatched_zones() -> None:
    base = {
        "name": "x",
        "zones": [{"name": "a"}],
        "identified": {
            "supply_temp_degc": 13.0,
            "zones": {
                "a": dict(
                    zip(
                        [
                            "c_air_kj_per_k",
                            "c_mass_kj_per_k",
                            "ua_out_kw_per_k",
                            "ua_air_mass_kw_per_k",
                            "ua_mass_out_kw_per_k",
                            "solar_air_m2",
                            "solar_mass_m2",
                            "occupied_gain_kw",
                            "base_gain_kw",
                        ],
                        np.delete(ZONES[0], [7, 8, 9, 10]).tolist(),  # a file without walls
                        strict=True,
                    ),
                    flow_min_kg_s=0.0,
                    flow_max_kg_s=0.5,
                    ventilation_flow_kg_s=0.1,
                    mass_temp_degc=24.0,
                )
            },
        },
    }
    identified = building_from_dict(base).identified
    assert identified is not None
    assert identified.zones[0].wall_solar_m2() == (0.0, 0.0, 0.0, 0.0)  # written before walls
    renamed = {**base, "zones": [{"name": "b"}]}
    with pytest.raises(BuildingConfigError, match="differ from"):
        building_from_dict(renamed)
    with pytest.raises(BuildingConfigError, match="no envelope"):
        gains = {
            "occupancy_m2_per_person": 10.0,
            "sensible_w_per_person": 75.0,
            "latent_w_per_person": 55.0,
            "lighting_w_per_m2": 10.0,
            "equipment_w_per_m2": 12.0,
        }
        building_from_dict({**base, "gains": gains})
    designed = {"name": "y", "zones": [{"name": "a"}]}
    with pytest.raises(BuildingConfigError) as caught:
        building_from_dict(designed)
    assert caught.value.field == "zones[0].floor_area_m2"


def test_a_run_starts_the_hidden_nodes_at_their_estimated_temperatures(model_path: Path) -> None:
    building = load_building(model_path)
    rc = building.identified
    assert rc is not None
    # [air a, air b, mass a, mass b]: the zones at the run's start, the mass at the file's
    np.testing.assert_array_equal(initial_node_temps_degc(rc, 26.0), [26.0, 26.0, 24.0, 24.0])
    run = hvacflex.simulate(
        "nmpc",
        start="2014-03-03",
        days=0.25,
        building=str(model_path),
        quiet=True,
        out=model_path.parent / "run",
    )
    assert run.summary["fallback_count"] == 0 and run.frame["power_kw"].notna().all()


def test_the_rc_plant_meters_the_occupied_terms_from_the_gain_channel(model_path: Path) -> None:
    building = load_building(model_path)
    rc = building.identified
    assert rc is not None
    plant = RCPlant(building)
    names = plant.plant.network.channel_names
    outdoor, flow = 31.0, np.array([0.3, 0.5])
    powers = []
    for people in (0.0, 1.0):
        d = np.array([outdoor if n.startswith("outdoor") else 0.0 for n in names])
        d[[i for i, n in enumerate(names) if n.startswith("internal_gain")]] = 1000.0 * people
        d[[i for i, n in enumerate(names) if n == "constant"]] = 1.0
        plant.reset(25.0)
        obs = plant.step(Actuation(flow_kg_s=flow), Disturbance(d, outdoor, 0.015), 1800.0)
        expected = identified_power_kw(rc, flow, obs.zone_mean_temp_degc, outdoor, people)
        assert obs.power_kw == pytest.approx(expected, rel=1e-9)
        powers.append(obs.power_kw)
    assert powers[1] > powers[0] + 0.7  # the occupied constant and outdoor air


def test_real_floor_areas_leave_the_gain_channel_at_1_kw_per_zone(tmp_path: Path) -> None:
    """The file's floor areas are the building's (per-m² KPIs) and not the gain channel's
    scale: the scheduled internal-gain channel is the people fraction × 1 kW either way."""
    from hvacflex.data.forecast import load_exogenous

    model = IdentifiedModel(
        name="two zones",
        zones=("a", "b"),
        energyplus_zones=("Zone A", "ZONE-B"),
        parameters=PARAMETERS,
        power=POWER,
        provenance={},
        air=AirSystem(SUPPLY_TEMP_DEGC, (0.0, 0.0), (0.5, 0.8), (0.0, 0.0), (24.0, 24.0)),
        floor_areas_m2=(120.0, 45.0),
    )
    building = load_building(write_identified_model(model, tmp_path / "model.toml"))
    assert building.floor_area_m2 == pytest.approx(165.0)
    assert building.gain_floor_areas_m2 == (1.0, 1.0)
    channels = building_channels(building)
    exo = load_exogenous(
        channels, building.gain_floor_areas_m2, building.gains, start="2014-03-04", steps=48
    )
    gains = np.asarray(exo.disturbances)[
        :48, [i for i, c in enumerate(channels) if c.kind == "internal_gain"]
    ]
    # the people fraction (its peak below 1) × 1 kW, not × 120 or 45 m²
    assert 0.5 * GAIN_CHANNEL_PEAK_W < gains.max() <= GAIN_CHANNEL_PEAK_W
    assert gains.min() >= 0.0


def test_an_identified_zone_refuses_a_height() -> None:
    base = {
        "name": "x",
        "zones": [{"name": "a", "height_m": 3.0}],
        "identified": {"supply_temp_degc": 13.0, "zones": {}},
    }
    with pytest.raises(BuildingConfigError) as caught:
        building_from_dict(base)
    assert caught.value.field == "zones[0].height_m"


def test_a_period_outside_the_validity_range_is_flagged() -> None:
    validity = IdentifiedValidity((23.0, 22.5), (27.0, 28.0), 24.0, 33.0)
    zone = [[25.0, 25.0], [27.5, 25.0], [25.0, 25.0], [25.0, 22.0]]
    outdoor = [30.0, 30.0, 34.0, 30.0]
    # period 1: zone a above its 27 °C; 2: the outdoor air above 33 °C; 3: zone b below 22.5
    assert validity.outside(zone, outdoor).tolist() == [False, True, True, True]


def test_a_run_on_a_model_with_a_validity_range_counts_the_periods_planned_outside_it(
    tmp_path: Path,
) -> None:
    """The MPC on an identified model trained only up to 25.5 °C: every period whose
    planned zone temperature or forecast outdoor air lies outside the trained range is
    flagged (``model_extrapolation``) and counted (``model_extrapolation_steps``)."""
    from hvacflex.config import preset, with_overrides
    from hvacflex.sim.run import run_simulation

    validity = IdentifiedValidity((20.0, 20.0), (25.5, 25.5), 26.0, 29.0)
    path = write_identified_model(_two_zone_model(validity), tmp_path / "model.toml")
    cfg = with_overrides(
        preset("nmpc", start="2014-03-03", days=1.0),
        {"building": str(path), "controller.reserve": False, "activation.mode": "never"},
    )
    frame = run_simulation(cfg, tmp_path / "run", progress=False).frame
    served = frame[[c for c in frame.columns if c.startswith("temp_served_")]].to_numpy()
    outdoor = frame["d_outdoor_temp_degc"].to_numpy()
    outside = (outdoor < 26.0) | (outdoor > 29.0) | (served > 25.5).any(axis=1)
    outside |= (served < 20.0).any(axis=1)
    assert outside.any()
    np.testing.assert_array_equal(frame["model_extrapolation"].to_numpy(), outside)
    from hvacflex.kpi import summary as kpi_summary

    assert kpi_summary(frame)["model_extrapolation_steps"] == outside.sum()


METERED = IdentifiedPower(
    base_kw=0.8,
    kw_per_kw_cooling=0.28,
    kw_per_k_outdoor=0.03,
    occupied_kw=0.6,
    kw_per_kg_s_k_outdoor_occupied=0.4,
    running_kw=1.5,
    fan_kw_per_kg_s=2.0,
    fan_kw_per_kg2_s2=3.0,
    kw_per_kw_cooling_k_outdoor=0.006,
    kw_per_kw2_cooling=-0.002,
    kw_per_kg_s_occupied=5.0,
)


def test_the_lp_row_is_the_tangent_of_the_metered_model_at_the_previous_plan() -> None:
    """Exact at the reference flow, with the model's derivative there (a central difference),
    for steps occupied and not; the running load in full where the reference runs."""
    t0, outdoor = 24.5, np.array([31.0, 29.0])
    occupied, reference = np.array([1.0, 0.0]), np.array([0.9, 0.4])
    p0, p = metered_affine_power(METERED, 13.0, 2, outdoor, t0, occupied, reference, 1.6)
    assert p.shape == (2, 2) and np.all(p[:, 0] == p[:, 1])
    for k in range(2):
        split = np.array([0.25, 0.75])  # any split of the total: one temperature T0

        def exact(total: float, k: int = k, split: np.ndarray = split) -> float:
            flows = total * split
            return float(
                metered_power_kw(METERED, 13.0, flows, np.full(2, t0), outdoor[k], occupied[k])
            )

        s = reference[k]
        assert p0[k] + p[k] @ (s * split) == pytest.approx(exact(s), rel=1e-12)
        slope = (exact(s + 1e-5) - exact(s - 1e-5)) / 2e-5
        assert p[k, 0] == pytest.approx(slope, rel=1e-6)


def test_a_loop_the_previous_plan_kept_off_pays_its_running_load_as_a_secant() -> None:
    t0, outdoor = 24.5, np.array([29.0])
    p0, p = metered_affine_power(METERED, 13.0, 2, outdoor, t0, None, np.array([0.0]), 1.6)
    off = float(metered_power_kw(METERED, 13.0, np.zeros(2), np.full(2, t0), 29.0))
    assert p0[0] == pytest.approx(off)  # off: the base load alone
    q = float(sensible_cooling_kw(1.0, t0, 13.0))
    plant = METERED.kw_per_kw_cooling + METERED.kw_per_kw_cooling_k_outdoor * (29.0 - 30.0)
    assert p[0, 0] == pytest.approx(METERED.fan_kw_per_kg_s + q * plant + 1.5 / 1.6)
    # at full flow the row still lies below the model (a lower bound until re-linearised)
    full = float(metered_power_kw(METERED, 13.0, np.full(2, 0.8), np.full(2, t0), 29.0))
    assert p0[0] + p[0] @ np.full(2, 0.8) <= full


def test_a_power_model_fitted_on_too_few_running_periods_is_refused_at_load() -> None:
    text = (resources_dir() / "buildings" / "office5.toml").read_text()
    base = tomllib.loads(text)
    base["power_models"] = {
        "rc": {
            "base_kw": 1.0,
            "kw_per_kw_cooling": 0.3,
            "kw_per_k_outdoor": 0.0,
            "running_periods": 20.0,
        }
    }
    with pytest.raises(BuildingConfigError, match="running_periods") as caught:
        building_from_dict(base)
    assert "refit it" in str(caught.value)
    base["power_models"]["rc"]["running_periods"] = 200.0
    building = building_from_dict(base)
    assert building.with_power_model_for("rc").metered_power == IdentifiedPower(
        base_kw=1.0, kw_per_kw_cooling=0.3, kw_per_k_outdoor=0.0, running_periods=200.0
    )
    assert building.with_power_model_for("energyplus").metered_power is None


def test_the_reserve_coefficient_of_a_metered_model_is_its_least_saving_by_hand() -> None:
    """Fan tangent at the curtailed flow, plant slope at the reference cooling, cooling per
    kg/s at the return air, no outdoor air: computed by hand."""
    zone = np.array([[24.0, 26.0]])
    coeff = metered_reserve_coeff(METERED, 13.0, [31.0], zone, [0.5], [1.2])
    q = CP_AIR_J_PER_KG_K * (zone - 13.0) / 1000.0
    q_ref = q.max() * 1.2
    plant = 0.28 + 0.006 * (31.0 - 30.0) + 2.0 * (-0.002) * q_ref
    fan = 2.0 + 2.0 * 3.0 * 0.5
    np.testing.assert_allclose(coeff, fan + plant * q, rtol=1e-12)


def test_hours_are_written_as_spans_and_read_back() -> None:
    flags = tuple(p < 12 or 30 <= p < 31 or p >= 40 for p in range(48))
    spans = hours_text(flags)
    assert spans == ["00:00-06:00", "15:00-15:30", "20:00-24:00"]
    assert parse_hours(spans) == flags
    assert hours_text([False] * 48) == [] and parse_hours([]) == (False,) * 48
    for bad in ("06:00-06:00", "6-7", "00:15-01:00", "00:00-24:30"):
        with pytest.raises(ValueError, match="HH:MM-HH:MM"):
            parse_hours([bad])


def test_fan_only_periods_are_looked_up_by_weekday_and_period() -> None:
    night = tuple(p < 12 or p >= 40 for p in range(48))
    idle = IdentifiedIdleAir(
        fan_only=(night,) * 5 + ((True,) * 48,) * 2, fan_only_difference_k=(-0.8,)
    )
    found = idle.fan_only_at([1, 1, 1, 5], [11, 12, 40, 20])
    np.testing.assert_array_equal(found, [True, False, True, True])
