"""A closed loop you step yourself: :class:`Simulation`, the public face of
:class:`hvacflex.sim.closed_loop.ClosedLoop` (``hvacflex.Simulation``).

::

    sim = hvacflex.Simulation("thermostat-25.5", start="2014-03-03", days=1)
    sim.step()                       # one 30-min period, decided by the scenario's controller
    sim.step(np.full(5, 0.3))        # one period with your action: zone flows [kg/s]
    result = sim.run()               # the rest, by the controller; result.summary, .results

A period's action is the scenario's controller's, a given :class:`~hvacflex.control.base.Action`,
or an array: the zones' supply-air flows (m,) [kg/s] on a flow-actuated plant (the RC
network), their set-points (m,) [°C] on a set-point-actuated one (EnergyPlus). Either way it
goes through the loop's one control step (:class:`hvacflex.sim.step.ControlStep`), so a
period decided here is recorded and graded exactly as ``simulate`` records and grades it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol, cast, runtime_checkable

import numpy as np
import pandas as pd

from hvacflex import kpi
from hvacflex.config import ScenarioConfig, resolve_scenario
from hvacflex.control.base import Action, Controller, FloatArray, PeriodInputs
from hvacflex.control.baselines import rule_action
from hvacflex.data.forecast import Forecast
from hvacflex.errors import HvacflexError, InputError
from hvacflex.results import STATUS_COLUMN
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.plant import Plant
from hvacflex.sim.plants import plant_summary, scenario_plant
from hvacflex.sim.setup import Setup, make_controller, prepare


@runtime_checkable
class Forecaster(Protocol):
    """What gives a controller its view of the coming periods (``hvacflex.Forecaster``):
    the scenario's :class:`hvacflex.data.forecast.Forecaster` by default, or your own, given
    to :class:`Simulation`."""

    def forecast(self, k: int, horizon: int) -> Forecast:
        """The forecast made at period ``k`` of periods k … k + horizon − 1: prices, φ, the
        disturbances (horizon, nd) in the building's channel order, the comfort bounds and
        occupancy (:class:`hvacflex.data.forecast.Forecast`)."""
        ...


UserAction = Action | Sequence[float] | np.ndarray
"""What :meth:`Simulation.step` applies: an :class:`Action`, or an array (m,) of the zones'
flows [kg/s] (flow actuation) or set-points [°C] (set-point actuation)."""


def flow_action(flow_kg_s: FloatArray | Sequence[float]) -> Action:
    """The :class:`~hvacflex.control.base.Action` a user's controller returns to run the zones
    at these flows (m,) [kg/s] for the period: no reserve offered, no plan (status
    ``"rule"``; the predicted temperatures NaN, which a set-point plant reads as the band's
    upper bound)."""
    flow = np.asarray(flow_kg_s, dtype=float)
    nan = np.full(flow.shape, np.nan)
    return Action(
        flow_kg_s=flow,
        reserve_flow_kg_s=np.zeros_like(flow),
        reserve_kw=0.0,
        planned_power_kw=float("nan"),
        status="rule",
        fallback=False,
        solve_time_s=0.0,
        planned_slack_max_k=0.0,
        delta_max_k=0.0,
        predicted_served_degc=nan,
        predicted_curtailed_degc=nan.copy(),
    )


@dataclass(frozen=True)
class SimulationResult:
    """The outcome of a :class:`Simulation` (``Simulation.run()``), held in memory.

    Attributes
    ----------
    results : one row per period (the results table of ``docs/explanation/architecture.md``).
    summary : the KPIs (:func:`hvacflex.kpi.summary`) and the plant keys (``plant``,
        ``plant_idf``, ``plant_actuation``, ``plant_curtailed_setpoint``), as in
        ``summary.json`` but for the timings.
    """

    results: pd.DataFrame
    summary: dict[str, Any]


class _GivenOrOwn:
    """A controller that applies the action handed to the next :meth:`act`, else asks the
    scenario's (or the user's) controller. The actions given are built here from the
    period's inputs: flows as a rule-based controller's (:func:`rule_action`), set-points as
    the one-step prediction the closed loop hands a set-point plant."""

    def __init__(self, own: Controller | None, setup: Setup, actuation: str) -> None:
        self.own = own
        self.pending: UserAction | None = None
        self.takes_measurements = bool(getattr(own, "takes_measurements", False))
        self.commits_ahead = int(getattr(own, "commits_ahead", 0))
        self._model = setup.model
        self._flow_max_kg_s = np.asarray(setup.building.hvac.flow_max_kg_s, dtype=float)
        self._actuation = actuation

    def act(self, inputs: PeriodInputs) -> Action:
        given, self.pending = self.pending, None
        if given is None:
            if self.own is None:
                raise HvacflexError(
                    "this simulation has no controller: give Simulation.step an action "
                    "(or give Simulation a controller)"
                )
            return self.own.act(inputs)
        if inputs.locked is not None:  # an IL event's locked plan runs, whatever is given
            return inputs.locked
        if isinstance(given, Action):
            return given
        values = np.asarray(given, dtype=float)
        d_now = np.asarray(inputs.forecast.disturbances[0], dtype=float)
        if self._actuation == "flow":
            return rule_action(self._model, inputs.x_degc, values, d_now)
        # set-points: flows at their maximum (never idle), the set-points as the plan's end
        # temperatures, which the loop clips to the comfort band at the period's end
        action = rule_action(self._model, inputs.x_degc, self._flow_max_kg_s.copy(), d_now)
        return replace(action, predicted_served_degc=values, predicted_curtailed_degc=values)

    def get_state(self) -> dict[str, Any]:
        return {} if self.own is None else self.own.get_state()

    def set_state(self, state: dict[str, Any]) -> None:
        if self.own is not None:
            self.own.set_state(state)


class Simulation:
    """A scenario's closed loop, stepped one 30-min period at a time (``hvacflex.Simulation``).

    Parameters
    ----------
    scenario : a preset name (``"rmpc"``, ``"thermostat-25.5"``…), a scenario TOML file, or a
        :class:`~hvacflex.config.ScenarioConfig` (``hvacflex.Scenario``).
    controller : your :class:`~hvacflex.control.base.Controller`; default: the one the
        scenario asks for. ``None`` together with ``own_controller=False``: no controller,
        every :meth:`step` needs an action. A dict is an override of the scenario's
        ``[controller]`` table instead (``{"peak_price_sgd_per_kw": 1.5}``), as in
        :func:`hvacflex.simulate`.
    plant : your :class:`~hvacflex.sim.plant.Plant`; default: the scenario's (``[plant]``).
        A dict is an override of the ``[plant]`` table (``{"kind": "energyplus"}``).
    forecaster : your :class:`Forecaster`; default: the scenario's.
    own_controller : build the scenario's controller when ``controller`` is None.
    **overrides : scenario settings, as :func:`hvacflex.simulate` takes them
        (``start="2014-03-03"``, ``days=1``, ``peak_price_sgd_per_kw=1.5``…).

    Raises
    ------
    ConfigError : an unknown preset, an invalid scenario or override (naming the field).
    """

    def __init__(
        self,
        scenario: str | Path | ScenarioConfig = "rmpc",
        *,
        controller: Controller | Mapping[str, Any] | None = None,
        plant: Plant | Mapping[str, Any] | None = None,
        forecaster: Forecaster | None = None,
        own_controller: bool = True,
        **overrides: Any,
    ) -> None:
        # a dict is the scenario's [controller] / [plant] table, as simulate takes it
        if isinstance(controller, Mapping):
            overrides["controller"], controller = controller, None
        if isinstance(plant, Mapping):
            overrides["plant"], plant = plant, None
        self.scenario: ScenarioConfig = resolve_scenario(scenario, overrides)
        setup = prepare(self.scenario)
        if forecaster is not None:  # the loop calls forecast(k, horizon) only
            setup = replace(setup, forecaster=cast(Any, forecaster))
        self.setup = setup
        self._zone_rows = setup.model.c.argmax(axis=1)
        self._scenario_controller = controller is None and own_controller
        self._controller = make_controller(setup) if self._scenario_controller else controller
        self._initial_controller_state = (
            None if self._controller is None else self._controller.get_state()
        )
        self._plant = plant
        self.loop = self._new_loop()

    @property
    def controller(self) -> Controller | None:
        """The controller that decides a period :meth:`step` is given no action for. Set it
        before the first period (a controller built from :attr:`zone_nodes`,
        :attr:`flow_max_kg_s`…)."""
        return self._controller

    @controller.setter
    def controller(self, controller: Controller | None) -> None:
        if self.k > 0:
            raise InputError(
                "the controller is set before the first period",
                field="controller",
                value=self.k,
                hint="call restart() first, or give the controller to Simulation(...)",
            )
        self.close()
        self._controller = controller
        self._scenario_controller = False
        self._initial_controller_state = None if controller is None else controller.get_state()
        self.loop = self._new_loop()

    def _new_loop(self) -> ClosedLoop:
        plant = self._plant
        if plant is None:
            plant = scenario_plant(self.setup)
        actuation = plant.actuations[0]
        self._control = _GivenOrOwn(self._controller, self.setup, actuation)
        return ClosedLoop(self.setup, cast(Controller, self._control), plant=plant)

    # -- where the run is ------------------------------------------------------------------
    @property
    def k(self) -> int:
        """The next period to simulate (0 … :attr:`steps`)."""
        return self.loop.k

    @property
    def steps(self) -> int:
        """The scenario's periods (48 a day)."""
        return self.loop.steps

    @property
    def done(self) -> bool:
        """True when every period has been simulated."""
        return self.loop.k >= self.loop.steps

    @property
    def actuation(self) -> str:
        """How the plant is driven: ``"flow"`` (zone flows [kg/s]) or ``"setpoint"`` (zone
        set-points [°C]); what an array given to :meth:`step` means."""
        return self.loop.actuation

    @property
    def zone_names(self) -> tuple[str, ...]:
        """The zones, in the order of every (m,) array."""
        return self.setup.zone_names

    @property
    def zone_nodes(self) -> np.ndarray:
        """(m,) the position of each zone's air node in the state ``PeriodInputs.x_degc``."""
        return np.asarray(self._zone_rows, dtype=int)

    @property
    def flow_max_kg_s(self) -> FloatArray:
        """(m,) each zone's largest supply-air flow [kg/s]."""
        return np.asarray(self.setup.building.hvac.flow_max_kg_s, dtype=float)

    @property
    def zone_temp_degc(self) -> FloatArray:
        """(m,) the zone air temperatures now [°C]."""
        return np.asarray(self.loop.x[self._zone_rows], dtype=float)

    # -- stepping --------------------------------------------------------------------------
    def step(self, action: UserAction | None = None) -> dict[str, Any]:
        """Simulate period :attr:`k` and advance.

        Parameters
        ----------
        action : None: the controller decides; an :class:`Action`; or an array (m,) of the
            zones' flows [kg/s] (:attr:`actuation` ``"flow"``) or set-points [°C]
            (``"setpoint"``; clipped to the comfort band at the period's end, as the MPC's are).

        Returns
        -------
        The period's results row as ``{column: value}`` (``power_kw``, ``temp_end_<zone>_degc``…;
        the settlement columns are in :attr:`results`).

        Raises
        ------
        InputError : the run is over, or the array is not (m,) finite values.
        """
        if self.done:
            raise InputError(
                "the simulation has run all its periods",
                field="step",
                value=self.k,
                hint="call restart() to start again from the first period",
            )
        if action is not None and not isinstance(action, Action):
            values = np.asarray(action, dtype=float)
            m = len(self.zone_names)
            if values.shape != (m,) or not np.isfinite(values).all():
                unit = "flows [kg/s]" if self.actuation == "flow" else "set-points [°C]"
                raise InputError(
                    f"an action is one finite value per zone, shape ({m},)",
                    field="action",
                    value=values.tolist(),
                    hint=f"give the zones' {unit} in the order {list(self.zone_names)}",
                )
            action = values
        k = self.loop.k
        self._control.pending = action
        self.loop.step()
        recorder = self.loop.recorder
        values_k = recorder.values[k].tolist()
        row: dict[str, Any] = dict(zip(recorder.float_columns, values_k, strict=True))
        row.update({name: bool(flags[k]) for name, flags in recorder.flags.items()})
        row[STATUS_COLUMN] = recorder.status[k]
        return row

    def run(self) -> SimulationResult:
        """Simulate the remaining periods with the controller and return the result (the
        plant is closed at the end)."""
        while not self.done:
            self.step()
        result = SimulationResult(self.results, self.summary)
        self.close()
        return result

    def restart(self) -> None:
        """Start again from the first period: the scenario's plant anew (or yours, reset),
        the controller back in the state it had when the simulation was made."""
        self.close()
        if self._scenario_controller:  # a fresh one: no solver state carried over
            self._controller = make_controller(self.setup)
        elif self._controller is not None and self._initial_controller_state is not None:
            self._controller.set_state(self._initial_controller_state)
        self.loop = self._new_loop()

    def close(self) -> None:
        """Release the plant (an EnergyPlus process); nothing to do on the RC network."""
        close = getattr(self.loop.plant, "close", None)
        if close is not None:
            close()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- results ---------------------------------------------------------------------------
    @property
    def results(self) -> pd.DataFrame:
        """The results of the periods so far, settled (one row per period)."""
        return self.loop.frame()

    @property
    def summary(self) -> dict[str, Any]:
        """The KPIs of the periods so far and the plant keys (``summary.json`` but for the
        timings).

        Raises
        ------
        InputError : no period has been simulated yet.
        """
        if self.k == 0:
            raise InputError(
                "no period simulated yet", field="summary", hint="call step() or run() first"
            )
        return {**kpi.summary(self.results), **plant_summary(self.scenario.plant)}
