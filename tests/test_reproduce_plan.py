"""The reproduction's plan: which runs, with which names, on which plant."""

from __future__ import annotations

from dataclasses import replace

from hvacflex.reproduce_energyplus import ENERGYPLUS_PREFIX, ENERGYPLUS_SCENARIOS, RC_WEEK_PREFIX
from hvacflex.reproduce_plan import REALISTIC_GROUPS, Plan, plan_groups


def _names(groups: dict[str, list]) -> list[str]:  # type: ignore[type-arg]
    return [cfg.name for jobs in groups.values() for _, cfg in jobs]


def test_every_run_of_a_plan_has_its_own_name() -> None:
    for plan in (
        Plan.quick(),
        Plan.full(),
        Plan.quick(energyplus=True),
        Plan.full(energyplus=True),
    ):
        names = _names(plan_groups(plan))
        assert len(names) == len(set(names)), names


def test_energyplus_runs_only_when_asked() -> None:
    assert plan_groups(Plan.quick())["energyplus"] == []
    jobs = plan_groups(Plan.quick(energyplus=True))["energyplus"]
    assert [params["scenario"] for params, _ in jobs] == list(ENERGYPLUS_SCENARIOS)
    for params, cfg in jobs:
        assert params["plant"] == "energyplus" and cfg.name.startswith(ENERGYPLUS_PREFIX)
        assert (cfg.plant.kind, cfg.plant.idf, cfg.plant.resolved_actuation) == (
            "energyplus",
            "generated",
            "setpoint",
        )
        assert (cfg.start, cfg.days) == ("2014-03-03", 7.0)


def test_the_scenario_runs_are_reused_when_they_cover_the_energyplus_period() -> None:
    """--quick: the week; the full run: the year on EnergyPlus too (issue 33)."""
    for plan in (Plan.quick(energyplus=True), Plan.full(energyplus=True)):
        assert plan.energyplus_week_is_scenario_period
        assert all(p["plant"] == "energyplus" for p, _ in plan_groups(plan)["energyplus"])
    full = Plan.full(energyplus=True)
    assert (full.energyplus_start, full.energyplus_days) == ("2014-01-01", 365.0)


def test_another_energyplus_period_gets_its_own_rc_runs() -> None:
    plan = replace(Plan.full(energyplus=True), energyplus_start="2014-03-03", energyplus_days=7.0)
    assert not plan.energyplus_week_is_scenario_period
    rc = [(p, cfg) for p, cfg in plan_groups(plan)["energyplus"] if p["plant"] == "rc"]
    assert [p["scenario"] for p, _ in rc] == list(ENERGYPLUS_SCENARIOS)
    for _, cfg in rc:
        assert cfg.name.startswith(RC_WEEK_PREFIX) and cfg.plant.kind == "rc"
        assert (cfg.start, cfg.days) == (plan.energyplus_start, plan.energyplus_days)


def test_the_full_run_uses_the_realistic_forecast_where_it_measures_the_findings() -> None:
    """Issue 33 item 1: the year's scenarios, Fig. 7 and the EnergyPlus runs see errors the
    controller does not know; the robustness sweep and the hot corner keep their boxes; the
    quick run keeps the presets' defaults."""
    groups = plan_groups(Plan.full(energyplus=True))
    del groups["ppp_energyplus"]  # both forecasts: the test below
    for group, jobs in groups.items():
        realistic = group in REALISTIC_GROUPS
        assert jobs, group
        for _, cfg in jobs:
            assert (cfg.forecast.weather == "statistical") is realistic, (group, cfg.name)
            assert (cfg.realisation.occupancy == "stochastic") is realistic, (group, cfg.name)
            if realistic:
                assert cfg.realisation.mode == "zero"
    quick = plan_groups(Plan.quick(energyplus=True))
    del quick["ppp_energyplus"]
    assert all(cfg.forecast.weather == "perfect" for jobs in quick.values() for _, cfg in jobs)


def test_fig7_on_energyplus_runs_each_phi_with_both_forecasts() -> None:
    """Issue 61 item 1: scenario (c) at every φ of the sweep on EnergyPlus office5, once with
    the presets' perfect forecast and once with the realistic one."""
    assert plan_groups(Plan.quick())["ppp_energyplus"] == []
    for plan in (Plan.quick(energyplus=True), Plan.full(energyplus=True)):
        jobs = plan_groups(plan)["ppp_energyplus"]
        assert len(jobs) == 2 * len(plan.ppp_values)
        for params, cfg in jobs:
            realistic = params["forecast"] == "realistic"
            assert params["forecast"] in ("perfect", "realistic")
            assert cfg.controller.peak_price_sgd_per_kw == params["peak_price_sgd_per_kw"]
            assert (cfg.plant.kind, cfg.plant.idf) == ("energyplus", "generated")
            assert (cfg.start, cfg.days) == (plan.sweep_start, plan.sweep_days)
            assert (cfg.forecast.weather == "statistical") is realistic
            assert (cfg.realisation.occupancy == "stochastic") is realistic
            assert (
                cfg.name.startswith(ENERGYPLUS_PREFIX)
                and cfg.name.endswith("-realistic") is realistic
            )


def test_no_feedback_leaves_out_the_two_affine_feedback_scenario_runs_only() -> None:
    for make in (Plan.quick, Plan.full):
        with_it = _names(plan_groups(make()))
        without = _names(plan_groups(make(feedback=False)))
        left_out = [name for name in with_it if name not in without]
        assert sorted(left_out) == ["rmpc-feedback", "rmpc-feedback-ppp"], left_out
        assert set(without) < set(with_it)
