"""The "does it pay?" table: every controller priced with one tariff and ranked against the
best rule-based baseline, per month and per m² (``does_it_pay.csv`` of the reproduction).

**One tariff** for every run, whatever its controller planned for, on money settled against
the meter::

    tariff cost = energy cost + φ × billed peak + IL penalties − settled reserve revenue

with the energy bought at the run's energy price (USEP), the peak billed per calendar month
(φ × the month's largest 30-min average power, :func:`hvacflex.kpi.monthly_ppp_charge_sgd`
at the one φ given, not the φ a controller planned with), the non-delivery penalties and the
**settled** reserve revenue (the activated periods' payments, whose delivery the meter
settled: :func:`hvacflex.kpi.reserve_revenue_settled_sgd`). The **unsettled** availability
payments (reserve paid in periods no activation tested, on the synthetic reserve price when
the scenario names no price file) stand beside it, in ``reserve_unsettled_sgd_per_month``, and
do not rank. **Per month** is :func:`hvacflex.kpi.monthly_average`: sums over the covered
days divided by the month-equivalents covered (a one-week run is scaled to a month), the peak
charge averaged over the months (a partial month's peak is its peak so far). **Per m²**
divides by the building's conditioned floor area (NaN — "not available" — when it is not
known: a model file without floor areas).

Comfort is graded on the **occupied** periods (:func:`hvacflex.kpi.occupied_mask`): the
reference is the best rule-based baseline, the cheapest under the tariff among the baselines
that keep occupied comfort (occupied discomfort ≤
:data:`hvacflex.report.text.COMFORT_TOLERANCE_KELVIN_HOURS`), or among all baselines when none
does; ``pays`` asks for a saving with occupied discomfort no higher than the reference's plus
the tolerance. The unoccupied excursions stand beside it.

Columns of :func:`does_it_pay` (one row per controller, cheapest first)
-----------------------------------------------------------------------
The deciding ones first (:data:`DECIDING_COLUMNS`): ``rank`` (1 = cheapest), ``controller``,
``tariff_cost_sgd_per_month``, ``saving_vs_reference_pct`` (of the reference's tariff cost;
positive = cheaper than it), ``pays``, ``discomfort_occupied_kelvin_hours_per_month``; then
``reserve_unsettled_sgd_per_month``, ``discomfort_unoccupied_kelvin_hours_per_month``,
``saving_vs_reference_sgd_per_month``, ``energy_cost_sgd_per_month``,
``peak_charge_sgd_per_month``, ``il_penalty_sgd_per_month``,
``reserve_settled_sgd_per_month``, ``peak_power_kw`` (mean of the monthly peaks),
``tariff_cost_sgd_per_m2_month``, ``saving_vs_reference_sgd_per_m2_month``, ``rule_based``
(bool), ``reference`` (the best baseline's name).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from pathlib import Path

import pandas as pd

from hvacflex import kpi
from hvacflex.errors import InputError
from hvacflex.report.text import COMFORT_TOLERANCE_KELVIN_HOURS

CSV_NAME = "does_it_pay.csv"
"""The table's file in the reproduction's output folder."""

DECIDING_COLUMNS: tuple[str, ...] = (
    "rank",
    "controller",
    "tariff_cost_sgd_per_month",
    "saving_vs_reference_pct",
    "pays",
    "discomfort_occupied_kelvin_hours_per_month",
)
"""The columns that decide, first in the table and always in view in the report."""

COLUMNS: tuple[str, ...] = (
    *DECIDING_COLUMNS,
    "reserve_unsettled_sgd_per_month",
    "discomfort_unoccupied_kelvin_hours_per_month",
    "saving_vs_reference_sgd_per_month",
    "energy_cost_sgd_per_month",
    "peak_charge_sgd_per_month",
    "il_penalty_sgd_per_month",
    "reserve_settled_sgd_per_month",
    "peak_power_kw",
    "tariff_cost_sgd_per_m2_month",
    "saving_vs_reference_sgd_per_m2_month",
    "rule_based",
    "reference",
)
"""The columns of :func:`does_it_pay`, in order (module docstring)."""

DETAIL_COLUMNS: tuple[str, ...] = tuple(c for c in COLUMNS if c not in DECIDING_COLUMNS)
"""The columns a report shows in an expandable detail, below the deciding ones."""


def tariff_month(results: pd.DataFrame, peak_price_sgd_per_kw: float) -> dict[str, float]:
    """One run's cost per month under the one tariff (module docstring) [SGD/month], its
    unsettled availability payments [SGD/month], its mean monthly peak [kW], its occupied and
    unoccupied discomfort per month [K·h/month] and the month-equivalents it covers
    (``months``)."""
    average = kpi.monthly_average(kpi.monthly_table(results, peak_price_sgd_per_kw))
    months = float(average["months"])
    energy = float(average["energy_cost_sgd"])
    peak = float(average["ppp_charge_sgd"])
    penalty = float(average["il_penalty_sgd"])
    settled = kpi.reserve_revenue_settled_sgd(results) / months
    return {
        "energy_cost_sgd_per_month": energy,
        "peak_charge_sgd_per_month": peak,
        "il_penalty_sgd_per_month": penalty,
        "reserve_settled_sgd_per_month": settled,
        "reserve_unsettled_sgd_per_month": kpi.reserve_revenue_unsettled_sgd(results) / months,
        "tariff_cost_sgd_per_month": energy + peak + penalty - settled,
        "peak_power_kw": float(average["peak_power_kw"]),
        "discomfort_occupied_kelvin_hours_per_month": (
            kpi.discomfort_occupied_kelvin_hours(results) / months
        ),
        "discomfort_unoccupied_kelvin_hours_per_month": (
            kpi.discomfort_unoccupied_kelvin_hours(results) / months
        ),
        "months": months,
    }


def _reference(rows: pd.DataFrame) -> str:
    """The best rule-based baseline (module docstring)."""
    baselines = rows[rows["rule_based"]]
    comfortable = baselines[
        baselines["discomfort_occupied_kelvin_hours_per_month"] * baselines["months"]
        <= COMFORT_TOLERANCE_KELVIN_HOURS
    ]
    pool = comfortable if not comfortable.empty else baselines
    return str(pool["tariff_cost_sgd_per_month"].idxmin())


def does_it_pay(
    frames: Mapping[str, pd.DataFrame],
    rule_based: Collection[str],
    *,
    peak_price_sgd_per_kw: float,
    floor_area_m2: float,
) -> pd.DataFrame:
    """Rank every controller under one tariff against the best rule-based baseline.

    Parameters
    ----------
    frames : controller name → its results frame (:mod:`hvacflex.results`), all of the same
        building and period.
    rule_based : the names in ``frames`` that are rule-based baselines (at least one).
    peak_price_sgd_per_kw : φ of the one tariff [SGD/kW per month].
    floor_area_m2 : the building's conditioned floor area [m²]; NaN (or any value that is not
        finite and > 0) when unknown: the per-m² columns are then NaN ("not available").

    Returns
    -------
    DataFrame with :data:`COLUMNS`, one row per controller, cheapest first.

    Raises
    ------
    InputError : no rule-based run among ``frames``.
    """
    baselines = [name for name in frames if name in rule_based]
    if not baselines:
        raise InputError(
            "the does-it-pay table needs a rule-based baseline run",
            field="rule_based",
            value=sorted(rule_based),
            hint=f"include a baseline among the runs {sorted(frames)}",
        )
    area_m2 = floor_area_m2 if math.isfinite(floor_area_m2) and floor_area_m2 > 0 else math.nan
    rows = pd.DataFrame(
        {name: tariff_month(frame, peak_price_sgd_per_kw) for name, frame in frames.items()}
    ).T
    rows["rule_based"] = [name in rule_based for name in rows.index]
    reference = _reference(rows)
    cost = rows["tariff_cost_sgd_per_month"].astype(float)
    reference_cost = float(cost[reference])
    saving = reference_cost - cost
    rows["tariff_cost_sgd_per_m2_month"] = cost / area_m2
    rows["reference"] = reference
    rows["saving_vs_reference_sgd_per_month"] = saving
    rows["saving_vs_reference_sgd_per_m2_month"] = saving / area_m2
    rows["saving_vs_reference_pct"] = 100.0 * saving / abs(reference_cost)
    discomfort = rows["discomfort_occupied_kelvin_hours_per_month"].astype(float) * rows["months"]
    rows["pays"] = (saving > 0) & (
        discomfort <= float(discomfort[reference]) + COMFORT_TOLERANCE_KELVIN_HOURS
    )
    rows = rows.sort_values("tariff_cost_sgd_per_month", kind="stable")
    rows["rank"] = range(1, len(rows) + 1)
    rows["controller"] = rows.index
    table = rows[list(COLUMNS)].reset_index(drop=True)
    return table.astype({"rank": int, "rule_based": bool, "pays": bool})


def write_does_it_pay(table: pd.DataFrame, out_dir: Path) -> Path:
    """Write ``table`` as :data:`CSV_NAME` in ``out_dir``; its path."""
    path = Path(out_dir) / CSV_NAME
    table.to_csv(path, index=False)  # NaN (e.g. per m² without a floor area): empty
    return path
