"""Sentences of the report, computed from the results.

Every claim the report makes about the runs (which scenario costs more, whether a controller
keeps comfort, whether the peak-power price lowers the peak, why reserve revenue is zero) is
produced here from the numbers, so the text says what the results show, not what the paper
found. Each function takes plain numbers (SGD, kW, K·h) and returns one sentence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

COMFORT_TOLERANCE_KELVIN_HOURS = 0.01
"""Discomfort [K·h] up to which a run counts as keeping the comfort band (numerical noise)."""

SAME_RELATIVE = 0.001
"""Relative difference below which two costs or peaks are reported as equal (0.1 %)."""


def _relative_change(new: float, old: float) -> float:
    """``(new − old) / |old|``, or NaN when ``old`` is 0."""
    return (new - old) / abs(old) if old != 0 else math.nan


def rises(value: float, reference: float) -> bool:
    """True when ``value`` exceeds ``reference`` by more than :data:`SAME_RELATIVE` of it
    (a strictly positive value against a zero reference rises)."""
    return value - reference > SAME_RELATIVE * abs(reference)


def keeps_comfort(discomfort_kelvin_hours: float) -> bool:
    """True when the discomfort is within :data:`COMFORT_TOLERANCE_KELVIN_HOURS`."""
    return discomfort_kelvin_hours <= COMFORT_TOLERANCE_KELVIN_HOURS


def cost_comparison(label: str, cost_sgd: float, reference: str, reference_cost_sgd: float) -> str:
    """``"(b) RMPC costs 3.1 % more than (a) NMPC (120.50 vs 116.88 SGD)."`` with the sign
    and the size from the numbers (net costs [SGD] over the same period)."""
    change = _relative_change(cost_sgd, reference_cost_sgd)
    numbers = f"({cost_sgd:,.2f} vs {reference_cost_sgd:,.2f} SGD)"
    if math.isnan(change):
        return f"{label} costs {cost_sgd:,.2f} SGD; {reference} costs nothing {numbers}."
    if abs(change) < SAME_RELATIVE:
        return f"{label} costs the same as {reference} to within 0.1 % {numbers}."
    direction = "more" if change > 0 else "less"
    return f"{label} costs {100 * abs(change):.1f} % {direction} than {reference} {numbers}."


def robustness_cost(nominal_cost_sgd: float, robust_cost_sgd: float) -> str:
    """Whether robustness costs extra, as the paper finds, from (a) and (b)'s net costs."""
    sentence = cost_comparison("(b) RMPC", robust_cost_sgd, "(a) NMPC", nominal_cost_sgd)
    change = _relative_change(robust_cost_sgd, nominal_cost_sgd)
    if change >= SAME_RELATIVE:
        return sentence[:-1] + ": robustness has a price, as in the paper."
    return sentence[:-1] + ": unlike the paper, robustness costs nothing extra here."


def peak_comparison(label: str, peak_kw: float, reference: str, reference_peak_kw: float) -> str:
    """Whether ``label`` lowers the peak [kW] against ``reference``, with the change."""
    change = _relative_change(peak_kw, reference_peak_kw)
    numbers = f"{reference_peak_kw:.1f} → {peak_kw:.1f} kW"
    if not math.isnan(change) and change <= -SAME_RELATIVE:
        return f"{label} lowers the peak against {reference} by {100 * -change:.1f} % ({numbers})."
    if not math.isnan(change) and change >= SAME_RELATIVE:
        return f"{label} raises the peak against {reference} by {100 * change:.1f} % ({numbers})."
    return f"{label} does not lower the peak against {reference} ({numbers})."


def ppp_sweep(
    phi_low: float, peak_low_kw: float, phi_high: float, peak_high_kw: float, cost_ratio: float
) -> str:
    """The peak and cost response from the lowest to the highest peak-power price φ.

    ``cost_ratio`` is the operational cost at ``phi_high`` over that at ``phi_low``.
    """
    change = _relative_change(peak_high_kw, peak_low_kw)
    span = f"Raising φ from {phi_low:g} to {phi_high:g} SGD/kW"
    cost = f"operational cost × {cost_ratio:.3f}" if math.isfinite(cost_ratio) else ""
    if not math.isnan(change) and change <= -SAME_RELATIVE:
        head = (
            f"{span} lowers the peak by {100 * -change:.1f} % "
            f"({peak_low_kw:.1f} → {peak_high_kw:.1f} kW)"
        )
    else:
        head = f"{span} does not lower the peak ({peak_low_kw:.1f} → {peak_high_kw:.1f} kW)"
    return f"{head}; {cost}." if cost else f"{head}."


def comfort(label: str, discomfort_kelvin_hours: float) -> str:
    """``"(a) NMPC keeps the comfort band (0.00 K·h)."`` or ``"… runs over the band …"``."""
    if keeps_comfort(discomfort_kelvin_hours):
        return f"{label} keeps the comfort band ({discomfort_kelvin_hours:.2f} K·h)."
    return f"{label} runs over the comfort band by {discomfort_kelvin_hours:.2f} K·h."


def nominal_vs_robust_comfort(
    nominal_kelvin_hours: float, robust_kelvin_hours: float, where: str
) -> str:
    """The comfort comparison of nominal and robust MPC, set against the paper's finding
    (nominal runs over the band, robust does not)."""
    nominal_ok = keeps_comfort(nominal_kelvin_hours)
    robust_ok = keeps_comfort(robust_kelvin_hours)
    numbers = f"{nominal_kelvin_hours:.2f} vs {robust_kelvin_hours:.2f} K·h"
    if not nominal_ok and robust_ok:
        return (
            f"{where}, the nominal MPC runs over the band and the robust one does not "
            f"({numbers}) — the paper's finding."
        )
    if nominal_ok and robust_ok:
        return (
            f"{where}, both the nominal and the robust MPC keep the band ({numbers}): "
            "these errors do not show the value of robustness."
        )
    if not nominal_ok and not robust_ok:
        return (
            f"{where}, both the nominal and the robust MPC run over the band ({numbers}) — "
            "the robust one should not; check its uncertainty box against the realised errors."
        )
    return (
        f"{where}, the robust MPC runs over the band and the nominal one does not "
        f"({numbers}) — contrary to the paper's finding."
    )


def _join(labels: Sequence[str]) -> str:
    """``["x"]`` → ``"x"``, ``["x", "y", "z"]`` → ``"x, y and z"``."""
    return labels[0] if len(labels) == 1 else f"{', '.join(labels[:-1])} and {labels[-1]}"


def reserve_revenue(label: str, revenue_sgd: float, energy_cost_sgd: float) -> str:
    """``"(a) NMPC earns 2.31 SGD of reserve revenue, 1.00 % of its energy cost."``"""
    share = 100 * revenue_sgd / energy_cost_sgd if energy_cost_sgd > 0 else math.nan
    tail = f", {share:.2f} % of its energy cost" if math.isfinite(share) else ""
    return f"{label} earns {revenue_sgd:,.2f} SGD of reserve revenue{tail}."


def no_reserve(
    labels: Sequence[str], *, offered: bool, robust: bool, event_steps: int | None = None
) -> str:
    """Why the scenarios ``labels`` earn no reserve revenue.

    Parameters
    ----------
    labels : the scenarios with zero reserve revenue.
    offered : whether their configuration lets the controller offer reserve (False: the
        configuration offers none).
    robust : whether any of them plans against the uncertainty box.
    event_steps : D of their IL event model (an activation of up to D periods anywhere in the
        horizon); None for the paper's whole-horizon model (curtailed for the whole horizon).
    """
    names = _join(labels)
    plural = len(labels) > 1
    if not offered:
        which = "their configurations offer" if plural else "its configuration offers"
        return f"{names} earn{'' if plural else 's'} no reserve revenue: {which} no reserve."
    margin = (
        " (and, for a robust controller, for every forecast error in the box)" if robust else ""
    )
    who = "none of them" if plural else "it"
    if event_steps is None:
        called = "curtailed for the whole horizon"
    else:
        called = (
            f"called for up to {event_steps} periods at any time in the horizon (within the "
            "event's comfort allowance)"
        )
    return (
        f"{names} earn{'' if plural else 's'} no reserve revenue: {who} offered reserve in any "
        "period. An offer must keep every zone in the comfort band if the reserve is "
        f"{called}{margin}, and at these (synthetic) reserve prices the optimiser found no "
        "offer whose revenue pays for the extra cooling this needs."
    )


PAPER_REVENUE_CHANGE_PCT = {"(b)": 1.7, "(c)": 12.0}
"""Reserve revenue of (b) and (c) against (a) in the paper's Table 1 [%]: it rises in both."""

NEGLIGIBLE_REVENUE_SGD = 1e-6
"""Revenue below this is zero up to solver tolerance [SGD]."""


def _revenue_move(revenue_sgd: float, reference_sgd: float) -> tuple[int, str]:
    """(+1 rises / 0 same / −1 falls, phrase) of a revenue against (a)'s."""
    change = _relative_change(revenue_sgd, reference_sgd)
    if math.isnan(change):
        if revenue_sgd > NEGLIGIBLE_REVENUE_SGD:
            return 1, "rises from nothing"
        return 0, "stays at zero"
    if abs(change) < SAME_RELATIVE:
        return 0, "stays the same"
    verb = "rises" if change > 0 else "falls"
    return (1 if change > 0 else -1), f"{verb} by {100 * abs(change):.1f} %"


def revenue_trend(
    model: str, revenue_a_sgd: float, revenue_b_sgd: float, revenue_c_sgd: float
) -> str:
    """Whether reserve revenue rises in (b) and (c) against (a) under ``model``, set against the
    paper's finding (it rises in both), from the three runs' reserve revenue [SGD]."""
    numbers = (
        f"(a) {revenue_a_sgd:,.2f}, (b) {revenue_b_sgd:,.2f}, (c) {revenue_c_sgd:,.2f} SGD "
        "over the run"
    )
    if max(revenue_a_sgd, revenue_b_sgd, revenue_c_sgd) <= NEGLIGIBLE_REVENUE_SGD:
        return (
            f"Under {model} no scenario earns reserve revenue ({numbers}), so the paper's "
            "rise in (b) and (c) cannot appear."
        )
    sign_b, move_b = _revenue_move(revenue_b_sgd, revenue_a_sgd)
    sign_c, move_c = _revenue_move(revenue_c_sgd, revenue_a_sgd)
    head = (
        f"Under {model}, reserve revenue {move_b} in (b) and {move_c} in (c) "
        f"against (a) ({numbers})"
    )
    if sign_b > 0 and sign_c > 0:
        return f"{head} — as in the paper."
    paper = ", ".join(f"{k} +{v:g} %" for k, v in PAPER_REVENUE_CHANGE_PCT.items())
    return f"{head} — unlike the paper, where it rises in both ({paper})."
