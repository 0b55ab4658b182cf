"""The public API: what ``import hvacflex`` offers.

``hvacflex/__init__.py`` exposes these names lazily, so ``import hvacflex`` (and the command
line) stays cheap; the first use of one imports this module and what it needs::

    import hvacflex

    run = hvacflex.simulate("rmpc", start="2014-03-03", days=1, out="results/rmpc")
    run.summary["net_cost_sgd"]          # the content of results/rmpc/summary.json
    run.results["power_kw"]              # the results table, one row per 30-min period
    hvacflex.simulate("rmpc-ppp", days=1, controller={"peak_price_sgd_per_kw": 1.5})

    sim = hvacflex.Simulation("thermostat-25.5", start="2014-03-03", days=1)
    sim.step()                           # one period by the scenario's controller
    sim.step([0.3, 0.3, 0.3, 0.3, 0.6])  # one period with your zone flows [kg/s]
    sim.run().summary                    # the rest; the KPIs

``Scenario`` (the scenario configuration, :class:`hvacflex.config.ScenarioConfig`),
``Building``, and the protocols a user's part implements — ``Controller``
(:class:`hvacflex.control.base.Controller`), ``Plant`` (:class:`hvacflex.sim.plant.Plant`) and
``Forecaster`` (:class:`hvacflex.simulation.Forecaster`) — complete the public names
(docs/reference/api.md).

:func:`simulate` builds its scenario on the path ``hvacflex simulate`` takes
(:func:`hvacflex.config.resolve_scenario`) and runs it with
:func:`hvacflex.sim.run.run_simulation`, so the two give the same results.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from hvacflex import kpi
from hvacflex.building.io import load_building as _load_building_file
from hvacflex.building.model import Building
from hvacflex.config import ScenarioConfig, load_config, preset, resolve_scenario
from hvacflex.constants import RUN_DIR
from hvacflex.control.base import Controller
from hvacflex.paths import resolve_building
from hvacflex.results import load_results
from hvacflex.sim.plant import Plant
from hvacflex.sim.run import DEFAULT_CHECKPOINT_EVERY, RunResult, run_simulation
from hvacflex.simulation import Forecaster, Simulation, SimulationResult

Scenario = ScenarioConfig
"""A scenario: the building, the data, the controller, the plant… (``hvacflex.Scenario``;
:func:`preset` and :func:`load_config` make one, ``Scenario.with_overrides`` changes one)."""

__all__ = [
    "Building",
    "Controller",
    "Forecaster",
    "Plant",
    "RunResult",
    "Scenario",
    "Simulation",
    "SimulationResult",
    "kpi_summary",
    "load_building",
    "load_config",
    "preset",
    "simulate",
]


def simulate(
    config_or_preset: str | Path | ScenarioConfig = "rmpc",
    out: str | Path = RUN_DIR,
    *,
    quiet: bool = False,
    fresh: bool = False,
    checkpoint_every: int = DEFAULT_CHECKPOINT_EVERY,
    **overrides: Any,
) -> RunResult:
    """Run a closed-loop simulation, as ``hvacflex simulate`` does, and return its result.

    Parameters
    ----------
    config_or_preset : a preset name (``"rmpc"``, ``"nmpc"``, … :data:`hvacflex.config.
        PRESET_NAMES`), a scenario TOML file (a ``Path``, or a string ending in ``.toml`` or
        naming a file), or a :class:`~hvacflex.config.ScenarioConfig`.
    out : the run's folder (``results.parquet``, ``summary.json``, ``config.json``, the
        checkpoint); default ``results/run`` like the command line's ``--out``. A finished
        run of the same inputs and code there is re-used; an unfinished one is resumed.
    quiet : no progress bar (``--quiet``).
    fresh : ignore existing results and checkpoints in ``out`` (``--fresh``).
    checkpoint_every : steps between checkpoints (``--checkpoint-every``; 336 = one week).
    **overrides : scenario settings, validated by the scenario schema like a TOML file:
        top-level fields (``start="2014-03-03"``, ``days=1``, ``seed=7``,
        ``building="office5"``), the command line's ``price_gap_fill``, unique leaf names or
        dotted paths (``peak_price_sgd_per_kw=1.5``), and tables as dicts merged into the
        scenario's table (``controller={"peak_price_sgd_per_kw": 1.5}``).

    Returns
    -------
    The :class:`RunResult`: ``summary`` (the KPIs, the content of ``summary.json``),
    ``results`` (the results DataFrame, one row per 30-min period), ``out_dir``.

    Raises
    ------
    ConfigError : an unknown preset, an invalid scenario file or override (naming the field,
        e.g. ``controller.peak_price``), or ``checkpoint_every`` < 1.
    DataError : missing or malformed data or building files.
    """
    config = resolve_scenario(config_or_preset, overrides)
    return run_simulation(
        config, out, progress=not quiet, resume=not fresh, checkpoint_every=checkpoint_every
    )


def load_building(name_or_path: str | Path) -> Building:
    """A building: a shipped name (``"office5"``, ``"room1"``…) or a building TOML file.

    Raises
    ------
    DataError : no such file and no shipped building of that name (the hint lists them).
    BuildingConfigError : an invalid building file (naming the file, field and value).
    """
    return _load_building_file(resolve_building(name_or_path))


def kpi_summary(
    results: pd.DataFrame | RunResult | SimulationResult | str | Path,
    peak_price_sgd_per_kw: float | None = None,
) -> dict[str, float]:
    """The KPIs of a run, as ``hvacflex kpi`` prints them (:func:`hvacflex.kpi.summary`).

    Parameters
    ----------
    results : a results DataFrame, a :class:`RunResult` or :class:`SimulationResult`, or a
        run folder / results Parquet file (read with :func:`hvacflex.kpi.load_results`).
    peak_price_sgd_per_kw : price the PPP charge at this φ [SGD/kW]; default: the run's
        ``peak_price_sgd_per_kw`` column.

    Returns
    -------
    ``{name: value}``, units in the names (``energy_kwh``, ``net_cost_sgd``, …). Unlike
    ``RunResult.summary`` it holds no timing keys (``steps_per_s``, ``time_*``), which only a
    simulation measures.
    """
    if isinstance(results, RunResult | SimulationResult):
        frame = results.results
    elif isinstance(results, pd.DataFrame):
        frame = results
    else:
        frame = load_results(results)
    return kpi.summary(frame, peak_price_sgd_per_kw)
