"""What a caller chooses about the optimisation, and the fixed constants of the LP objective.

The one home of the robust modes (:data:`RobustMode`), the feedback policy structures
(:data:`FeedbackStructure`, :class:`FeedbackOptions`), the default comfort penalty ρ and the
reserve tie-break. Imports nothing from the rest of :mod:`hvacflex.opt`, so every module of
the package (and the scenario configuration) can import it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from hvacflex.errors import ProblemError

RobustMode = Literal["tightening", "dual", "none", "feedback"]
"""How the problem is made robust: δ in the bounds, explicit dual λ's, nominal (δ = 0), or
affine disturbance-feedback policies (:mod:`hvacflex.opt.feedback`)."""
ROBUST_MODES: tuple[str, ...] = get_args(RobustMode)

FeedbackStructure = Literal["full", "memory", "zone-local", "time-invariant"]
"""Which gains an affine disturbance-feedback policy has (:mod:`hvacflex.opt.feedback`)."""
FEEDBACK_STRUCTURES: tuple[str, ...] = get_args(FeedbackStructure)

DEFAULT_COMFORT_PENALTY_SGD_PER_KELVIN_HOUR = 100.0
"""Default comfort penalty ρ [SGD per K·h] (an exact penalty at the paper's scale)."""

DEFAULT_COMFORT_PENALTY_BEYOND_KNEE_SGD_PER_KELVIN_HOUR = 1000.0
"""Default ρ₂, the price of a zone's slack beyond a comfort knee [SGD per K·h]."""

RESERVE_TIE_BREAK_SGD_PER_KG_S_HOUR = 1e-5
"""Cost per kg/s of reserve flow per hour that breaks the b = 0 tie towards r = 0
[SGD/(kg/s·h)]; excluded from the reported objective."""

UNSEEN_TIE_BREAK_SGD_PER_KW_HOUR = 1e-6
"""Cost per kW of the unseen rise σ per hour on top of the reserve price, so that the paid
capacity R and σ are not raised together at no cost (:func:`hvacflex.opt.lp.add_visible_offers`)
[SGD/(kW·h)]."""

_FEEDBACK_SOURCE = "RMPCProblem.feedback"


@dataclass(frozen=True)
class FeedbackOptions:
    """Structure of the affine disturbance-feedback policy (``RMPCProblem.robust="feedback"``).

    Parameters
    ----------
    structure : "full", "memory", "zone-local" or "time-invariant"
        (:mod:`hvacflex.opt.feedback`)
    memory_steps : L ≥ 1, for "memory" and "time-invariant": innovations older than L steps
        get no gain (the gains' lag k − j is at most L)
    zero_gains : force all gains to zero (the open-loop RMPC; for verification)
    """

    structure: FeedbackStructure = "time-invariant"
    memory_steps: int = 4
    zero_gains: bool = False

    def __post_init__(self) -> None:
        if self.structure not in FEEDBACK_STRUCTURES:
            raise ProblemError(
                f"unknown feedback structure; expected one of {FEEDBACK_STRUCTURES}",
                source=_FEEDBACK_SOURCE,
                field="structure",
                value=self.structure,
            )
        if (
            isinstance(self.memory_steps, bool)
            or not isinstance(self.memory_steps, int)
            or self.memory_steps < 1
        ):
            raise ProblemError(
                "memory must be an integer ≥ 1 step",
                source=_FEEDBACK_SOURCE,
                field="memory_steps",
                value=self.memory_steps,
            )

    def check(self, *, ny: int, m: int) -> None:
        """Zone-local feedback pairs input i with comfort output i: it needs ny = m."""
        if self.structure == "zone-local" and ny != m:
            raise ProblemError(
                f"zone-local feedback pairs input i with comfort output i, but ny = {ny} ≠ m = {m}",
                source=_FEEDBACK_SOURCE,
                field="structure",
                value=self.structure,
                hint="use structure 'time-invariant', 'memory' or 'full'",
            )
