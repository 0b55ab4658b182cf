"""The one HiGHS session (:class:`HighsSession`) on LPs solved by hand.

The LP of every test: max x + y s.t. x + 2y ≤ 4, 3x + y ≤ 6, 0 ≤ x, y ≤ 10, written as
min −x − y. Its optimum is the intersection of both rows: x = 8/5, y = 6/5, objective −14/5,
with x and y basic and both rows at their upper bound.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse

from hvacflex.errors import ProblemError
from hvacflex.opt.basis import BASIC, UPPER, SolverBasis
from hvacflex.opt.highs_lp import (
    BASE_OPTIONS,
    DANTZIG_PRICING,
    HIGHS_ERROR,
    WARM_DUAL_FEASIBILITY_TOLERANCE,
    WARM_SCALE_STRATEGY,
    HighsSession,
    RunOutcome,
    SessionOptions,
    pass_csc_model,
    quiet_highs,
)
from hvacflex.opt.solution import SolveStatus

COST = np.array([-1.0, -1.0])
MATRIX = sparse.csc_matrix(np.array([[1.0, 2.0], [3.0, 1.0]]))
ROW_LOWER, ROW_UPPER = np.full(2, -np.inf), np.array([4.0, 6.0])
COL_LOWER, COL_UPPER = np.zeros(2), np.full(2, 10.0)
OPTIMUM = np.array([8.0 / 5.0, 6.0 / 5.0])
#: The optimal basis: both columns basic, both rows nonbasic at their upper bound.
OPTIMAL_BASIS = (np.array([BASIC, BASIC], dtype=np.int8), np.array([UPPER, UPPER], dtype=np.int8))


def _session(
    options: SessionOptions | None = None,
    *,
    source: str = "test",
    method: str | None = None,
    warm_pricing: int | None = None,
) -> HighsSession:
    """A session holding the hand-solved LP."""
    session = HighsSession(
        source, "lp", options or SessionOptions(), method=method, warm_pricing=warm_pricing
    )
    matrix = (
        MATRIX.indptr.astype(np.int32),
        MATRIX.indices.astype(np.int32),
        MATRIX.data.astype(np.float64),
    )
    assert pass_csc_model(session.highs, COST, COL_LOWER, COL_UPPER, ROW_LOWER, ROW_UPPER, matrix)
    return session


def test_a_cold_run_reaches_the_hand_computed_optimum() -> None:
    session = _session()
    elapsed_s, status = session.run(False)
    assert status is SolveStatus.OPTIMAL and elapsed_s >= 0.0
    np.testing.assert_allclose(session.values(), OPTIMUM, atol=1e-9)
    assert float(session.highs.getInfo().objective_function_value) == pytest.approx(-14.0 / 5.0)
    assert sorted(session.basic_variables().tolist()) == [0, 1]  # x and y basic
    assert session.model_status_text() == "Optimal"


def test_options_are_base_options_and_per_run_scaling_and_method() -> None:
    session = _session(SessionOptions(feasibility_tolerance=1e-10), method="ipm")
    highs = session.highs
    for option, value in BASE_OPTIONS.items():
        assert highs.getOptionValue(option)[1] == value, option
    for option in ("primal_feasibility_tolerance", "dual_feasibility_tolerance"):
        assert highs.getOptionValue(option)[1] == 1e-10
    default_scale = quiet_highs().getOptionValue("simplex_scale_strategy")[1]
    session.run(True)
    assert highs.getOptionValue("simplex_scale_strategy")[1] == WARM_SCALE_STRATEGY
    assert highs.getOptionValue("solver")[1] == "simplex"
    session.run(False)
    assert highs.getOptionValue("simplex_scale_strategy")[1] == default_scale
    assert highs.getOptionValue("solver")[1] == "ipm"
    # without a method every run keeps HiGHS's own choice
    plain = _session()
    plain.run(True)
    assert plain.highs.getOptionValue("solver")[1] == "choose"


def test_warm_pricing_applies_to_warm_runs_only() -> None:
    pricing, tolerance = "simplex_dual_edge_weight_strategy", "dual_feasibility_tolerance"
    devex = BASE_OPTIONS[pricing]
    assert devex != DANTZIG_PRICING
    session = _session(warm_pricing=DANTZIG_PRICING)
    highs = session.highs
    cold_tolerance = highs.getOptionValue(tolerance)[1]
    assert cold_tolerance > WARM_DUAL_FEASIBILITY_TOLERANCE
    assert highs.getOptionValue(pricing)[1] == devex  # before any run: the base options
    session.run(False)
    assert highs.getOptionValue(pricing)[1] == devex
    session.set_start(*OPTIMAL_BASIS)
    _, status = session.run(True)
    assert highs.getOptionValue(pricing)[1] == DANTZIG_PRICING
    assert highs.getOptionValue(tolerance)[1] == WARM_DUAL_FEASIBILITY_TOLERANCE
    assert status is SolveStatus.OPTIMAL
    np.testing.assert_allclose(session.values(), OPTIMUM, atol=1e-9)
    session.run(False)
    assert highs.getOptionValue(pricing)[1] == devex
    assert highs.getOptionValue(tolerance)[1] == cold_tolerance
    # a caller's tighter tolerance holds on warm runs too
    tight = _session(SessionOptions(feasibility_tolerance=1e-10), warm_pricing=DANTZIG_PRICING)
    tight.run(True)
    assert tight.highs.getOptionValue(tolerance)[1] == 1e-10
    # without it every run prices with the base options' Devex
    plain = _session()
    plain.run(True)
    assert plain.highs.getOptionValue(pricing)[1] == devex


def test_the_time_limit_is_re_armed_on_the_run_clock_before_every_run() -> None:
    session = _session(SessionOptions(time_limit_s=5.0))
    for _ in range(3):
        clock_s = float(session.highs.getRunTime())
        session.run(False)
        assert session.highs.getOptionValue("time_limit")[1] == pytest.approx(clock_s + 5.0)
    with pytest.raises(ProblemError, match="time limit"):
        _session(SessionOptions(time_limit_s=0.0))


def test_starting_from_the_optimal_basis_needs_no_iteration() -> None:
    session = _session()
    assert session.set_start(*OPTIMAL_BASIS) and session.has_basis
    _, status = session.run(True)
    assert status is SolveStatus.OPTIMAL and session.iterations() == 0
    np.testing.assert_allclose(session.values(), OPTIMUM, atol=1e-9)


def test_a_refused_start_runs_cold() -> None:
    session = _session()
    three_basic = (np.array([BASIC, BASIC], dtype=np.int8), np.array([BASIC, UPPER], dtype=np.int8))
    assert not session.set_start(*three_basic) and not session.has_basis
    _, status = session.run(False)
    assert status is SolveStatus.OPTIMAL and session.iterations() > 0


def test_the_stored_basis_rotates_only_with_time_shift() -> None:
    rotation = (np.array([1, 0]), np.array([1, 0]))
    basis = (np.array([BASIC, UPPER], dtype=np.int8), np.array([0, BASIC], dtype=np.int8))
    for time_shift, expected in ((True, ([UPPER, BASIC], [BASIC, 0])), (False, basis)):
        session = _session(SessionOptions(time_shift=time_shift))
        session.basis = basis
        col_status, row_status = session.start_statuses(rotation, shift=True)
        assert col_status.tolist() == list(expected[0])
        assert row_status.tolist() == list(expected[1])
        unrotated = session.start_statuses(rotation, shift=False)
        assert [a.tolist() for a in unrotated] == [b.tolist() for b in basis]


def _with_basis(options: SessionOptions | None = None) -> HighsSession:
    """A session holding the LP and, as its stored basis, the optimal one."""
    session = _session(options)
    session.basis = OPTIMAL_BASIS
    return session


def _ladder(
    session: HighsSession, failures: int, *, warm: bool
) -> tuple[list[bool], list[str], RunOutcome]:
    """Run the retry ladder with the first ``failures`` runs forced to a solver error (each
    counted as 1 s); the runs' warm flags, the calls of ``restart`` and the outcome."""
    real_run = session.run
    runs: list[bool] = []
    calls: list[str] = []

    def run(warm: bool) -> tuple[float, SolveStatus]:
        runs.append(warm)
        if len(runs) <= failures:
            return 1.0, SolveStatus.ERROR
        return real_run(warm)

    def restart() -> bool:
        calls.append("unrotated")
        return session.set_start(*OPTIMAL_BASIS)

    session.run = run  # type: ignore[method-assign]
    outcome = session.run_with_retries(warm, restart)
    return runs, calls, outcome


def test_a_failed_rotated_start_is_retried_unrotated_still_warm() -> None:
    session = _with_basis()
    runs, calls, outcome = _ladder(session, 1, warm=True)
    assert runs == [True, True] and calls == ["unrotated"]
    assert outcome.status is SolveStatus.OPTIMAL and outcome.warm
    assert outcome.iterations == 0  # the unrotated start is the optimal basis
    assert outcome.highs_time_s >= 1.0  # the failed run's time counts
    np.testing.assert_allclose(session.values(), OPTIMUM, atol=1e-9)


def test_a_failed_unrotated_retry_ends_cold() -> None:
    session = _with_basis()
    runs, calls, outcome = _ladder(session, 2, warm=True)
    assert runs == [True, True, False] and calls == ["unrotated"]
    assert outcome.status is SolveStatus.OPTIMAL and not outcome.warm
    assert outcome.iterations > 0 and outcome.highs_time_s >= 2.0
    assert not session.has_basis  # the cold run started from no basis
    np.testing.assert_allclose(session.values(), OPTIMUM, atol=1e-9)


def test_no_unrotated_retry_without_time_shift_or_basis_and_no_retry_after_a_cold_run() -> None:
    runs, calls, outcome = _ladder(_with_basis(SessionOptions(time_shift=False)), 1, warm=True)
    assert runs == [True, False] and calls == [] and outcome.status is SolveStatus.OPTIMAL
    runs, calls, outcome = _ladder(_session(), 1, warm=True)  # no stored basis
    assert runs == [True, False] and calls == []
    runs, calls, outcome = _ladder(_with_basis(), 1, warm=False)  # cold: reported as is
    assert runs == [False] and calls == [] and outcome.status is SolveStatus.ERROR


def test_iterations_are_never_negative_after_a_solver_error() -> None:
    """HiGHS reports −1 simplex iterations for a run that failed; a retried solve must not
    subtract it from the iterations of the runs that follow."""

    class FailedInfo:
        simplex_iteration_count = -1

    class AfterFailure:
        def getInfo(self) -> FailedInfo:
            return FailedInfo()

        def getInfoValue(self, name: str) -> tuple[object, int]:
            return HIGHS_ERROR, 123456  # no valid record: the value means nothing

    session = _session()
    session.run(False)
    assert session.iterations() > 0
    session.highs = AfterFailure()
    assert session.iterations() == 0


def test_basis_get_set_round_trip_and_refusals() -> None:
    session = _session()
    assert session.get_basis() is None
    session.run(False)
    held = session.get_basis(or_highs=True)  # HiGHS's own basis, none stored
    assert held is not None and held.fingerprint == "lp"
    assert held.col_status.tolist() == [BASIC, BASIC]
    session.keep(OPTIMAL_BASIS)
    assert session.has_basis and not session.basis_given
    basis = session.get_basis()
    assert basis is not None
    basis.col_status[0] = UPPER  # a copy: the stored basis is untouched
    assert session.basis is not None and session.basis[0][0] == BASIC
    other = _session()
    other.set_basis(SolverBasis("lp", *OPTIMAL_BASIS), 2, 2)
    assert other.basis_given and other.basis is not None
    assert other.basis[1].tolist() == [UPPER, UPPER]
    with pytest.raises(ProblemError, match="another problem structure"):
        other.set_basis(SolverBasis("other", *OPTIMAL_BASIS), 2, 2)
    with pytest.raises(ProblemError, match="not a simplex basis"):
        other.set_basis(SolverBasis("lp", OPTIMAL_BASIS[0], OPTIMAL_BASIS[0]), 2, 2)


def test_another_structure_is_refused_naming_the_first_difference() -> None:
    session = _session(source="RMPCSolver")
    session.check_same_structure([])
    with pytest.raises(ProblemError, match=r"differs from the solver's in \['horizon'") as error:
        session.check_same_structure(["horizon", "robust"])
    assert error.value.field == "horizon" and "build a new RMPCSolver" in str(error.value.hint)
