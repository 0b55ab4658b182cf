r"""The robust MPC problem on plain arrays (DESIGN §3, paper eq. 11–13) and its sparse LP.

Problem
-------
Given the affine model ``x+ = A x + B u + E d + g`` (n states, m inputs, nd disturbances),
comfort outputs ``y = C x`` (ny outputs, a selection, C ≥ 0), the measured state ``x_0`` and
forecasts over ``k = 0..N-1``, find zone flows ``u_k`` (m) [kg/s], reserve flows ``r_k ≥ 0``
[kg/s] (zero on inputs outside ``reserve_mask``), comfort slack ``ε_k ≥ 0`` (ny) [K] for
``k = 1..N`` and the peak epigraph ``β ≥ 0`` [SGD] solving

.. math::

    \min\; &\sum_{k=0}^{N-1} \Delta t\,(c_k P_k - b_k R_k)/1000
           + \rho\,\Delta t \sum_{k=1}^{N} \mathbf 1^\top \varepsilon_k + \beta \\
    \text{s.t. }\; & x_{k+1} = A x_k + B u_k + E \hat d_k + g
        && \text{(served: IL not activated)} \\
    & z_{k+1} = A z_k + B (u_k - r_k) + E \hat d_k + g,\quad z_0 = x_0
        && \text{(curtailed: IL activated)} \\
    & y^{lo}_k + \delta_k - \varepsilon_k \le C x_k,\; C z_k \le y^{hi}_k - \delta_k + \varepsilon_k
        && k = 1..N \text{ (both bounds, both trajectories)} \\
    & u^{min}_k \le u_k - r_k,\quad u_k \le u^{max}_k,\quad r_k \ge 0,\quad
      r_{k,i} = 0 \text{ if not mask}_i \\
    & P_k = p^0_k + p_k^\top u_k,\quad R_k = p_k^\top r_k,\quad \phi_k P_k \le \beta,\quad
      \beta \ge \phi P^{floor},\quad 0 \le \varepsilon_k \le \varepsilon^{max}

with Δt in hours, P and R in kW, c and b in SGD/MWh, ρ in SGD/(K·h), φ in SGD/kW. The robust
margin ``δ_k = Σ_{j<k} |C A^{k-1-j} E| σ_j`` is the worst case of the box error
``|w_j| ≤ σ_j`` (see :mod:`hvacflex.opt.robust`); ``robust="dual"`` carries the paper's
per-row dual variables explicitly instead, ``robust="none"`` sets δ = 0 (nominal MPC).

Why two trajectories suffice
----------------------------
Under any activation pattern ``a_j ∈ [0, 1]`` the state is
``x_k − Σ_{j<k} A^{k-1-j} B_r (a_j r_j)``. If ``A ≥ 0``, ``C ≥ 0``, ``r ≥ 0`` and all
reserve-carrying columns ``B_r`` of B share one sign, each term has one sign, so every
activated output lies between the served ``C x_k`` and the curtailed ``C z_k``; the band
(tightened by the same δ) then holds for all patterns. :class:`RMPCProblem` refuses problems
that violate these conditions.

IL event model (``il_event_max_steps`` = D set): instead of z, the event set holds at most one
event of ≤ D curtailed steps, with an allowance α on the upper bound during the event and R
steps after it; its exact robust counterpart is a block of ≈ N²·ny/2 rows over (x, r, ε)
appended after the peak rows (:mod:`hvacflex.opt.events`; z is dropped).

Sparse LP (state-space form)
----------------------------
States stay variables, so the constraint matrix is banded and ``x_0``, ``d̂``, ``g``, bounds
and prices enter only right-hand sides, bounds and costs. Columns, in order:
``x_1..x_N`` (N·n), ``z_1..z_N`` (N·n, only if some input carries reserve), ``u`` (N·m),
``r`` (N·m_r, reserve-carrying inputs only), ``ε`` (N·ny), ``P`` (N), ``β`` (1), then the
dual λ's. Rows: served and curtailed dynamics (N·n each, equalities), comfort upper/lower
rows per trajectory (N·ny each), ``u − r ≥ u_min`` (N·m_r), power definition (N,
coefficients ``−p_k`` change every step), peak rows ``φ_k P_k − β ≤ 0`` (N), and in the dual
form one equality ``λ₁ − λ₂ = ±h`` per (robust row, disturbance entry).

Reserve tie-break: when ``b = 0`` the optimum is degenerate in r. Every reserve flow carries
a cost of :data:`RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR` × Δt (1e-5 SGD per kg/s·h, orders of
magnitude below any reserve price that matters), which breaks the tie towards zero reserve.
It is *excluded* from the reported objective (reported separately as ``tie_break_sgd``).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from hvacflex.errors import ProblemError
from hvacflex.opt import events as events_mod
from hvacflex.opt import robust as robust_mod

if TYPE_CHECKING:
    from hvacflex.opt.feedback import FeedbackOptions

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

RobustMode = Literal["tightening", "dual", "none", "feedback"]
ROBUST_MODES: tuple[str, ...] = ("tightening", "dual", "none", "feedback")

#: Elementwise tolerance for A ≥ 0 (the discretised RC network is Metzler up to round-off).
SIGN_TOLERANCE = 1e-12
#: Default comfort penalty ρ [SGD per K·h] (an exact penalty at the paper's scale).
DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR = 100.0
#: Cost per kg/s of reserve flow per hour that breaks the b = 0 tie towards r = 0 [SGD/(kg/s·h)].
RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR = 1e-5
#: Price conversion: Δt[h] · price[SGD/MWh] · power[kW] / KW_PER_MW = SGD.
KW_PER_MW = 1000.0

_SOURCE = "RMPCProblem"


def _shape_text(shapes: tuple[tuple[int, ...], ...]) -> str:
    return " or ".join(str(s) for s in shapes)


def _float_array(
    name: str,
    value: object,
    shapes: tuple[tuple[int, ...], ...],
    *,
    target: tuple[int, ...] | None = None,
    allow_neg_inf: bool = False,
    allow_pos_inf: bool = False,
) -> FloatArray:
    """Copy ``value`` to a read-only float array of one of ``shapes``, broadcast to ``target``."""
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ProblemError(
            "must be a numeric array",
            source=_SOURCE,
            field=name,
            value=type(value).__name__,
            hint=f"pass an array of shape {_shape_text(shapes)}",
        ) from exc
    if array.shape not in shapes:
        raise ProblemError(
            f"wrong shape: expected {_shape_text(shapes)}, got {array.shape}",
            source=_SOURCE,
            field=name,
            hint="N is the number of rows of d_forecast; n, m, nd, ny come from the matrices",
        )
    if np.isnan(array).any():
        raise ProblemError(
            f"contains NaN at index {tuple(int(i) for i in np.argwhere(np.isnan(array))[0])}",
            source=_SOURCE,
            field=name,
            hint="fill missing values before building the problem",
        )
    bad = np.isinf(array)
    if allow_neg_inf:
        bad &= array > 0
    if allow_pos_inf:
        bad &= array < 0
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ProblemError(
            f"contains an infinite value at index {index}",
            source=_SOURCE,
            field=name,
            value=float(array[index]),
            hint="only y_min may be -inf and y_max +inf (no bound)",
        )
    if target is not None and array.shape != target:
        array = np.broadcast_to(array, target).copy()
    array.setflags(write=False)
    return array


def _matrix_shape(
    name: str, value: object, expected: str, fits: Callable[[int, int], bool]
) -> tuple[int, int]:
    """The (rows, columns) of ``value`` if it is 2-D and ``fits(rows, columns)``; else raise."""
    shape = np.asarray(value).shape
    if len(shape) != 2 or not fits(shape[0], shape[1]):
        raise ProblemError(
            f"wrong shape: expected {expected}, got {shape}", source=_SOURCE, field=name
        )
    return int(shape[0]), int(shape[1])


@dataclass(frozen=True, eq=False, kw_only=True)
class RMPCProblem:
    """One robust MPC problem on plain arrays (DESIGN §3); validated on construction.

    Parameters
    ----------
    a_matrix, b_matrix, e_matrix : (n,n), (n,m), (n,nd) ``x+ = A x + B u + E d + g`` [-, K per
        kg/s, K per disturbance unit]
    c_matrix : (ny,n) comfort outputs, a selection (C ≥ 0)
    x0 : (n,) measured state [°C]
    d_forecast : (N,nd) forecast disturbances d̂_0..d̂_{N-1}; N is the horizon
    d_sigma : (N,nd) or (nd,) box half-widths σ ≥ 0 of the forecast error [disturbance units]
    energy_price_sgd_per_mwh, reserve_price_sgd_per_mwh : (N,) c_k, b_k [SGD/MWh]
    power_offset_kw : (N,) p0_k [kW]
    power_coeff_kw_per_kg_s : (N,m) p_k: P_k = p0_k + p_k·u_k, R_k = p_k·r_k [kW per kg/s]
    u_min, u_max : (m,) or (N,m) flow bounds [kg/s]; u_min ≤ u − r, u ≤ u_max
    y_min, y_max : (N,ny) or (ny,) comfort bounds on C x_1..C x_N [°C]; y_min may be −inf,
        y_max +inf
    affine_term : (n,) g [K]; default zeros
    peak_price_sgd_per_kw : scalar or (N,) φ ≥ 0 [SGD/kW]; 0 disables the peak term
    peak_floor_kw : billing-period peak already incurred [kW]: β ≥ φ·floor (needs a constant φ)
    reserve_mask : (m,) bool, inputs that may offer reserve; default all
    comfort_penalty_sgd_per_kelvin_hour : ρ ≥ 0 [SGD per K·h]
    dt_h : Δt > 0 [h]
    robust : "tightening" (δ in the bounds), "dual" (explicit λ, verification), "none" (δ = 0),
        "feedback" (affine disturbance-feedback policies, :mod:`hvacflex.opt.feedback`)
    slack_max_kelvin : cap on ε [K]; None = unbounded (soft comfort), 0 = hard comfort
    feedback : policy structure for ``robust="feedback"`` (default ``FeedbackOptions()``);
        must be None for the other modes
    il_event_max_steps : D, the longest IL event [steps], 1 ≤ D ≤ N; None = the paper's
        whole-horizon model (curtailed trajectory for all N steps, strict band). See
        :mod:`hvacflex.opt.events`; not with robust="dual" or "feedback"
    il_event_allowance_kelvin : α ≥ 0 [K] added to the upper comfort bound during an event and
        R steps after it (event model only)
    il_event_recovery_steps : R ≥ 0 [steps] (event model only)
    il_allowance_carry_steps : c, 0 ≤ c ≤ N: outputs 1..c get α under every pattern, the
        served plan included (event model only)

    After construction every array field is a read-only float array of its full shape
    (``d_sigma`` (N,nd), ``u_min``/``u_max`` (N,m), ``y_min``/``y_max`` (N,ny),
    ``peak_price_sgd_per_kw`` (N,), ``affine_term`` (n,), ``reserve_mask`` (m,) bool).
    """

    a_matrix: FloatArray
    b_matrix: FloatArray
    e_matrix: FloatArray
    c_matrix: FloatArray
    x0: FloatArray
    d_forecast: FloatArray
    d_sigma: FloatArray
    energy_price_sgd_per_mwh: FloatArray
    reserve_price_sgd_per_mwh: FloatArray
    power_offset_kw: FloatArray
    power_coeff_kw_per_kg_s: FloatArray
    u_min: FloatArray
    u_max: FloatArray
    y_min: FloatArray
    y_max: FloatArray
    affine_term: FloatArray | None = None
    peak_price_sgd_per_kw: float | FloatArray = 0.0
    peak_floor_kw: float = 0.0
    reserve_mask: BoolArray | None = None
    comfort_penalty_sgd_per_kelvin_hour: float = DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR
    dt_h: float = 0.5
    robust: RobustMode = "tightening"
    slack_max_kelvin: float | None = None
    feedback: FeedbackOptions | None = None
    il_event_max_steps: int | None = None
    il_event_allowance_kelvin: float = 0.0
    il_event_recovery_steps: int = 0
    il_allowance_carry_steps: int = 0
    _structure: RMPCStructure = field(init=False, repr=False)

    def __post_init__(self) -> None:
        def put(name: str, value: object) -> None:
            object.__setattr__(self, name, value)

        n, _ = _matrix_shape(
            "a_matrix", self.a_matrix, "(n, n) with n ≥ 1", lambda r, c: r == c > 0
        )
        put("a_matrix", _float_array("a_matrix", self.a_matrix, ((n, n),)))
        _, m = _matrix_shape(
            "b_matrix", self.b_matrix, f"({n}, m) with m ≥ 1", lambda r, c: r == n and c > 0
        )
        put("b_matrix", _float_array("b_matrix", self.b_matrix, ((n, m),)))
        _, nd = _matrix_shape("e_matrix", self.e_matrix, f"({n}, nd)", lambda r, c: r == n)
        put("e_matrix", _float_array("e_matrix", self.e_matrix, ((n, nd),)))
        ny, _ = _matrix_shape(
            "c_matrix", self.c_matrix, f"(ny, {n}) with ny ≥ 1", lambda r, c: c == n and r > 0
        )
        put("c_matrix", _float_array("c_matrix", self.c_matrix, ((ny, n),)))
        horizon, _ = _matrix_shape(
            "d_forecast", self.d_forecast, f"(N, {nd}) with N ≥ 1", lambda r, c: c == nd and r > 0
        )
        put("d_forecast", _float_array("d_forecast", self.d_forecast, ((horizon, nd),)))
        put("x0", _float_array("x0", self.x0, ((n,),)))
        put(
            "d_sigma",
            _float_array("d_sigma", self.d_sigma, ((horizon, nd), (nd,)), target=(horizon, nd)),
        )
        for name in (
            "energy_price_sgd_per_mwh",
            "reserve_price_sgd_per_mwh",
            "power_offset_kw",
        ):
            put(name, _float_array(name, getattr(self, name), ((horizon,),)))
        put(
            "power_coeff_kw_per_kg_s",
            _float_array("power_coeff_kw_per_kg_s", self.power_coeff_kw_per_kg_s, ((horizon, m),)),
        )
        for name in ("u_min", "u_max"):
            put(
                name,
                _float_array(name, getattr(self, name), ((m,), (horizon, m)), target=(horizon, m)),
            )
        put(
            "y_min",
            _float_array(
                "y_min",
                self.y_min,
                ((ny,), (horizon, ny)),
                target=(horizon, ny),
                allow_neg_inf=True,
            ),
        )
        put(
            "y_max",
            _float_array(
                "y_max",
                self.y_max,
                ((ny,), (horizon, ny)),
                target=(horizon, ny),
                allow_pos_inf=True,
            ),
        )
        if self.affine_term is None:
            affine = np.zeros(n)
            affine.setflags(write=False)
        else:
            affine = _float_array("affine_term", self.affine_term, ((n,),))
        put("affine_term", affine)
        put(
            "peak_price_sgd_per_kw",
            _float_array(
                "peak_price_sgd_per_kw",
                self.peak_price_sgd_per_kw,
                ((), (horizon,)),
                target=(horizon,),
            ),
        )
        if self.reserve_mask is None:
            mask = np.ones(m, dtype=bool)
        else:
            mask_raw = np.array(self.reserve_mask)
            if mask_raw.shape != (m,) or mask_raw.dtype != np.bool_:
                raise ProblemError(
                    f"expected a bool array of shape ({m},), got {mask_raw.dtype} {mask_raw.shape}",
                    source=_SOURCE,
                    field="reserve_mask",
                    hint="True where the input (zone) may offer interruptible-load reserve",
                )
            mask = mask_raw.copy()
        mask.setflags(write=False)
        put("reserve_mask", mask)
        self._check_values()
        put(
            "_structure",
            RMPCStructure(
                a_matrix=self.a_matrix,
                b_matrix=self.b_matrix,
                e_matrix=self.e_matrix,
                c_matrix=self.c_matrix,
                horizon=horizon,
                reserve_mask=mask,
                robust=self.robust,
                il_event_max_steps=self.il_event_max_steps,
                il_event_recovery_steps=self.il_event_recovery_steps,
            ),
        )

    def _check_values(self) -> None:
        for name in ("peak_floor_kw", "comfort_penalty_sgd_per_kelvin_hour", "dt_h"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or not np.isfinite(value):
                raise ProblemError(
                    "must be a finite number", source=_SOURCE, field=name, value=value
                )
        if self.dt_h <= 0:
            raise ProblemError(
                "time step must be > 0 h", source=_SOURCE, field="dt_h", value=self.dt_h
            )
        if self.comfort_penalty_sgd_per_kelvin_hour < 0:
            raise ProblemError(
                "comfort penalty must be ≥ 0",
                source=_SOURCE,
                field="comfort_penalty_sgd_per_kelvin_hour",
                value=self.comfort_penalty_sgd_per_kelvin_hour,
                hint="DESIGN §3 uses ρ ≈ 100 SGD per K·h",
            )
        if self.peak_floor_kw < 0:
            raise ProblemError(
                "peak floor must be ≥ 0 kW",
                source=_SOURCE,
                field="peak_floor_kw",
                value=self.peak_floor_kw,
            )
        if self.slack_max_kelvin is not None and (
            not isinstance(self.slack_max_kelvin, int | float)
            or not np.isfinite(self.slack_max_kelvin)
            or self.slack_max_kelvin < 0
        ):
            raise ProblemError(
                "slack cap must be a finite number ≥ 0 K, or None for unbounded slack",
                source=_SOURCE,
                field="slack_max_kelvin",
                value=self.slack_max_kelvin,
            )
        if self.robust not in ROBUST_MODES:
            raise ProblemError(
                f"unknown robust mode; expected one of {ROBUST_MODES}",
                source=_SOURCE,
                field="robust",
                value=self.robust,
            )
        self._check_nonnegative("d_sigma", self.d_sigma, "box half-widths σ")
        self._check_nonnegative("peak_price_sgd_per_kw", self.phi, "peak price φ")
        self._check_bounds("u_min", self.u_min, "u_max", self.u_max)
        self._check_bounds("y_min", self.y_min, "y_max", self.y_max)
        phi = self.peak_price_sgd_per_kw
        if self.peak_floor_kw > 0 and np.ptp(phi) > 0:
            raise ProblemError(
                "a peak floor needs a constant peak price (β ≥ φ·floor)",
                source=_SOURCE,
                field="peak_floor_kw",
                value=self.peak_floor_kw,
                hint="pass a scalar peak_price_sgd_per_kw in billing-period mode",
            )
        self._check_sign_conditions()
        events_mod.check_event_problem(self)
        self._check_feedback()

    def _check_feedback(self) -> None:
        from hvacflex.opt.feedback import FeedbackOptions, check_feedback_problem

        if self.robust != "feedback":
            if self.feedback is not None:
                raise ProblemError(
                    "feedback options apply only to robust='feedback'",
                    source=_SOURCE,
                    field="feedback",
                    value=self.feedback,
                    hint=f"set robust='feedback' or feedback=None (robust is {self.robust!r})",
                )
            return
        if self.feedback is None:
            object.__setattr__(self, "feedback", FeedbackOptions())
        elif not isinstance(self.feedback, FeedbackOptions):
            raise ProblemError(
                "expected a FeedbackOptions",
                source=_SOURCE,
                field="feedback",
                value=type(self.feedback).__name__,
            )
        check_feedback_problem(self)

    @staticmethod
    def _check_nonnegative(name: str, values: FloatArray, what: str) -> None:
        if (values < 0).any():
            index = tuple(int(i) for i in np.argwhere(values < 0)[0])
            raise ProblemError(
                f"{what} must be ≥ 0, but at index {index} it is {float(values[index])!r}",
                source=_SOURCE,
                field=name,
            )

    @staticmethod
    def _check_bounds(
        lower_name: str, lower: FloatArray, upper_name: str, upper: FloatArray
    ) -> None:
        if (lower > upper).any():
            index = tuple(int(i) for i in np.argwhere(lower > upper)[0])
            raise ProblemError(
                f"{lower_name} must not exceed {upper_name}, but at index {index} "
                f"{lower_name} = {float(lower[index])!r} > {upper_name} = "
                f"{float(upper[index])!r}",
                source=_SOURCE,
                field=lower_name,
                hint="index is (step, input) or (step, output)",
            )

    def _check_sign_conditions(self) -> None:
        """Refuse problems where served + curtailed do not cover every IL activation pattern."""
        mask = np.asarray(self.reserve_mask, dtype=bool)
        if not mask.any():
            return
        why = (
            "the two-trajectory robust reformulation (served x and curtailed z) covers every "
            "partial IL activation pattern only if A ≥ 0, C ≥ 0 and all reserve-carrying "
            "columns of B have one sign"
        )
        if (self.a_matrix < -SIGN_TOLERANCE).any():
            index = tuple(int(i) for i in np.argwhere(self.a_matrix < -SIGN_TOLERANCE)[0])
            raise ProblemError(
                f"A has a negative entry at {index}; {why}",
                source=_SOURCE,
                field="a_matrix",
                value=float(self.a_matrix[index]),
                hint="discretise a Metzler (RC-network) model exactly (ZOH), or set "
                "reserve_mask all False to plan without reserve",
            )
        if (self.c_matrix < 0).any():
            index = tuple(int(i) for i in np.argwhere(self.c_matrix < 0)[0])
            raise ProblemError(
                f"C has a negative entry at {index}; {why}",
                source=_SOURCE,
                field="c_matrix",
                value=float(self.c_matrix[index]),
                hint="use a selection (or non-negative averaging) of states as comfort outputs",
            )
        columns = self.b_matrix[:, mask]
        if (columns < 0).any() and (columns > 0).any():
            raise ProblemError(
                f"reserve-carrying columns of B (inputs {np.flatnonzero(mask).tolist()}) have "
                f"entries of both signs; {why}",
                source=_SOURCE,
                field="b_matrix",
                hint="offer reserve only on cooling inputs (B ≤ 0) or only on heating inputs "
                "(B ≥ 0); heating/reheat inputs with reserve need the general robust form",
            )

    # ------------------------------------------------------------------ dimensions
    @property
    def n(self) -> int:
        """Number of states."""
        return int(self.a_matrix.shape[0])

    @property
    def m(self) -> int:
        """Number of inputs (zone flows)."""
        return int(self.b_matrix.shape[1])

    @property
    def nd(self) -> int:
        """Number of disturbance channels."""
        return int(self.e_matrix.shape[1])

    @property
    def ny(self) -> int:
        """Number of comfort outputs."""
        return int(self.c_matrix.shape[0])

    @property
    def horizon(self) -> int:
        """Prediction horizon N [steps]."""
        return int(self.d_forecast.shape[0])

    @property
    def structure(self) -> RMPCStructure:
        """What fixes the LP's sparsity pattern (see :class:`RMPCStructure`)."""
        return self._structure

    @property
    def g(self) -> FloatArray:
        """(n,) affine term of the dynamics [K]."""
        return np.asarray(self.affine_term, dtype=np.float64)

    @property
    def phi(self) -> FloatArray:
        """(N,) peak price φ_k [SGD/kW]."""
        return np.asarray(self.peak_price_sgd_per_kw, dtype=np.float64)


@dataclass(frozen=True, eq=False, kw_only=True)
class RMPCStructure:
    """The parts of a problem that fix the LP's columns, rows and constant coefficients."""

    a_matrix: FloatArray
    b_matrix: FloatArray
    e_matrix: FloatArray
    c_matrix: FloatArray
    horizon: int
    reserve_mask: BoolArray
    robust: str
    il_event_max_steps: int | None = None  # D; None = whole-horizon model
    il_event_recovery_steps: int = 0  # R (α and c enter row bounds only)

    def differences(self, other: RMPCStructure) -> list[str]:
        """Names of the fields in which ``other`` differs from this structure."""
        names = []
        for name in ("a_matrix", "b_matrix", "e_matrix", "c_matrix", "reserve_mask"):
            if not np.array_equal(getattr(self, name), getattr(other, name)):
                names.append(name)
        if self.horizon != other.horizon:
            names.append("horizon")
        for name in ("robust", "il_event_max_steps", "il_event_recovery_steps"):
            if getattr(self, name) != getattr(other, name):
                names.append(name)
        return names

    def fingerprint(self) -> str:
        """A hex digest identifying this structure (used to match saved solver bases)."""
        digest = hashlib.sha256()
        for array in (self.a_matrix, self.b_matrix, self.e_matrix, self.c_matrix):
            digest.update(str(array.shape).encode())
            digest.update(np.ascontiguousarray(array).tobytes())
        digest.update(np.ascontiguousarray(self.reserve_mask).tobytes())
        digest.update(f"{self.horizon}|{self.robust}".encode())
        if self.il_event_max_steps is not None:
            digest.update(f"|D={self.il_event_max_steps}|R={self.il_event_recovery_steps}".encode())
        return digest.hexdigest()


# ---------------------------------------------------------------------- LP layout


@dataclass(frozen=True, eq=False)
class LPLayout:
    """Column and row indices of every variable and constraint block of the sparse LP.

    Index arrays are shaped like the quantity they hold (e.g. ``col_u`` is (N, m)). The
    curtailed blocks (``col_z``, ``row_dyn_z``, ``row_hi_z``, ``row_lo_z``) are empty when no
    input carries reserve (then the curtailed trajectory equals the served one) and in the
    event model (``il_event_max_steps`` set), which has the event rows ``row_event``
    (described by ``events``, :mod:`hvacflex.opt.events`) instead.
    """

    horizon: int
    n: int
    m: int
    nd: int
    ny: int
    reserve_inputs: IntArray  # (m_r,) indices of reserve-carrying inputs
    robust: str
    col_x: IntArray  # (N, n)
    col_z: IntArray  # (N, n) or (0, n)
    col_u: IntArray  # (N, m)
    col_r: IntArray  # (N, m_r)
    col_eps: IntArray  # (N, ny)
    col_power: IntArray  # (N,)
    col_beta: int
    num_core_cols: int  # columns before the dual λ's
    num_cols: int
    row_dyn_x: IntArray  # (N, n)
    row_dyn_z: IntArray
    row_hi_x: IntArray  # (N, ny)
    row_lo_x: IntArray
    row_hi_z: IntArray
    row_lo_z: IntArray
    row_flow: IntArray  # (N, m_r)
    row_power: IntArray  # (N,)
    row_peak: IntArray  # (N,)
    row_event: IntArray  # (num_event_rows,) IL event rows (event model), else empty
    events: events_mod.EventRows  # what each event row is (empty for the whole-horizon model)
    num_core_rows: int  # rows before the dual λ rows
    num_rows: int
    # dual form: coefficient σ_{j,l} (or −σ) on (row, λ col) pairs
    dual_rows: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    dual_cols_1: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    dual_cols_2: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    dual_sigma_index: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    dual_sign: FloatArray = field(default_factory=lambda: np.zeros(0))

    @property
    def has_curtailed(self) -> bool:
        """Whether a separate curtailed trajectory z exists (reserve, whole-horizon model)."""
        return self.col_z.size > 0

    @property
    def has_reserve(self) -> bool:
        """Whether some input carries reserve (r columns and ``u − r ≥ u_min`` rows exist)."""
        return self.reserve_inputs.size > 0


def _take(counter: list[int], shape: tuple[int, ...]) -> IntArray:
    size = int(np.prod(shape)) if shape else 1
    indices = np.arange(counter[0], counter[0] + size, dtype=np.int64).reshape(shape)
    counter[0] += size
    return indices


def build_layout(structure: RMPCStructure) -> LPLayout:
    """Assign column and row indices for a problem structure (see the module docstring)."""
    horizon = structure.horizon
    n, m = structure.b_matrix.shape
    nd = structure.e_matrix.shape[1]
    ny = structure.c_matrix.shape[0]
    reserve_inputs = np.flatnonzero(structure.reserve_mask).astype(np.int64)
    m_r = reserve_inputs.size
    n_z = horizon if m_r and structure.il_event_max_steps is None else 0
    cols = [0]
    col_x = _take(cols, (horizon, n))
    col_z = _take(cols, (n_z, n))
    col_u = _take(cols, (horizon, m))
    col_r = _take(cols, (horizon, m_r))
    col_eps = _take(cols, (horizon, ny))
    col_power = _take(cols, (horizon,))
    col_beta = int(_take(cols, (1,))[0])
    num_core_cols = cols[0]
    rows = [0]
    row_dyn_x = _take(rows, (horizon, n))
    row_dyn_z = _take(rows, (n_z, n))
    row_hi_x = _take(rows, (horizon, ny))
    row_lo_x = _take(rows, (horizon, ny))
    row_hi_z = _take(rows, (n_z, ny))
    row_lo_z = _take(rows, (n_z, ny))
    row_flow = _take(rows, (horizon, m_r))
    row_power = _take(rows, (horizon,))
    row_peak = _take(rows, (horizon,))
    events = events_mod.event_rows(
        horizon, ny, structure.il_event_max_steps, structure.il_event_recovery_steps
    )
    row_event = _take(rows, (events.num_rows,))
    num_core_rows = rows[0]
    extra: dict[str, IntArray | FloatArray] = {}
    if structure.robust == "dual":
        responses = robust_mod.impulse_responses(
            structure.a_matrix, structure.e_matrix, structure.c_matrix, horizon
        )
        step, output, dist_step, channel, _ = robust_mod.dual_row_entries(responses)
        entries = step.size
        robust_sets = [(row_hi_x, 1.0), (row_lo_x, -1.0)]
        if m_r:
            robust_sets += [(row_hi_z, 1.0), (row_lo_z, -1.0)]
        parts_rows, parts_c1, parts_c2, parts_sigma, parts_sign = [], [], [], [], []
        for row_block, sign in robust_sets:
            parts_rows.append(row_block[step, output])
            parts_c1.append(_take(cols, (entries,)))
            parts_c2.append(_take(cols, (entries,)))
            parts_sigma.append(dist_step * nd + channel)
            parts_sign.append(np.full(entries, sign))
        extra = {
            "dual_rows": np.concatenate(parts_rows),
            "dual_cols_1": np.concatenate(parts_c1),
            "dual_cols_2": np.concatenate(parts_c2),
            "dual_sigma_index": np.concatenate(parts_sigma),
            "dual_sign": np.concatenate(parts_sign),
        }
        rows[0] += int(extra["dual_rows"].size)
    return LPLayout(
        horizon=horizon,
        n=n,
        m=m,
        nd=nd,
        ny=ny,
        reserve_inputs=reserve_inputs,
        robust=structure.robust,
        col_x=col_x,
        col_z=col_z,
        col_u=col_u,
        col_r=col_r,
        col_eps=col_eps,
        col_power=col_power,
        col_beta=col_beta,
        num_core_cols=num_core_cols,
        num_cols=cols[0],
        row_dyn_x=row_dyn_x,
        row_dyn_z=row_dyn_z,
        row_hi_x=row_hi_x,
        row_lo_x=row_lo_x,
        row_hi_z=row_hi_z,
        row_lo_z=row_lo_z,
        row_flow=row_flow,
        row_power=row_power,
        row_peak=row_peak,
        row_event=row_event,
        events=events,
        num_core_rows=num_core_rows,
        num_rows=rows[0],
        **extra,  # type: ignore[arg-type]
    )


def _block(
    rows: IntArray, cols: IntArray, values: FloatArray, *, keep_zeros: bool = False
) -> tuple[IntArray, IntArray, FloatArray]:
    rows_b, cols_b, values_b = np.broadcast_arrays(rows, cols, values)
    r, c, v = rows_b.ravel(), cols_b.ravel(), values_b.ravel().astype(np.float64)
    if not keep_zeros:
        keep = v != 0.0
        r, c, v = r[keep], c[keep], v[keep]
    return r, c, v


def assemble_matrix(
    structure: RMPCStructure,
    layout: LPLayout,
    power_coeff_kw_per_kg_s: FloatArray,
    peak_price_sgd_per_kw: FloatArray,
    d_sigma: FloatArray,
) -> sparse.csc_matrix:
    """The LP's constraint matrix (num_rows × num_cols, CSC) for the current coefficients.

    The step-varying coefficients are ``−p_k`` on (power row k, u_k), ``φ_k`` on (peak row k,
    P_k) and, in the dual form, ``±σ_{j,l}`` on (robust row, λ). They are stored even when
    zero so that their positions are known; the solver updates them in place.
    """
    a, b, c = structure.a_matrix, structure.b_matrix, structure.c_matrix
    horizon = layout.horizon
    ridx = layout.reserve_inputs
    eye = np.eye(layout.n)
    blocks: list[tuple[IntArray, IntArray, FloatArray]] = []
    trajectories = [(layout.col_x, layout.row_dyn_x, layout.row_hi_x, layout.row_lo_x)]
    if layout.has_curtailed:
        trajectories.append((layout.col_z, layout.row_dyn_z, layout.row_hi_z, layout.row_lo_z))
    for col_state, row_dyn, row_hi, row_lo in trajectories:
        blocks.append(_block(row_dyn[:, :, None], col_state[:, None, :], eye[None]))
        if horizon > 1:
            blocks.append(_block(row_dyn[1:, :, None], col_state[:-1, None, :], -a[None]))
        blocks.append(_block(row_dyn[:, :, None], layout.col_u[:, None, :], -b[None]))
        blocks.append(_block(row_hi[:, :, None], col_state[:, None, :], c[None]))
        blocks.append(_block(row_lo[:, :, None], col_state[:, None, :], c[None]))
        blocks.append(_block(row_hi, layout.col_eps, np.array(-1.0)))
        blocks.append(_block(row_lo, layout.col_eps, np.array(1.0)))
    if layout.has_curtailed:
        blocks.append(
            _block(layout.row_dyn_z[:, :, None], layout.col_r[:, None, :], b[:, ridx][None])
        )
    if layout.has_reserve:
        blocks.append(_block(layout.row_flow, layout.col_u[:, ridx], np.array(1.0)))
        blocks.append(_block(layout.row_flow, layout.col_r, np.array(-1.0)))
    blocks.append(_block(layout.row_power, layout.col_power, np.array(1.0)))
    blocks.append(
        _block(layout.row_power[:, None], layout.col_u, -power_coeff_kw_per_kg_s, keep_zeros=True)
    )
    blocks.append(_block(layout.row_peak, layout.col_power, peak_price_sgd_per_kw, keep_zeros=True))
    blocks.append(_block(layout.row_peak, np.array(layout.col_beta), np.array(-1.0)))
    if layout.robust == "dual":
        sigma = d_sigma.ravel()[layout.dual_sigma_index] * layout.dual_sign
        blocks.append(_block(layout.dual_rows, layout.dual_cols_1, sigma, keep_zeros=True))
        blocks.append(_block(layout.dual_rows, layout.dual_cols_2, sigma, keep_zeros=True))
        eq_rows = np.arange(layout.num_core_rows, layout.num_rows, dtype=np.int64)
        blocks.append(_block(eq_rows, layout.dual_cols_1, np.array(1.0)))
        blocks.append(_block(eq_rows, layout.dual_cols_2, np.array(-1.0)))
    if layout.events.num_rows:
        event_block = events_mod.event_matrix(
            layout.events,
            events_mod.reserve_responses(a, b[:, ridx], c, horizon),
            c,
            col_x=layout.col_x,
            col_r=layout.col_r,
            col_eps=layout.col_eps,
            num_cols=layout.num_cols,
        ).tocoo()
        blocks.append((layout.row_event[event_block.row], event_block.col, event_block.data))
    rows = np.concatenate([blk[0] for blk in blocks])
    cols = np.concatenate([blk[1] for blk in blocks])
    values = np.concatenate([blk[2] for blk in blocks])
    matrix = sparse.csc_matrix(
        (values, (rows, cols)), shape=(layout.num_rows, layout.num_cols), dtype=np.float64
    )
    matrix.sort_indices()
    return matrix


def dual_equality_rhs(structure: RMPCStructure, layout: LPLayout) -> FloatArray:
    """Right-hand sides ``±h`` of the dual form's ``λ₁ − λ₂ = ±h`` rows (constant per structure)."""
    if layout.robust != "dual":
        return np.zeros(0)
    responses = robust_mod.impulse_responses(
        structure.a_matrix, structure.e_matrix, structure.c_matrix, layout.horizon
    )
    *_, values = robust_mod.dual_row_entries(responses)
    sets = layout.dual_rows.size // values.size
    rhs: FloatArray = np.tile(values, sets) * layout.dual_sign
    return rhs


@dataclass(frozen=True, eq=False)
class LPVectors:
    """Costs, column bounds and row bounds of the core (non-λ) part of the LP for one step."""

    cost: FloatArray  # (num_core_cols,)
    col_lower: FloatArray
    col_upper: FloatArray
    row_lower: FloatArray  # (num_core_rows,)
    row_upper: FloatArray


def fill_plan_columns(
    problem: RMPCProblem,
    cost: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    *,
    col_u: IntArray,
    col_r: IntArray,
    col_eps: IntArray,
    col_beta: int,
    reserve_inputs: IntArray,
) -> None:
    """Write the costs and bounds of the flow, reserve, slack and peak columns in place.

    Shared by the open-loop LP and the feedback LP (:mod:`hvacflex.opt.feedback`):
    ``col_u`` (N, m) flows, ``col_r`` (N, m_r) reserve flows of ``reserve_inputs``,
    ``col_eps`` (N, ny) comfort slack, ``col_beta`` the peak epigraph β. The energy cost
    sits elsewhere in each LP (on P_k here, on u_k there).
    """
    dt = problem.dt_h
    p = problem.power_coeff_kw_per_kg_s
    cost[col_r] = (
        -dt * problem.reserve_price_sgd_per_mwh[:, None] * p[:, reserve_inputs] / KW_PER_MW
        + dt * RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR
    )
    cost[col_eps] = problem.comfort_penalty_sgd_per_kelvin_hour * dt
    cost[col_beta] = 1.0
    lower[col_u] = problem.u_min
    upper[col_u] = problem.u_max
    lower[col_r] = 0.0
    upper[col_r] = (problem.u_max - problem.u_min)[:, reserve_inputs]
    lower[col_eps] = 0.0
    if problem.slack_max_kelvin is not None:
        upper[col_eps] = problem.slack_max_kelvin
    lower[col_beta] = float(problem.phi[0]) * problem.peak_floor_kw


def dynamics_rhs(problem: RMPCProblem) -> FloatArray:
    """(N, n) right-hand sides of the dynamics rows ``x_{k+1} − A x_k − B u_k = E d̂_k + g``
    (for k = 0 also ``+ A x_0``) [K]."""
    rhs: FloatArray = problem.d_forecast @ problem.e_matrix.T + problem.g
    rhs[0] += problem.a_matrix @ problem.x0
    return rhs


def lp_vectors(problem: RMPCProblem, layout: LPLayout, delta: FloatArray) -> LPVectors:
    """Costs and bounds for ``problem`` given the robust margins ``delta`` (N, ny) [K].

    In the dual form pass ``delta = 0``: the λ's carry the robustness.
    """
    ridx = layout.reserve_inputs
    inf = np.inf
    cost = np.zeros(layout.num_core_cols)
    lower = np.full(layout.num_core_cols, -inf)
    upper = np.full(layout.num_core_cols, inf)
    fill_plan_columns(
        problem,
        cost,
        lower,
        upper,
        col_u=layout.col_u,
        col_r=layout.col_r,
        col_eps=layout.col_eps,
        col_beta=layout.col_beta,
        reserve_inputs=ridx,
    )
    cost[layout.col_power] = problem.dt_h * problem.energy_price_sgd_per_mwh / KW_PER_MW

    row_lower = np.empty(layout.num_core_rows)
    row_upper = np.empty(layout.num_core_rows)
    rhs = dynamics_rhs(problem)
    hi = problem.y_max - delta
    lo = problem.y_min + delta
    if layout.events.num_rows:
        hi = hi + events_mod.carry_allowance(
            layout.horizon,
            layout.ny,
            problem.il_event_allowance_kelvin,
            problem.il_allowance_carry_steps,
        )
        event_lower, event_upper = events_mod.event_row_bounds(
            layout.events,
            problem.y_max,
            delta,
            problem.il_event_allowance_kelvin,
            problem.il_allowance_carry_steps,
        )
        row_lower[layout.row_event] = event_lower
        row_upper[layout.row_event] = event_upper
    for row_dyn, row_hi, row_lo in (
        (layout.row_dyn_x, layout.row_hi_x, layout.row_lo_x),
        (layout.row_dyn_z, layout.row_hi_z, layout.row_lo_z),
    ):
        if row_dyn.size == 0:
            continue
        row_lower[row_dyn] = rhs
        row_upper[row_dyn] = rhs
        row_lower[row_hi] = -inf
        row_upper[row_hi] = hi
        row_lower[row_lo] = lo
        row_upper[row_lo] = inf
    row_lower[layout.row_flow] = problem.u_min[:, ridx]
    row_upper[layout.row_flow] = inf
    row_lower[layout.row_power] = problem.power_offset_kw
    row_upper[layout.row_power] = problem.power_offset_kw
    row_lower[layout.row_peak] = -inf
    row_upper[layout.row_peak] = 0.0
    return LPVectors(cost, lower, upper, row_lower, row_upper)
