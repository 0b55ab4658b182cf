"""A scenario as a Gymnasium environment: :func:`make_env` (the ``gym`` extra).

::

    from hvacflex.gym import make_env

    env = make_env("thermostat-25.5", start="2014-03-03", days=1)   # 48 steps
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

An episode is the scenario's periods (a 1-day scenario is 48 steps of 30 min), run on a
:class:`hvacflex.Simulation` with your agent as the controller: what the loop records and
grades is what ``simulate`` records and grades (docs/reference/api.md, "Gymnasium environment").

**Action** (``Box``, float32, shape (m,), zone order of ``env.zone_names``): the plant's
actuation — the zones' supply-air flows [kg/s] on a flow-actuated plant (the RC network;
bounds: the lowest minimum flow to the largest maximum flow; each period clips to that
period's minimum, higher while occupied, and the maximum), the zones' set-points [°C] on a
set-point-actuated plant (EnergyPlus; bounds: the scenario's lowest comfort lower bound to
its highest upper bound; each period clips to its comfort band, as the MPC's are).

**Observation** (``Box``, float32, shape (3m + 9,)), in this order (``env.observation_names``):

===============================  ======  ===========================================
``zone_temp_<zone>_degc``        m       zone air temperature now [°C]
``comfort_lower_<zone>_degc``    m       the period's comfort band, lower bound [°C]
``comfort_upper_<zone>_degc``    m       the period's comfort band, upper bound [°C]
``outdoor_temp_degc``            1       forecast outdoor temperature of the period [°C]
``hour_sin``, ``hour_cos``       2       time of day of the period's start, on the circle
``weekday``                      1       day of the week, 0 (Monday) … 6
``occupied``                     1       1 when the period is occupied, else 0
``energy_price_sgd_per_mwh``     1       forecast energy price of the period [SGD/MWh]
``peak_price_sgd_per_kw``        1       peak-power price φ [SGD/kW]
``month_peak_kw``                1       largest power of the month so far [kW] (0 at start)
``previous_power_kw``            1       power of the period before [kW] (0 at start)
===============================  ======  ===========================================

The forecast values are the scenario's forecaster's view of the period starting now (what a
controller sees; the data itself under perfect foresight).

**Reward** of period k: −(energy cost + the peak charge's increment + the comfort penalty)
[SGD]: ``P_k c_k Δt / 1000`` with the period's price c_k [SGD/MWh]; ``max(charge so far this
month, φ_k P_k) − charge so far`` (the monthly peak-power charge of :func:`hvacflex.kpi.
ppp_charge_monthly_sgd`, charged as it grows); ``ρ Δt Σ_zone deviation`` with ρ the
scenario's ``controller.comfort_penalty_sgd_per_kelvin_hour`` and the deviation of each
zone's end temperature from the band [K]. So an episode's return is −(``energy_cost_sgd`` +
``ppp_charge_monthly_sgd`` + ρ ``discomfort_kelvin_hours``) of its KPIs (the whole months'
peak charges: an episode shorter than a month is charged the month's peak as a bill would).
The MPC's comfort knee (``controller.comfort_knee_k``) is not part of the reward: ρ alone.

**Episode end**: ``terminated`` is True after the scenario's last period (the bill is
complete; nothing is truncated). **info**: every step ``period``, ``power_kw``,
``energy_cost_sgd``, ``peak_charge_increment_sgd``, ``comfort_penalty_sgd``,
``discomfort_kelvin_hours`` (the period's terms); the last step adds ``kpi``, the episode's
KPIs (:func:`hvacflex.kpi.summary`, as ``simulate``'s ``summary.json`` holds them).

The environment is deterministic: ``reset(seed=…)`` seeds ``env.np_random`` (for the
action space's samples); the scenario's own ``seed`` draws its disturbances.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from hvacflex.errors import require_extra

require_extra("gym", "hvacflex.gym")

import gymnasium  # noqa: E402  (after the check, so a missing extra says how to install it)
from gymnasium import spaces  # noqa: E402

from hvacflex import results as schema  # noqa: E402
from hvacflex.config import ScenarioConfig  # noqa: E402
from hvacflex.data.signals import effective_peak_price  # noqa: E402
from hvacflex.simulation import Simulation  # noqa: E402
from hvacflex.units import KWH_PER_MWH  # noqa: E402

__all__ = ["HvacflexEnv", "make_env"]

_TIME_FEATURES = (
    "outdoor_temp_degc",
    "hour_sin",
    "hour_cos",
    "weekday",
    "occupied",
    "energy_price_sgd_per_mwh",
    "peak_price_sgd_per_kw",
    "month_peak_kw",
    "previous_power_kw",
)
"""The observation's entries after the 3m per-zone ones, in order."""


def make_env(
    preset_or_scenario_path: str | Path | ScenarioConfig,
    start: str | None = None,
    days: float | None = None,
    **overrides: Any,
) -> HvacflexEnv:
    """The scenario as a Gymnasium environment (module docstring: action, observation,
    reward, info).

    Parameters
    ----------
    preset_or_scenario_path : a preset name (``"thermostat-25.5"``), a scenario TOML file or a
        :class:`~hvacflex.config.ScenarioConfig`.
    start : first day, ``"YYYY-MM-DD"`` (default: the scenario's).
    days : the episode's length in days (48 steps a day; default: the scenario's).
    **overrides : other scenario settings, as :func:`hvacflex.simulate` takes them.

    Raises
    ------
    ConfigError : an unknown preset, an invalid scenario or override (naming the field).
    """
    given = {"start": start, "days": days}
    return HvacflexEnv(
        preset_or_scenario_path,
        **{k: v for k, v in given.items() if v is not None},
        **overrides,
    )


class HvacflexEnv(gymnasium.Env[np.ndarray, np.ndarray]):
    """A scenario's closed loop as a Gymnasium environment (:func:`make_env`)."""

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012 (gymnasium declares it so)

    def __init__(self, scenario: str | Path | ScenarioConfig, **overrides: Any) -> None:
        super().__init__()
        self.simulation = Simulation(scenario, own_controller=False, **overrides)
        sim = self.simulation
        self.scenario = sim.scenario
        self.zone_names = sim.zone_names
        exo = sim.setup.exogenous
        steps = sim.steps
        hvac = sim.setup.building.hvac
        self._flow_max_kg_s = np.asarray(hvac.flow_max_kg_s, dtype=float)
        self._flow_min_kg_s = (
            np.asarray(hvac.flow_min_at(np.array([False]))[0], dtype=float),
            np.asarray(hvac.flow_min_at(np.array([True]))[0], dtype=float),
        )
        """(m,) lowest flow [kg/s] when unoccupied and when occupied."""
        if sim.actuation == "flow":
            low = np.minimum(*self._flow_min_kg_s)
            high = self._flow_max_kg_s
        else:
            m = len(self.zone_names)
            low = np.full(m, float(np.min(exo.comfort_lower_degc[:steps])))
            high = np.full(m, float(np.max(exo.comfort_upper_degc[:steps])))
        self.action_space = spaces.Box(
            low.astype(np.float32), high.astype(np.float32), dtype=np.float32
        )
        self.observation_names = (
            *(f"zone_temp_{z}_degc" for z in self.zone_names),
            *(f"comfort_lower_{z}_degc" for z in self.zone_names),
            *(f"comfort_upper_{z}_degc" for z in self.zone_names),
            *_TIME_FEATURES,
        )
        self.observation_space = spaces.Box(
            -np.inf, np.inf, shape=(len(self.observation_names),), dtype=np.float32
        )
        self._dt_h = self.scenario.dt_s / 3600.0
        self._comfort_weight = self.scenario.controller.comfort_penalty_sgd_per_kelvin_hour
        self._month = np.asarray(exo.index.year * 12 + exo.index.month)
        """The calendar month (local time) of each period: the peak charge's bill."""
        self._start_episode()

    def _start_episode(self) -> None:
        self._month_charge_sgd = 0.0
        self._month_peak_kw = 0.0
        self._previous_power_kw = 0.0

    # -- gymnasium -----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if self.simulation.k > 0:
            self.simulation.restart()
        self._start_episode()
        return self._observation(), {"period": 0}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        sim = self.simulation
        k = sim.k
        values = np.asarray(action, dtype=float)
        if sim.actuation == "flow":
            occupied = bool(sim.setup.exogenous.occupied[k])
            values = np.clip(values, self._flow_min_kg_s[int(occupied)], self._flow_max_kg_s)
        row = sim.step(values)
        info = self._period_terms(k, row)
        reward = -(
            info["energy_cost_sgd"]
            + info["peak_charge_increment_sgd"]
            + info["comfort_penalty_sgd"]
        )
        terminated = sim.done
        if terminated:
            info["kpi"] = sim.summary
            sim.close()
        return self._observation(), float(reward), terminated, False, info

    def close(self) -> None:
        self.simulation.close()

    # -- the period's terms --------------------------------------------------------------
    def _period_terms(self, k: int, row: dict[str, Any]) -> dict[str, Any]:
        """The reward's terms of period ``k`` from its results ``row`` [SGD]."""
        power_kw = float(row["power_kw"])
        energy_cost = power_kw * float(row["energy_price_sgd_per_mwh"]) * self._dt_h / KWH_PER_MWH
        if k > 0 and self._month[k] != self._month[k - 1]:  # a new bill: the charge restarts
            self._month_charge_sgd = 0.0
            self._month_peak_kw = 0.0
        charge = max(self._month_charge_sgd, float(row["peak_price_sgd_per_kw"]) * power_kw)
        increment = charge - self._month_charge_sgd
        self._month_charge_sgd = charge
        self._month_peak_kw = max(self._month_peak_kw, power_kw)
        self._previous_power_kw = power_kw
        deviation_k = 0.0
        for zone in self.zone_names:
            temp = float(row[schema.TEMP_END.name(zone)])
            lower = float(row[schema.COMFORT_LOWER.name(zone)])
            upper = float(row[schema.COMFORT_UPPER.name(zone)])
            deviation_k += max(lower - temp, 0.0) + max(temp - upper, 0.0)
        discomfort = deviation_k * self._dt_h
        return {
            "period": k,
            "power_kw": power_kw,
            "energy_cost_sgd": energy_cost,
            "peak_charge_increment_sgd": increment,
            "comfort_penalty_sgd": self._comfort_weight * discomfort,
            "discomfort_kelvin_hours": discomfort,
        }

    def _observation(self) -> np.ndarray:
        """The observation of the period starting now (module docstring)."""
        sim = self.simulation
        k = sim.k
        forecast = sim.setup.forecaster.forecast(k, 1)
        outdoor = next(
            i for i, ch in enumerate(sim.setup.model.channels) if ch.kind == "outdoor_temp"
        )
        when = sim.setup.exogenous.index[k]
        hour = when.hour + when.minute / 60.0
        peak_price = effective_peak_price(forecast, self.scenario.controller.peak_price_sgd_per_kw)
        features = [
            float(forecast.disturbances[0][outdoor]),
            math.sin(2 * math.pi * hour / 24.0),
            math.cos(2 * math.pi * hour / 24.0),
            float(when.weekday()),
            float(bool(forecast.occupied[0])),
            float(forecast.energy_price_sgd_per_mwh[0]),
            peak_price,
            self._month_peak_kw,
            self._previous_power_kw,
        ]
        observation = np.concatenate(
            [
                sim.zone_temp_degc,
                np.asarray(forecast.comfort_lower_degc[0], dtype=float),
                np.asarray(forecast.comfort_upper_degc[0], dtype=float),
                features,
            ]
        )
        return observation.astype(np.float32)
