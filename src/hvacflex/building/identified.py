"""An identified grey-box model as a building: its parameters and its power model.

A building identified from trend data (``hvacflex identify fit``, docs/identify.md) has no
walls or windows; its ``[identified]`` table holds the fitted RC network instead. Per zone
``i`` an air node and one mass node, and per unconditioned zone of the data (a plenum) a
boundary node (all temperatures [°C])::

    C_a,i dTa_i/dt = UA_o,i (To − Ta_i) + UA_am,i (Tm_i − Ta_i) + Σ_j UA_ij (Ta_j − Ta_i)
                     + Σ_b UA_ib (Tb_b − Ta_i) + S_a,i G + Σ_o S_o,i I_o + P_occ,i f(t) + P_0,i
                     + ṁ_i c_p (T_s − Ta_i)
    C_m,i dTm_i/dt = UA_am,i (Ta_i − Tm_i) + UA_mo,i (To − Tm_i) + S_m,i G
    C_b dTb_b/dt   = Σ_i UA_ib (Ta_i − Tb_b) + UA_bo,b (To − Tb_b) + S_b G + P_occ,b f(t)

``G`` is the global horizontal irradiance (the ``solar`` channel of azimuth 0, tilt 0),
``I_o`` the irradiance on a wall facing ``o`` of :data:`WALL_ORIENTATIONS` (the ``solar``
channels of tilt 90: a zone's windows face some of them, and the east zone's morning sun is
not the horizontal's noon),
``f(t)`` the office schedule's people fraction (the zone's ``internal_gain`` channel carries
:data:`GAIN_CHANNEL_PEAK_W` × f), the constant gains ``P_0`` enter through the ``constant``
channel. The HVAC input is the supply air flow ``ṁ`` at the supply temperature ``T_s`` fitted
from the data, so the delivered sensible cooling is ``Q = ṁ c_p (Ta − T_s)`` — the quantity
the fit used — and the building runs through the same linearisation, plant and controller as
a designed one. The HVAC electricity is the fitted affine model
``P = base + a ΣQ + b To`` [kW] (:class:`IdentifiedPower`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from hvacflex.units import CP_AIR_J_PER_KG_K, W_PER_KW

FloatArray = npt.NDArray[np.float64]

WALL_ORIENTATIONS = (("north", 0.0), ("east", 90.0), ("south", 180.0), ("west", 270.0))
"""The vertical planes whose irradiance enters an identified zone's air node: (name, azimuth
clockwise from north [°]). A building need not face north: the fit finds each zone's share
of each (``solar_wall_<name>_m2``)."""
GAIN_CHANNEL_PEAK_W = 1000.0
"""An identified zone's ``internal_gain`` channel at a people fraction of 1 [W]: the gain
channel's nominal floor area (:data:`NOMINAL_FLOOR_AREA_M2`) × 1 person/m² × this sensible
gain per person."""
NOMINAL_FLOOR_AREA_M2 = 1.0
"""The floor area that scales an identified zone's ``internal_gain`` channel
(:data:`GAIN_CHANNEL_PEAK_W`; ``Building.gain_floor_areas_m2``) — not its floor area, which
is the model file's ``floor_area_m2`` (NaN when the file gives none)."""
NOMINAL_HEIGHT_M = 1.0
"""The height an identified zone carries (unused by its network)."""


@dataclass(frozen=True)
class IdentifiedZone:
    """One fitted zone (units in the names; C in kJ/K, UA in kW/K, S in m², P in kW).

    ``flow_min_kg_s`` / ``flow_max_kg_s`` bound the supply flow (the training data's range),
    ``ventilation_flow_kg_s`` is the flow the zone's unit does not go below while occupied;
    ``mass_temp_degc`` is the mass node's mean estimated temperature on the test days, where a
    run starts it (a mass of weeks' time constant is not re-estimated within a day);
    ``solar_wall_<o>_m2`` its share of the irradiance on a wall facing ``o`` of
    :data:`WALL_ORIENTATIONS` (0 in files written before the walls were fitted).
    """

    name: str
    c_air_kj_per_k: float
    c_mass_kj_per_k: float
    ua_out_kw_per_k: float
    ua_air_mass_kw_per_k: float
    ua_mass_out_kw_per_k: float
    solar_air_m2: float
    solar_mass_m2: float
    occupied_gain_kw: float
    base_gain_kw: float
    flow_min_kg_s: float
    flow_max_kg_s: float
    ventilation_flow_kg_s: float
    mass_temp_degc: float
    solar_wall_north_m2: float = 0.0
    solar_wall_east_m2: float = 0.0
    solar_wall_south_m2: float = 0.0
    solar_wall_west_m2: float = 0.0

    def wall_solar_m2(self) -> tuple[float, ...]:
        """The wall shares in :data:`WALL_ORIENTATIONS` order [m²]."""
        return tuple(float(getattr(self, f"solar_wall_{o}_m2")) for o, _ in WALL_ORIENTATIONS)


@dataclass(frozen=True)
class IdentifiedCoupling:
    """Heat exchange ``ua_kw_per_k`` [kW/K] between the air nodes of two zones."""

    zone_a: str
    zone_b: str
    ua_kw_per_k: float


@dataclass(frozen=True)
class IdentifiedBoundary:
    """An unconditioned zone of the data (a plenum) as a node of the model.

    Attributes
    ----------
    name : the data's (IDF's) name of the zone.
    c_kj_per_k : its capacitance [kJ/K]; ua_out_kw_per_k : to the outdoor air [kW/K];
    solar_m2 : share of the horizontal irradiance it absorbs [m²];
    occupied_gain_kw : gain at a people fraction of 1 [kW] (e.g. lights in a return plenum);
    ua_zone_kw_per_k : zone name → conductance to that zone's air node [kW/K];
    temp_degc : its mean measured temperature on the test days (a run's start) [°C].
    """

    name: str
    c_kj_per_k: float
    ua_out_kw_per_k: float
    solar_m2: float
    occupied_gain_kw: float
    ua_zone_kw_per_k: tuple[tuple[str, float], ...]
    temp_degc: float


@dataclass(frozen=True)
class IdentifiedPower:
    """HVAC electricity [kW] ≈ ``base_kw + kw_per_kw_cooling · ΣQ + kw_per_k_outdoor · To
    + occupied_kw · occ + kw_per_kg_s_k_outdoor_occupied · occ · Σṁ (To − Ta)``
    (period means; Q the delivered sensible cooling [kW], To the outdoor temperature [°C],
    occ the occupied share [–], ṁ the zone supply flows [kg/s], Ta the zone temperatures
    [°C]: the last term is the outdoor air the air system mixes in while the building is
    occupied, which a weekend without it does not draw)."""

    base_kw: float
    kw_per_kw_cooling: float
    kw_per_k_outdoor: float
    occupied_kw: float = 0.0
    kw_per_kg_s_k_outdoor_occupied: float = 0.0


@dataclass(frozen=True)
class IdentifiedValidity:
    """The range the training data covered — where the fitted model is an interpolation.

    Attributes
    ----------
    zone_temp_min_degc, zone_temp_max_degc : (m,) each zone's lowest and highest measured air
    temperature on the training days [°C] (zone order); outdoor_temp_min_degc,
    outdoor_temp_max_degc : the outdoor air's [°C]. (The supply flows' range is each zone's
    ``flow_min_kg_s`` … ``flow_max_kg_s``.)
    """

    zone_temp_min_degc: tuple[float, ...]
    zone_temp_max_degc: tuple[float, ...]
    outdoor_temp_min_degc: float
    outdoor_temp_max_degc: float

    def outside(
        self, zone_temp_degc: npt.ArrayLike, outdoor_temp_degc: npt.ArrayLike
    ) -> npt.NDArray[np.bool_]:
        """(T,) whether each period lies outside the range: a zone temperature (T, m) [°C] or
        the outdoor temperature (T,) [°C] beyond what the training data saw."""
        temp = np.atleast_2d(np.asarray(zone_temp_degc, dtype=np.float64))
        outdoor = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
        zone = (temp < np.asarray(self.zone_temp_min_degc)) | (
            temp > np.asarray(self.zone_temp_max_degc)
        )
        out: npt.NDArray[np.bool_] = (
            zone.any(axis=1)
            | (outdoor < self.outdoor_temp_min_degc)
            | (outdoor > self.outdoor_temp_max_degc)
        )
        return out


@dataclass(frozen=True)
class IdentifiedRC:
    """The ``[identified]`` table of a building file.

    Attributes
    ----------
    zones : (m,) in the building's zone order; couplings : zone pairs; boundaries : nodes of
    unconditioned zones; supply_temp_degc : the supply air temperature of the HVAC input [°C];
    power : the HVAC electricity model, or None (no meter in the data: ideal loads);
    provenance : where it came from (data file, train and test days);
    validity : the training data's range, or None (files written before it was recorded).
    """

    zones: tuple[IdentifiedZone, ...]
    couplings: tuple[IdentifiedCoupling, ...]
    boundaries: tuple[IdentifiedBoundary, ...]
    supply_temp_degc: float
    power: IdentifiedPower | None
    provenance: tuple[tuple[str, str], ...] = ()
    validity: IdentifiedValidity | None = None


def sensible_cooling_kw(
    flow_kg_s: npt.ArrayLike, zone_temp_degc: npt.ArrayLike, supply_temp_degc: npt.ArrayLike
) -> FloatArray:
    """(…, m) the sensible cooling ``ṁ c_p (Ta − T_s)`` [kW] supply air delivers: flows
    [kg/s] into zones at ``Ta`` [°C], supplied at ``T_s`` [°C] (broadcast). The one home of
    this formula: the fit's cooling input, the power model and the observer's delivered
    input take it from here."""
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    temp = np.asarray(zone_temp_degc, dtype=np.float64)
    supply = np.asarray(supply_temp_degc, dtype=np.float64)
    out: FloatArray = flow * CP_AIR_J_PER_KG_K * (temp - supply) / W_PER_KW
    return out


def identified_power_kw(
    rc: IdentifiedRC,
    flow_kg_s: npt.ArrayLike,
    zone_temp_degc: npt.ArrayLike,
    outdoor_temp_degc: float,
    occupied: float = 0.0,
) -> float:
    """The power model's HVAC electricity [kW] for (m,) flows [kg/s] and zone temperatures
    [°C] at an occupied share ``occupied`` [–] (0 without a power model)."""
    if rc.power is None:
        return 0.0
    total = float(sensible_cooling_kw(flow_kg_s, zone_temp_degc, rc.supply_temp_degc).sum())
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    outdoor_air = float((flow * (outdoor_temp_degc - np.asarray(zone_temp_degc))).sum())
    p = rc.power
    return max(
        p.base_kw
        + p.kw_per_kw_cooling * total
        + p.kw_per_k_outdoor * outdoor_temp_degc
        + occupied * (p.occupied_kw + p.kw_per_kg_s_k_outdoor_occupied * outdoor_air),
        0.0,
    )


def identified_occupied_share(channel_names: tuple[str, ...], d: npt.ArrayLike) -> float:
    """The occupied share [–] an identified building's disturbances ``d`` (nd,) carry: its
    first ``internal_gain`` channel over :data:`GAIN_CHANNEL_PEAK_W` (0 without one)."""
    values = np.asarray(d, dtype=np.float64)
    for i, name in enumerate(channel_names):
        if name.startswith("internal_gain"):
            return float(np.clip(values[i] / GAIN_CHANNEL_PEAK_W, 0.0, 1.0))
    return 0.0


def identified_affine_power(
    rc: IdentifiedRC,
    outdoor_temp_degc: npt.ArrayLike,
    zone_temp_ref_degc: float,
    occupied: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """The LP's ``P_k = p0_k + p_kᵀ u_k`` of the power model, the cooling and the outdoor
    air taken at ``T₀``.

    Parameters
    ----------
    outdoor_temp_degc : (N,) forecast outdoor temperature [°C].
    zone_temp_ref_degc : T₀ [°C], where ``Q_i = ṁ_i c_p (T₀ − T_s)``.
    occupied : (N,) forecast occupied share [–] (None: 0).

    Returns
    -------
    p0 : (N,) [kW]; p : (N, m) [kW per kg/s] (zeros without a power model).
    """
    outdoor = np.asarray(outdoor_temp_degc, dtype=np.float64)
    m = len(rc.zones)
    if rc.power is None:
        return np.zeros(outdoor.shape[0]), np.zeros((outdoor.shape[0], m))
    per_kg_s = rc.power.kw_per_kw_cooling * float(
        sensible_cooling_kw(1.0, zone_temp_ref_degc, rc.supply_temp_degc)
    )
    occ = np.zeros_like(outdoor) if occupied is None else np.asarray(occupied, dtype=np.float64)
    power = rc.power
    p0: FloatArray = power.base_kw + power.kw_per_k_outdoor * outdoor + power.occupied_kw * occ
    outdoor_air_k = occ * (outdoor - zone_temp_ref_degc)
    per_flow = per_kg_s + power.kw_per_kg_s_k_outdoor_occupied * outdoor_air_k
    p: FloatArray = np.repeat(np.maximum(per_flow, 0.0)[:, None], m, axis=1)
    return p0, p


def initial_node_temps_degc(rc: IdentifiedRC, zone_temp_degc: float) -> FloatArray:
    """(2m + nb,) a run's first state: the zones at ``zone_temp_degc`` [°C], the mass and
    boundary nodes at their estimated temperatures (node order of the identified network)."""
    return np.array(
        [zone_temp_degc] * len(rc.zones)
        + [z.mass_temp_degc for z in rc.zones]
        + [b.temp_degc for b in rc.boundaries]
    )
