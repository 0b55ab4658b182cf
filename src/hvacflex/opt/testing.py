"""Seeded random RMPC problems for tests and benchmarks: small, stable, Metzler (A ≥ 0, B ≤ 0).

Public so that ``tests/`` and ``benchmarks/`` share one generator:

>>> from hvacflex.opt.testing import random_problem
>>> problem = random_problem(0, horizon=8)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import expm

from hvacflex.constants import PERIOD_S
from hvacflex.opt.problem import RMPCProblem
from hvacflex.units import SECONDS_PER_HOUR


def random_model(
    rng: np.random.Generator, n: int, m: int, nd: int, dt_h: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A random RC network discretised by ZOH: (A, B, E, g), A ≥ 0, B ≤ 0.

    Nodes 0..m-1 are the zones; disturbance 0 is the outdoor temperature [°C], the others are
    heat gains [kW]. Continuous time in hours, capacitances in kWh/K.
    """
    conductance = rng.uniform(0.1, 1.0, (n, n)) * (rng.random((n, n)) < 0.7)
    conductance = np.triu(conductance, 1)
    conductance = conductance + conductance.T  # kW/K
    loss = rng.uniform(0.05, 0.3, n)  # kW/K to outdoor air
    cap = rng.uniform(1.0, 4.0, n)  # kWh/K
    a_cont = (conductance - np.diag(conductance.sum(axis=1) + loss)) / cap[:, None]
    b_cont = np.zeros((n, m))
    b_cont[np.arange(m), np.arange(m)] = -rng.uniform(6.0, 10.0, m) / cap[:m]  # K/h per kg/s
    e_cont = np.zeros((n, nd))
    e_cont[:, 0] = loss / cap
    if nd > 1:
        e_cont[:, 1:] = rng.uniform(0.0, 1.0, (n, nd - 1)) / cap[:, None]
    g_cont = rng.uniform(-1.0, 0.5, n) / cap  # K/h (linearisation constant)
    return zoh_discretise(a_cont, b_cont, e_cont, g_cont, dt_h)


def zoh_discretise(
    a_cont: np.ndarray, b_cont: np.ndarray, e_cont: np.ndarray, g_cont: np.ndarray, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Exact (zero-order hold) discretisation of ``ẋ = A x + B u + E d + g`` over ``dt``.

    Parameters
    ----------
    a_cont, b_cont, e_cont : (n,n), (n,m), (n,nd) continuous-time matrices [per time unit]
    g_cont : (n,) constant term [K per time unit]
    dt : step, in the time unit of the matrices

    Returns
    -------
    (A, B, E, g) of ``x+ = A x + B u + E d + g``.
    """
    n, m, nd = a_cont.shape[0], b_cont.shape[1], e_cont.shape[1]
    size = n + m + nd + 1
    aug = np.zeros((size, size))
    aug[:n, :n] = a_cont
    aug[:n, n : n + m] = b_cont
    aug[:n, n + m : n + m + nd] = e_cont
    aug[:n, -1] = g_cont
    phi = expm(aug * dt)
    return phi[:n, :n], phi[:n, n : n + m], phi[:n, n + m : n + m + nd], phi[:n, -1]


def random_problem(
    seed: int,
    *,
    n: int = 4,
    m: int = 2,
    nd: int = 3,
    horizon: int = 8,
    dt_h: float = PERIOD_S / SECONDS_PER_HOUR,
    **overrides: Any,
) -> RMPCProblem:
    """A seeded random problem with nonzero g, reserve on every input; override any field."""
    rng = np.random.default_rng(seed)
    a, b, e, g = random_model(rng, n, m, nd, dt_h)
    ny = m
    c = np.zeros((ny, n))
    c[np.arange(ny), np.arange(ny)] = 1.0
    d = np.empty((horizon, nd))
    d[:, 0] = 30.0 + 2.0 * np.sin(np.linspace(0.0, np.pi, horizon)) + rng.normal(0, 0.3, horizon)
    d[:, 1:] = rng.uniform(1.0, 3.0, (horizon, nd - 1))
    sigma = np.empty((horizon, nd))
    sigma[:, 0] = 0.5
    sigma[:, 1:] = 0.15 * d[:, 1:]
    fields: dict[str, Any] = dict(
        a_matrix=a,
        b_matrix=b,
        e_matrix=e,
        c_matrix=c,
        affine_term=g,
        x0=rng.uniform(23.0, 25.0, n),
        d_forecast=d,
        d_sigma=sigma,
        energy_price_sgd_per_mwh=rng.uniform(80.0, 250.0, horizon),
        reserve_price_sgd_per_mwh=rng.uniform(1.0, 30.0, horizon),
        peak_price_sgd_per_kw=1.5,
        peak_floor_kw=0.0,
        power_offset_kw=rng.uniform(0.5, 1.5, horizon),
        power_coeff_kw_per_kg_s=rng.uniform(2.0, 4.0, (horizon, m)),
        u_min=np.full(m, 0.1),
        u_max=np.full(m, 1.5),
        y_min=np.full((horizon, ny), 22.0),
        y_max=np.full((horizon, ny), 26.0),
        reserve_mask=np.ones(m, dtype=bool),
        comfort_penalty_sgd_per_kelvin_hour=100.0,
        dt_h=dt_h,
    )
    fields.update(overrides)
    return RMPCProblem(**fields)
