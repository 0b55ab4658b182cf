"""Trend data simulated from a known grey-box model (the fit's identifiability tests), as
the ``synthetic_trend`` fixture."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
import pytest

from hvacflex.data.weather import EpwLocation
from hvacflex.identify.fit import wall_irradiance_kw_per_m2
from hvacflex.identify.greybox import EXOGENOUS_INPUTS, GreyBoxParameters, discretize
from hvacflex.units import CP_AIR_J_PER_KG_K

TRUE_ZONES = np.array(
    [  # C_a, C_m, UA_o, UA_am, UA_mo, S_a, S_m, S_north, S_east, S_south, S_west, P_occ, P_0
        [800.0, 3.0e4, 0.05, 0.8, 0.03, 3.0, 6.0, 0.0, 4.0, 1.0, 0.0, 1.5, 0.4],
        [1200.0, 6.0e4, 0.08, 1.2, 0.05, 5.0, 8.0, 1.0, 0.0, 0.0, 3.0, 2.5, 0.2],
    ]
)
TRUE = GreyBoxParameters(TRUE_ZONES, np.array([[0, 1]], dtype=np.int64), np.array([0.3]))
ZONES = ("Room-A", "ROOM_b")
SUPPLY_TEMP_DEGC = 14.0
SITE = EpwLocation(1.37, 103.98, 8.0, 15.0, "Singapore Changi")
"""The site of the synthetic data (the wall irradiances are computed there)."""
COOLING = len(EXOGENOUS_INPUTS)
"""Where the cooling inputs start in ``u``."""


def make_synthetic_trend(days: int, seed: int = 0, noise_k: float = 0.0) -> pd.DataFrame:
    """(days · 48, columns) a trend frame of :data:`TRUE` driven by random flows."""
    rng = np.random.default_rng(seed)
    steps = days * 48
    index = pd.date_range("2014-03-03", periods=steps, freq="30min", tz="Asia/Singapore")
    hour = index.hour.to_numpy() + index.minute.to_numpy() / 60
    outdoor = 27 + 4 * np.sin((hour - 9) / 24 * 2 * np.pi) + rng.normal(0, 0.3, steps)
    ghi = np.clip(900 * np.sin((hour - 7) / 12 * np.pi), 0, None) * rng.uniform(0.5, 1, steps)
    occupied = ((hour >= 8) & (hour < 18) & (index.day_of_week.to_numpy() < 5)).astype(float)
    flow = rng.choice([0.05, 0.2, 0.4], size=(steps, 2))
    walls = wall_irradiance_kw_per_m2(index, ghi, SITE)  # as the fit computes them
    model = discretize(TRUE)
    x = np.full(4, 25.0)
    temps = np.empty((steps, 2))
    for k in range(steps):
        # the mean temperature solves y = c x + d u with u's cooling depending on y
        base = np.r_[outdoor[k], ghi[k] / 1000, occupied[k], 1.0, walls[k], 0.0, 0.0]
        gain = flow[k] * CP_AIR_J_PER_KG_K / 1000.0
        d_cooling = model.d_mean[:, COOLING:]
        lhs = np.eye(2) - d_cooling * gain[None, :]
        rhs = model.c_mean @ x + model.d_mean @ base - d_cooling @ (gain * SUPPLY_TEMP_DEGC)
        temps[k] = np.linalg.solve(lhs, rhs)
        u = base.copy()
        u[COOLING:] = gain * (temps[k] - SUPPLY_TEMP_DEGC)
        x = model.a @ x + model.b @ u
    frame = pd.DataFrame(index=index)
    for i, zone in enumerate(ZONES):
        frame[f"temp_{zone}_degc"] = temps[:, i] + rng.normal(0, noise_k, steps)
        frame[f"supply_flow_{zone}_kg_s"] = flow[:, i]
        frame[f"supply_temp_{zone}_degc"] = SUPPLY_TEMP_DEGC
    frame["outdoor_temp_degc"] = outdoor
    frame["ghi_w_per_m2"] = ghi
    frame["occupied"] = occupied
    cooling = (flow * CP_AIR_J_PER_KG_K / 1000 * (temps - SUPPLY_TEMP_DEGC)).sum(axis=1)
    frame["hvac_power_kw"] = 1.0 + 0.3 * cooling + 0.05 * outdoor
    return frame


@pytest.fixture(scope="session")
def synthetic_trend() -> Callable[..., pd.DataFrame]:
    """:func:`make_synthetic_trend`."""
    return make_synthetic_trend
