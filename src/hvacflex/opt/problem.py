r"""The robust MPC problem on plain arrays (docs/explanation/model.md §3, paper eq. 11–13) and its
validation.

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

IL event model (``events`` set, :class:`~hvacflex.opt.blocks.ILEventModel`, D = its
``max_steps``): instead of z, the event set holds at most one
event of ≤ D curtailed steps, with an allowance α on the upper bound during the event and R
steps after it; its exact robust counterpart is a block of ≈ N²·ny/2 rows over (x, r, ε)
(:mod:`hvacflex.opt.events`, added by :func:`hvacflex.opt.lp.add_il_event_comfort`; z is
dropped).

Reserve tie-break: when ``b = 0`` the optimum is degenerate in r. Every reserve flow carries
a cost of :data:`~hvacflex.opt.options.RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR` × Δt (1e-5 SGD
per kg/s·h, orders of magnitude below any reserve price that matters), which breaks the tie
towards zero reserve.
It is *excluded* from the reported objective (reported separately as ``tie_break_sgd``).

The problem is a core (the fields every robust mode reads) plus feature blocks
(:mod:`hvacflex.opt.blocks`: events, commitments, offer baselines, power cap, feedback), each
None when off. The LP itself is built by :mod:`hvacflex.opt.lp` (open loop) and
:mod:`hvacflex.opt.feedback`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from hvacflex.constants import PERIOD_S
from hvacflex.errors import ProblemError
from hvacflex.opt.blocks import (
    FEATURE_BLOCKS,
    ComfortKnee,
    ILEventModel,
    OfferBaselines,
    PowerCap,
    ReserveCommitment,
    StepLinearisation,
)
from hvacflex.opt.checks import check_bounds, check_nonnegative, float_array, matrix_shape
from hvacflex.opt.options import (
    DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR,
    ROBUST_MODES,
    FeedbackOptions,
    RobustMode,
)
from hvacflex.opt.structure import RMPCStructure
from hvacflex.units import SECONDS_PER_HOUR

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Elementwise tolerance for A ≥ 0 (the discretised RC network is Metzler up to round-off).
SIGN_TOLERANCE = 1e-12

_SOURCE = "RMPCProblem"


@dataclass(frozen=True, eq=False, kw_only=True)
class RMPCProblem:
    """One robust MPC problem on plain arrays (docs/explanation/model.md §3); validated on
    construction.

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
    power_coeff_kw_per_kg_s : (N,m) p_k: P_k = p0_k + p_k·u_k [kW per kg/s]
    u_min, u_max : (m,) or (N,m) flow bounds [kg/s]; u_min ≤ u − r, u ≤ u_max
    y_min, y_max : (N,ny) or (ny,) comfort bounds on C x_1..C x_N [°C]; y_min may be −inf,
        y_max +inf
    affine_term : (n,) g [K], or (N,n) g_k of each step; default zeros
    peak_price_sgd_per_kw : scalar or (N,) φ ≥ 0 [SGD/kW]; 0 disables the peak term
    peak_floor_kw : billing-period peak already incurred [kW]: β ≥ φ·floor (needs a constant φ)
    reserve_mask : (m,) bool, inputs that may offer reserve; default all
    comfort_penalty_sgd_per_kelvin_hour : ρ ≥ 0 [SGD per K·h]
    dt_h : Δt > 0 [h]
    robust : "tightening" (δ in the bounds), "dual" (explicit λ, verification), "none" (δ = 0),
        "feedback" (affine disturbance-feedback policies, :mod:`hvacflex.opt.feedback`)
    slack_max_kelvin : cap on ε [K]; None = unbounded (soft comfort), 0 = hard comfort
    reserve_power_coeff_kw_per_kg_s : (N,m) q_k, the reserve capacity offered R_k = q_k·r_k
        [kW per kg/s] — a lower bound of the real power reduction per kg/s shed (fan tangent
        at the low flow, coil at the curtailed mixed-air state); None = p_k (the paper's)

    Feature blocks (:mod:`hvacflex.opt.blocks`; None = the feature is off):

    events : :class:`~hvacflex.opt.blocks.ILEventModel`, the IL event model (D, α, R, c);
        None = the paper's whole-horizon model. Not with robust="dual" or "feedback"
    commitments : :class:`~hvacflex.opt.blocks.ReserveCommitment`, the reserve flows
        r_0 … r_{g−1} already committed to the market; None = every r_k free
    offer_baselines : :class:`~hvacflex.opt.blocks.OfferBaselines`, the settlement baselines
        each step's offer is measured against (event model, open loop only); None = the
        reserve is paid at q_k·r_k
    power_cap : :class:`~hvacflex.opt.blocks.PowerCap`, a cap on the plan's power P_k (open
        loop only); None = no cap
    comfort_knee : :class:`~hvacflex.opt.blocks.ComfortKnee`, ε priced at ρ₂ ≥ ρ beyond a
        knee δ [K]; None = ρ on all of ε
    step_linearisation : :class:`~hvacflex.opt.blocks.StepLinearisation`, each step's input
        matrix B diag(s_k) (the supply air linearised at each step's zone temperature); None =
        B at every step. Not with robust="feedback"
    feedback : :class:`~hvacflex.opt.options.FeedbackOptions`, the policy structure of
        ``robust="feedback"`` (default ``FeedbackOptions()`` there); must be None otherwise

    After construction every array field is a read-only float array of its full shape
    (``d_sigma`` (N,nd), ``u_min``/``u_max`` (N,m), ``y_min``/``y_max`` (N,ny),
    ``peak_price_sgd_per_kw`` (N,), ``affine_term`` (n,) or (N,n) as given, ``reserve_mask``
    (m,) bool;
    ``power_cap``'s cap (N,)).
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
    dt_h: float = PERIOD_S / SECONDS_PER_HOUR
    robust: RobustMode = "tightening"
    slack_max_kelvin: float | None = None
    reserve_power_coeff_kw_per_kg_s: FloatArray | None = None
    # feature blocks (hvacflex.opt.blocks.FEATURE_BLOCKS)
    events: ILEventModel | None = None
    commitments: ReserveCommitment | None = None
    offer_baselines: OfferBaselines | None = None
    power_cap: PowerCap | None = None
    comfort_knee: ComfortKnee | None = None
    step_linearisation: StepLinearisation | None = None
    feedback: FeedbackOptions | None = None
    _structure: RMPCStructure = field(init=False, repr=False)

    def __post_init__(self) -> None:
        horizon, m, ny = self._normalise_matrices()
        self._normalise_series(horizon, m, ny)
        self._normalise_options(m)
        self._check_values()
        object.__setattr__(
            self,
            "_structure",
            RMPCStructure(
                a_matrix=self.a_matrix,
                b_matrix=self.b_matrix,
                e_matrix=self.e_matrix,
                c_matrix=self.c_matrix,
                horizon=horizon,
                reserve_mask=np.asarray(self.reserve_mask, dtype=bool),
                robust=self.robust,
                il_event_max_steps=None if self.events is None else self.events.max_steps,
                il_event_recovery_steps=0 if self.events is None else self.events.recovery_steps,
                visible_offers=self.offer_baselines is not None,
                comfort_knee=self.comfort_knee is not None,
                input_scale=self.input_scale,
            ),
        )

    @property
    def reserve_kw_per_kg_s(self) -> FloatArray:
        """(N, m) q_k, the reserve capacity per kg/s of reserve flow [kW per kg/s] (the
        normalised ``reserve_power_coeff_kw_per_kg_s``; p_k where that was None)."""
        coeff = self.reserve_power_coeff_kw_per_kg_s
        assert coeff is not None  # set by __post_init__
        return coeff

    def _put(self, name: str, value: object) -> None:
        object.__setattr__(self, name, value)

    def _normalise_matrices(self) -> tuple[int, int, int]:
        """Check and copy A, B, E, C, d̂ and x0; return (N, m, ny)."""
        put = self._put
        n, _ = matrix_shape("a_matrix", self.a_matrix, "(n, n) with n ≥ 1", lambda r, c: r == c > 0)
        put("a_matrix", float_array("a_matrix", self.a_matrix, ((n, n),)))
        _, m = matrix_shape(
            "b_matrix", self.b_matrix, f"({n}, m) with m ≥ 1", lambda r, c: r == n and c > 0
        )
        put("b_matrix", float_array("b_matrix", self.b_matrix, ((n, m),)))
        _, nd = matrix_shape("e_matrix", self.e_matrix, f"({n}, nd)", lambda r, c: r == n)
        put("e_matrix", float_array("e_matrix", self.e_matrix, ((n, nd),)))
        ny, _ = matrix_shape(
            "c_matrix", self.c_matrix, f"(ny, {n}) with ny ≥ 1", lambda r, c: c == n and r > 0
        )
        put("c_matrix", float_array("c_matrix", self.c_matrix, ((ny, n),)))
        horizon, _ = matrix_shape(
            "d_forecast", self.d_forecast, f"(N, {nd}) with N ≥ 1", lambda r, c: c == nd and r > 0
        )
        put("d_forecast", float_array("d_forecast", self.d_forecast, ((horizon, nd),)))
        put("x0", float_array("x0", self.x0, ((n,),)))
        return horizon, m, ny

    def _normalise_series(self, horizon: int, m: int, ny: int) -> None:
        """Check, copy and broadcast σ, prices, power model and bounds to their full shapes."""
        put = self._put
        nd = self.nd
        put(
            "d_sigma",
            float_array("d_sigma", self.d_sigma, ((horizon, nd), (nd,)), target=(horizon, nd)),
        )
        for name in (
            "energy_price_sgd_per_mwh",
            "reserve_price_sgd_per_mwh",
            "power_offset_kw",
        ):
            put(name, float_array(name, getattr(self, name), ((horizon,),)))
        put(
            "power_coeff_kw_per_kg_s",
            float_array("power_coeff_kw_per_kg_s", self.power_coeff_kw_per_kg_s, ((horizon, m),)),
        )
        reserve_coeff = self.reserve_power_coeff_kw_per_kg_s
        put(
            "reserve_power_coeff_kw_per_kg_s",
            self.power_coeff_kw_per_kg_s
            if reserve_coeff is None
            else float_array("reserve_power_coeff_kw_per_kg_s", reserve_coeff, ((horizon, m),)),
        )
        for name in ("u_min", "u_max"):
            put(
                name,
                float_array(name, getattr(self, name), ((m,), (horizon, m)), target=(horizon, m)),
            )
        bands = ((ny,), (horizon, ny))
        put(
            "y_min",
            float_array("y_min", self.y_min, bands, target=(horizon, ny), allow_neg_inf=True),
        )
        put(
            "y_max",
            float_array("y_max", self.y_max, bands, target=(horizon, ny), allow_pos_inf=True),
        )
        put(
            "peak_price_sgd_per_kw",
            float_array(
                "peak_price_sgd_per_kw",
                self.peak_price_sgd_per_kw,
                ((), (horizon,)),
                target=(horizon,),
            ),
        )
        if self.power_cap is not None:
            put("power_cap", self.power_cap.over(horizon))

    def _normalise_options(self, m: int) -> None:
        """Default and check the affine term g and the reserve mask."""
        if self.affine_term is None:
            affine = np.zeros(self.n)
            affine.setflags(write=False)
        else:
            shapes = ((self.n,), (self.horizon, self.n))
            affine = float_array("affine_term", self.affine_term, shapes)
        self._put("affine_term", affine)
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
        self._put("reserve_mask", mask)

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
                hint="docs/explanation/model.md §3 uses ρ ≈ 100 SGD per K·h",
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
        check_nonnegative("d_sigma", self.d_sigma, "box half-widths σ")
        check_nonnegative("peak_price_sgd_per_kw", self.phi, "peak price φ")
        check_bounds("u_min", self.u_min, "u_max", self.u_max)
        check_bounds("y_min", self.y_min, "y_max", self.y_max)
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
        self._check_blocks()

    def _check_blocks(self) -> None:
        """Check each feature block against the core (and the blocks it needs)."""
        mask = np.asarray(self.reserve_mask, dtype=bool)
        for name, block in (
            ("events", self.events),
            ("commitments", self.commitments),
            ("offer_baselines", self.offer_baselines),
            ("power_cap", self.power_cap),
            ("comfort_knee", self.comfort_knee),
        ):
            wanted = FEATURE_BLOCKS[name]
            if block is not None and not isinstance(block, wanted):
                raise ProblemError(
                    f"expected {wanted.__name__} or None",
                    source=_SOURCE,
                    field=name,
                    value=type(block).__name__,
                    hint=f"build it with hvacflex.opt.{wanted.__name__}(...)",
                )
        if self.events is not None:
            self.events.check(
                horizon=self.horizon, robust=self.robust, b_reserve=self.b_matrix[:, mask]
            )
        if self.commitments is not None:
            self.commitments.check(
                horizon=self.horizon, u_min=self.u_min, u_max=self.u_max, reserve_mask=mask
            )
        if self.offer_baselines is not None:
            self.offer_baselines.check(horizon=self.horizon, events=self.events, robust=self.robust)
        if self.comfort_knee is not None:
            self.comfort_knee.check(rho=self.comfort_penalty_sgd_per_kelvin_hour)
        if self.step_linearisation is not None:
            self.step_linearisation.check(horizon=self.horizon, m=self.m, robust=self.robust)
        self._check_feedback()

    @property
    def fixed_reserve_steps(self) -> int:
        """g, the number of leading steps whose reserve is committed (0 without a commitment)."""
        return 0 if self.commitments is None else self.commitments.steps

    @property
    def power_max_kw(self) -> FloatArray:
        """(N,) the cap on the plan's power P_k [kW]; +inf where none (no ``power_cap``)."""
        if self.power_cap is None:
            return np.full(self.horizon, np.inf)
        return self.power_cap.kw

    def _check_feedback(self) -> None:
        if self.power_cap is not None:
            self.power_cap.check(robust=self.robust)
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
        assert self.feedback is not None
        self.feedback.check(ny=self.ny, m=self.m)

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

    def with_price_and_cap(
        self,
        energy_price_sgd_per_mwh: FloatArray,
        power_max_kw: float | FloatArray = np.inf,
    ) -> RMPCProblem:
        """This problem with another energy price (N,) [SGD/MWh] and power cap (scalar or
        (N,)) [kW] — equal to ``dataclasses.replace(self, energy_price_sgd_per_mwh=...,
        power_cap=PowerCap(power_max_kw=...))``, but only the two new fields are checked (the
        rest was) and the :attr:`structure` object is shared (the cap becomes ``power_cap``;
        None if +inf everywhere), so a warm :class:`~hvacflex.opt.RMPCSolver`
        needs no structure comparison (fleet coordination re-solves one step at many prices).

        Raises
        ------
        ProblemError
            as the constructor does for these two fields.
        """
        horizon = self.horizon
        price = float_array("energy_price_sgd_per_mwh", energy_price_sgd_per_mwh, ((horizon,),))
        cap = PowerCap(power_max_kw=power_max_kw).over(horizon)
        variant = copy.copy(self)
        variant._put("energy_price_sgd_per_mwh", price)
        variant._put("power_cap", cap if np.isfinite(cap.kw).any() else None)
        variant._check_feedback()
        return variant

    @property
    def input_scale(self) -> FloatArray | None:
        """(N, m) s_k of ``step_linearisation`` (None without it: B at every step)."""
        block = self.step_linearisation
        return None if block is None else block.input_scale

    @property
    def step_b_matrix(self) -> FloatArray:
        """(N, n, m) B diag(s_k) of each step (B at every step without ``input_scale``)."""
        return self.structure.step_b_matrix

    def scaled_flows(self, flows_kg_s: FloatArray, inputs: IntArray | None = None) -> FloatArray:
        """(N, k) flows [kg/s] of the inputs ``inputs`` (all m when None) as B's columns
        see them: s_k ⊙ flows (the flows themselves without ``input_scale``)."""
        if self.input_scale is None:
            return flows_kg_s
        scale = self.input_scale if inputs is None else self.input_scale[:, inputs]
        scaled: FloatArray = flows_kg_s * scale
        return scaled

    @property
    def g(self) -> FloatArray:
        """(n,) affine term of the dynamics [K], or (N, n) one per step."""
        return np.asarray(self.affine_term, dtype=np.float64)

    @property
    def phi(self) -> FloatArray:
        """(N,) peak price φ_k [SGD/kW]."""
        return np.asarray(self.peak_price_sgd_per_kw, dtype=np.float64)
