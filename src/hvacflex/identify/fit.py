"""Fit the grey-box model (:mod:`hvacflex.identify.greybox`) to trend data.

Inputs from the trend file (:mod:`hvacflex.identify.trend`): the delivered sensible cooling
of zone ``i`` is ``Q_i = ṁ_i c_p (T_i − T_supply,i)`` [kW] from its measured supply flow and
supply temperature (period means); a zone without them is refused (setpoint-only data needs a
model of the local loop, which this fit does not have). Zones of the file with a temperature
only (an attic, a plenum) can be boundaries: their measured temperatures are inputs, each
fitted zone's air node exchanging heat with each of them through a fitted conductance.

The fit minimises, with ``scipy.optimize.least_squares`` (trust-region reflective, bounds of
:data:`BOUNDS`), the 24-h prediction errors — each training day simulated from its midnight
state, estimated by the Kalman filter from the measurements before it — plus the one-step
errors, plus a penalty on estimated mass temperatures outside the measured range
(:data:`MASS_BAND_K`), plus weak priors (:data:`PRIOR_WEIGHT`) pulling each parameter toward
:data:`INITIAL` (log scale for the positive ones). The first day only warms the filter up.

The evaluation (:func:`evaluate`) runs the filter over the whole file and reports, on the
test days, per zone: ``rmse_1step_k`` (the one-step predictor: the filter with a heat-gain
state per zone, its noise levels tuned on the training days, :func:`tune_filter`),
``rmse_24h_k`` (24-h simulations from each midnight's estimated state) and ``bias_k`` (mean
24-h error, predicted − measured). Both take the cooling's change from one period to the next
as coming early in the period (:func:`~hvacflex.identify.greybox.discretize`'s
``cooling_change_share``), by the share that predicts the training days best
(:func:`tune_predictor`); the calibrated model error (:func:`one_step_errors`) is the
controller's view, which plans period means: the plain zero-order hold.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd
import scipy.optimize

from hvacflex.building.identified import (
    WALL_ORIENTATIONS,
    IdentifiedIdleAir,
    sensible_cooling_kw,
)
from hvacflex.constants import PERIODS_PER_DAY
from hvacflex.data.solar import SolarSite, decompose_ghi, surface_irradiance_w_per_m2
from hvacflex.data.weather_forecast import period_of_day
from hvacflex.errors import InputError
from hvacflex.identify.greybox import (
    EXOGENOUS_INPUTS,
    ZONE_PARAMETERS,
    DiscreteModel,
    FilterNoise,
    FloatArray,
    GreyBoxParameters,
    cooling_change_kw,
    discretize,
    filter_states,
    one_step_predictions,
    simulate_windows,
    time_constants_s,
)
from hvacflex.identify.model_file import AirSystem, BoundaryNode
from hvacflex.identify.physics import ZonePhysics, zone_bounds, zone_priors
from hvacflex.identify.trend import (
    DHI,
    DNI,
    GHI,
    OCCUPIED,
    OUTDOOR_TEMP,
    TrendData,
    zone_column,
)

PERIOD_S_HOURS = 0.5
"""One period in hours (kW → kWh)."""
WARMUP_DAYS = 1
"""Days at the start of the file that only warm the state estimate up."""
MIN_TRAIN_DAYS = 3
"""Fewer training days than this are refused (besides the warm-up day)."""
ONE_STEP_WEIGHT = 1.0
"""Weight of the one-step errors next to the 24-h errors in the fit."""
MASS_BAND_K = 2.0
"""The estimated mass temperatures should stay within the measured zone temperatures' range
widened by this [K] (a physical prior: a slab is not colder or warmer than every room)."""
MASS_BAND_WEIGHT = 1.0
"""Weight of a mass temperature outside that band, per K, next to a 1-K prediction error."""
PRIOR_WEIGHT = 0.02
"""Weight of the priors: a residual of this size per unit of log (or linear) deviation."""
MAX_EVALUATIONS = 200
"""Most residual evaluations per fit (``least_squares``'s ``max_nfev``)."""
BOUND_TOLERANCE = 1e-4
"""A parameter within this share of its (log) range from a bound is reported at the bound."""
TIME_CONSTANT_RANGE_S = (60.0, 28 * 86400.0)
"""Physically plausible time constants (a minute … four weeks) [s]; outside: a warning."""
FILTER_AIR_K = (0.1, 0.3, 1.0)
FILTER_MASS_K = (0.02, 0.1, 0.3)
FILTER_GAIN_KW = (0.0, 0.1, 0.3, 1.0)
FILTER_GAIN_PERSISTENCE = (0.5, 0.8, 0.9, 0.95)
"""The one-step predictor's noise levels searched (:func:`tune_filter`): air and mass process
noise [K], the unmeasured gain's noise [kW] and persistence [–]."""
COOLING_CHANGE_SHARES = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)
"""The shares of the cooling's change that come early in the period searched
(:func:`tune_predictor`) [–]."""

INITIAL: dict[str, float] = {
    "c_air_kj_per_k": 2.0e3,
    "c_mass_kj_per_k": 1.0e5,
    "ua_out_kw_per_k": 0.05,
    "ua_air_mass_kw_per_k": 0.5,
    "ua_mass_out_kw_per_k": 0.05,
    "solar_air_m2": 2.0,
    "solar_mass_m2": 2.0,
    **{f"solar_wall_{name}_m2": 0.5 for name, _ in WALL_ORIENTATIONS},
    "occupied_gain_kw": 1.0,
    "base_gain_kw": 0.5,
    "ua_kw_per_k": 0.05,
}
"""Starting point and prior of every parameter (its unit in its name)."""
BOUNDS: dict[str, tuple[float, float]] = {
    "c_air_kj_per_k": (10.0, 1.0e5),
    "c_mass_kj_per_k": (1.0e3, 1.0e7),
    "ua_out_kw_per_k": (1.0e-4, 50.0),
    "ua_air_mass_kw_per_k": (1.0e-3, 50.0),
    "ua_mass_out_kw_per_k": (1.0e-4, 50.0),
    "solar_air_m2": (0.0, 200.0),
    "solar_mass_m2": (0.0, 200.0),
    **{f"solar_wall_{name}_m2": (0.0, 200.0) for name, _ in WALL_ORIENTATIONS},
    "occupied_gain_kw": (0.0, 100.0),
    "base_gain_kw": (-50.0, 50.0),
    "ua_kw_per_k": (1.0e-4, 20.0),
}
"""Physical bounds of every parameter."""
LINEAR_PRIOR_SCALE = {
    "solar_air_m2": 10.0,
    "solar_mass_m2": 10.0,
    **{f"solar_wall_{name}_m2": 10.0 for name, _ in WALL_ORIENTATIONS},
    "occupied_gain_kw": 2.0,
    "base_gain_kw": 2.0,
}
"""Linear parameters: the deviation from the prior that counts as one unit [their unit]."""
VENTILATION_QUANTILE = 0.05
"""The least occupied flow of a zone is this quantile of its training flows while occupied."""
FLOWING_KG_S = 1e-3
"""A period-mean supply flow above this counts as air supplied [kg/s]."""
MAX_COIL_SUPPLY_TEMP_DEGC = 18.0
"""A flow-weighted mean supply temperature of cooling air at or above this is no coil's
(a cycling constant-volume unit) [°C]."""
COIL_SUPPLY_QUANTILE = 0.05
"""Then the coil's supply temperature is this quantile of the cooling periods' [–]."""
COOLING_DIFFERENCE_K = 1.0
"""Supply air this much colder than the zone counts as cooling air [K] (a constant-volume
fan also moves air while its coil is off)."""
IDLE_FLOW_SHARE = 0.05
"""A zone whose flow lies within this share of its flow range above its minimum is idle [–]."""
FAN_ONLY_SHARE = 0.1
"""A period of the day is fan-only when at least this share of the idle zones' periods there
were (a pull-down that starts the coil at night makes the others coil air) [–]."""
WORKING_DAYS_PER_WEEK = 5
"""Monday … Friday: the days an air system's schedule treats alike (pooled in
:func:`idle_air`), Saturday and Sunday the others."""
CouplingPhysics = tuple[tuple[float, float, float] | None, ...] | None
"""Per coupling (zone pairs, then zone–boundary pairs) its (low, high, prior) [kW/K], or None:
the generic bounds."""
BOUNDARY_MIN_RATE = 1e-6
"""Lower bound of a boundary node's ``Δt / C`` in its fit [K per kJ]: a finite capacitance."""


@dataclass(frozen=True)
class FitData:
    """The fit's arrays on the 30-min grid.

    Attributes
    ----------
    index : (T,) period starts; zones : (m,) the data's zone names.
    y : (T, m) measured zone temperatures [°C]; u : (T, 8 + m + nb) the model's inputs
    (:data:`~hvacflex.identify.greybox.EXOGENOUS_INPUTS`, the cooling, the boundaries).
    boundaries : (nb,) the data's unconditioned zones whose temperatures are inputs.
    """

    index: pd.DatetimeIndex
    zones: tuple[str, ...]
    y: FloatArray
    u: FloatArray
    boundaries: tuple[str, ...] = ()


def wall_irradiance_kw_per_m2(
    index: pd.DatetimeIndex,
    ghi_w_per_m2: FloatArray,
    site: SolarSite,
    dni_w_per_m2: FloatArray | None = None,
    dhi_w_per_m2: FloatArray | None = None,
) -> FloatArray:
    """(T, 4) irradiance on vertical planes facing :data:`WALL_ORIENTATIONS` [kW/m²], period
    means, by the transposition the controller's forecasts use
    (:func:`hvacflex.data.solar.surface_irradiance_w_per_m2`) at ``site``, from (T,) GHI, DNI
    and DHI [W/m²] on the tz-aware period starts ``index`` — or, without DNI and DHI, from
    the GHI's Erbs decomposition (:func:`hvacflex.data.solar.decompose_ghi`)."""
    if dni_w_per_m2 is None or dhi_w_per_m2 is None:
        dni_w_per_m2, dhi_w_per_m2 = decompose_ghi(index, ghi_w_per_m2, site)
    weather = pd.DataFrame(
        {"ghi_w_per_m2": ghi_w_per_m2, "dni_w_per_m2": dni_w_per_m2, "dhi_w_per_m2": dhi_w_per_m2},
        index=index,
    )
    walls = [(azimuth, 90.0) for _, azimuth in WALL_ORIENTATIONS]
    return surface_irradiance_w_per_m2(weather, site, walls).to_numpy(dtype=np.float64) / 1000.0


def fit_inputs(
    data: TrendData, zones: tuple[str, ...], site: SolarSite, boundaries: tuple[str, ...] = ()
) -> FitData:
    """The model's inputs and outputs for ``zones`` (the data's spelling, any case) at
    ``site`` (where the wall irradiances are computed, :func:`wall_irradiance_kw_per_m2`).

    Raises
    ------
    InputError
        for a zone the data lacks, or one without supply flow and temperature.
    """
    lookup = {z.lower(): z for z in data.zones}
    spelled = []
    for zone in zones:
        if zone.lower() not in lookup:
            raise InputError(
                "the trend data has no such zone",
                source=data.source,
                field="--zones",
                value=zone,
                hint=f"its zones are {list(data.zones)}",
            )
        spelled.append(lookup[zone.lower()])
    names = tuple(spelled)
    for zone in names:
        if not data.has(zone_column("supply_flow", zone)):
            raise InputError(
                "the fit needs the zone's supply flow and supply temperature",
                source=data.source,
                field=zone_column("supply_flow", zone),
                hint="export the zone's supply air flow and temperature (setpoint-only data "
                "is not supported by this fit)",
            )
    y = data.zone_series("temp", names)
    flow = data.zone_series("supply_flow", names)
    supply = data.zone_series("supply_temp", names)
    assert y is not None and flow is not None and supply is not None
    measured = data.has(DNI) and data.has(DHI)
    split = (data.column(DNI), data.column(DHI)) if measured else (None, None)
    u = np.column_stack(
        [
            data.column(OUTDOOR_TEMP),
            data.column(GHI) / 1000.0,
            data.column(OCCUPIED),
            np.ones(len(y)),
            wall_irradiance_kw_per_m2(data.index, data.column(GHI), site, *split),
            sensible_cooling_kw(flow, y, supply),
            data.frame[[zone_column("temp", b) for b in boundaries]].to_numpy(dtype=np.float64),
        ]
    )
    return FitData(index=data.index, zones=names, y=y, u=u, boundaries=tuple(boundaries))


def cooling_kw(data: FitData) -> FloatArray:
    """(T, m) the delivered sensible cooling input [kW]."""
    m, first = data.y.shape[1], len(EXOGENOUS_INPUTS)
    return data.u[:, first : first + m]


# ---- parameter vector ------------------------------------------------------------------


def _names(m: int, pairs: int) -> list[tuple[str, str]]:
    return [(n, s) for _ in range(m) for n, s in ZONE_PARAMETERS] + [("ua_kw_per_k", "log")] * pairs


def _to_vector(values: FloatArray, m: int, pairs: int) -> FloatArray:
    return np.array(
        [np.log(v) if s == "log" else v for v, (_, s) in zip(values, _names(m, pairs), strict=True)]
    )


def _from_vector(
    theta: FloatArray,
    couplings: np.ndarray,
    edges: np.ndarray | None = None,
    boundaries: int = 0,
    *,
    log: bool = True,
) -> GreyBoxParameters:
    """Parameters of ``theta``: zone parameters, then the couplings', then the boundary
    couplings' (``edges``: (q, 2) zone–boundary pairs) conductances (``log=False``: values
    taken as they are, e.g. flags)."""
    edges = np.zeros((0, 2), dtype=np.int64) if edges is None else edges
    m = _zones_of(theta, len(couplings) + len(edges))
    names = _names(m, len(couplings) + len(edges))
    values = np.array(
        [np.exp(t) if s == "log" and log else t for t, (_, s) in zip(theta, names, strict=True)]
    )
    k = len(ZONE_PARAMETERS)
    split = m * k + len(couplings)
    return GreyBoxParameters(
        zone=values[: m * k].reshape(m, k),
        couplings=np.asarray(couplings, dtype=np.int64).reshape(-1, 2),
        coupling_ua_kw_per_k=values[m * k : split],
        boundaries=boundaries,
        boundary_couplings=np.asarray(edges, dtype=np.int64).reshape(-1, 2),
        boundary_ua_kw_per_k=values[split:],
    )


def _zones_of(theta: FloatArray, pairs: int) -> int:
    return (len(theta) - pairs) // len(ZONE_PARAMETERS)


def _initial_and_bounds(
    m: int,
    pairs: int,
    physics: tuple[ZonePhysics, ...] | None = None,
    coupling_physics: CouplingPhysics = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The prior (= start), lower and upper bounds (in the optimiser's log/linear space) and
    the priors' scales of every parameter: per zone from its ``physics``
    (:func:`~hvacflex.identify.physics.zone_bounds`, ``zone_priors``) where given, per
    coupling (zone pairs, then zone–boundary edges) its ``(low, high, prior)`` where given,
    else the generic :data:`INITIAL` and :data:`BOUNDS`. A parameter with equal bounds is
    fixed."""
    names = _names(m, pairs)
    zone_physics = physics if physics is not None else tuple(ZonePhysics() for _ in range(m))
    k = len(ZONE_PARAMETERS)
    initial, low, high = [], [], []
    for position, (name, _) in enumerate(names):
        if position < m * k:
            bounds = zone_bounds(zone_physics[position // k], BOUNDS)
            prior = zone_priors(zone_physics[position // k], INITIAL, bounds)[name]
        else:
            bounds, prior = BOUNDS, INITIAL[name]
            known = None if coupling_physics is None else coupling_physics[position - m * k]
            if known is not None:
                bounds, prior = {name: (known[0], known[1])}, known[2]
        initial.append(prior)
        low.append(bounds[name][0])
        high.append(bounds[name][1])
    scale = np.array([1.0 if s == "log" else LINEAR_PRIOR_SCALE[n] for n, s in names])
    return (
        _to_vector(np.array(initial), m, pairs),
        _to_vector(np.array(low), m, pairs),
        _to_vector(np.array(high), m, pairs),
        scale,
    )


# ---- residuals -------------------------------------------------------------------------


def _day_starts(index: pd.DatetimeIndex, first: int, last: int) -> np.ndarray:
    """Positions of the local midnights k with first ≤ k and k + 48 ≤ last."""
    k = np.flatnonzero((index.hour == 0) & (index.minute == 0))
    return k[(k >= first) & (k + PERIODS_PER_DAY <= last)]


def predictions(
    model: DiscreteModel,
    data: FitData,
    starts: np.ndarray,
    states: FloatArray | None = None,
    noise: FilterNoise | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One-step and 24-h predictions on the days starting at ``starts`` (``states``: the
    filter's estimates (T, n), if already computed; ``noise``: the one-step predictor's
    levels, default the plain filter's).

    Returns
    -------
    one_step : (D, 48, m), simulated : (D, 48, m), measured : (D, 48, m) [°C].
    """
    states = filter_states(model, data.y, data.u) if states is None else states
    if noise is None:
        one_step_all = np.einsum("ij,tj->ti", model.c_mean, states) + data.u @ model.d_mean.T
    else:
        one_step_all = one_step_predictions(model, data.y, data.u, noise)
    rows = _day_rows(starts)
    change = cooling_change_kw(data.u, data.y.shape[1])[rows]
    simulated = simulate_windows(model, states[starts], data.u[rows], PERIODS_PER_DAY, change)
    return one_step_all[rows], simulated, data.y[rows]


def _residuals(
    theta: FloatArray,
    couplings: np.ndarray,
    edges: np.ndarray,
    data: FitData,
    starts: np.ndarray,
    prior: FloatArray,
    scale: FloatArray,
) -> FloatArray:
    m = data.y.shape[1]
    try:
        model = discretize(_from_vector(theta, couplings, edges, len(data.boundaries)))
        states = filter_states(model, data.y, data.u)
        one_step, simulated, measured = predictions(model, data, starts, states)
    except (np.linalg.LinAlgError, ValueError):
        return np.full(3 * starts.size * PERIODS_PER_DAY * m + theta.size, 1e3)
    rows = _day_rows(starts).ravel()
    mass = states[rows, m : 2 * m]
    low, high = data.y.min() - MASS_BAND_K, data.y.max() + MASS_BAND_K
    outside = np.maximum(mass - high, 0.0) + np.maximum(low - mass, 0.0)
    return np.concatenate(
        [
            (simulated - measured).ravel(),
            ONE_STEP_WEIGHT * (one_step - measured).ravel(),
            MASS_BAND_WEIGHT * outside.ravel(),
            PRIOR_WEIGHT * (theta - prior) / scale,
        ]
    )


@dataclass(frozen=True)
class FitResult:
    """A fitted model.

    Attributes
    ----------
    zones : (m,) the data's zone names; parameters : the fitted values.
    standard_errors : same shapes as ``parameters`` (``zone``, ``coupling_ua_kw_per_k``),
        from the Jacobian at the optimum (NaN where not identifiable).
    converged : whether ``least_squares`` reported convergence; message : its message.
    warnings : (w,) non-physical or doubtful findings (also raised as warnings).
    filter_noise : the one-step predictor's noise levels, tuned on the training days with the
        plain zero-order hold (the calibrated model error's predictor).
    cooling_change_share : γ of the graded predictions (:func:`tune_predictor`) [–];
        change_noise : their filter's noise levels (None: ``filter_noise``).
    prior, lower, upper : the priors' centres and the bounds (same shapes; equal bounds: a
        fixed parameter); at_bound : 1.0 where a free parameter ended on a bound, else 0.0.
    """

    zones: tuple[str, ...]
    parameters: GreyBoxParameters
    standard_errors: GreyBoxParameters
    converged: bool
    message: str
    warnings: tuple[str, ...]
    filter_noise: FilterNoise = field(default_factory=FilterNoise)
    cooling_change_share: float = 0.0
    change_noise: FilterNoise | None = None
    prior: GreyBoxParameters | None = None
    lower: GreyBoxParameters | None = None
    upper: GreyBoxParameters | None = None
    at_bound: GreyBoxParameters | None = None


def _standard_errors(
    result: scipy.optimize.OptimizeResult,
    theta: FloatArray,
    free: np.ndarray,
    layout: tuple[np.ndarray, np.ndarray, int],
) -> GreyBoxParameters:
    """The standard errors of the parameters ``theta``: the free ones' from the covariance
    ``σ² (JᵀJ)⁺`` at the optimum (``J`` the residuals' Jacobian, priors included, ``σ²`` the
    residual variance), through the log transform where searched in log; 0 for a fixed one."""
    couplings, edges, boundaries = layout
    jac = np.asarray(result.jac)
    dof = max(int(result.fun.size) - jac.shape[1], 1)
    sigma2 = 2.0 * float(result.cost) / dof
    covariance = np.linalg.pinv(jac.T @ jac) * sigma2
    se_theta = np.zeros(theta.size)
    se_theta[free] = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    m = _zones_of(theta, len(couplings) + len(edges))
    values = _from_vector(theta, couplings, edges, boundaries)
    flat = np.concatenate(
        [values.zone.ravel(), values.coupling_ua_kw_per_k, values.boundary_ua_kw_per_k]
    )
    logs = np.array([s == "log" for _, s in _names(m, len(couplings) + len(edges))])
    se = np.where(logs, flat * se_theta, se_theta)
    k = len(ZONE_PARAMETERS)
    split = m * k + len(couplings)
    return GreyBoxParameters(
        zone=se[: m * k].reshape(m, k),
        couplings=values.couplings,
        coupling_ua_kw_per_k=se[m * k : split],
        boundaries=boundaries,
        boundary_couplings=values.boundary_couplings,
        boundary_ua_kw_per_k=se[split:],
    )


def _physical_warnings(p: GreyBoxParameters) -> list[str]:
    found = []
    low, high = TIME_CONSTANT_RANGE_S
    taus = time_constants_s(p)
    if not np.all(np.isfinite(taus)) or taus.min() < low or taus.max() > high:
        found.append(
            f"time constants {taus.min():.3g} … {taus.max():.3g} s lie outside "
            f"{low:g} … {high:g} s (a minute … four weeks)"
        )
    return found


def _bound_warnings(
    theta: FloatArray, low: FloatArray, high: FloatArray, zones: tuple[str, ...]
) -> list[str]:
    """``"<zone>: <parameter> at its bound <b>"`` for every zone parameter the optimiser
    pushed onto a bound (the data do not determine it, or want a value the priors call
    non-physical)."""
    found = []
    span = high - low
    k = len(ZONE_PARAMETERS)
    for index in np.flatnonzero((_at_bound(theta, low, high) > 0) & (span > 0)):
        if index >= len(zones) * k:
            continue  # a coupling at zero is a legitimate finding
        name = ZONE_PARAMETERS[index % k][0]
        if name.startswith("solar_") or name == "ua_mass_out_kw_per_k":
            continue  # zero solar share or no mass-outdoor path: physical
        zone = zones[index // k]
        near = (
            low[index]
            if theta[index] - low[index] <= BOUND_TOLERANCE * span[index]
            else high[index]
        )
        value = float(np.exp(near)) if ZONE_PARAMETERS[index % k][1] == "log" else float(near)
        found.append(f"{zone}: {name} at its bound {value:g}")
    return found


def fit_model(
    data: FitData,
    couplings: list[tuple[int, int]],
    train: tuple[int, int],
    physics: tuple[ZonePhysics, ...] | None = None,
    coupling_physics: CouplingPhysics = None,
    on_evaluation: Callable[[], None] | None = None,
) -> FitResult:
    """Fit the grey-box model on the periods ``train = (first, end)`` (module docstring);
    every fitted zone may exchange heat with every boundary of ``data``; ``physics`` (m,):
    what is known of each zone (floor area, façades: :mod:`hvacflex.identify.physics`),
    which bounds its parameters and centres their priors; ``coupling_physics``: per coupling
    (``couplings``, then every zone–boundary pair) its ``(low, high, prior)`` [kW/K] or None
    (:func:`~hvacflex.identify.physics.coupling_bounds`).
    ``on_evaluation`` is called after each evaluation of the model's residuals (the
    optimiser's and its finite-difference Jacobian's: a heartbeat of the long fit).

    Raises
    ------
    InputError
        for fewer than :data:`MIN_TRAIN_DAYS` whole training days after the warm-up day.
    """
    first, end = train
    starts = _day_starts(data.index, first + WARMUP_DAYS * PERIODS_PER_DAY, end)
    if starts.size < MIN_TRAIN_DAYS:
        raise InputError(
            f"too few days to fit: {starts.size} whole training days after the "
            f"{WARMUP_DAYS}-day warm-up, need {MIN_TRAIN_DAYS}",
            field="--train",
            hint="collect or export more days (the issue's target: fit 14, test 7)",
        )
    pairs = np.array(couplings, dtype=np.int64).reshape(-1, 2)
    m, nb = data.y.shape[1], len(data.boundaries)
    edges = np.array([(i, b) for i in range(m) for b in range(nb)], dtype=np.int64).reshape(-1, 2)
    prior, low, high, scale = _initial_and_bounds(
        m, len(pairs) + len(edges), physics, coupling_physics
    )
    free = high > low
    window = FitData(data.index[:end], data.zones, data.y[:end], data.u[:end], data.boundaries)

    def residuals(x: FloatArray) -> FloatArray:
        theta = prior.copy()
        theta[free] = x
        out = _residuals(theta, pairs, edges, window, starts, prior, scale)
        if on_evaluation is not None:
            on_evaluation()
        return out

    result = scipy.optimize.least_squares(
        residuals,
        np.clip(prior[free], low[free], high[free]),
        bounds=(low[free], high[free]),
        method="trf",
        x_scale="jac",
        max_nfev=MAX_EVALUATIONS,
    )
    theta = prior.copy()
    theta[free] = result.x
    parameters = _from_vector(theta, pairs, edges, nb)
    found = _physical_warnings(parameters) + _bound_warnings(theta, low, high, data.zones)
    if not result.success:
        found.append(f"the optimiser did not converge: {result.message}")
    for text in found:
        warnings.warn(text, stacklevel=2)
    plain_noise = tune_filter(discretize(parameters), window, starts)
    share, change_noise = tune_predictor(parameters, window, starts, plain_noise)
    return FitResult(
        zones=data.zones,
        parameters=parameters,
        standard_errors=_standard_errors(result, theta, free, (pairs, edges, nb)),
        converged=bool(result.success),
        message=str(result.message),
        warnings=tuple(found),
        filter_noise=plain_noise,
        cooling_change_share=share,
        change_noise=change_noise,
        prior=_from_vector(prior, pairs, edges, nb),
        lower=_from_vector(low, pairs, edges, nb),
        upper=_from_vector(high, pairs, edges, nb),
        at_bound=_from_vector(
            np.where(free, _at_bound(theta, low, high), 0.0), pairs, edges, nb, log=False
        ),
    )


def _at_bound(theta: FloatArray, low: FloatArray, high: FloatArray) -> FloatArray:
    """(n,) 1.0 where ``theta`` lies within :data:`BOUND_TOLERANCE` of its (log) range from a
    bound, else 0.0."""
    span = high - low
    near = (theta - low <= BOUND_TOLERANCE * span) | (high - theta <= BOUND_TOLERANCE * span)
    return near.astype(np.float64)


def tune_filter(model: DiscreteModel, data: FitData, starts: np.ndarray) -> FilterNoise:
    """The noise levels (grid of :data:`FILTER_AIR_K` … :data:`FILTER_GAIN_PERSISTENCE`) whose
    one-step predictor has the least mean squared error over the zones on the days starting at
    ``starts`` (the training days): the filter's covariances estimated from the data."""
    rows = _day_rows(starts).ravel()
    best, best_mse = FilterNoise(), np.inf
    for air_k in FILTER_AIR_K:
        for mass_k in FILTER_MASS_K:
            for gain_kw in FILTER_GAIN_KW:
                for rho in FILTER_GAIN_PERSISTENCE if gain_kw > 0 else (0.0,):
                    noise = FilterNoise(air_k, mass_k, gain_kw, rho)
                    mse = _training_mse(model, data, rows, noise)
                    if mse < best_mse:
                        best, best_mse = noise, mse
    return best


def _day_rows(starts: np.ndarray) -> np.ndarray:
    """(D, 48) the periods of the whole days starting at ``starts`` (D,)."""
    rows: np.ndarray = starts[:, None] + np.arange(PERIODS_PER_DAY)[None, :]
    return rows


def _training_mse(
    model: DiscreteModel, data: FitData, rows: np.ndarray, noise: FilterNoise
) -> float:
    predicted = one_step_predictions(model, data.y, data.u, noise)
    return float(((predicted[rows] - data.y[rows]) ** 2).mean())


def tune_predictor(
    parameters: GreyBoxParameters,
    data: FitData,
    starts: np.ndarray,
    plain_noise: FilterNoise | None = None,
) -> tuple[float, FilterNoise]:
    """The share of the cooling's change that comes early in the period (of
    :data:`COOLING_CHANGE_SHARES`) and the filter's noise levels (:func:`tune_filter`) whose
    one-step predictor has the least mean squared error over the zones on the days starting at
    ``starts`` (the training days); ``plain_noise``: the plain hold's (γ = 0) levels, when
    already tuned."""
    rows = _day_rows(starts).ravel()
    best, best_mse = (0.0, FilterNoise()), np.inf
    for share in COOLING_CHANGE_SHARES:
        model = discretize(parameters, cooling_change_share=share)
        if share == 0.0 and plain_noise is not None:
            noise = plain_noise
        else:
            noise = tune_filter(model, data, starts)
        mse = _training_mse(model, data, rows, noise)
        if mse < best_mse:
            best, best_mse = (share, noise), mse
    return best


def graded_predictor(result: FitResult) -> tuple[DiscreteModel, FilterNoise]:
    """The model and filter noise of the fit report's predictions (module docstring)."""
    noise = result.filter_noise if result.change_noise is None else result.change_noise
    return discretize(result.parameters, cooling_change_share=result.cooling_change_share), noise


def evaluate(result: FitResult, data: FitData, test: tuple[int, int]) -> pd.DataFrame:
    """The fit report on the test periods (module docstring).

    Returns
    -------
    One row per zone: ``zone``, ``rmse_1step_k``, ``rmse_24h_k``, ``bias_k``, ``days``,
    ``cooling_change_share`` (the predictions' γ, :func:`tune_predictor`).
    """
    starts = _day_starts(data.index, *test)
    if starts.size == 0:
        raise InputError(
            "no whole test day", field="--test", hint="give at least one whole day to test on"
        )
    model, noise = graded_predictor(result)
    one_step, simulated, measured = predictions(model, data, starts, noise=noise)
    error_1, error_24 = one_step - measured, simulated - measured
    return pd.DataFrame(
        {
            "zone": list(result.zones),
            "rmse_1step_k": np.sqrt((error_1**2).mean(axis=(0, 1))),
            "rmse_24h_k": np.sqrt((error_24**2).mean(axis=(0, 1))),
            "bias_k": error_24.mean(axis=(0, 1)),
            "days": starts.size,
            "cooling_change_share": result.cooling_change_share,
        }
    )


def prediction_frame(result: FitResult, data: FitData, test: tuple[int, int]) -> pd.DataFrame:
    """The test days' series: per zone ``measured_<zone>_degc``, ``predicted_1step_<zone>_degc``
    and ``predicted_24h_<zone>_degc`` (the data's zone names), index the period starts."""
    starts = _day_starts(data.index, *test)
    model, noise = graded_predictor(result)
    one_step, simulated, measured = predictions(model, data, starts, noise=noise)
    rows = _day_rows(starts).ravel()
    columns: dict[str, FloatArray] = {}
    for i, zone in enumerate(result.zones):
        columns[f"measured_{zone}_degc"] = measured[:, :, i].ravel()
        columns[f"predicted_1step_{zone}_degc"] = one_step[:, :, i].ravel()
        columns[f"predicted_24h_{zone}_degc"] = simulated[:, :, i].ravel()
    return pd.DataFrame(columns, index=data.index[rows])


def air_system(
    inputs: FitData, data: TrendData, train: tuple[int, int], mass_temp_degc: FloatArray
) -> AirSystem:
    """The supply air the training data show: the flow-weighted mean supply temperature of
    every fitted zone while its air cools (supply at least :data:`COOLING_DIFFERENCE_K` below
    the zone; one value, the model's ``T_s``), each zone's flow range and its
    :data:`VENTILATION_QUANTILE` occupied flow; ``mass_temp_degc`` (m,) is passed through.

    A constant-volume unit whose coil cycles within the period has a period-mean supply
    temperature that is no coil's (fan-only minutes mixed in) and a flow that does not follow
    its cooling: when that mean is not below :data:`MAX_COIL_SUPPLY_TEMP_DEGC`, ``T_s`` is the
    :data:`COIL_SUPPLY_QUANTILE` quantile of the cooling periods' supply temperatures and the
    flows are the equivalent flows ``Q / (c_p (T − T_s))`` that deliver the measured cooling.

    Raises
    ------
    InputError
        when no zone received air in the training periods.
    """
    first, end = train
    flow = data.zone_series("supply_flow", inputs.zones)
    supply = data.zone_series("supply_temp", inputs.zones)
    assert flow is not None and supply is not None
    flow, supply = flow[first:end], supply[first:end]
    cooling = (flow > FLOWING_KG_S) & (inputs.y[first:end] - supply > COOLING_DIFFERENCE_K)
    if not np.any(cooling):
        raise InputError(
            "no cooling supply air in the training periods",
            source=data.source,
            field="supply_flow",
            hint="train on days when the HVAC ran",
        )
    weights = np.where(cooling, flow, 0.0)
    supply_temp = float((weights * supply).sum() / weights.sum())
    if supply_temp >= MAX_COIL_SUPPLY_TEMP_DEGC:  # cycling constant-volume coils
        supply_temp = float(np.quantile(supply[cooling], COIL_SUPPLY_QUANTILE))
        zone_temp = inputs.y[first:end]
        delivered_kw = cooling_kw(inputs)[first:end]
        warmer = np.maximum(zone_temp, supply_temp + 1.0)  # at least 1 K above the coil
        per_kg_s_kw = sensible_cooling_kw(1.0, warmer, supply_temp)
        flow = np.clip(delivered_kw / per_kg_s_kw, 0.0, None)
    occupied = data.column(OCCUPIED)[first:end] > 0
    low = flow.min(axis=0)
    high = np.maximum(flow.max(axis=0), low + FLOWING_KG_S)
    vent = np.quantile(flow[occupied], VENTILATION_QUANTILE, axis=0) if occupied.any() else low
    return AirSystem(
        supply_temp_degc=supply_temp,
        flow_min_kg_s=tuple(float(v) for v in low),
        flow_max_kg_s=tuple(float(v) for v in high),
        ventilation_flow_kg_s=tuple(float(v) for v in np.clip(vent, low, high)),
        mass_temp_degc=tuple(float(v) for v in mass_temp_degc),
    )


def idle_air(
    inputs: FitData,
    data: TrendData,
    train: tuple[int, int],
    air: AirSystem,
    coil_available: npt.NDArray[np.bool_] | None = None,
    fan_available: npt.NDArray[np.bool_] | None = None,
) -> IdentifiedIdleAir | None:
    """When an idle zone's air is fan-only (``[identified.idle_air]``), from the training data.

    Fan-only air is supply air that is no cooling air (at most :data:`COOLING_DIFFERENCE_K`
    below the zone: return and outdoor air, with the fan's heat — about 1 K *warmer* than
    the zone in 5ZoneAirCooled's nights and the reference small office's mornings) in a
    period the fan runs and the coil does not cool the zone. Two kinds of air system, told
    apart by the flow of that air (:func:`_units_per_zone`):

    * **one coil for every zone** (5ZoneAirCooled's VAV system): fan-only air comes at the
      zones' minimum flows. A zone is idle in a period when air flows at most
      :data:`IDLE_FLOW_SHARE` of its flow range above its minimum; its air is fan-only where
      the coil is scheduled off (a call starts the coil for every zone);
    * **a unit per zone whose coil cycles on the zone's thermostat** (the reference small
      office's PSZ-AC): fan-only air comes at the fan's constant flow, above the idle share.
      While the fan runs on its schedule a zone that does not call receives it whatever the
      other zones do; a zone is idle when its fan runs, and each zone's
      ``fan_only_flow_kg_s`` is the median flow of its fan-only periods.

    The hours, per weekday and 30-min period: with the IDF's schedules on the training
    periods (``identify fit --idf``; ``coil_available``, ``fan_available`` (T,), or None
    where not readable — :mod:`hvacflex.energyplus.schedules`), where on most of the training
    days of that weekday the fans are scheduled on (a fan left unread: on) and — one coil —
    the coils off. Without them, from the air itself: a period of the day is fan-only on the
    working days (Monday … Friday, pooled) or on the weekend (pooled) when at least
    :data:`FAN_ONLY_SHARE` of the idle zones' periods there were (a zone that calls for
    cooling starts one coil for every zone: 5ZoneAirCooled's `range` data leave no zone idle
    alone from 18:00 to 21:00, so the data cannot tell those hours).

    Each zone's ``fan_only_difference_k`` is the median zone − supply temperature of its
    fan-only periods in those hours [K] (of every zone's where it has none; 0 where no zone
    has any). None when no period is fan-only, or for equivalent flows (``T_s`` ≥
    :data:`MAX_COIL_SUPPLY_TEMP_DEGC`: a flow that is not the fan's).
    """
    if air.supply_temp_degc >= MAX_COIL_SUPPLY_TEMP_DEGC:
        return None
    first, end = train
    flow = data.zone_series("supply_flow", inputs.zones)
    supply = data.zone_series("supply_temp", inputs.zones)
    assert flow is not None and supply is not None
    flow, supply, zone_temp = flow[first:end], supply[first:end], inputs.y[first:end]
    no_cooling = (flow > FLOWING_KG_S) & (zone_temp - supply <= COOLING_DIFFERENCE_K)
    cycling = _units_per_zone(flow, no_cooling, air)
    idle = flow > FLOWING_KG_S
    if not cycling:
        low, high = np.asarray(air.flow_min_kg_s), np.asarray(air.flow_max_kg_s)
        idle &= flow <= low + IDLE_FLOW_SHARE * (high - low)
    fan_only = idle & no_cooling
    starts = inputs.index[first:end]
    scheduled = _scheduled_fan_only(coil_available, fan_available, cycling)
    if scheduled is None:
        table = _fan_only_hours_from_air(idle, fan_only, starts, period_of_day(starts))
    else:
        slot = np.asarray(starts.day_of_week) * PERIODS_PER_DAY + period_of_day(starts)
        days = np.bincount(slot, minlength=7 * PERIODS_PER_DAY)
        on = np.bincount(slot, weights=scheduled, minlength=7 * PERIODS_PER_DAY)
        table = ((days > 0) & (2.0 * on > days)).reshape(7, PERIODS_PER_DAY)
        fan_only &= scheduled[:, None]
    if not table.any():
        return None
    return IdentifiedIdleAir(
        fan_only=tuple(tuple(bool(v) for v in row) for row in table),
        fan_only_difference_k=_zone_medians(zone_temp - supply, fan_only),
        fan_only_flow_kg_s=_zone_medians(flow, fan_only) if cycling else None,
    )


def _units_per_zone(flow: FloatArray, no_cooling: npt.NDArray[np.bool_], air: AirSystem) -> bool:
    """Whether the air that does not cool (``no_cooling`` (T, m) periods of ``flow`` (T, m)
    [kg/s]) comes at a fan's flow, above :data:`IDLE_FLOW_SHARE` of the zones' flow ranges
    (pooled median): constant-volume units per zone, whose coils cycle on their own
    thermostats (:func:`idle_air`); False where it comes at the minimum flows (one VAV
    system) or no air is fan-only."""
    if not no_cooling.any():
        return False
    low, high = np.asarray(air.flow_min_kg_s), np.asarray(air.flow_max_kg_s)
    share = (flow - low) / (high - low)
    return bool(np.median(share[no_cooling]) > IDLE_FLOW_SHARE)


def _scheduled_fan_only(
    coil_available: npt.NDArray[np.bool_] | None,
    fan_available: npt.NDArray[np.bool_] | None,
    cycling: bool,
) -> npt.NDArray[np.bool_] | None:
    """(T,) the periods the IDF's schedules make fan-only (:func:`idle_air`), or None: the
    schedule that decides is not known (then the air decides)."""
    if cycling:  # the zone's own coil cycles: the fan's schedule decides
        return fan_available
    if coil_available is None:
        return None
    fans = np.ones_like(coil_available) if fan_available is None else fan_available
    out: npt.NDArray[np.bool_] = fans & ~coil_available
    return out


def _zone_medians(values: FloatArray, where: npt.NDArray[np.bool_]) -> tuple[float, ...]:
    """(m,) each zone's median of ``values`` (T, m) over its ``where`` (T, m) periods; the
    median over every zone's where a zone has none (0 where no zone has any)."""
    overall = float(np.median(values[where])) if where.any() else 0.0
    return tuple(
        float(np.median(values[where[:, i], i])) if where[:, i].any() else overall
        for i in range(values.shape[1])
    )


def _fan_only_hours_from_air(
    idle: npt.NDArray[np.bool_],
    fan_only: npt.NDArray[np.bool_],
    starts: pd.DatetimeIndex,
    period: npt.NDArray[np.int64],
) -> npt.NDArray[np.bool_]:
    """(7, 48) the fan-only hours the air shows (:func:`idle_air`, without the IDF)."""
    weekend = np.asarray(starts.day_of_week >= WORKING_DAYS_PER_WEEK, dtype=np.int64)
    slot = weekend * PERIODS_PER_DAY + period
    idle_count = np.bincount(slot, weights=idle.sum(axis=1), minlength=2 * PERIODS_PER_DAY)
    fan_count = np.bincount(slot, weights=fan_only.sum(axis=1), minlength=2 * PERIODS_PER_DAY)
    by_class = ((idle_count > 0) & (fan_count >= FAN_ONLY_SHARE * idle_count)).reshape(2, -1)
    table: npt.NDArray[np.bool_] = by_class[
        [0] * WORKING_DAYS_PER_WEEK + [1] * (7 - WORKING_DAYS_PER_WEEK)
    ]
    return table


def fit_boundary_nodes(
    parameters: GreyBoxParameters,
    inputs: FitData,
    train: tuple[int, int],
    test: tuple[int, int],
) -> tuple[BoundaryNode, ...]:
    """Each boundary as a node for the controller's model (it has no forecast of a measured
    boundary temperature): ``C_b dTb/dt = Σ_i UA_ib (Ta_i − Tb) + UA_bo (To − Tb) + S_b G +
    P_b occ`` with the fitted zone conductances ``UA_ib``, the other terms by non-negative
    linear least squares of the measured period-to-period changes on the training periods
    (``ΔTb = (Δt/C_b)·[…]``, forward Euler over 30 min); its start temperature is its mean
    on the ``test`` periods."""
    first, end = train
    m = inputs.y.shape[1]
    boundary_temp = inputs.u[first:end, len(EXOGENOUS_INPUTS) + m :]
    outdoor, ghi, occ = (inputs.u[first:end, i] for i in range(3))
    zone_temp = inputs.y[first:end]
    nodes = []
    for b in range(parameters.boundaries):
        tb = boundary_temp[:, b]
        exchange = np.zeros(len(tb))
        for (i, k), ua in zip(
            parameters.boundary_couplings, parameters.boundary_ua_kw_per_k, strict=True
        ):
            if k == b:
                exchange += ua * (zone_temp[:, i] - tb)
        regressors = np.column_stack([exchange, outdoor - tb, ghi, occ])[:-1]
        change = np.diff(tb)
        solution = scipy.optimize.lsq_linear(
            regressors, change, bounds=([BOUNDARY_MIN_RATE, 0.0, 0.0, 0.0], np.inf)
        )
        rate, ua_out, solar, gain = (float(v) for v in solution.x)
        dt_s = PERIOD_S_HOURS * 3600.0
        nodes.append(
            BoundaryNode(
                c_kj_per_k=dt_s / rate,
                ua_out_kw_per_k=ua_out / rate,
                solar_m2=solar / rate,
                occupied_gain_kw=gain / rate,
                temp_degc=float(inputs.u[test[0] : test[1], len(EXOGENOUS_INPUTS) + m + b].mean()),
            )
        )
    return tuple(nodes)


def one_step_errors(
    result: FitResult, data: FitData, periods: tuple[int, int]
) -> tuple[pd.DatetimeIndex, FloatArray]:
    """The one-step predictor's errors (predicted − measured) [K] on the whole days of
    ``periods = (first, end)``: (index (T,), errors (T, m))."""
    model = discretize(result.parameters)
    predicted = one_step_predictions(model, data.y, data.u, result.filter_noise)
    starts = _day_starts(data.index, *periods)
    rows = _day_rows(starts).ravel()
    return data.index[rows], predicted[rows] - data.y[rows]


def mean_mass_temps_degc(result: FitResult, data: FitData, periods: tuple[int, int]) -> FloatArray:
    """(m,) the filter's mean mass-node temperature estimates over ``periods`` [°C]."""
    model = discretize(result.parameters)
    states = filter_states(model, data.y, data.u)
    m = data.y.shape[1]
    mean: FloatArray = states[periods[0] : periods[1], m : 2 * m].mean(axis=0)
    return mean
