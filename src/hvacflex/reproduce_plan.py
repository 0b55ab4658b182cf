"""What ``hvacflex reproduce`` runs: the paper's scenarios and the baselines, the PPP and
uncertainty sweeps, the hot-corner runs and — with ``--energyplus`` — the week on
EnergyPlus (:mod:`hvacflex.reproduce_energyplus`), as a :class:`Plan` and its jobs (one
(parameters, configuration) pair a closed-loop run), and the labels the report gives them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from hvacflex.config import (
    BASELINE_PRESETS,
    DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW,
    PAPER_FEEDBACK_SCENARIOS,
    PAPER_MODEL_SCENARIOS,
    PAPER_SCENARIOS,
    ScenarioConfig,
    preset,
    scaled_uncertainty,
    with_overrides,
)
from hvacflex.reproduce_energyplus import energyplus_jobs, on_energyplus

ScenarioLabel = str

PPP_VALUES_SGD_PER_KW: tuple[float, ...] = (
    0.5,
    1.0,
    1.5,
    2.0,
    3.0,
    5.0,
    7.5,
    10.0,
    15.0,
    20.0,
    30.0,
)
QUICK_PPP_VALUES_SGD_PER_KW: tuple[float, ...] = (0.5, 1.5, 5.0, 30.0)
UNCERTAINTY_LEVELS: tuple[float, ...] = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5)
QUICK_UNCERTAINTY_LEVELS: tuple[float, ...] = (0.0, 0.25, 0.5)

TARIFF_PEAK_PRICE_SGD_PER_KW = DEFAULT_PEAK_PRICE_PAPER_SGD_PER_KW
"""φ of the one tariff every comparison prices every run with [SGD/kW per month]: the
paper's peak-power price, billed on each calendar month's peak whether or not the
controller planned for it."""

SCENARIO_LABELS: dict[str, str] = {
    "a": "(a) NMPC",
    "b": "(b) RMPC",
    "c": "(c) RMPC + PPP",
    "thermostat": "thermostat",
} | {name: name for name in BASELINE_PRESETS}
RULE_BASED_SCENARIOS: tuple[str, ...] = ("thermostat", *BASELINE_PRESETS)
"""Scenario keys of the rule-based runs (the baselines "does it pay?" ranks against)."""
WHOLE_HORIZON_PREFIX = "paper-"
"""Key prefix of the scenarios run with the paper's whole-horizon reserve model."""
SCENARIO_LABELS |= {
    f"{WHOLE_HORIZON_PREFIX}{letter}": f"{SCENARIO_LABELS[letter]}, whole-horizon"
    for letter in PAPER_MODEL_SCENARIOS
}
FEEDBACK_PREFIX = "feedback-"
"""Key prefix of the robust scenarios run with affine disturbance feedback."""
SCENARIO_LABELS |= {
    f"{FEEDBACK_PREFIX}{letter}": f"{SCENARIO_LABELS[letter]}, affine feedback, whole-horizon"
    for letter in PAPER_FEEDBACK_SCENARIOS
}


REALISTIC_FORECAST: dict[str, Any] = {
    "forecast.weather": "statistical",
    "realisation.occupancy": "stochastic",
    "realisation.mode": "zero",
}
"""Overrides of the full run's scenario, Fig. 7 and EnergyPlus jobs (issue 33 item 1): the
statistical weather forecaster and stochastic occupancy, the plant seeing the data —
docs/explanation/forecast.md's "realistic" case, errors the controller does not know. The robustness
sweep and the hot corner keep drawing errors in their boxes: that is what they measure."""

REALISTIC_GROUPS: tuple[str, ...] = ("scenarios", "ppp", "energyplus")
"""The report groups :data:`REALISTIC_FORECAST` applies to in a realistic plan."""

STRESS_KEY = "stress-b"
"""Key of scenario (b) (``rmpc``) run with ``[activation] mode = "stress"``: one activation
every weekday in office hours, so that Table 1 shows the reserve delivered and settled."""
SCENARIO_LABELS[STRESS_KEY] = "(b) RMPC, stress activations"


def stress_config(name: str, *, start: str, days: float) -> ScenarioConfig:
    """Preset ``name`` over the period with an activation every weekday (``stress``)."""
    cfg = preset(name, start=start, days=days)
    return replace(
        cfg, name=f"{cfg.name}-stress", activation=replace(cfg.activation, mode="stress")
    )


def model_names() -> dict[str, str]:
    """Reserve model → its name in the report, with the product presets' D, α and R."""
    reserve = preset(PAPER_SCENARIOS["a"]).reserve
    return {
        "event": f"the event model (D = {reserve.event_max_steps}, "
        f"α = {reserve.event_allowance_k:g} K, R = {reserve.event_recovery_steps})",
        "whole-horizon": "the paper's whole-horizon model",
    }


@dataclass(frozen=True)
class Plan:
    """What a reproduction runs: periods and sweep values.

    ``energyplus`` adds the EnergyPlus section
    (:mod:`hvacflex.reproduce_energyplus`): its scenarios over
    ``energyplus_days`` from ``energyplus_start`` on EnergyPlus office5 (the generated IDF)
    beside the same runs on the RC plant.
    """

    start: str
    days: float
    sweep_start: str
    sweep_days: float
    uncertainty_days: float
    ppp_values: tuple[float, ...]
    uncertainty_levels: tuple[float, ...]
    robustness_feedback: bool
    """Run the robustness sweep's affine-feedback RMPC beside NMPC and RMPC (its 3-day runs;
    not :attr:`feedback_scenarios`, the feedback years)."""
    energyplus: bool = False
    energyplus_start: str = "2014-03-03"
    energyplus_days: float = 7.0
    realistic: bool = False
    """Apply :data:`REALISTIC_FORECAST` to the :data:`REALISTIC_GROUPS` (the full run)."""
    feedback_scenarios: bool = True
    """Run (b) and (c) with affine feedback over the period (``feedback-*``); in the full
    run these two years are the longest runs (several times an open-loop year each)."""

    @classmethod
    def full(cls, *, energyplus: bool = False, feedback: bool = True) -> Plan:
        """The year; ``feedback=False`` leaves out the two affine-feedback years (the
        robustness sweep's 3-day feedback runs stay)."""
        return cls(
            start="2014-01-01",
            days=365.0,
            sweep_start="2014-03-03",
            sweep_days=28.0,
            uncertainty_days=3.0,
            ppp_values=PPP_VALUES_SGD_PER_KW,
            uncertainty_levels=UNCERTAINTY_LEVELS,
            robustness_feedback=True,
            energyplus=energyplus,
            energyplus_start="2014-01-01",
            energyplus_days=365.0,
            realistic=True,
            feedback_scenarios=feedback,
        )

    @classmethod
    def quick(cls, *, energyplus: bool = False, feedback: bool = True) -> Plan:
        """One week; ``feedback=False`` leaves out the affine-feedback weeks."""
        return cls(
            start="2014-03-03",
            days=7.0,
            sweep_start="2014-03-03",
            sweep_days=7.0,
            uncertainty_days=2.0,
            ppp_values=QUICK_PPP_VALUES_SGD_PER_KW,
            uncertainty_levels=QUICK_UNCERTAINTY_LEVELS,
            robustness_feedback=False,
            energyplus=energyplus,
            feedback_scenarios=feedback,
        )

    @property
    def energyplus_week_is_scenario_period(self) -> bool:
        """True when the scenario runs cover the EnergyPlus week exactly (``--quick``): the
        RC side of the EnergyPlus section is then those runs."""
        return (self.start, self.days) == (self.energyplus_start, self.energyplus_days)


def scenario_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """Scenarios (a), (b), (c) with each reserve model, (b) and (c) with affine feedback, the
    thermostat and the strong baselines, and (b) under stress activations, over the plan's
    period (keys ``a``, ``paper-a``, …, ``feedback-b``, ``feedback-c``, ``thermostat``, the
    baselines' preset names and :data:`STRESS_KEY`)."""
    whole_horizon = [
        (f"{WHOLE_HORIZON_PREFIX}{letter}", name) for letter, name in PAPER_MODEL_SCENARIOS.items()
    ]
    feedback = [
        (f"{FEEDBACK_PREFIX}{letter}", name)
        for letter, name in PAPER_FEEDBACK_SCENARIOS.items()
        if plan.feedback_scenarios
    ]
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    baselines = [(name, name) for name in RULE_BASED_SCENARIOS]
    runs = [*PAPER_SCENARIOS.items(), *whole_horizon, *feedback, *baselines]
    for letter, name in runs:
        cfg = preset(name, start=plan.start, days=plan.days)
        jobs.append(({"scenario": letter}, cfg))
    stress = stress_config(PAPER_SCENARIOS["b"], start=plan.start, days=plan.days)
    jobs.append(({"scenario": STRESS_KEY}, stress))
    return jobs


def ppp_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """Scenario (c) with each peak-power price of the sweep."""
    base = preset("rmpc-ppp", start=plan.sweep_start, days=plan.sweep_days)
    return [
        (
            {"peak_price_sgd_per_kw": phi},
            replace(
                base,
                name=f"ppp-{phi:g}",
                controller=replace(base.controller, peak_price_sgd_per_kw=phi),
            ),
        )
        for phi in plan.ppp_values
    ]


def ppp_energyplus_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """Fig. 7 on EnergyPlus (issue 61 item 1): scenario (c) at each φ of the sweep on
    EnergyPlus office5 (``energyplus-ppp-<φ>``), with the presets' perfect forecast and with
    :data:`REALISTIC_FORECAST` (``energyplus-ppp-<φ>-realistic``); parameters
    ``peak_price_sgd_per_kw`` and ``forecast``."""
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for forecast in ("perfect", "realistic"):
        for params, cfg in ppp_jobs(plan):
            moved = on_energyplus(cfg)
            if forecast == "realistic":
                moved = replace(
                    with_overrides(moved, REALISTIC_FORECAST), name=f"{moved.name}-realistic"
                )
            jobs.append((params | {"forecast": forecast}, moved))
    return jobs


def uncertainty_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """NMPC and open-loop RMPC (and feedback RMPC) at each uncertainty level."""
    controllers = ["nmpc", "rmpc"] + (["rmpc-feedback"] if plan.robustness_feedback else [])
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for controller in controllers:
        for level in plan.uncertainty_levels:
            cfg = scaled_uncertainty(
                preset(controller, start=plan.sweep_start, days=plan.uncertainty_days), level
            )
            cfg = replace(cfg, name=f"{controller}-unc{round(100 * level)}")
            jobs.append(({"controller": controller, "uncertainty_level": level}, cfg))
    return jobs


HOT_CORNER_LEVEL = 0.1
"""Box half-width (fraction of heat gains) of the hot-corner comfort comparison."""


def corner_jobs(plan: Plan) -> list[tuple[dict[str, Any], ScenarioConfig]]:
    """NMPC and RMPC with every forecast error at the hot corner of a ±10 % box."""
    jobs: list[tuple[dict[str, Any], ScenarioConfig]] = []
    for controller in ("nmpc", "rmpc"):
        cfg = scaled_uncertainty(
            preset(controller, start=plan.sweep_start, days=plan.uncertainty_days),
            HOT_CORNER_LEVEL,
        )
        cfg = replace(
            cfg,
            name=f"{controller}-hot-corner",
            realisation=replace(cfg.realisation, mode="worst-upper"),
        )
        jobs.append(({"scenario": controller}, cfg))
    return jobs


JobGroups = dict[str, list[tuple[dict[str, Any], ScenarioConfig]]]


def plan_groups(plan: Plan) -> JobGroups:
    """The plan's jobs by report group (``scenarios``, ``ppp``, ``uncertainty``, ``corner``,
    ``energyplus``, ``ppp_energyplus``), each a list of (parameters, configuration)."""
    groups: JobGroups = {
        "scenarios": scenario_jobs(plan),
        "ppp": ppp_jobs(plan),
        "uncertainty": uncertainty_jobs(plan),
        "corner": corner_jobs(plan),
        "energyplus": energyplus_jobs(
            plan.energyplus_start,
            plan.energyplus_days,
            with_rc_week=not plan.energyplus_week_is_scenario_period,
        )
        if plan.energyplus
        else [],
        "ppp_energyplus": ppp_energyplus_jobs(plan) if plan.energyplus else [],
    }
    if plan.realistic:
        for group in REALISTIC_GROUPS:
            groups[group] = [
                (params, with_overrides(cfg, REALISTIC_FORECAST)) for params, cfg in groups[group]
            ]
    return groups
