"""An identified grey-box model as a building: its parameters and its power model.

A building identified from trend data (``hvacflex identify fit``, docs/guide/identify.md) has no
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
a designed one. The HVAC electricity is the power model fitted to the meter
(:class:`IdentifiedPower`: fan with its floor, the plant's part load and outdoor-temperature
dependence, the outdoor air while occupied, the base load while the air loop runs), which a
designed building can carry too (its ``[power_models.<plant>]``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from hvacflex.constants import PERIOD_S, PERIODS_PER_DAY
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


PLANT_REFERENCE_OUTDOOR_DEGC = 30.0
"""The outdoor temperature [°C] at which a metered power model's ``kw_per_kw_cooling`` holds:
its plant's outdoor-temperature term is ``kw_per_kw_cooling_k_outdoor · ΣQ (To − 30 °C)``."""
REFERENCE_HUMIDITY_KG_PER_KG = 0.018
"""The outdoor humidity ratio [kg/kg] at which a metered power model's ``occupied_kw`` holds
(a 23.5 °C dew point at sea level): its outdoor air's moisture term is
``kw_per_humidity_ratio_occupied · occ · (Wo − 0.018)``."""
RUNNING_FLOW_KG_S = 1e-3
"""A period-mean total supply flow above this counts as the air loop running [kg/s]."""
MIN_RUNNING_PERIODS = 96
"""The fewest training periods with the air loop running a power model is fitted on (30-min
periods: about two working days); fewer leave its fan, coil and plant terms undetermined."""


@dataclass(frozen=True)
class IdentifiedPower:
    """A power model fitted to a building's meter: HVAC electricity [kW] per period ≈ ::

        base_kw + kw_per_k_outdoor · To + occupied_kw · occ                  (base load)
        + running_kw · run                                  (while the air loop runs)
        + fan_kw_per_kg_s · S + fan_kw_per_kg2_s2 · S²      (fan above its floor)
        + ΣQ · (kw_per_kw_cooling + kw_per_kw_cooling_k_outdoor · (To − 30 °C))
        + kw_per_kw2_cooling · (ΣQ)²                        (plant: outdoor temp, part load)
        + occ · (kw_per_kg_s_k_outdoor_occupied · Σṁ (To − Ta) + kw_per_kg_s_occupied · S)
        + occ · kw_per_humidity_ratio_occupied · (Wo − 0.018)      (outdoor air's moisture)

    (period means; Q = ṁ c_p (Ta − T_s) the zones' delivered sensible cooling [kW], To the
    outdoor temperature [°C], Wo its humidity ratio [kg/kg] (:data:`REFERENCE_HUMIDITY_KG_PER_KG`),
    occ the occupied share [–] (the outdoor-air damper open), ṁ the
    zone supply flows and S = Σṁ [kg/s], Ta the zone temperatures [°C], run = 1 while
    S > :data:`RUNNING_FLOW_KG_S`, else 0). ``running_kw`` is what the air loop draws as soon
    as it runs (the fan's static-pressure floor, pumps, controls); the last line is the outdoor
    air the damper lets in while occupied: its sensible heat and its moisture (the coil's
    latent load per kg/s of supply); the moisture line is that air's latent load as the
    outdoor humidity moves it (the ventilation air is about constant while occupied: a
    humid afternoon loads the coil at the same supply flow). Every term but the first five
    defaults to 0 (files written before them). ``running_periods`` is the number of
    training periods with the loop running (None: not recorded)."""

    base_kw: float
    kw_per_kw_cooling: float
    kw_per_k_outdoor: float
    occupied_kw: float = 0.0
    kw_per_kg_s_k_outdoor_occupied: float = 0.0
    running_kw: float = 0.0
    fan_kw_per_kg_s: float = 0.0
    fan_kw_per_kg2_s2: float = 0.0
    kw_per_kw_cooling_k_outdoor: float = 0.0
    kw_per_kw2_cooling: float = 0.0
    kw_per_kg_s_occupied: float = 0.0
    kw_per_humidity_ratio_occupied: float = 0.0
    running_periods: float | None = None


def metered_power_kw(
    power: IdentifiedPower,
    supply_temp_degc: float,
    flow_kg_s: npt.ArrayLike,
    zone_temp_degc: npt.ArrayLike,
    outdoor_temp_degc: npt.ArrayLike,
    occupied: npt.ArrayLike = 0.0,
    outdoor_humidity_ratio_kg_per_kg: npt.ArrayLike = REFERENCE_HUMIDITY_KG_PER_KG,
) -> FloatArray:
    """(…) the power model's HVAC electricity [kW], never below 0: flows (…, m) [kg/s] into
    zones at (…, m) [°C] supplied at ``supply_temp_degc`` [°C], outdoor temperature [°C],
    occupied share [–] and outdoor humidity ratio [kg/kg] (…) (:class:`IdentifiedPower`)."""
    flow = np.asarray(flow_kg_s, dtype=np.float64)
    temp = np.asarray(zone_temp_degc, dtype=np.float64)
    outdoor = np.asarray(outdoor_temp_degc, dtype=np.float64)
    occ = np.asarray(occupied, dtype=np.float64)
    total = flow.sum(axis=-1)
    cooling = sensible_cooling_kw(flow, temp, supply_temp_degc).sum(axis=-1)
    outdoor_air = (flow * (outdoor[..., None] - temp)).sum(axis=-1)
    p = power
    value = (
        p.base_kw
        + p.kw_per_k_outdoor * outdoor
        + p.occupied_kw * occ
        + p.running_kw * (total > RUNNING_FLOW_KG_S)
        + p.fan_kw_per_kg_s * total
        + p.fan_kw_per_kg2_s2 * total**2
        + cooling
        * (
            p.kw_per_kw_cooling
            + p.kw_per_kw_cooling_k_outdoor * (outdoor - PLANT_REFERENCE_OUTDOOR_DEGC)
        )
        + p.kw_per_kw2_cooling * cooling**2
        + occ * (p.kw_per_kg_s_k_outdoor_occupied * outdoor_air + p.kw_per_kg_s_occupied * total)
        + occ * humidity_term_kw(p, outdoor_humidity_ratio_kg_per_kg)
    )
    out: FloatArray = np.maximum(value, 0.0)
    return out


def humidity_term_kw(
    power: IdentifiedPower, outdoor_humidity_ratio_kg_per_kg: npt.ArrayLike
) -> FloatArray:
    """(…) the occupied outdoor air's moisture term [kW] at an occupied share of 1:
    ``kw_per_humidity_ratio_occupied · (Wo − 0.018)`` at the outdoor humidity ratio (…)
    [kg/kg]."""
    humidity = np.asarray(outdoor_humidity_ratio_kg_per_kg, dtype=np.float64)
    term: FloatArray = power.kw_per_humidity_ratio_occupied * (
        humidity - REFERENCE_HUMIDITY_KG_PER_KG
    )
    return term


def metered_affine_power(
    power: IdentifiedPower,
    supply_temp_degc: float,
    zones: int,
    outdoor_temp_degc: npt.ArrayLike,
    zone_temp_ref_degc: float,
    occupied: npt.ArrayLike | None = None,
    total_flow_ref_kg_s: npt.ArrayLike | None = None,
    total_flow_max_kg_s: float = 0.0,
    outdoor_humidity_ratio_kg_per_kg: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """The LP's ``P_k = p0_k + p_kᵀ u_k`` of a metered power model, re-linearised along a
    reference flow (the previous plan's).

    At the reference temperature T₀ every zone's kg/s delivers the same cooling
    ``q = c_p (T₀ − T_s)`` and the same outdoor air, so the model is a function of the total
    flow S alone, ``P(S) = c + α S + β S²`` (β the fan's and the plant's part-load curvature);
    the LP takes its tangent at the step's reference flow S̄_k, ``P(S̄) + P'(S̄)(S − S̄)``
    (exact at S̄, slope never below 0). The running load counts in full where S̄_k runs; where
    the reference is off (the previous plan kept the loop off and nothing forces it on) it
    enters as its secant over [0, ``total_flow_max_kg_s``], ``running_kw · S / S_max``, so
    the plan that starts the loop pays for it (a lower bound until the next re-linearisation).

    Parameters
    ----------
    zones : m, the number of zone flows.
    outdoor_temp_degc : (N,) forecast outdoor temperature [°C].
    zone_temp_ref_degc : T₀ [°C].
    occupied : (N,) forecast occupied share [–] (None: 0).
    total_flow_ref_kg_s : (N,) the reference total flow S̄_k [kg/s] (None: 0 — off).
    total_flow_max_kg_s : S_max, the largest total flow [kg/s] (0: the running load is
        counted only where the reference runs).
    outdoor_humidity_ratio_kg_per_kg : (N,) forecast outdoor humidity ratio [kg/kg] (None: the
        reference 0.018, where the moisture term is 0).

    Returns
    -------
    p0 : (N,) [kW]; p : (N, m) [kW per kg/s], the same for every zone.
    """
    outdoor = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    steps = outdoor.shape[0]
    occ = np.zeros(steps) if occupied is None else np.asarray(occupied, dtype=np.float64)
    ref = np.zeros(steps) if total_flow_ref_kg_s is None else np.asarray(total_flow_ref_kg_s)
    ref = np.broadcast_to(np.maximum(ref.astype(np.float64), 0.0), (steps,))
    p = power
    q = float(sensible_cooling_kw(1.0, zone_temp_ref_degc, supply_temp_degc))  # kW per kg/s
    plant = p.kw_per_kw_cooling + p.kw_per_kw_cooling_k_outdoor * (
        outdoor - PLANT_REFERENCE_OUTDOOR_DEGC
    )
    alpha = (
        p.fan_kw_per_kg_s
        + q * plant
        + occ * (p.kw_per_kg_s_k_outdoor_occupied * (outdoor - zone_temp_ref_degc))
        + occ * p.kw_per_kg_s_occupied
    )
    beta = p.fan_kw_per_kg2_s2 + p.kw_per_kw2_cooling * q**2
    constant = p.base_kw + p.kw_per_k_outdoor * outdoor + p.occupied_kw * occ
    if outdoor_humidity_ratio_kg_per_kg is not None:
        constant = constant + occ * humidity_term_kw(p, outdoor_humidity_ratio_kg_per_kg)
    running = ref > RUNNING_FLOW_KG_S
    slope = np.maximum(alpha + 2.0 * beta * ref, 0.0)
    value_at_ref = constant + alpha * ref + beta * ref**2
    p0: FloatArray = value_at_ref - slope * ref + np.where(running, p.running_kw, 0.0)
    if total_flow_max_kg_s > 0.0:
        slope = slope + np.where(running, 0.0, p.running_kw / total_flow_max_kg_s)
    per_flow: FloatArray = np.repeat(slope[:, None], zones, axis=1)
    return p0, per_flow


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


WEEKDAYS = ("monday", "tuesday", "wednesday", "thursday", "friday", "saturday", "sunday")
"""The keys of ``[identified.idle_air] fan_only_hours``, Monday first (pandas' ``day_of_week``
0 … 6)."""
PERIOD_MIN = round(PERIOD_S / 60)
"""The period [min]: the resolution of the idle air's hours."""


def hours_text(periods: npt.ArrayLike) -> list[str]:
    """The (48,) bool periods of a day as ``"HH:MM-HH:MM"`` spans (end exclusive, ``24:00``
    the day's end): ``[True] * 12 + [False] * 36`` → ``["00:00-06:00"]``."""
    flags = np.asarray(periods, dtype=bool).reshape(PERIODS_PER_DAY)
    spans, start = [], None
    for k, flag in enumerate([*flags.tolist(), False]):
        if flag and start is None:
            start = k
        elif not flag and start is not None:
            spans.append(f"{_clock(start)}-{_clock(k)}")
            start = None
    return spans


def _clock(period: int) -> str:
    minutes = period * PERIOD_MIN
    return f"{minutes // 60:02d}:{minutes % 60:02d}"


def parse_hours(spans: list[str]) -> tuple[bool, ...]:
    """The inverse of :func:`hours_text`: (48,) bool periods of a day.

    Raises
    ------
    ValueError
        naming the span that is not ``"HH:MM-HH:MM"`` on the half hour with start < end.
    """
    flags = [False] * PERIODS_PER_DAY
    for span in spans:
        start, end = _span_periods(span)
        flags[start:end] = [True] * (end - start)
    return tuple(flags)


def _span_periods(span: str) -> tuple[int, int]:
    parts = span.split("-")
    periods = [_period_of(part) for part in parts] if len(parts) == 2 else []
    if len(periods) != 2 or None in periods or periods[0] >= periods[1]:  # type: ignore[operator]
        raise ValueError(f"{span!r} is not a span 'HH:MM-HH:MM' on the half hour with start < end")
    return int(periods[0]), int(periods[1])  # type: ignore[arg-type]


def _period_of(clock: str) -> int | None:
    hours, _, minutes = clock.strip().partition(":")
    if not (hours.isdigit() and minutes.isdigit() and len(minutes) == 2):
        return None
    total = int(hours) * 60 + int(minutes)
    if total % PERIOD_MIN:
        return None
    period = total // PERIOD_MIN
    return period if period <= PERIODS_PER_DAY else None


@dataclass(frozen=True)
class IdentifiedIdleAir:
    """What an idle zone's supply air delivers when the air system's coil is scheduled off.

    An air system may run its fans while its cooling coil is scheduled off (5ZoneAirCooled:
    out of the IDF's weekday 06:00–20:00 and all weekend), or while a zone's own cycling
    coil is idle (the reference small office's packaged units, on ``HVACOperationSchd``): a
    zone at its minimum flow then receives fan-only air — return and outdoor air, about a
    kelvin warmer than the zone, not the coil's ``T_s``. The training data show it
    (``hvacflex.identify.idle_air``); the controller plans such a zone's idle input as that
    air (``control.problem_builder``), so a night's minimum flow is not counted as the coil's
    cooling.

    Attributes
    ----------
    fan_only : (7, 48) per weekday (Monday first) and 30-min period of the day, True where
        an idle zone's air was fan-only in the training data.
    fan_only_difference_k : (m,) each zone's median zone − supply temperature of its fan-only
        air [K] (zone order).
    fan_only_flow_kg_s : (m,) each zone's fan-only flow [kg/s] where every zone has a unit
        whose coil cycles on the zone's own thermostat (the reference small office's PSZ-AC:
        the constant-volume fan runs on its schedule, a zone that does not call receives its
        flow of fan-only air whatever the others do); None: one air system whose coil, once
        a zone's call starts it, cools every zone, the fan-only flow its minimum flow.
    """

    fan_only: tuple[tuple[bool, ...], ...]
    fan_only_difference_k: tuple[float, ...]
    fan_only_flow_kg_s: tuple[float, ...] | None = None

    def fan_only_at(
        self, weekday: npt.ArrayLike, period_of_day: npt.ArrayLike
    ) -> npt.NDArray[np.bool_]:
        """(T,) whether each period is a fan-only one: ``weekday`` (T,) 0 = Monday … 6,
        ``period_of_day`` (T,) 0 … 47."""
        table = np.asarray(self.fan_only, dtype=bool)
        out: npt.NDArray[np.bool_] = table[
            np.asarray(weekday, dtype=np.int64), np.asarray(period_of_day, dtype=np.int64)
        ]
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
    idle_air : the idle zones' fan-only air out of the coil's hours, or None (not learned:
        the minimum flow is the coil's air at every hour).
    """

    zones: tuple[IdentifiedZone, ...]
    couplings: tuple[IdentifiedCoupling, ...]
    boundaries: tuple[IdentifiedBoundary, ...]
    supply_temp_degc: float
    power: IdentifiedPower | None
    provenance: tuple[tuple[str, str], ...] = ()
    validity: IdentifiedValidity | None = None
    idle_air: IdentifiedIdleAir | None = None


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


def metered_reserve_coeff(
    power: IdentifiedPower,
    supply_temp_degc: float,
    outdoor_temp_degc: npt.ArrayLike,
    zone_temp_degc: npt.ArrayLike,
    total_flow_curtailed_kg_s: npt.ArrayLike,
    total_flow_ref_kg_s: npt.ArrayLike,
) -> FloatArray:
    """(N, m) the power a kg/s of flow shed surely saves under a metered power model [kW per
    kg/s] — a lower bound along the previous plan, built as the design curves'
    (``hvac.reserve_power_coeff``): the fan's tangent at the curtailed total flow (convex:
    the least slope of the cut), the plant's slope at the reference flow's cooling (concave:
    the least of a cut below it; not at full flow, where the fitted curvature would be
    extrapolated), the cooling per kg/s at the coolest return air the period may see, and no
    outdoor air shed (the damper's air is the ventilation need, not a share of the flow).

    Parameters
    ----------
    outdoor_temp_degc : (N,) [°C]; zone_temp_degc : (N, m) return-air estimate [°C];
    total_flow_curtailed_kg_s : (N,) total flow after the cut [kg/s];
    total_flow_ref_kg_s : (N,) the reference (previous plan's) total flow [kg/s].
    """
    outdoor = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    zone = np.asarray(zone_temp_degc, dtype=np.float64)
    low = np.asarray(total_flow_curtailed_kg_s, dtype=np.float64)
    p = power
    q = sensible_cooling_kw(1.0, zone, supply_temp_degc)  # (N, m) kW per kg/s
    q_ref = q.max(axis=1) * np.asarray(total_flow_ref_kg_s, dtype=np.float64)  # (N,) kW
    plant = p.kw_per_kw_cooling + p.kw_per_kw_cooling_k_outdoor * (
        outdoor - PLANT_REFERENCE_OUTDOOR_DEGC
    )
    plant_slope = np.maximum(plant + 2.0 * min(p.kw_per_kw2_cooling, 0.0) * q_ref, 0.0)
    fan = p.fan_kw_per_kg_s + 2.0 * p.fan_kw_per_kg2_s2 * np.maximum(low, 0.0)
    coeff: FloatArray = np.maximum(fan[:, None] + plant_slope[:, None] * q, 0.0)
    return coeff


def identified_power_kw(
    rc: IdentifiedRC,
    flow_kg_s: npt.ArrayLike,
    zone_temp_degc: npt.ArrayLike,
    outdoor_temp_degc: float,
    occupied: float = 0.0,
    outdoor_humidity_ratio_kg_per_kg: float = REFERENCE_HUMIDITY_KG_PER_KG,
) -> float:
    """The power model's HVAC electricity [kW] for (m,) flows [kg/s] and zone temperatures
    [°C] at an occupied share ``occupied`` [–] and an outdoor humidity ratio [kg/kg] (0
    without a power model)."""
    if rc.power is None:
        return 0.0
    return float(
        metered_power_kw(
            rc.power,
            rc.supply_temp_degc,
            flow_kg_s,
            zone_temp_degc,
            outdoor_temp_degc,
            occupied,
            outdoor_humidity_ratio_kg_per_kg,
        )
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
    total_flow_ref_kg_s: npt.ArrayLike | None = None,
    outdoor_humidity_ratio_kg_per_kg: npt.ArrayLike | None = None,
) -> tuple[FloatArray, FloatArray]:
    """The LP's ``P_k = p0_k + p_kᵀ u_k`` of the building's power model
    (:func:`metered_affine_power` at T₀ ``zone_temp_ref_degc`` [°C], (N,) forecast outdoor
    temperature [°C], occupied share [–] and outdoor humidity ratio [kg/kg] (None: the
    reference), re-linearised at the (N,) reference total flow [kg/s]; its largest total
    flow the sum of the zones' ``flow_max_kg_s``).

    Returns
    -------
    p0 : (N,) [kW]; p : (N, m) [kW per kg/s] (zeros without a power model).
    """
    outdoor = np.atleast_1d(np.asarray(outdoor_temp_degc, dtype=np.float64))
    m = len(rc.zones)
    if rc.power is None:
        return np.zeros(outdoor.shape[0]), np.zeros((outdoor.shape[0], m))
    return metered_affine_power(
        rc.power,
        rc.supply_temp_degc,
        m,
        outdoor,
        zone_temp_ref_degc,
        occupied,
        total_flow_ref_kg_s,
        float(sum(z.flow_max_kg_s for z in rc.zones)),
        outdoor_humidity_ratio_kg_per_kg,
    )


def initial_node_temps_degc(rc: IdentifiedRC, zone_temp_degc: float) -> FloatArray:
    """(2m + nb,) a run's first state: the zones at ``zone_temp_degc`` [°C], the mass and
    boundary nodes at their estimated temperatures (node order of the identified network)."""
    return np.array(
        [zone_temp_degc] * len(rc.zones)
        + [z.mass_temp_degc for z in rc.zones]
        + [b.temp_degc for b in rc.boundaries]
    )
