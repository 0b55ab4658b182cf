"""hvacflex: robust predictive control of building HVAC in electricity markets.

A building's air-conditioning buys energy at real-time prices (Singapore NEMS USEP), offers
interruptible-load reserve, keeps a utility peak-power price in check, and keeps room comfort
for every forecast error inside a box. See ``docs/explanation/model.md`` for the model and the
problem.

The public API (:mod:`hvacflex.api`)::

    import hvacflex

    run = hvacflex.simulate("rmpc", start="2014-03-03", days=1, out="results/rmpc")
    run.summary["net_cost_sgd"]; run.results["power_kw"]; run.out_dir
    hvacflex.preset("rmpc-ppp"); hvacflex.load_config("scenario.toml")
    hvacflex.load_building("office5"); hvacflex.kpi_summary("results/rmpc")

    sim = hvacflex.Simulation("thermostat-25.5", start="2014-03-03", days=1)
    sim.step(); sim.step([0.3, 0.3, 0.3, 0.3, 0.6]); sim.run().summary

``Scenario``, ``Building`` and the protocols ``Controller``, ``Plant`` and ``Forecaster``
complete the names (docs/reference/api.md).

Its names are loaded on first use (PEP 562), so ``import hvacflex`` imports neither numpy,
pandas nor the solver, and the command line starts as fast as without them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from hvacflex.version import __version__

if TYPE_CHECKING:
    from hvacflex.api import (
        Building,
        Controller,
        Forecaster,
        Plant,
        RunResult,
        Scenario,
        Simulation,
        SimulationResult,
        kpi_summary,
        load_building,
        load_config,
        preset,
        simulate,
    )

__all__ = [
    "Building",
    "Controller",
    "Forecaster",
    "Plant",
    "RunResult",
    "Scenario",
    "Simulation",
    "SimulationResult",
    "__version__",
    "kpi_summary",
    "load_building",
    "load_config",
    "preset",
    "simulate",
]

_API_NAMES = frozenset(__all__) - {"__version__"}
"""The names :mod:`hvacflex.api` provides, imported on first access."""


def __getattr__(name: str) -> Any:
    """``hvacflex.simulate`` and the other API names, from :mod:`hvacflex.api` on first use."""
    if name not in _API_NAMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from hvacflex import api

    value = getattr(api, name)
    globals()[name] = value  # later accesses skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
