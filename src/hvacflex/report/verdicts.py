"""Verdicts on the paper's findings, computed from the runs: holds, does not hold, or not
comparable — each with the paper's number and ours.

The findings are those of Hanif et al. (2016) that the reproduction can test
(docs/explanation/model.md §5: "expected shape, not numbers"):

* robustness costs a few per cent: (b) RMPC costs more than (a) NMPC, by at most
  :data:`FEW_PERCENT_MAX_PCT` (paper: +4.0 %);
* the peak-power price costs more: (c) costs more than (b) (paper: +2.2 %);
* the peak-power price lowers the peak: (c)'s peak below (b)'s (paper: Fig. 6);
* NMPC violates comfort under uncertainty, RMPC almost never;
* reserve revenue rises in (b) and (c) against (a) (paper: +1.7 %, +12 %);
* the peak reduction saturates beyond about :data:`SATURATION_PRICE_SGD_PER_KW` SGD/kW
  (Fig. 7): at least :data:`SATURATION_SHARE` of the reduction over the sweep is reached there;
* and two that cannot be compared: the level of cost (the paper's building is unpublished)
  and reserve revenue ≈ 1 % of energy cost (the synthetic reserve price is calibrated to it).

Each function takes plain numbers (SGD, kW, K·h) and a ``basis`` (what the numbers were
graded on: plant, period, scaling) and returns a :class:`Verdict`; :func:`verdict_table`
lays them out. Two questions a user asks — does peak shaving pay, does selling reserve work —
are answered from the "does it pay?" table (:mod:`hvacflex.report.does_it_pay`) by
:func:`peak_shaving_answer` and :func:`reserve_answer`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import pandas as pd

from hvacflex.errors import InputError
from hvacflex.report.text import COMFORT_TOLERANCE_KELVIN_HOURS, SAME_RELATIVE, rises

HOLDS = "holds"
DOES_NOT_HOLD = "does not hold"
NOT_COMPARABLE = "not comparable"
VERDICTS = (HOLDS, DOES_NOT_HOLD, NOT_COMPARABLE)
"""The three verdicts."""

FEW_PERCENT_MAX_PCT = 10.0
"""Largest robust premium [%] that still reads as the paper's "a few per cent"."""

SATURATION_PRICE_SGD_PER_KW = 5.0
"""Peak-power price [SGD/kW] beyond which the paper's Fig. 7 shows little more reduction."""

SATURATION_SHARE = 2.0 / 3.0
"""Share of the sweep's whole peak reduction that must be reached at φ ≤
:data:`SATURATION_PRICE_SGD_PER_KW` for the reduction to count as saturating."""

MIN_PEAK_REDUCTION_SHARE = 0.02
"""A sweep whose peak falls by less than this share of its lowest-φ peak over the whole
sweep has no reduction to saturate (0.1 kW of 52 kW reached "2,400 %" by φ = 5 otherwise)."""

ALMOST_NEVER_SHARE = 0.1
"""RMPC "almost never" violates comfort: its discomfort is within the tolerance or at most
this share of NMPC's."""

PAPER_MONTHLY_ENERGY_COST_SGD = {"a": 1471.0, "b": 1530.0, "c": 1565.0}
"""Table 1's monthly average energy cost per scenario [SGD/month]."""

PAPER_MONTHLY_RESERVE_REVENUE_SGD = {"a": 15.25, "b": 15.52, "c": 17.10}
"""Table 1's monthly average reserve revenue per scenario [SGD/month]."""


@dataclass(frozen=True)
class Verdict:
    """One paper finding judged against our runs.

    Attributes
    ----------
    finding : the paper's claim, in a sentence.
    paper : the paper's number(s).
    ours : our number(s).
    verdict : one of :data:`VERDICTS`.
    basis : what our numbers were graded on (plant, period, scaling).
    key : the finding's identifier (keyword only), e.g. ``"robustness_premium"``: the column
        of the seed study's per-week-seed table (:mod:`hvacflex.robustness`).
    """

    finding: str
    paper: str
    ours: str
    verdict: str
    basis: str
    key: str = field(kw_only=True)

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise InputError(
                "unknown verdict", field="verdict", value=self.verdict, hint=f"one of {VERDICTS}"
            )


def _change_pct(new: float, old: float) -> float:
    """``100 (new − old) / |old|`` [%], NaN when ``old`` is 0."""
    return 100.0 * (new - old) / abs(old) if old != 0 else math.nan


def _paper_change_pct(new: str, old: str) -> float:
    return _change_pct(PAPER_MONTHLY_ENERGY_COST_SGD[new], PAPER_MONTHLY_ENERGY_COST_SGD[old])


def robustness_premium(nominal_cost_sgd: float, robust_cost_sgd: float, basis: str) -> Verdict:
    """(b) costs more than (a) by a few per cent (0.1 % … :data:`FEW_PERCENT_MAX_PCT`).

    Parameters
    ----------
    nominal_cost_sgd, robust_cost_sgd : energy cost of (a) and (b) over the same period [SGD].
    """
    change = _change_pct(robust_cost_sgd, nominal_cost_sgd)
    holds = 100.0 * SAME_RELATIVE <= change <= FEW_PERCENT_MAX_PCT
    return Verdict(
        finding="Robustness costs a few per cent: (b) RMPC costs more than (a) NMPC",
        paper=f"{_paper_change_pct('b', 'a'):+.1f} % energy cost (1,471 → 1,530 SGD/month)",
        ours=f"{change:+.1f} % energy cost ({nominal_cost_sgd:,.2f} → {robust_cost_sgd:,.2f} SGD)",
        verdict=HOLDS if holds else DOES_NOT_HOLD,
        basis=basis,
        key="robustness_premium",
    )


def peak_price_costs_more(robust_cost_sgd: float, ppp_cost_sgd: float, basis: str) -> Verdict:
    """(c) costs more than (b): the energy bought to flatten the peak."""
    change = _change_pct(ppp_cost_sgd, robust_cost_sgd)
    return Verdict(
        finding="The peak-power price costs energy: (c) costs more than (b)",
        paper=f"{_paper_change_pct('c', 'b'):+.1f} % energy cost (1,530 → 1,565 SGD/month)",
        ours=f"{change:+.1f} % energy cost ({robust_cost_sgd:,.2f} → {ppp_cost_sgd:,.2f} SGD)",
        verdict=HOLDS if change >= 100.0 * SAME_RELATIVE else DOES_NOT_HOLD,
        basis=basis,
        key="ppp_costs_more",
    )


def peak_price_lowers_peak(robust_peak_kw: float, ppp_peak_kw: float, basis: str) -> Verdict:
    """(c) has a lower peak than (b)."""
    change = _change_pct(ppp_peak_kw, robust_peak_kw)
    return Verdict(
        finding="The peak-power price lowers the peak: (c) below (b)",
        paper="lower (Fig. 6, 7; no number published)",
        ours=f"{change:+.1f} % ({robust_peak_kw:.1f} → {ppp_peak_kw:.1f} kW)",
        verdict=HOLDS if change <= -100.0 * SAME_RELATIVE else DOES_NOT_HOLD,
        basis=basis,
        key="ppp_lowers_peak",
    )


def robust_keeps_comfort(
    nominal_kelvin_hours: float, robust_kelvin_hours: float, basis: str, *, case: str = ""
) -> Verdict:
    """NMPC violates comfort, RMPC almost never (:data:`ALMOST_NEVER_SHARE`); ``case`` names
    the disturbances (e.g. "hot corner") in the finding, so that two cases stay apart."""
    nominal_violates = nominal_kelvin_hours > COMFORT_TOLERANCE_KELVIN_HOURS
    robust_almost_never = robust_kelvin_hours <= max(
        COMFORT_TOLERANCE_KELVIN_HOURS, ALMOST_NEVER_SHARE * nominal_kelvin_hours
    )
    return Verdict(
        finding="NMPC violates comfort under uncertainty, RMPC almost never"
        + (f" ({case})" if case else ""),
        paper="NMPC violates (Fig. 5), RMPC keeps the band",
        ours=f"NMPC {nominal_kelvin_hours:.3g} K·h, RMPC {robust_kelvin_hours:.3g} K·h",
        verdict=HOLDS if nominal_violates and robust_almost_never else DOES_NOT_HOLD,
        basis=basis,
        key="robust_keeps_comfort",
    )


def reserve_revenue_rises(
    nominal_sgd: float, robust_sgd: float, ppp_sgd: float, basis: str
) -> Verdict:
    """Reserve revenue rises in (b) and (c) against (a) (each by more than
    :data:`~hvacflex.report.text.SAME_RELATIVE`, :func:`~hvacflex.report.text.rises`); not
    comparable when (a) earns none."""
    paper = PAPER_MONTHLY_RESERVE_REVENUE_SGD
    paper_text = (
        f"(b) {_change_pct(paper['b'], paper['a']):+.1f} %, "
        f"(c) {_change_pct(paper['c'], paper['a']):+.1f} %"
    )
    finding = "Reserve revenue rises in (b) and (c) against (a)"
    if abs(nominal_sgd) < 1e-6:
        return Verdict(
            finding,
            paper_text,
            f"(a) earns no reserve revenue ((b) {robust_sgd:,.2f}, (c) {ppp_sgd:,.2f} SGD)",
            NOT_COMPARABLE,
            basis,
            key="revenue_rises",
        )
    ours = (
        f"(b) {_change_pct(robust_sgd, nominal_sgd):+.1f} %, "
        f"(c) {_change_pct(ppp_sgd, nominal_sgd):+.1f} % ((a) {nominal_sgd:,.2f} SGD)"
    )
    both = rises(robust_sgd, nominal_sgd) and rises(ppp_sgd, nominal_sgd)
    return Verdict(
        finding, paper_text, ours, HOLDS if both else DOES_NOT_HOLD, basis, key="revenue_rises"
    )


def peak_reduction_saturates(
    peak_price_sgd_per_kw: Sequence[float], peak_power_kw: Sequence[float], basis: str
) -> Verdict:
    """The peak reduction saturates beyond :data:`SATURATION_PRICE_SGD_PER_KW`: at least
    :data:`SATURATION_SHARE` of the reduction from the lowest to the highest φ is reached at
    φ ≤ that price; does not hold when the sweep lowers the peak by no more than
    :data:`MIN_PEAK_REDUCTION_SHARE`. Not comparable when the sweep does not straddle it.

    Parameters
    ----------
    peak_price_sgd_per_kw, peak_power_kw : (z,) the sweep's φ [SGD/kW] and peaks [kW].
    """
    sweep = pd.Series(list(peak_power_kw), index=list(peak_price_sgd_per_kw)).sort_index()
    finding = f"The peak reduction saturates beyond ~{SATURATION_PRICE_SGD_PER_KW:g} SGD/kW"
    paper = f"Fig. 7: little further reduction beyond ~{SATURATION_PRICE_SGD_PER_KW:g} SGD/kW"
    low, high = float(sweep.index[0]), float(sweep.index[-1])
    if not low < SATURATION_PRICE_SGD_PER_KW < high:
        ours = f"sweep φ {low:g}–{high:g} SGD/kW does not straddle it"
        return Verdict(finding, paper, ours, NOT_COMPARABLE, basis, key="peak_reduction_saturates")
    total_kw = float(sweep.iloc[0] - sweep.iloc[-1])
    at_knee_kw = float(sweep.iloc[0] - sweep[sweep.index <= SATURATION_PRICE_SGD_PER_KW].min())
    if total_kw <= MIN_PEAK_REDUCTION_SHARE * float(sweep.iloc[0]):
        ours = f"no reduction over the sweep ({sweep.iloc[0]:.1f} → {sweep.iloc[-1]:.1f} kW)"
        return Verdict(finding, paper, ours, DOES_NOT_HOLD, basis, key="peak_reduction_saturates")
    share = at_knee_kw / total_kw
    ours = (
        f"{100 * share:.0f} % of the {total_kw:.1f} kW reduction (φ {low:g} → {high:g}) "
        f"reached by φ = {SATURATION_PRICE_SGD_PER_KW:g}"
    )
    return Verdict(
        finding,
        paper,
        ours,
        HOLDS if share >= SATURATION_SHARE else DOES_NOT_HOLD,
        basis,
        key="peak_reduction_saturates",
    )


def cost_level(nominal_monthly_cost_sgd: float, basis: str) -> Verdict:
    """The level of cost: not comparable (the paper's building is unpublished)."""
    return Verdict(
        finding="Level of cost: (a) NMPC per month",
        paper=f"{PAPER_MONTHLY_ENERGY_COST_SGD['a']:,.0f} SGD/month (the year 2014)",
        ours=f"{nominal_monthly_cost_sgd:,.2f} SGD/month (office5: the paper's building is "
        "unpublished)",
        verdict=NOT_COMPARABLE,
        basis=basis,
        key="cost_level",
    )


def reserve_share(
    nominal_revenue_sgd: float, nominal_energy_cost_sgd: float, basis: str
) -> Verdict:
    """Reserve revenue ≈ 1 % of energy cost: not comparable (the synthetic reserve price is
    calibrated on (a) to give it)."""
    paper = PAPER_MONTHLY_RESERVE_REVENUE_SGD["a"] / PAPER_MONTHLY_ENERGY_COST_SGD["a"]
    share = nominal_revenue_sgd / nominal_energy_cost_sgd if nominal_energy_cost_sgd else math.nan
    return Verdict(
        finding="Reserve revenue of (a) ≈ 1 % of its energy cost",
        paper=f"{100 * paper:.2f} %",
        ours=f"{100 * share:.2f} % (the SYNTHETIC reserve price was calibrated to this)",
        verdict=NOT_COMPARABLE,
        basis=basis,
        key="reserve_share",
    )


def scenario_verdicts(
    summaries: Mapping[str, Mapping[str, float]],
    basis: str,
    *,
    comfort_basis: str | None = None,
    comfort_case: str = "",
    revenue_basis: str | None = None,
) -> list[Verdict]:
    """The findings judged on scenarios (a), (b), (c) — key ``a``/``b``/``c`` →
    :func:`hvacflex.kpi.summary` of its run — for those whose runs are there, in the order
    robustness premium, (c) costs more, (c)'s lower peak, comfort, reserve revenue; the comfort
    and revenue verdicts state ``comfort_basis`` / ``revenue_basis`` (default ``basis``)."""
    a, b, c = (summaries.get(key) for key in ("a", "b", "c"))
    found: list[Verdict] = []
    if a is not None and b is not None:
        found.append(robustness_premium(a["energy_cost_sgd"], b["energy_cost_sgd"], basis))
    if b is not None and c is not None:
        found.append(peak_price_costs_more(b["energy_cost_sgd"], c["energy_cost_sgd"], basis))
        found.append(peak_price_lowers_peak(b["peak_power_kw"], c["peak_power_kw"], basis))
    if a is not None and b is not None:
        found.append(
            robust_keeps_comfort(
                a["discomfort_kelvin_hours"],
                b["discomfort_kelvin_hours"],
                comfort_basis or basis,
                case=comfort_case,
            )
        )
    if a is not None and b is not None and c is not None:
        found.append(
            reserve_revenue_rises(
                a["reserve_revenue_sgd"],
                b["reserve_revenue_sgd"],
                c["reserve_revenue_sgd"],
                revenue_basis or basis,
            )
        )
    return found


VERDICT_COLUMNS = ("finding", "verdict", "paper", "ours", "basis")
"""Columns of :func:`verdict_table`, in order."""


def verdict_table(verdicts: Sequence[Verdict]) -> pd.DataFrame:
    """One row per verdict, columns :data:`VERDICT_COLUMNS` (index: ``finding``)."""
    rows = [{column: getattr(v, column) for column in VERDICT_COLUMNS} for v in verdicts]
    return pd.DataFrame(rows, columns=list(VERDICT_COLUMNS)).set_index("finding")


def _row(table: pd.DataFrame, controller: str) -> pd.Series:
    rows = table[table["controller"] == controller]
    if rows.empty:
        raise InputError(
            "controller not in the does-it-pay table",
            field="controller",
            value=controller,
            hint=f"one of {list(table['controller'])}",
        )
    return rows.iloc[0]


def peak_shaving_answer(table: pd.DataFrame, with_ppp: str, without_ppp: str) -> str:
    """Does peak shaving pay? ``with_ppp`` against ``without_ppp`` (controller names of the
    "does it pay?" table, :func:`hvacflex.report.does_it_pay.does_it_pay`), both billed the
    same peak price; and ``with_ppp`` against the table's reference baseline."""
    shaved, plain = _row(table, with_ppp), _row(table, without_ppp)
    cost, other = (
        float(shaved["tariff_cost_sgd_per_month"]),
        float(plain["tariff_cost_sgd_per_month"]),
    )
    pays = cost < other
    head = "Does peak shaving pay? " + ("Yes" if pays else "No")
    saving = float(shaved["saving_vs_reference_sgd_per_month"])
    peak_charge = float(shaved["peak_charge_sgd_per_month"])
    other_peak_charge = float(plain["peak_charge_sgd_per_month"])
    return (
        f"{head}: under one tariff {with_ppp} costs {cost:,.2f} SGD/month against "
        f"{other:,.2f} for {without_ppp} (peak {float(shaved['peak_power_kw']):.1f} vs "
        f"{float(plain['peak_power_kw']):.1f} kW; billed peak {peak_charge:,.2f} "
        f"vs {other_peak_charge:,.2f} SGD/month), and "
        f"{abs(saving):,.2f} SGD/month {'less' if saving > 0 else 'more'} than the best "
        f"rule-based baseline, {shaved['reference']}."
    )


def reserve_answer(table: pd.DataFrame, offering: str, not_offering: str) -> str:
    """Does selling reserve work? ``offering`` (a controller that plans for IL events) against
    ``not_offering`` (the same controller under a model that offers none, or no reserve), from
    the "does it pay?" table: the revenue, settled against the meter and unsettled
    (availability payments no activation tested), and whether the tariff cost falls by more
    than the energy it costs — on settled money, and with the availability payments."""
    sells, other = _row(table, offering), _row(table, not_offering)
    settled = float(sells["reserve_settled_sgd_per_month"])
    unsettled = float(sells["reserve_unsettled_sgd_per_month"])
    revenue = settled + unsettled
    energy_extra = float(sells["energy_cost_sgd_per_month"]) - float(
        other["energy_cost_sgd_per_month"]
    )
    net = float(other["tariff_cost_sgd_per_month"]) - float(sells["tariff_cost_sgd_per_month"])
    net_with_availability = net + unsettled - float(other["reserve_unsettled_sgd_per_month"])
    if revenue > 0 and net > 0:
        head = "Yes, a little"
    elif revenue > 0 and net_with_availability > 0:
        head = "Only on availability payments no activation settled"
    else:
        head = "No"
    share = revenue / float(sells["energy_cost_sgd_per_month"])
    return (
        f"Does selling reserve work? {head}: {offering} earns {revenue:,.2f} SGD/month of "
        f"reserve revenue ({100 * share:.2f} % of its energy cost, at the SYNTHETIC reserve "
        f"price), {settled:,.2f} of it settled against the meter and {unsettled:,.2f} "
        f"unsettled availability payments, for {energy_extra:+,.2f} SGD/month of energy "
        f"against {not_offering}; under one tariff (settled money) it is {abs(net):,.2f} "
        f"SGD/month {'cheaper' if net > 0 else 'dearer'}, with the availability payments "
        f"{abs(net_with_availability):,.2f} SGD/month "
        f"{'cheaper' if net_with_availability > 0 else 'dearer'}."
    )
