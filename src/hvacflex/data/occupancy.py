"""A stochastic occupancy model per zone: the internal gains the plant sees.

The schedule (:mod:`hvacflex.data.gains`) is what a controller expects; real offices fill
and empty at other times, with other head counts. This model draws, for each zone and each
day, independently and reproducibly:

* a time shift ``s`` of the whole day's profile, uniform on −:data:`MAX_SHIFT_STEPS` …
  +:data:`MAX_SHIFT_STEPS` 30-min periods (early or late arrival and departure);
* an attendance factor ``a ~ N(1, ATTENDANCE_SD)`` clipped to [:data:`ATTENDANCE_MIN`,
  :data:`ATTENDANCE_MAX`];
* a plug-load factor ``b ~ N(1, PLUG_LOAD_SD)`` clipped to [:data:`PLUG_MIN`,
  :data:`PLUG_MAX`];

and then, per period k, the people present ``n_k ~ Binomial(N, min(1, a · f_people(k + s)))``
with ``N = round(A / a_p)`` the zone's design head count. The zone's sensible gain [W] is::

    q_k = q_p · n_k + A · q_light · f_light(k + s) + A · q_plug · b · f_plug(k + s)

(``f`` the schedule's fractions, ``A`` the floor area; the same symbols as
:mod:`hvacflex.data.gains`). The draws of a day are seeded by (``seed``, zone position,
day number since 1970-01-01), so a day's gains do not depend on when a run starts or how
long it is, and two runs with the same seed see the same occupants. On average the people
term is close to the schedule's (the attendance factor has mean 1 before clipping at 1).

Planning for early arrivals (issue 55 item 3 (c)). A zone's occupants arrive ``−s``
periods after the schedule (``s`` > 0: early), ``−s`` uniform like ``s``; its q-quantile is
:func:`first_arrival_offset_steps` (q = :data:`FIRST_ARRIVAL_QUANTILE` = 5 %: 2 periods,
1 h early, since each offset has probability 1/5). A controller that forecasts the schedule
while the plant sees this model plans the morning with
:func:`early_arrival_gain_disturbances`: before each working day's occupied hours, each
zone's expected gain is the larger of the schedule's and the schedule's shifted to that
arrival, so the pre-cooling that the first occupied hours need is planned in time instead
of being metered as a pull-down the plan did not see.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.constants import PERIOD, PERIODS_PER_DAY, TIMEZONE
from hvacflex.data.forecast import InternalGainDensities
from hvacflex.data.gains import (
    DEFAULT_OFFICE_SCHEDULE,
    OfficeSchedule,
    office_schedule,
    working_day_mask,
    zone_internal_gains_w,
)
from hvacflex.errors import ConfigError

MAX_SHIFT_STEPS = 2
"""Largest shift of a day's profile [30-min periods] (±1 h)."""
ATTENDANCE_SD = 0.15
"""Standard deviation of the daily attendance factor (fraction of the design head count)."""
ATTENDANCE_MIN, ATTENDANCE_MAX = 0.4, 1.3
"""Range of the daily attendance factor."""
PLUG_LOAD_SD = 0.1
"""Standard deviation of the daily plug-load factor."""
PLUG_MIN, PLUG_MAX = 1.0 - 3 * PLUG_LOAD_SD, 1.0 + 3 * PLUG_LOAD_SD
"""Range of the daily plug-load factor."""
FIRST_ARRIVAL_QUANTILE = 0.05
"""The quantile of a zone's first arrival each working day that the controller plans the
morning for (:func:`early_arrival_gain_disturbances`)."""


def stochastic_zone_gains_w(
    index: pd.DatetimeIndex,
    floor_area_m2: float,
    occupancy_m2_per_person: float,
    sensible_w_per_person: float,
    lighting_w_per_m2: float,
    equipment_w_per_m2: float,
    *,
    seed: int,
    zone_position: int,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
) -> np.ndarray:
    """Sensible internal gain of one zone under stochastic occupancy (module docstring).

    Parameters
    ----------
    index : (T,) period starts (tz-aware).
    floor_area_m2 : zone floor area [m²].
    occupancy_m2_per_person : floor area per person at full occupancy [m²/person], > 0.
    sensible_w_per_person : sensible heat per person [W/person].
    lighting_w_per_m2, equipment_w_per_m2 : design power densities [W/m²].
    seed : seed of the draws.
    zone_position : the zone's position (0, 1, …), part of the seed.
    schedule : the office schedule the profile follows.

    Returns
    -------
    (T,) sensible gain [W], ≥ 0.
    """
    if not np.isfinite(occupancy_m2_per_person) or occupancy_m2_per_person <= 0:
        raise ConfigError(
            "must be > 0", field="occupancy_m2_per_person", value=occupancy_m2_per_person
        )
    local = index.tz_convert(TIMEZONE)
    first_day = local[0].normalize()
    days_index = pd.date_range(
        first_day, local[-1].normalize() + pd.Timedelta(days=1), freq=PERIOD, inclusive="left"
    )
    shifted = {
        s: office_schedule(days_index + s * PERIOD, schedule)
        .to_numpy()
        .reshape(-1, PERIODS_PER_DAY, 3)
        for s in range(-MAX_SHIFT_STEPS, MAX_SHIFT_STEPS + 1)
    }
    head_count = max(round(floor_area_m2 / occupancy_m2_per_person), 0)
    day_gains = np.empty((len(days_index) // PERIODS_PER_DAY, PERIODS_PER_DAY))
    for d, midnight in enumerate(days_index[::PERIODS_PER_DAY]):
        day_number = int((midnight.tz_localize(None) - pd.Timestamp(0)).days)
        rng = np.random.default_rng([seed, zone_position, day_number])
        shift = int(rng.integers(-MAX_SHIFT_STEPS, MAX_SHIFT_STEPS + 1))
        attendance = float(np.clip(rng.normal(1.0, ATTENDANCE_SD), ATTENDANCE_MIN, ATTENDANCE_MAX))
        plug = float(np.clip(rng.normal(1.0, PLUG_LOAD_SD), PLUG_MIN, PLUG_MAX))
        fractions = shifted[shift][d]
        people = rng.binomial(head_count, np.clip(attendance * fractions[:, 0], 0.0, 1.0))
        day_gains[d] = (
            sensible_w_per_person * people
            + floor_area_m2 * lighting_w_per_m2 * fractions[:, 1]
            + floor_area_m2 * equipment_w_per_m2 * plug * fractions[:, 2]
        )
    position = np.asarray((local - first_day) // PERIOD)
    gains: np.ndarray = day_gains.ravel()[position]
    return gains


def stochastic_gain_disturbances(
    disturbances: np.ndarray,
    channels: Sequence[DisturbanceChannel],
    index: pd.DatetimeIndex,
    zone_floor_areas_m2: Sequence[float],
    gains: InternalGainDensities,
    *,
    seed: int,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
) -> np.ndarray:
    """The disturbances with each ``internal_gain`` channel replaced by stochastic occupancy.

    Parameters
    ----------
    disturbances : (T, nd) disturbances on ``index`` in ``channels`` order (the scheduled
        gains, as :func:`hvacflex.data.forecast.load_exogenous` builds them).
    channels : (nd,) the building's channels; the i-th ``internal_gain`` channel is zone i.
    index : (T,) period starts.
    zone_floor_areas_m2 : (m,) floor area per zone [m²], zone order.
    gains : the building's gain densities (``InternalGains``: ``occupancy_m2_per_person``,
        ``sensible_w_per_person``, ``lighting_w_per_m2``, ``equipment_w_per_m2``).
    seed : seed of the occupancy draws.

    Returns
    -------
    (T, nd) a new array; the other channels are unchanged.
    """
    out = np.array(disturbances, dtype=float)
    gain_columns = [i for i, ch in enumerate(channels) if ch.kind == "internal_gain"]
    for zone, column in enumerate(gain_columns):
        out[:, column] = stochastic_zone_gains_w(
            index,
            float(zone_floor_areas_m2[zone]),
            gains.occupancy_m2_per_person,
            gains.sensible_w_per_person,
            gains.lighting_w_per_m2,
            gains.equipment_w_per_m2,
            seed=seed,
            zone_position=zone,
            schedule=schedule,
        )
    return out


def first_arrival_offset_steps(quantile: float = FIRST_ARRIVAL_QUANTILE) -> int:
    """The ``quantile`` of a zone's arrival relative to the schedule [30-min periods, < 0:
    early]: the offset −s is uniform on −:data:`MAX_SHIFT_STEPS` … +:data:`MAX_SHIFT_STEPS`,
    so the smallest o whose probability P(−s ≤ o) = (o + MAX + 1) / (2 MAX + 1) ≥ quantile.

    Raises
    ------
    ConfigError : ``quantile`` outside (0, 1].
    """
    if not 0.0 < quantile <= 1.0:
        raise ConfigError("must be in (0, 1]", field="first_arrival_quantile", value=quantile)
    count = 2 * MAX_SHIFT_STEPS + 1
    return -MAX_SHIFT_STEPS + max(int(np.ceil(quantile * count - 1e-12)) - 1, 0)


def early_arrival_gain_disturbances(
    disturbances: np.ndarray,
    channels: Sequence[DisturbanceChannel],
    index: pd.DatetimeIndex,
    zone_floor_areas_m2: Sequence[float],
    gains: InternalGainDensities,
    *,
    quantile: float = FIRST_ARRIVAL_QUANTILE,
    schedule: OfficeSchedule = DEFAULT_OFFICE_SCHEDULE,
) -> np.ndarray:
    """The disturbances a controller plans with for occupants who may arrive early.

    In the periods of each working day before its occupied hours start (local time), each
    ``internal_gain`` channel becomes the larger of its value and the zone's scheduled gain
    with the profile moved to the ``quantile`` of the first arrival
    (:func:`first_arrival_offset_steps`: the gain at period k is the schedule's at
    k − o); every other period and channel is unchanged.

    Parameters
    ----------
    disturbances : (T, nd) the scheduled disturbances on ``index`` in ``channels`` order.
    channels : (nd,) the building's channels; the i-th ``internal_gain`` channel is zone i.
    index : (T,) period starts (tz-aware).
    zone_floor_areas_m2 : (m,) floor area per zone [m²], zone order.
    gains : the building's gain densities.
    quantile : q in (0, 1].
    schedule : the office schedule of ``disturbances``.

    Returns
    -------
    (T, nd) a new array [the channels' units: W for gains], ≥ ``disturbances`` elementwise.
    """
    out = np.array(disturbances, dtype=float)
    offset = first_arrival_offset_steps(quantile)
    if offset >= 0:
        return out
    local = index.tz_convert(TIMEZONE)
    hours = np.asarray(local.hour) + np.asarray(local.minute) / 60.0
    morning = working_day_mask(index, schedule) & (hours < schedule.occupied_hours[0])
    early_index = index - offset * PERIOD
    gain_columns = [i for i, ch in enumerate(channels) if ch.kind == "internal_gain"]
    for zone, column in enumerate(gain_columns):
        early = zone_internal_gains_w(
            early_index,
            float(zone_floor_areas_m2[zone]),
            gains.occupancy_m2_per_person,
            gains.sensible_w_per_person,
            gains.lighting_w_per_m2,
            gains.equipment_w_per_m2,
            schedule,
        )
        out[:, column] = np.where(morning, np.maximum(out[:, column], early), out[:, column])
    return out
