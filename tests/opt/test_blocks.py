"""The problem's feature blocks (issue 58): a core with no mode-specific field, and each
feature a frozen, validated dataclass with its own LP family."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hvacflex.errors import ProblemError
from hvacflex.opt import ILEventModel, PowerCap, ReserveCommitment, RMPCProblem
from hvacflex.opt.blocks import FEATURE_BLOCKS
from hvacflex.opt.feedback import build_feedback_lp
from hvacflex.opt.lp import FEATURE_FAMILIES, build_lp
from hvacflex.opt.testing import random_problem

#: The core: what every robust mode (tightening, dual, none, feedback; whole-horizon or event
#: model) reads. A field valid in one mode only belongs in a block of hvacflex.opt.blocks.
CORE_FIELDS = (
    "a_matrix",
    "b_matrix",
    "e_matrix",
    "c_matrix",
    "x0",
    "d_forecast",
    "d_sigma",
    "energy_price_sgd_per_mwh",
    "reserve_price_sgd_per_mwh",
    "power_offset_kw",
    "power_coeff_kw_per_kg_s",
    "u_min",
    "u_max",
    "y_min",
    "y_max",
    "affine_term",
    "peak_price_sgd_per_kw",
    "peak_floor_kw",
    "reserve_mask",
    "comfort_penalty_sgd_per_kelvin_hour",
    "dt_h",
    "robust",
    "slack_max_kelvin",
    "reserve_power_coeff_kw_per_kg_s",
)


def test_the_core_has_only_fields_every_mode_reads() -> None:
    names = [f.name for f in dataclasses.fields(RMPCProblem) if f.init]
    core = tuple(name for name in names if name not in FEATURE_BLOCKS)
    assert core == CORE_FIELDS, "a new field belongs in a feature block (hvacflex.opt.blocks)"
    blocks = {f.name: f for f in dataclasses.fields(RMPCProblem) if f.name in FEATURE_BLOCKS}
    assert set(blocks) == set(FEATURE_BLOCKS)
    assert all(f.default is None for f in blocks.values())  # off unless given


@pytest.mark.parametrize("name", sorted(FEATURE_BLOCKS))
def test_each_block_is_frozen_validated_and_has_its_own_lp_family(name: str) -> None:
    block = FEATURE_BLOCKS[name]
    assert dataclasses.is_dataclass(block)
    assert block.__dataclass_params__.frozen  # type: ignore[attr-defined]
    assert "__post_init__" in vars(block)  # its own validation
    family = FEATURE_FAMILIES.get(name, build_feedback_lp if name == "feedback" else None)
    assert family is not None and callable(family)
    assert family.__name__.startswith(("add_", "build_feedback"))


def _lp(problem: RMPCProblem):  # type: ignore[no-untyped-def]
    program, layout = build_lp(problem, np.zeros((problem.horizon, problem.ny)))
    return program, layout


def test_a_power_cap_changes_only_the_power_columns_upper_bounds() -> None:
    problem = random_problem(0)
    cap = np.linspace(5.0, 9.0, problem.horizon)
    capped = dataclasses.replace(problem, power_cap=PowerCap(power_max_kw=cap))
    (free, layout), (bounded, _) = _lp(problem), _lp(capped)
    changed = np.flatnonzero(free.col_upper != bounded.col_upper)
    np.testing.assert_array_equal(changed, layout.plan.power)
    np.testing.assert_array_equal(bounded.col_upper[layout.plan.power], cap)
    np.testing.assert_array_equal(free.col_lower, bounded.col_lower)
    assert free.num_rows == bounded.num_rows


def test_a_commitment_fixes_only_the_committed_reserve_columns() -> None:
    problem = random_problem(1)
    fixed = np.array([[0.3, 0.0], [0.1, 1.4 + 5e-10]])  # round-off: clipped into the room 1.4
    committed = dataclasses.replace(problem, commitments=ReserveCommitment(reserve_kg_s=fixed))
    assert committed.fixed_reserve_steps == 2 and problem.fixed_reserve_steps == 0
    (free, layout), (bounded, _) = _lp(problem), _lp(committed)
    r = layout.plan.r
    np.testing.assert_array_equal(bounded.col_lower[r[:2]], [[0.3, 0.0], [0.1, 1.4]])
    np.testing.assert_array_equal(bounded.col_upper[r[:2]], bounded.col_lower[r[:2]])
    others = np.setdiff1d(np.arange(free.num_cols), r[:2])
    np.testing.assert_array_equal(free.col_lower[others], bounded.col_lower[others])
    np.testing.assert_array_equal(free.col_upper[others], bounded.col_upper[others])


def test_power_cap_is_validated() -> None:
    with pytest.raises(ProblemError, match="NaN") as info:
        PowerCap(power_max_kw=np.array([1.0, np.nan]))
    assert info.value.field == "power_cap.power_max_kw"
    with pytest.raises(ProblemError, match="infinite"):
        PowerCap(power_max_kw=-np.inf)
    with pytest.raises(ProblemError, match=r"\(\) or \(N,\)"):
        PowerCap(power_max_kw=np.ones((2, 2)))
    with pytest.raises(ProblemError, match="expected"):
        random_problem(0, power_cap=PowerCap(power_max_kw=np.ones(3)))  # N = 8
    capped = random_problem(0, power_cap=PowerCap(power_max_kw=4.0))
    np.testing.assert_array_equal(capped.power_max_kw, np.full(8, 4.0))
    assert np.isinf(random_problem(0).power_max_kw).all()  # no cap: +inf everywhere


def test_reserve_commitment_is_validated() -> None:
    with pytest.raises(ProblemError, match="committed reserve flows must be ≥ 0") as info:
        ReserveCommitment(reserve_kg_s=np.array([[0.1, -0.2]]))
    assert info.value.field == "commitments.reserve_kg_s"
    with pytest.raises(ProblemError, match=r"\(g, m\)"):
        ReserveCommitment(reserve_kg_s=np.array([0.1, 0.2]))
    block = ReserveCommitment(reserve_kg_s=np.zeros((0, 2)))
    assert block.steps == 0 and not block.reserve_kg_s.flags.writeable


def test_event_model_is_a_value() -> None:
    """Equal event models are equal (the solver's structure compares D and R)."""
    assert ILEventModel(max_steps=2, recovery_steps=1) == ILEventModel(
        max_steps=2, recovery_steps=1
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        ILEventModel(max_steps=2).max_steps = 3  # type: ignore[misc]
