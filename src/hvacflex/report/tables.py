"""The paper's Table 1 from our runs, the published values beside it, and table rendering.

Table 1 of Hanif et al. (2016) gives, for scenarios (a) NMPC, (b) RMPC and (c) RMPC with a
PPP of 1.5 SGD/kW over 2014, the monthly average energy cost, reserve revenue and "Total"
(= cost − revenue; the PPP charge is not in it), with the % change against (a).
:func:`table1` builds the same layout from :func:`hvacflex.kpi.monthly_table` outputs; the
averaging over months (partial months included) is :func:`hvacflex.kpi.monthly_average`'s.
"""

from __future__ import annotations

import html
import math
import numbers
from collections.abc import Mapping

import numpy as np
import pandas as pd

from hvacflex import kpi
from hvacflex.errors import InputError

TABLE1_QUANTITIES = ("energy_cost_sgd", "reserve_revenue_sgd", "net_cost_sgd")
"""Monthly-average quantities of Table 1 [SGD per month]."""

TABLE1_COLUMNS = (
    "energy_cost_sgd",
    "energy_cost_change_pct",
    "reserve_revenue_sgd",
    "reserve_revenue_change_pct",
    "net_cost_sgd",
    "net_cost_change_pct",
)
"""Columns of :func:`table1` and :data:`PAPER_TABLE1`, in display order."""

TABLE1_IL_COLUMNS = (
    "il_offered_kwh",
    "il_delivered_metered_kwh",
    "il_shortfall_kwh",
    "il_penalty_sgd",
    "il_net_revenue_sgd",
)
"""The reserve's settlement beside Table 1 [per month]: capacity due in activated periods,
delivered against the metered baseline, shortfall, penalty, and net revenue (revenue −
penalty). Not in the published table (the paper activates nothing)."""

PAPER_TABLE1 = pd.DataFrame(
    {
        "energy_cost_sgd": [1471.0, 1530.0, 1565.0],
        "energy_cost_change_pct": [0.0, 4.0, 6.4],
        "reserve_revenue_sgd": [15.25, 15.52, 17.10],
        "reserve_revenue_change_pct": [0.0, 1.7, 12.0],
        "net_cost_sgd": [1455.8, 1514.5, 1547.9],
        "net_cost_change_pct": [0.0, 4.0, 6.3],
    },
    index=pd.Index(["(a) NMPC", "(b) RMPC", "(c) RMPC + PPP 1.5 SGD/kW"], name="scenario"),
)
"""Table 1 as published (monthly averages over 2014, SGD; % vs (a) as printed, rounded).

Treat as read-only; :func:`paper_table1` returns a copy.
"""


def paper_table1() -> pd.DataFrame:
    """A copy of :data:`PAPER_TABLE1`."""
    return PAPER_TABLE1.copy()


NEGLIGIBLE_SGD = 1e-6
"""Amounts below this are zero up to solver tolerance; a change relative to them is undefined."""


def _change_pct(value: float, reference: float) -> float:
    if math.isnan(reference) or abs(reference) < NEGLIGIBLE_SGD:
        return math.nan
    return 100.0 * (value / reference - 1.0)


def table1(monthly: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Table 1 from our runs: monthly averages and % change against the first scenario.

    Parameters
    ----------
    monthly : scenario label → :func:`hvacflex.kpi.monthly_table` of that run, in display
        order; the first is the reference (the paper's (a)).

    Returns
    -------
    DataFrame indexed by scenario (``scenario``) with :data:`TABLE1_COLUMNS` [SGD per month,
    %], :data:`TABLE1_IL_COLUMNS` [kWh or SGD per month] where the tables have them, and
    ``months`` (month-equivalents averaged over) and ``days`` (days covered).
    """
    if not monthly:
        raise InputError("table1 needs at least one scenario", field="monthly", value={})
    averages = {label: kpi.monthly_average(table) for label, table in monthly.items()}
    reference = next(iter(averages.values()))
    rows = {}
    for label, average in averages.items():
        row: dict[str, float] = {}
        for quantity in TABLE1_QUANTITIES:
            value = float(average[quantity])
            row[quantity] = value
            row[quantity.replace("_sgd", "_change_pct")] = _change_pct(
                value, float(reference[quantity])
            )
        for quantity in TABLE1_IL_COLUMNS:
            if quantity in average.index:
                row[quantity] = float(average[quantity])
        row["months"] = float(average["months"])
        row["days"] = float(average["days"])
        rows[label] = row
    frame = pd.DataFrame.from_dict(rows, orient="index")
    settled = [c for c in TABLE1_IL_COLUMNS if c in frame.columns]
    return frame[[*TABLE1_COLUMNS, *settled, "months", "days"]].rename_axis("scenario")


def side_by_side(ours: pd.DataFrame, paper: pd.DataFrame | None = None) -> pd.DataFrame:
    """Our Table 1 beside the published one, row by row in scenario order (a), (b), (c).

    Parameters
    ----------
    ours : :func:`table1` output (its row labels are kept).
    paper : the published table; default :data:`PAPER_TABLE1`.

    Returns
    -------
    DataFrame with, for each of :data:`TABLE1_COLUMNS`, a column ``"<name> (ours)"`` and
    ``"<name> (paper)"``, plus ``paper_scenario``; rows beyond the paper's three have NaN
    paper values.
    """
    paper = PAPER_TABLE1 if paper is None else paper
    n = len(ours)
    paper_rows = paper.reindex(paper.index[: min(n, len(paper))]).reset_index()
    paper_rows = paper_rows.reindex(range(n))
    result = pd.DataFrame(index=ours.index)
    result["paper_scenario"] = paper_rows[paper.index.name or "index"].to_numpy()
    for column in TABLE1_COLUMNS:
        result[f"{column} (ours)"] = ours[column].to_numpy(float)
        result[f"{column} (paper)"] = paper_rows[column].to_numpy(float)
    return result


RESERVE_MODEL_COLUMN = "reserve_model"
"""Column of :func:`table1_models` naming the reserve model of each row."""


def table1_models(tables: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """Table 1 of several reserve models in one table: one block of rows per model.

    Parameters
    ----------
    tables : reserve model name → a :func:`table1` (or :func:`side_by_side`) output of that
        model's scenarios (a), (b), (c), in display order; each keeps its % against its own
        (a), so the blocks compare the scenarios within a model and the rows across models.

    Returns
    -------
    DataFrame with the rows of every table in order (index ``scenario``, the row labels of the
    tables, which must be distinct) and a first column :data:`RESERVE_MODEL_COLUMN`.
    """
    if not tables:
        raise InputError("table1_models needs at least one model", field="tables", value={})
    labels = [label for table in tables.values() for label in table.index]
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise InputError(
            "scenario labels repeat across reserve models",
            field="tables",
            value=repeated,
            hint="label each model's scenarios distinctly, e.g. '(a) NMPC, whole-horizon'",
        )
    blocks = [table.assign(**{RESERVE_MODEL_COLUMN: model}) for model, table in tables.items()]
    frame = pd.concat(blocks)
    columns = [RESERVE_MODEL_COLUMN, *(c for c in frame.columns if c != RESERVE_MODEL_COLUMN)]
    return frame[columns].rename_axis("scenario")


# ----------------------------------------------------------------------------- rendering


COUNT_NAMES = (
    *kpi.COUNT_KPIS,
    "buildings",
    "feeder_infeasible_steps",
    "coordination_iterations_max",
)
"""KPI names whose values are counts (printed without decimals, also when stored as float)."""


NOT_AVAILABLE = "not available"
"""A per-m² value of a building whose floor area is unknown."""


def format_value(column: str, value: object) -> str:
    """Display text of one value by the unit in its name (a column or a KPI name).

    NaN as "–" (per m², ``_per_m2``: "not available", the floor area is unknown); booleans
    as "yes" / "no"; integers and counts (:data:`COUNT_NAMES`) whole; ``_pct`` signed with
    one decimal and ``%``; ``_share`` (a fraction) in %; durations ``…_s`` and
    ``max_delta_vs_half_band`` to four significant digits; other numbers with two decimals;
    anything else as ``str``.
    """
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, numbers.Integral):
        return f"{int(value):,d}"
    if isinstance(value, numbers.Real):
        number = float(value)
        if math.isnan(number):
            return NOT_AVAILABLE if "_per_m2" in column else "–"
        if column in COUNT_NAMES:
            return f"{number:,.0f}"
        if "_pct" in column:
            return f"{number:+.1f} %"
        if "_share" in column:
            return f"{100.0 * number:.2f} %"
        if column.endswith("_s") or column == "max_delta_vs_half_band":
            return f"{number:.4g}"
        return f"{number:,.2f}"
    return str(value)


LABELS: dict[str, str] = {
    # the "does it pay?" table (hvacflex.report.does_it_pay)
    "rank": "Rank",
    "controller": "Controller",
    "tariff_cost_sgd_per_month": "Tariff cost [SGD/month]",
    "saving_vs_reference_pct": "Saving vs reference [%]",
    "pays": "Pays",
    "discomfort_occupied_kelvin_hours_per_month": "Occupied discomfort [K·h/month]",
    "reserve_unsettled_sgd_per_month": "Unsettled reserve (availability) [SGD/month]",
    "discomfort_unoccupied_kelvin_hours_per_month": "Unoccupied discomfort [K·h/month]",
    "saving_vs_reference_sgd_per_month": "Saving vs reference [SGD/month]",
    "energy_cost_sgd_per_month": "HVAC energy cost [SGD/month]",
    "peak_charge_sgd_per_month": "HVAC peak charge [SGD/month]",
    "il_penalty_sgd_per_month": "IL penalty [SGD/month]",
    "reserve_settled_sgd_per_month": "Settled reserve [SGD/month]",
    "peak_power_kw": "HVAC peak [kW]",
    "tariff_cost_sgd_per_m2_month": "Tariff cost [SGD/m²/month]",
    "saving_vs_reference_sgd_per_m2_month": "Saving vs reference [SGD/m²/month]",
    "rule_based": "Rule-based",
    "reference": "Reference",
}
"""Human headers with units of the columns the HTML reports show (:func:`to_html`); a
column not listed keeps its name (which carries its unit)."""


_TABLE1_HEADS = {
    "energy_cost_sgd": "HVAC energy cost [SGD/month]",
    "energy_cost_change_pct": "Energy cost vs (a) [%]",
    "reserve_revenue_sgd": "Reserve revenue [SGD/month]",
    "reserve_revenue_change_pct": "Reserve revenue vs (a) [%]",
    "net_cost_sgd": "Total [SGD/month]",
    "net_cost_change_pct": "Total vs (a) [%]",
}

TABLE1_LABELS: dict[str, str] = {
    "scenario": "Scenario",
    "reserve_model": "Reserve model",
    "paper_scenario": "Paper's scenario",
    **_TABLE1_HEADS,
    **{
        f"{name} ({side})": f"{head}, {side}"
        for name, head in _TABLE1_HEADS.items()
        for side in ("ours", "paper")
    },
    "il_offered_kwh": "IL due [kWh/month]",
    "il_delivered_metered_kwh": "IL delivered, metered [kWh/month]",
    "il_shortfall_kwh": "IL shortfall [kWh/month]",
    "il_penalty_sgd": "IL penalty [SGD/month]",
    "il_net_revenue_sgd": "IL net revenue [SGD/month]",
    "months": "Months",
    "days": "Days",
}
"""Headers (human, with units) of :func:`table1` and :func:`side_by_side` in a report."""


def _header_and_rows(frame: pd.DataFrame) -> tuple[list[str], list[list[str]]]:
    index_name = str(frame.index.name) if frame.index.name is not None else ""
    header = [index_name, *(str(col) for col in frame.columns)]
    rows = [
        [
            str(label),
            *(format_value(str(col), value) for col, value in zip(frame.columns, row, strict=True)),
        ]
        for label, row in zip(frame.index, frame.itertuples(index=False), strict=True)
    ]
    return header, rows


def _escape_markdown(text: str) -> str:
    return text.replace("|", r"\|")


def to_markdown(frame: pd.DataFrame) -> str:
    """A GitHub-flavoured Markdown table of ``frame`` (index as first column), cells by
    :func:`format_value`, numbers right-aligned."""
    header, rows = _header_and_rows(frame)
    align = ["---", *("---:" for _ in frame.columns)]
    lines = [
        "| " + " | ".join(_escape_markdown(h) for h in header) + " |",
        "| " + " | ".join(align) + " |",
        *("| " + " | ".join(_escape_markdown(cell) for cell in row) + " |" for row in rows),
    ]
    return "\n".join(lines) + "\n"


def to_html(
    frame: pd.DataFrame, *, caption: str | None = None, labels: Mapping[str, str] | None = None
) -> str:
    """An HTML ``<table class="hvacflex">`` of ``frame`` (index as first column), cells by
    :func:`format_value` (by the column's name), headers by ``labels`` over :data:`LABELS`
    (human, with units), all text escaped; numeric cells carry ``class="num"``."""
    header, rows = _header_and_rows(frame)
    heads = LABELS | dict(labels or {})
    header = [heads.get(name, name) for name in header]
    parts = ['<table class="hvacflex">']
    if caption:
        parts.append(f"<caption>{html.escape(caption)}</caption>")
    parts.append("<thead><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header))
    parts.append("</tr></thead><tbody>")
    numeric = [
        pd.api.types.is_numeric_dtype(frame[col]) and not pd.api.types.is_bool_dtype(frame[col])
        for col in frame.columns
    ]
    for row in rows:
        cells = [f"<th>{html.escape(row[0])}</th>"]
        cells += [
            f'<td class="num">{html.escape(cell)}</td>'
            if is_num
            else f"<td>{html.escape(cell)}</td>"
            for cell, is_num in zip(row[1:], numeric, strict=True)
        ]
        parts.append("<tr>" + "".join(cells) + "</tr>")
    parts.append("</tbody></table>")
    return "\n".join(parts)
