"""The perfect-foresight peak bound (issue 61 item 1) against cases solved by hand."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.config import preset
from hvacflex.errors import InputError, SolverError
from hvacflex.opt.highs_lp import LPResult
from hvacflex.opt.solution import SolveStatus
from hvacflex.sim import peak_bound
from hvacflex.sim.peak_bound import PeakBoundProblem, bound_peak_kw, minimum_peak


def _integrator(heat_k: list[float], u_max_kg_s: float = 10.0) -> PeakBoundProblem:
    """One zone, a pure integrator x_{k+1} = x_k − u_k + d_k [K per kg/s], from 25 °C in a
    band of [20, 25] °C, power P_k = 1 kW per kg/s × u_k."""
    steps = len(heat_k)
    return PeakBoundProblem(
        a=np.eye(1),
        b=-np.eye(1),
        e=np.eye(1),
        g=np.zeros(1),
        c=np.eye(1),
        x0_degc=np.array([25.0]),
        d=np.array(heat_k)[:, None],
        u_min_kg_s=np.zeros((steps, 1)),
        u_max_kg_s=np.array([u_max_kg_s]),
        y_min_degc=np.full((steps, 1), 20.0),
        y_max_degc=np.full((steps, 1), 25.0),
        p0_kw=np.zeros(steps),
        p_kw_per_kg_s=np.ones((steps, 1)),
    )


def test_pre_cooling_spreads_a_late_heat_gain_over_the_period() -> None:
    """4 K of heat in the last period, 5 K of room below the bound: cooled 4/3 K a period
    from the start, the peak is 4/3 kW (without storage it would be 4)."""
    bound = minimum_peak(_integrator([0.0, 0.0, 4.0]))
    assert bound.peak_kw == pytest.approx(4.0 / 3.0, abs=1e-6)
    assert bound.excursion_k == pytest.approx(0.0, abs=1e-9)
    assert bound.flow_kg_s.sum() == pytest.approx(4.0, abs=1e-5)


def test_the_zone_temperatures_are_the_flows_run_on_the_model() -> None:
    problem = _integrator([1.0, 0.0, 4.0, 2.0])
    bound = minimum_peak(problem)
    x, temps = problem.x0_degc, []
    for flow, d in zip(bound.flow_kg_s, problem.d, strict=True):
        x = problem.a @ x + problem.b @ flow + problem.e @ d + problem.g
        temps.append(problem.c @ x)
    np.testing.assert_allclose(bound.zone_temp_degc, np.array(temps), atol=1e-6)
    assert np.all(bound.zone_temp_degc <= 25.0 + 1e-6)


def test_the_lower_bound_limits_pre_cooling() -> None:
    """12 K in the last period: at most 5 K can be stored before it (20 °C floor), so the
    last period cools 7: the peak is 7 kW."""
    bound = minimum_peak(_integrator([0.0, 0.0, 12.0]))
    assert bound.peak_kw == pytest.approx(7.0, abs=1e-6)
    assert bound.power_kw.max() == pytest.approx(7.0, abs=1e-6)


def test_an_unreachable_band_is_left_by_the_least_excursion_first() -> None:
    """1 kg/s at most: 3 K cooled against 12 K of heat leaves 34 °C at the end, 9 K above the
    band (the least excursion); keeping it needs every period at full flow: peak 1 kW."""
    bound = minimum_peak(_integrator([0.0, 0.0, 12.0], u_max_kg_s=1.0))
    assert bound.excursion_k == pytest.approx(9.0, abs=1e-6)
    assert bound.peak_kw == pytest.approx(1.0, abs=1e-6)


def test_office5_day_bound_keeps_the_band_below_the_full_load_power() -> None:
    config = preset("rmpc-ppp", start="2014-03-04", days=1)
    bound = bound_peak_kw(config)
    assert bound.flow_kg_s.shape == (48, 5)
    assert bound.excursion_k == pytest.approx(0.0, abs=1e-4)
    assert bound.peak_kw == pytest.approx(bound.power_kw.max(), rel=1e-6)
    assert 5.0 < bound.peak_kw < 60.0  # office5's design full load is ≈ 60 kW


@pytest.mark.parametrize(
    ("status", "error"),
    [
        (SolveStatus.TIME_LIMIT, SolverError),
        (SolveStatus.ERROR, SolverError),
        (SolveStatus.INFEASIBLE, InputError),
        (SolveStatus.UNBOUNDED, InputError),
    ],
)
def test_a_solve_without_optimum_names_its_status_and_blames_the_input_only_when_it_is(
    monkeypatch: pytest.MonkeyPatch, status: SolveStatus, error: type[Exception]
) -> None:
    """A solver failure (time limit, numerical trouble) is a SolverError, not bad input
    (exit 2 "fix your input" would mislead); an infeasible or unbounded LP is the input's."""

    def failing(cost: np.ndarray, *args: object, **kwargs: object) -> LPResult:
        return LPResult(status, np.full(cost.size, np.nan), "", 0.0)

    monkeypatch.setattr(peak_bound, "solve_lp", failing)
    with pytest.raises(error, match=status.name) as info:
        minimum_peak(_integrator([0.0, 0.0, 4.0]))
    assert isinstance(info.value, SolverError) is (error is SolverError)


@pytest.mark.parametrize("ipm_status", [SolveStatus.ERROR, SolveStatus.INFEASIBLE])
def test_an_interior_point_stopping_in_numerical_trouble_is_solved_again_with_the_simplex(
    monkeypatch: pytest.MonkeyPatch, ipm_status: SolveStatus
) -> None:
    """HiGHS's interior point ended in ``ERROR`` on a 28-day office5 bound (and may call the
    always-feasible LP "infeasible or unbounded"): the simplex solves the same LP, and the
    bound is the one an interior point that succeeds gives."""
    problem = _integrator([0.0, 0.0, 12.0], u_max_kg_s=1.0)
    expected = minimum_peak(problem)
    solve = peak_bound.solve_lp
    methods: list[str] = []

    def ipm_failing(cost: np.ndarray, *args: object, **kwargs: object) -> LPResult:
        method = str(kwargs["method"])
        methods.append(method)
        if method == peak_bound.LP_METHOD:
            return LPResult(ipm_status, np.full(cost.size, np.nan), "", 0.0)
        return solve(cost, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(peak_bound, "solve_lp", ipm_failing)
    bound = minimum_peak(problem)
    assert methods == ["ipm", "simplex", "ipm", "simplex"]
    assert bound.peak_kw == pytest.approx(expected.peak_kw, abs=1e-6)
    assert bound.excursion_k == pytest.approx(expected.excursion_k, abs=1e-6)


def test_a_model_without_an_outdoor_temperature_is_refused_by_name() -> None:
    """Not a bare StopIteration: an InputError naming the channels it has."""
    channels = (DisturbanceChannel("ground_temp_degc", "ground_temp"),)
    with pytest.raises(InputError, match="outdoor_temp") as info:
        peak_bound._outdoor_index(channels, preset("rmpc-ppp"))
    assert info.value.field == "channels"
    assert info.value.value == ["ground_temp"]
    assert (
        peak_bound._outdoor_index(
            (*channels, DisturbanceChannel("outdoor_temp_degc", "outdoor_temp")), preset("rmpc-ppp")
        )
        == 1
    )


def test_the_second_stage_gives_the_least_excursion_relative_room(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The least excursion is a sum of many slacks from an interior-point solve: the second
    stage holds it within a relative room, not 1e-8 K absolute (9 K here: ≥ 9e-7 K)."""
    calls: list[np.ndarray] = []
    solve = peak_bound.solve_lp

    def spy(
        cost: np.ndarray, rows: object, lower: object, upper: np.ndarray, *a: object, **k: object
    ) -> LPResult:
        calls.append(np.asarray(upper))
        return solve(cost, rows, lower, upper, *a, **k)  # type: ignore[arg-type]

    monkeypatch.setattr(peak_bound, "solve_lp", spy)
    bound = minimum_peak(_integrator([0.0, 0.0, 12.0], u_max_kg_s=1.0))
    room_k = calls[1][-1] - bound.excursion_k  # the second stage's last row: Σ s ≤ least + room
    assert room_k >= 1e-7 * bound.excursion_k
    assert room_k == pytest.approx(
        peak_bound.excursion_room_k(bound.excursion_k) - bound.excursion_k
    )
    assert bound.peak_kw == pytest.approx(1.0, abs=1e-6)


def test_the_office5_bound_is_at_most_the_peak_of_a_feasible_policy(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """On office5's model over a morning (a tiny case): the flows of the least-energy policy
    that keeps the band (an LP on the same rows, the excursion fixed at 0) are feasible, so
    the bound is at most their peak; and the bound's own flows, replayed through the model
    step by step, keep the band and draw its peak."""
    captured: list[PeakBoundProblem] = []
    monkeypatch.setattr(peak_bound, "minimum_peak", captured.append)
    bound_peak_kw(preset("rmpc-ppp", start="2014-03-04", days=0.25))
    problem = captured[0]
    monkeypatch.undo()
    bound = minimum_peak(problem)
    assert bound.excursion_k == pytest.approx(0.0, abs=1e-6)
    t_steps, m = problem.u_min_kg_s.shape
    nu, nx = t_steps * m, t_steps * problem.a.shape[0]
    rows, row_lower, row_upper, col_lower, col_upper = peak_bound._constraints(problem)
    col_upper[nu + nx : nu + nx + nu] = 0.0  # no excursion: the band kept throughout
    energy = np.concatenate([problem.p_kw_per_kg_s.ravel(), np.zeros(nx + nu + 1)])
    policy = peak_bound.solve_lp(energy, rows, row_lower, row_upper, col_lower, col_upper)
    assert policy.status is SolveStatus.OPTIMAL
    flows = policy.x[:nu].reshape(t_steps, m)
    policy_peak_kw = float((problem.p0_kw + (problem.p_kw_per_kg_s * flows).sum(axis=1)).max())
    assert bound.peak_kw <= policy_peak_kw + 1e-6
    x = problem.x0_degc
    for k in range(t_steps):  # replay the bound's flows
        x = problem.a @ x + problem.b @ bound.flow_kg_s[k] + problem.e @ problem.d[k] + problem.g
        zone = problem.c @ x
        assert (zone >= problem.y_min_degc[k] - 1e-5).all()
        assert (zone <= problem.y_max_degc[k] + 1e-5).all()
    assert bound.power_kw.max() == pytest.approx(bound.peak_kw, rel=1e-6)
