"""RMPCProblem validation: shapes, values and the two-trajectory sign conditions."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import ReserveCommitment, RMPCProblem, StepLinearisation
from hvacflex.opt.testing import random_problem


def test_defaults_and_broadcasting() -> None:
    prob = random_problem(0, affine_term=None, reserve_mask=None, d_sigma=np.full(3, 0.2))
    assert prob.horizon == 8 and (prob.n, prob.m, prob.nd, prob.ny) == (4, 2, 3, 2)
    np.testing.assert_array_equal(prob.g, np.zeros(4))
    assert prob.reserve_mask is not None and prob.reserve_mask.all()
    assert prob.d_sigma.shape == (8, 3) and prob.u_min.shape == (8, 2)
    assert prob.phi.shape == (8,)
    assert not prob.x0.flags.writeable


def test_input_arrays_are_copied() -> None:
    x0 = np.full(4, 24.0)
    prob = random_problem(0, x0=x0)
    x0[0] = 99.0
    assert prob.x0[0] == 24.0


@pytest.mark.parametrize(
    ("field", "value", "fragment"),
    [
        ("d_sigma", np.ones((7, 3)), "expected (8, 3) or (3,), got (7, 3)"),
        ("x0", np.ones(5), "expected (4,), got (5,)"),
        ("power_coeff_kw_per_kg_s", np.ones((8, 3)), "expected (8, 2), got (8, 3)"),
        ("u_min", np.ones((8, 3)), "expected (2,) or (8, 2), got (8, 3)"),
        ("c_matrix", np.ones((2, 5)), "expected (ny, 4)"),
        ("energy_price_sgd_per_mwh", np.r_[np.ones(7), np.nan], "NaN"),
        ("x0", np.r_[np.ones(3), np.inf], "infinite"),
        ("y_min", np.full(2, np.inf), "infinite"),
        ("d_sigma", -np.ones(3), "σ must be ≥ 0"),
        ("u_min", np.full(2, 2.0), "u_min must not exceed u_max"),
        ("y_min", np.full(2, 27.0), "y_min must not exceed y_max"),
        ("dt_h", 0.0, "time step must be > 0"),
        ("robust", "worst", "unknown robust mode"),
        ("slack_max_kelvin", -1.0, "slack cap"),
        ("peak_price_sgd_per_kw", -1.0, "φ must be ≥ 0"),
        ("reserve_mask", np.ones(2), "bool array"),
        ("comfort_penalty_sgd_per_kelvin_hour", -1.0, "penalty must be ≥ 0"),
        ("affine_term", np.ones((7, 4)), "expected (4,) or (8, 4), got (7, 4)"),
    ],
)
def test_invalid_values_are_refused(field: str, value: object, fragment: str) -> None:
    with pytest.raises(ProblemError) as info:
        random_problem(0, **{field: value})
    assert fragment in str(info.value)
    assert f"field '{field}'" in str(info.value)
    assert "RMPCProblem" in str(info.value)


def test_unbounded_comfort_sides_are_allowed() -> None:
    prob = random_problem(0, y_min=np.full(2, -np.inf), y_max=np.full(2, np.inf))
    assert np.isinf(prob.y_min).all()


def test_peak_floor_needs_constant_peak_price() -> None:
    with pytest.raises(ProblemError, match="constant peak price"):
        random_problem(0, peak_floor_kw=5.0, peak_price_sgd_per_kw=np.linspace(0.0, 2.0, 8))
    random_problem(0, peak_floor_kw=5.0, peak_price_sgd_per_kw=np.full(8, 1.5))


def test_negative_a_is_refused_with_explanation() -> None:
    prob = random_problem(0)
    a = prob.a_matrix.copy()
    a[0, 1] = -1e-3
    with pytest.raises(ProblemError) as info:
        dataclasses.replace(prob, a_matrix=a)
    text = str(info.value)
    assert "A has a negative entry at (0, 1)" in text
    assert "partial IL activation" in text and "reserve_mask" in text
    # round-off within the tolerance is accepted; without reserve the condition is moot
    a[0, 1] = -1e-13
    dataclasses.replace(prob, a_matrix=a)
    a[0, 1] = -1e-3
    dataclasses.replace(prob, a_matrix=a, reserve_mask=np.zeros(2, dtype=bool))


def test_mixed_sign_reserve_columns_are_refused() -> None:
    prob = random_problem(0)
    b = prob.b_matrix.copy()
    b[:, 1] = np.abs(b[:, 1])  # a heating input next to a cooling one
    with pytest.raises(ProblemError, match="both signs"):
        dataclasses.replace(prob, b_matrix=b)
    # fine when only one sign carries reserve, or all columns are heating
    dataclasses.replace(prob, b_matrix=b, reserve_mask=np.array([True, False]))
    dataclasses.replace(prob, b_matrix=np.abs(prob.b_matrix))


def test_negative_output_matrix_is_refused() -> None:
    prob = random_problem(0)
    c = prob.c_matrix.copy()
    c[0, 2] = -0.5
    with pytest.raises(ProblemError, match="C has a negative entry"):
        dataclasses.replace(prob, c_matrix=c)


def test_problem_is_frozen() -> None:
    prob = random_problem(0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        prob.dt_h = 1.0  # type: ignore[misc]
    assert isinstance(prob, RMPCProblem)


def _commitment(reserve_kg_s: object) -> ReserveCommitment:
    return ReserveCommitment(reserve_kg_s=np.asarray(reserve_kg_s, dtype=float))


def test_committed_reserve_that_cannot_be_shed_is_refused() -> None:
    with pytest.raises(ProblemError, match="cannot be shed") as info:
        random_problem(3, commitments=_commitment([[2.0, 0.0]]))  # room 1.4 kg/s
    assert info.value.field == "commitments.reserve_kg_s"
    with pytest.raises(ProblemError, match="reserve allowed: False"):
        random_problem(
            3, reserve_mask=np.array([True, False]), commitments=_commitment([[0.1, 0.1]])
        )
    with pytest.raises(ProblemError, match="wrong shape"):
        random_problem(3, horizon=4, commitments=_commitment(np.zeros((4, 2))))  # g < N


def test_a_step_linearisation_is_validated_refused_by_feedback_and_changes_the_structure() -> None:
    with pytest.raises(ProblemError, match="must be > 0") as info:
        StepLinearisation(input_scale=np.r_[np.ones((7, 2)), [[1.0, 0.0]]])
    assert info.value.field == "step_linearisation.input_scale"
    with pytest.raises(ProblemError, match=r"expected \(8, 2\), got \(8, 3\)"):
        random_problem(0, step_linearisation=StepLinearisation(input_scale=np.ones((8, 3))))
    with pytest.raises(ProblemError, match="not supported by the affine-feedback LP"):
        random_problem(
            0, robust="feedback", step_linearisation=StepLinearisation(input_scale=np.ones((8, 2)))
        )
    scaled = random_problem(0, step_linearisation=StepLinearisation(input_scale=np.ones((8, 2))))
    assert scaled.input_scale is not None and not scaled.input_scale.flags.writeable
