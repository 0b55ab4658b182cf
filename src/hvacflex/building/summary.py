"""``hvacflex building show``: a readable summary of a building and its models.

:func:`summarize` computes the numbers (:class:`BuildingSummary`), :func:`format_summary`
renders them as plain text. Design cooling load: steady state with every zone held at
``DESIGN_ZONE_TEMP_DEGC``, the ASHRAE 0.4 % cooling design outdoor condition of Singapore
(Changi, ASHRAE climatic design data as given in the TMYx header), design irradiance on every
exterior orientation at once (non-coincident, so an upper estimate) and full internal gains.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hvacflex.building.air_handler import outdoor_air_kg_s
from hvacflex.building.discretize import (
    DEFAULT_LINEARISATION_TEMP_DEGC,
    continuous_affine_model,
    linearize,
)
from hvacflex.building.hvac import affine_power_error, hvac_power
from hvacflex.building.model import Building
from hvacflex.building.rc import build_network, envelope_ua_w_per_k
from hvacflex.constants import PERIOD_S
from hvacflex.units import (
    CP_AIR_J_PER_KG_K,
    RHO_AIR_KG_PER_M3,
    SECONDS_PER_HOUR,
    W_PER_KW,
)

DESIGN_OUTDOOR_TEMP_DEGC = 33.2
"""Singapore Changi 0.4 % cooling design dry bulb (ASHRAE climatic design data) [°C]."""
DESIGN_OUTDOOR_HUMIDITY_RATIO_KG_PER_KG = 0.0194
"""Humidity ratio at 33.2 °C dry bulb / 26.4 °C mean coincident wet bulb [kg/kg]."""
DESIGN_SOLAR_VERTICAL_W_PER_M2 = 400.0
"""Design irradiance on a vertical façade (E/W peaks near the equator reach ~500) [W/m²]."""
DESIGN_SOLAR_HORIZONTAL_W_PER_M2 = 950.0
"""Design irradiance on a horizontal roof [W/m²]."""
DESIGN_ZONE_TEMP_DEGC = 24.0
"""Zone temperature held for the design load [°C]."""
A_TOLERANCE = -1e-12
"""Elementwise tolerance of the discrete A ≥ 0 check (docs/explanation/model.md §1)."""
VENTILATION_L_S_PER_PERSON = 5.5
VENTILATION_L_S_PER_M2 = 0.3
"""Outdoor-air requirement (docs/explanation/model.md §1) [L/s per person, L/s per m²]."""


@dataclass(frozen=True)
class ZoneSummary:
    name: str
    floor_area_m2: float
    volume_m3: float
    capacitance_mj_per_k: float
    flow_min_kg_s: float
    ventilation_flow_kg_s: float
    flow_max_kg_s: float
    design_load_kw: float
    design_flow_kg_s: float
    reserve: bool


@dataclass(frozen=True)
class BuildingSummary:
    """Numbers shown by ``hvacflex building show`` (units in the names)."""

    name: str
    description: str
    source: str
    floor_area_m2: float
    zones: tuple[ZoneSummary, ...]
    node_names: tuple[str, ...]
    channel_names: tuple[str, ...]
    time_constants_h: tuple[float, ...]
    time_constants_min_flow_h: tuple[float, ...]
    ua_walls_w_per_k: float
    ua_ground_w_per_k: float
    ua_windows_w_per_k: float
    ua_total_w_per_k: float
    design_zone_load_kw: float
    design_coil_load_kw: float
    design_power_kw: float
    flow_min_total_kg_s: float
    flow_max_total_kg_s: float
    outdoor_air_at_ventilation_flow_l_s: float
    ventilation_need_l_s: float
    dt_s: float
    linearisation_temp_degc: float
    a_min: float
    a_nonnegative: bool
    b_reserve_max: float
    b_reserve_nonpositive: bool
    spectral_radius: float
    affine_power_max_abs_kw: float
    affine_power_max_rel: float


def design_disturbance(b: Building) -> np.ndarray:
    """(nd,) design-day disturbance vector in the building's channel order."""
    net = build_network(b)
    d = np.zeros(len(net.channels))
    for j, channel in enumerate(net.channels):
        if channel.kind == "outdoor_temp":
            d[j] = DESIGN_OUTDOOR_TEMP_DEGC
        elif channel.kind == "solar":
            vertical = channel.tilt_deg is not None and channel.tilt_deg > 0
            d[j] = DESIGN_SOLAR_VERTICAL_W_PER_M2 if vertical else DESIGN_SOLAR_HORIZONTAL_W_PER_M2
        elif channel.kind == "window_solar_gain" and channel.window is not None:
            window = channel.window
            shgc = window.shgc_normal if window.shgc_normal is not None else window.shgc
            d[j] = shgc * DESIGN_SOLAR_VERTICAL_W_PER_M2
        elif channel.kind == "internal_gain":
            area_m2 = b.gain_floor_areas_m2[b.zone_index(str(channel.zone))]
            d[j] = area_m2 * b.gains.peak_sensible_w_per_m2
        elif channel.kind == "ground_temp":
            d[j] = DESIGN_ZONE_TEMP_DEGC
        elif channel.kind == "constant":
            d[j] = 1.0
    return d


def summarize(
    b: Building,
    dt_s: float = PERIOD_S,
    linearisation_temp_degc: float = DEFAULT_LINEARISATION_TEMP_DEGC,
) -> BuildingSummary:
    """Compute the summary of a building (see :class:`BuildingSummary`)."""
    net = build_network(b)
    lm = linearize(b, dt_s, linearisation_temp_degc, network=net)
    hvac = b.hvac
    flow_min = np.asarray(hvac.flow_min_kg_s)
    flow_max = np.asarray(hvac.flow_max_kg_s)

    tau = np.sort(-1.0 / np.linalg.eigvals(net.a_cont).real) / SECONDS_PER_HOUR
    a_min_flow, *_ = continuous_affine_model(b, net, flow_min, linearisation_temp_degc)
    tau_min = np.sort(-1.0 / np.linalg.eigvals(a_min_flow).real) / SECONDS_PER_HOUR

    d = design_disturbance(b)
    zone_load_w = net.zone_heat_extraction_w(d, DESIGN_ZONE_TEMP_DEGC)
    per_kg_s = CP_AIR_J_PER_KG_K * (DESIGN_ZONE_TEMP_DEGC - hvac.supply_temp_degc)
    design_flow = np.maximum(zone_load_w / per_kg_s, 0.0)
    operating_flow = np.clip(design_flow, flow_min, flow_max)
    people_latent_w = b.floor_area_m2 / b.gains.occupancy_m2_per_person
    people_latent_w *= b.gains.latent_w_per_person
    power = hvac_power(
        hvac,
        operating_flow,
        np.full(len(b.zones), DESIGN_ZONE_TEMP_DEGC),
        DESIGN_OUTDOOR_TEMP_DEGC,
        DESIGN_OUTDOOR_HUMIDITY_RATIO_KG_PER_KG,
        latent_gain_w=people_latent_w,
    )
    ua = envelope_ua_w_per_k(b)
    reserve = np.asarray(b.reserve_mask)
    b_reserve = lm.b[:, reserve]
    error = affine_power_error(
        hvac,
        [DESIGN_OUTDOOR_TEMP_DEGC],
        [DESIGN_OUTDOOR_HUMIDITY_RATIO_KG_PER_KG],
        linearisation_temp_degc,
        flow_min_kg_s=hvac.ventilation_flow_kg_s,
    )
    people = b.floor_area_m2 / b.gains.occupancy_m2_per_person
    zones = tuple(
        ZoneSummary(
            name=z.name,
            floor_area_m2=z.floor_area_m2,
            volume_m3=z.volume_m3,
            capacitance_mj_per_k=z.capacitance_j_per_k / 1e6,
            flow_min_kg_s=float(flow_min[i]),
            ventilation_flow_kg_s=float(hvac.ventilation_flow_kg_s[i]),
            flow_max_kg_s=float(flow_max[i]),
            design_load_kw=float(zone_load_w[i] / W_PER_KW),
            design_flow_kg_s=float(design_flow[i]),
            reserve=bool(reserve[i]),
        )
        for i, z in enumerate(b.zones)
    )
    return BuildingSummary(
        name=b.name,
        description=b.description,
        source=str(b.source_path) if b.source_path else "<in memory>",
        floor_area_m2=b.floor_area_m2,
        zones=zones,
        node_names=net.node_names,
        channel_names=net.channel_names,
        time_constants_h=tuple(float(t) for t in tau),
        time_constants_min_flow_h=tuple(float(t) for t in tau_min),
        ua_walls_w_per_k=ua["walls"],
        ua_ground_w_per_k=ua["ground"],
        ua_windows_w_per_k=ua["windows"],
        ua_total_w_per_k=ua["total"],
        design_zone_load_kw=float(zone_load_w.sum() / W_PER_KW),
        design_coil_load_kw=float(
            (np.maximum(power.coil_sensible_w, 0.0) + power.coil_latent_w) / W_PER_KW
        ),
        design_power_kw=float(power.total_kw),
        flow_min_total_kg_s=float(flow_min.sum()),
        flow_max_total_kg_s=float(flow_max.sum()),
        outdoor_air_at_ventilation_flow_l_s=float(
            outdoor_air_kg_s(hvac, sum(hvac.ventilation_flow_kg_s)) / RHO_AIR_KG_PER_M3 * 1000.0
        ),
        ventilation_need_l_s=people * VENTILATION_L_S_PER_PERSON
        + b.floor_area_m2 * VENTILATION_L_S_PER_M2,
        dt_s=lm.dt_s,
        linearisation_temp_degc=linearisation_temp_degc,
        a_min=float(lm.a.min()),
        a_nonnegative=bool(lm.a.min() >= A_TOLERANCE),
        b_reserve_max=float(b_reserve.max()) if b_reserve.size else 0.0,
        b_reserve_nonpositive=bool(b_reserve.size == 0 or b_reserve.max() <= 0.0),
        spectral_radius=float(np.max(np.abs(np.linalg.eigvals(lm.a)))),
        affine_power_max_abs_kw=error.max_abs_kw,
        affine_power_max_rel=error.max_rel,
    )


def _yes(flag: bool) -> str:
    return "yes" if flag else "NO"


def _taus(values: tuple[float, ...]) -> str:
    shown = [f"{t:.3g}" for t in values]
    return ", ".join(shown)


def ventilation_warning(s: BuildingSummary) -> str | None:
    """A warning line when the outdoor air at ventilation flow is below the requirement
    (:data:`VENTILATION_L_S_PER_PERSON`, :data:`VENTILATION_L_S_PER_M2`), else None."""
    if s.outdoor_air_at_ventilation_flow_l_s >= s.ventilation_need_l_s:
        return None
    return (
        f"WARNING: ventilation below requirement: outdoor air at ventilation flow "
        f"{s.outdoor_air_at_ventilation_flow_l_s:.0f} L/s < {s.ventilation_need_l_s:.0f} L/s "
        f"needed ({VENTILATION_L_S_PER_PERSON:g} L/s per person + {VENTILATION_L_S_PER_M2:g} "
        "L/s per m²); raise [hvac] ventilation_flow_kg_s or outdoor_air_fraction"
    )


def undersized_zone_warnings(s: BuildingSummary) -> list[str]:
    """A warning line per zone whose design load needs more supply air than its maximum flow
    (``design_flow_kg_s`` > ``flow_max_kg_s``): at design conditions that zone warms above
    the design temperature whatever the controller does."""
    return [
        f"WARNING: zone {z.name!r} is under-sized: its design load {z.design_load_kw:.1f} kW "
        f"needs {z.design_flow_kg_s:.2f} kg/s of supply air, its maximum flow is "
        f"{z.flow_max_kg_s:.2f} kg/s; raise [hvac] flow_max_kg_s for it (or lower its gains)"
        for z in s.zones
        if z.design_flow_kg_s > z.flow_max_kg_s
    ]


def format_comfort_band(
    occupied_degc: tuple[float, float],
    unoccupied_degc: tuple[float, float],
    occupied_hours: tuple[int, int],
    source: str,
) -> str:
    """The comfort band as one line: occupied band [°C] in the occupied hours of working
    days (local time), unoccupied band otherwise, and where it comes from (``source``)."""
    return (
        f"Comfort band ({source}): {occupied_degc[0]:g}–{occupied_degc[1]:g} °C occupied "
        f"({occupied_hours[0]:02d}:00–{occupied_hours[1]:02d}:00 working days), "
        f"{unoccupied_degc[0]:g}–{unoccupied_degc[1]:g} °C otherwise; set it in the "
        "scenario's [comfort] table"
    )


def format_summary(s: BuildingSummary) -> str:
    """Plain-text rendering of a :class:`BuildingSummary` (with :func:`ventilation_warning`
    under the flow range when ventilation falls short, and :func:`undersized_zone_warnings`
    under the zones table; the zones table marks such a zone's "needs" with ``!``)."""
    warning = ventilation_warning(s)
    lines = [
        f"Building {s.name!r}  ({s.source})",
        f"  {s.description}",
        f"Floor area {s.floor_area_m2:,.1f} m², {len(s.zones)} zones, {len(s.node_names)} nodes, "
        f"{len(s.channel_names)} disturbance channels",
        "",
        "Zones                area m²  volume m³  C MJ/K  flow min/vent/max kg/s  design load kW  "
        "needs kg/s  reserve",
    ]
    for z in s.zones:
        lines.append(
            f"  {z.name:<18} {z.floor_area_m2:8.1f} {z.volume_m3:10.1f}"
            f" {z.capacitance_mj_per_k:7.2f}"
            f"  {z.flow_min_kg_s:4.2f}/{z.ventilation_flow_kg_s:4.2f}/{z.flow_max_kg_s:<4.2f}"
            f"         {z.design_load_kw:14.1f}"
            f"  {z.design_flow_kg_s:10.2f}{'!' if z.design_flow_kg_s > z.flow_max_kg_s else ' '}"
            f" {'yes' if z.reserve else 'no'}"
        )
    lines += [
        *undersized_zone_warnings(s),
        "",
        "Nodes: " + ", ".join(s.node_names),
        "Disturbances d: " + ", ".join(s.channel_names),
        "",
        "Time constants [h] (eigenvalues of a_cont, no VAV): " + _taus(s.time_constants_h),
        "Time constants [h] at minimum flow:                 " + _taus(s.time_constants_min_flow_h),
        "",
        f"Envelope UA [W/K]: walls {s.ua_walls_w_per_k:.1f}, ground {s.ua_ground_w_per_k:.1f}, "
        f"windows {s.ua_windows_w_per_k:.1f}, total {s.ua_total_w_per_k:.1f} "
        f"({s.ua_total_w_per_k / s.floor_area_m2:.2f} W/m²K of floor)",
        f"Design cooling load (T_out {DESIGN_OUTDOOR_TEMP_DEGC:g} °C, zones "
        f"{DESIGN_ZONE_TEMP_DEGC:g} °C, all façades {DESIGN_SOLAR_VERTICAL_W_PER_M2:g} W/m², "
        "full gains):",
        f"  zones sensible {s.design_zone_load_kw:.1f} kW "
        f"({s.design_zone_load_kw * 1000 / s.floor_area_m2:.0f} W/m²); coil incl. outdoor air "
        f"and latent {s.design_coil_load_kw:.1f} kW "
        f"({s.design_coil_load_kw * 1000 / s.floor_area_m2:.0f} W/m²); "
        f"electric {s.design_power_kw:.1f} kW",
        f"Flow range: Σ {s.flow_min_total_kg_s:.2f} – {s.flow_max_total_kg_s:.2f} kg/s; outdoor "
        f"air at ventilation flow {s.outdoor_air_at_ventilation_flow_l_s:.0f} L/s (need "
        f"{s.ventilation_need_l_s:.0f} L/s)",
        *([warning] if warning else []),
        "",
        f"Discrete model (Δt {s.dt_s:g} s, T₀ {s.linearisation_temp_degc:g} °C):",
        f"  A ≥ 0 elementwise (tol {A_TOLERANCE:g}): {_yes(s.a_nonnegative)} (min {s.a_min:.3g})",
        f"  reserve-carrying B columns ≤ 0: {_yes(s.b_reserve_nonpositive)} "
        f"(max {s.b_reserve_max:.3g})",
        f"  spectral radius of A: {s.spectral_radius:.6f} "
        f"({'stable' if s.spectral_radius < 1 else 'NOT stable'})",
        f"Affine power model at design conditions: max error {s.affine_power_max_abs_kw:.2f} kW "
        f"({100 * s.affine_power_max_rel:.1f} %) over the occupied flow range (secants)",
    ]
    return "\n".join(lines)


def building_summary_text(b: Building) -> str:
    """``format_summary(summarize(b))``."""
    return format_summary(summarize(b))
