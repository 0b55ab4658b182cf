"""The fleet's flexibility envelope: the least and the most power it can hold, and for how long.

Per period, from every building's current state on its controller's model (the step problem
:meth:`hvacflex.fleet.agent.BuildingAgent.begin_step` builds: the state now, the
forecast, the flow box, the comfort band and the affine power P_k = p0_k + p_k·u_k), a
**hold** of h periods at a constant power level λ [kW] is a flow trajectory u_0 … u_{h−1}
inside the flow box with P_k = λ in every one of the h periods. A building can hold every
level of an interval; its ends, with the comfort band kept at every period end of the hold
(the forecast taken as exact, no robust margin), are the building's envelope:

* ``min_power_kw`` = min λ, ``max_power_kw`` = max λ over the holds that keep comfort.

The state is the plant's true state as the building's model holds it (the fleet path runs
no Kalman filter). Each building's envelope is one small LP over the condensed dynamics (its
(h, m) flows, (h, ny) comfort slacks ε ≥ 0 [K] and the level, for every duration and both
ends at once: the blocks are independent, so one solve finds every block's optimum). The
slack is weighted by :data:`SLACK_WEIGHT_KW_PER_KELVIN`, so it is minimised before the
level; where even the least-slack hold needs more than :data:`COMFORT_TOLERANCE_K` (a zone
already outside its band that no flow brings back in time, e.g. a 120-min hold from 06:00
across the start of occupancy), no hold of that duration keeps comfort and the building's
range for it is NaN: **not comfort-keeping**. A block whose LP fails (it is solved again
alone when the joint solve fails) is NaN too, and logged.

The fleet's envelope (:func:`fleet_envelope`) is the **sum** of the comfort-keeping
buildings' ranges, each building holding its own constant level: a conservative
approximation of what the fleet can hold, which only needs the *sum* to be constant (the
buildings may trade power between them during the hold; on 8 buildings at 14:00 the summed
120-min minimum read 346.53 kW against 343.07 kW for the coupled LP). The row's
``buildings`` column says how many buildings it sums; the others cannot hold that
duration in comfort and are left out (their power is not in the row).

``envelope.csv`` (a fleet run writes it; :func:`envelope_frame`): one row per period and
duration, columns ``time``, ``duration_min``, ``min_power_kw``, ``max_power_kw``, ``buildings``.

:func:`hold_flows` gives a building's flows (h, m) [kg/s] of a hold at a given affine level
over the h periods left of it (the hold re-planned each period from the state then: the
closed-loop check of the envelope, :meth:`hvacflex.fleet.agent.BuildingAgent.advance_held`,
which finds the affine level whose flows the plant's power model puts at the envelope's
level).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import sparse

from hvacflex.constants import PERIOD_S
from hvacflex.control.base import FloatArray
from hvacflex.opt import RMPCProblem
from hvacflex.opt.solve import solve_lp
from hvacflex.units import SECONDS_PER_HOUR

_LOG = logging.getLogger(__name__)

ENVELOPE_FILE = "envelope.csv"
ENVELOPE_COLUMNS = ("time", "duration_min", "min_power_kw", "max_power_kw", "buildings")
DURATIONS_MIN = (30, 60, 120)
"""The hold durations of ``envelope.csv`` [min]."""
SLACK_WEIGHT_KW_PER_KELVIN = 1.0e4
"""Weight of the comfort slack against the level in a hold's objective [kW per K]: large
enough that the least slack comes first (0.001 K outweighs 10 kW)."""
COMFORT_TOLERANCE_K = 1.0e-6
"""The largest comfort slack [K] of a hold that still counts as keeping comfort."""


@dataclass(frozen=True)
class HoldModel:
    """A building's condensed model over the first h periods of its step problem.

    Attributes
    ----------
    gain : (h·ny, h·m) the comfort outputs' response to the flows: row j·ny + i is zone
        output i at the end of period j, column l·m + c flow c in period l (0 for l > j)
        [K per kg/s].
    free : (h·ny,) the outputs with every flow at 0 (initial state, forecast, affine term)
        [°C].
    y_min, y_max : (h·ny,) the comfort band at the period ends [°C] (±inf allowed).
    u_min, u_max : (h·m,) the flow box [kg/s].
    p0 : (h,) power offsets [kW]; p : (h, m) power coefficients [kW per kg/s].
    """

    gain: FloatArray
    free: FloatArray
    y_min: FloatArray
    y_max: FloatArray
    u_min: FloatArray
    u_max: FloatArray
    p0: FloatArray
    p: FloatArray

    @property
    def steps(self) -> int:
        return int(self.p0.shape[0])

    @property
    def m(self) -> int:
        return int(self.p.shape[1])

    @property
    def ny(self) -> int:
        return int(self.gain.shape[0] // self.steps)

    def first(self, steps: int) -> HoldModel:
        """The model of the first ``steps`` periods (1 ≤ steps ≤ :attr:`steps`): the leading
        blocks, equal to :func:`hold_model` of that many periods (the response of period j
        depends only on the periods up to j), so one model built at the longest hold serves
        every shorter one."""
        if not 1 <= steps <= self.steps:
            raise ValueError(f"a hold of {steps} periods does not fit a model of {self.steps}")
        rows, columns = steps * self.ny, steps * self.m
        return HoldModel(
            gain=self.gain[:rows, :columns],
            free=self.free[:rows],
            y_min=self.y_min[:rows],
            y_max=self.y_max[:rows],
            u_min=self.u_min[:columns],
            u_max=self.u_max[:columns],
            p0=self.p0[:steps],
            p=self.p[:steps],
        )


def hold_model(problem: RMPCProblem, steps: int) -> HoldModel:
    """The condensed model of ``problem``'s first ``steps`` periods (1 ≤ steps ≤ N)."""
    if not 1 <= steps <= problem.horizon:
        raise ValueError(f"a hold of {steps} periods does not fit a horizon of {problem.horizon}")
    a, b, c = problem.a_matrix, problem.b_matrix, problem.c_matrix
    g = np.broadcast_to(problem.g, (problem.horizon, problem.n))  # g, or g_k of each step
    scale = problem.input_scale
    if scale is None:
        scale = np.ones((problem.horizon, problem.m))
    m, ny = problem.m, problem.ny
    gain = np.zeros((steps * ny, steps * m))
    free = np.zeros(steps * ny)
    x = np.asarray(problem.x0, dtype=float)
    responses = [b]  # A^j B, j = 0 … steps − 1
    for _ in range(1, steps):
        responses.append(a @ responses[-1])
    for j in range(steps):
        x = a @ x + problem.e_matrix @ problem.d_forecast[j] + g[j]
        free[j * ny : (j + 1) * ny] = c @ x
        for lag in range(j + 1):  # the flows of step j − lag through B diag(s_{j−lag})
            block = (c @ responses[lag]) * scale[j - lag]
            gain[j * ny : (j + 1) * ny, (j - lag) * m : (j - lag + 1) * m] = block
    return HoldModel(
        gain=gain,
        free=free,
        y_min=problem.y_min[:steps].ravel(),
        y_max=problem.y_max[:steps].ravel(),
        u_min=problem.u_min[:steps].ravel(),
        u_max=problem.u_max[:steps].ravel(),
        p0=np.asarray(problem.power_offset_kw[:steps], dtype=float),
        p=np.asarray(problem.power_coeff_kw_per_kg_s[:steps], dtype=float),
    )


@dataclass(frozen=True)
class _Block:
    """One hold's LP block: cost, matrix (rows × its columns), row and column bounds."""

    cost: FloatArray
    matrix: sparse.csr_matrix
    row_lower: FloatArray
    row_upper: FloatArray
    col_lower: FloatArray
    col_upper: FloatArray
    slack: slice
    """The block's slack columns ε."""


@dataclass(frozen=True)
class _Solved:
    """A block's optimum: its columns (NaN if its LP failed) and largest slack [K] (NaN
    if failed)."""

    x: FloatArray
    max_slack_k: float

    @property
    def ok(self) -> bool:
        return not np.isnan(self.max_slack_k)


def _hold_matrix(model: HoldModel) -> sparse.csr_matrix:
    """The hold LP's rows on columns (u (h·m), ε (h·ny), λ): comfort low [G I 0], comfort
    high [G −I 0], power [diag(p_k) 0 −1] (the same for every objective of the model: built
    once, dense then compressed, as the model is small)."""
    h, m, ny = model.steps, model.m, model.ny
    outputs, flows = h * ny, h * m
    dense = np.zeros((2 * outputs + h, flows + outputs + 1))
    dense[:outputs, :flows] = model.gain
    dense[outputs : 2 * outputs, :flows] = model.gain
    dense[:outputs, flows : flows + outputs] = np.eye(outputs)
    dense[outputs : 2 * outputs, flows : flows + outputs] = -np.eye(outputs)
    for k in range(h):
        dense[2 * outputs + k, k * m : (k + 1) * m] = model.p[k]
    dense[2 * outputs :, -1] = -1.0
    return sparse.csr_matrix(dense)


def _hold_block(
    model: HoldModel,
    sense: float,
    level: float | None = None,
    matrix: sparse.csr_matrix | None = None,
) -> _Block:
    """The hold LP on columns (u (h·m), ε (h·ny), λ): comfort rows y_min − ε ≤ free + G u ≤
    y_max + ε, power rows p_k·u_k − λ = −p0_k; cost sense·λ + W·Σε (``sense`` +1: the
    least level, −1: the most, 0: the least slack at ``level``, which fixes λ); ``matrix``:
    the model's :func:`_hold_matrix` where the caller has it already."""
    h, m, ny = model.steps, model.m, model.ny
    inf = np.full(h * ny, np.inf)
    row_lower = np.concatenate([model.y_min - model.free, -inf, -model.p0])
    row_upper = np.concatenate([inf, model.y_max - model.free, -model.p0])
    cost = np.concatenate([np.zeros(h * m), np.full(h * ny, SLACK_WEIGHT_KW_PER_KELVIN), [sense]])
    low = -np.inf if level is None else level
    high = np.inf if level is None else level
    return _Block(
        cost,
        _hold_matrix(model) if matrix is None else matrix,
        row_lower,
        row_upper,
        np.concatenate([model.u_min, np.zeros(h * ny), [low]]),
        np.concatenate([model.u_max, inf, [high]]),
        slice(h * m, h * m + h * ny),
    )


def _solve_joint(blocks: Sequence[_Block]) -> FloatArray | None:
    """The blocks' columns solved as one LP (None if it fails)."""
    result = solve_lp(
        np.concatenate([b.cost for b in blocks]),
        sparse.block_diag([b.matrix for b in blocks], format="csr"),
        np.concatenate([b.row_lower for b in blocks]),
        np.concatenate([b.row_upper for b in blocks]),
        np.concatenate([b.col_lower for b in blocks]),
        np.concatenate([b.col_upper for b in blocks]),
    )
    return np.asarray(result.x, dtype=float) if result.status.ok else None


def _solve_blocks(blocks: Sequence[_Block]) -> list[_Solved]:
    """Solve the independent blocks as one LP; each block's optimum and largest slack.
    If the joint LP fails, every block is solved alone, so one failed block (NaN, logged)
    leaves the others theirs."""
    lengths = [len(b.cost) for b in blocks]
    x = _solve_joint(blocks)
    if x is not None:
        parts = list(np.split(x, np.cumsum(lengths)[:-1]))
    else:
        parts = []
        for i, block in enumerate(blocks):
            alone = _solve_joint([block])
            if alone is None:
                _LOG.warning("hold LP block %d of %d failed: no hold for it", i, len(blocks))
                alone = np.full(len(block.cost), np.nan)
            parts.append(alone)
    return [
        _Solved(part, float(np.max(part[block.slack], initial=0.0)))
        for block, part in zip(blocks, parts, strict=True)
    ]


def building_envelope(
    problem: RMPCProblem,
    steps: Sequence[int],
    plant_power_kw: Callable[[FloatArray], float] | None = None,
) -> FloatArray:
    """(D, 2) the least and the most power [kW] the building holds for each of ``steps``
    (D,) periods from its state now without leaving comfort (see the module docstring; the
    condensed model is built once, at the longest hold, :meth:`HoldModel.first`);
    both NaN for a duration where no hold keeps comfort (the least slack above
    :data:`COMFORT_TOLERANCE_K`) or either end's LP failed (logged).

    ``plant_power_kw`` maps a hold's flows (h, m) [kg/s] to the mean power [kW] the plant's
    power model predicts for them over the hold; given, each end is that mean power of the
    flows of the affine-extreme hold (the LP's least or most affine level) instead of the
    LP's affine power (a secant, which over-states the power of large flows and
    under-states that of small ones). It is neither constant over the hold (only the
    affine power is) nor the plant model's own extreme."""
    if not steps:
        return np.empty((0, 2))
    longest = hold_model(problem, max(steps))  # built once, sliced for the shorter holds
    blocks, models = [], []
    for h in steps:
        model = longest.first(h)
        matrix = _hold_matrix(model)  # both ends share the rows
        blocks += [_hold_block(model, 1.0, matrix=matrix), _hold_block(model, -1.0, matrix=matrix)]
        models += [model, model]
    levels, keeps = [], []
    for model, solved in zip(models, _solve_blocks(blocks), strict=True):
        x = solved.x
        flows = x[: model.steps * model.m].reshape(model.steps, model.m)
        keeps.append(solved.ok and solved.max_slack_k <= COMFORT_TOLERANCE_K)
        if plant_power_kw is None or not solved.ok:
            levels.append(x[-1])
        else:
            levels.append(plant_power_kw(flows))
    # the plant's power of the two ends' flows may cross by a little: the range is their span
    envelope = np.sort(np.array(levels, dtype=float).reshape(len(steps), 2), axis=1)
    envelope[~np.array(keeps).reshape(len(steps), 2).all(axis=1)] = np.nan
    return envelope


def fleet_envelope(buildings_kw: FloatArray) -> FloatArray:
    """(D, 3) the fleet's envelope from its buildings' (B, D, 2) [kW]: per duration the
    least and the most power [kW] summed over the buildings whose range is not NaN (the
    comfort-keeping ones), and how many they are (NaN power where none is)."""
    keeps = np.logical_not(np.isnan(buildings_kw).any(axis=2))  # (B, D)
    count = keeps.sum(axis=0).astype(float)
    total = np.where(keeps[:, :, None], buildings_kw, 0.0).sum(axis=0)
    total[count == 0] = np.nan
    return np.column_stack([total, count])


def hold_flows(problem: RMPCProblem, level_kw: float, steps: int) -> FloatArray:
    """(steps, m) the flows [kg/s] of a hold at the affine power ``level_kw`` [kW] over
    ``problem``'s first ``steps`` periods with the least comfort slack, the level clipped
    into the flow box's power range over those periods."""
    model = hold_model(problem, steps)
    low = model.p0 + np.sum(
        np.minimum(
            model.p * model.u_min.reshape(steps, -1), model.p * model.u_max.reshape(steps, -1)
        ),
        axis=1,
    )
    high = model.p0 + np.sum(
        np.maximum(
            model.p * model.u_min.reshape(steps, -1), model.p * model.u_max.reshape(steps, -1)
        ),
        axis=1,
    )
    level = float(np.clip(level_kw, np.max(low), max(np.max(low), np.min(high))))
    x = _solve_blocks([_hold_block(model, 0.0, level)])[0].x
    return x[: steps * model.m].reshape(steps, model.m)


def envelope_frame(index: pd.DatetimeIndex, envelope_kw: FloatArray) -> pd.DataFrame:
    """``envelope.csv``'s rows from the fleet's envelope (T, D, 3) (:func:`fleet_envelope`:
    least and most power [kW], buildings summed) at the periods ``index`` (T,) and
    :data:`DURATIONS_MIN` (D,), period by period."""
    steps, durations = envelope_kw.shape[:2]
    return pd.DataFrame(
        {
            "time": np.repeat(index[:steps], durations),
            "duration_min": np.tile(np.array(DURATIONS_MIN[:durations]), steps),
            "min_power_kw": envelope_kw[:, :, 0].ravel(),
            "max_power_kw": envelope_kw[:, :, 1].ravel(),
            "buildings": envelope_kw[:, :, 2].ravel().astype(int),
        },
        columns=list(ENVELOPE_COLUMNS),
    )


def duration_steps(dt_h: float = PERIOD_S / SECONDS_PER_HOUR) -> tuple[int, ...]:
    """:data:`DURATIONS_MIN` in periods of ``dt_h`` [h] (default: the 30-min period)."""
    return tuple(round(minutes / 60.0 / dt_h) for minutes in DURATIONS_MIN)
