"""Plausibility checks of a fitted model: ``checks.csv`` of ``identify fit``.

One row per finding: ``check``, ``zone`` (a zone's identifier, a coupled pair
``a-b`` as in ``fit_parameters.csv``, a boundary's name, or empty for the whole fit),
``parameter``, ``status`` (``ok`` or ``warning``) and ``detail``. The checks:

* ``bound`` — every free parameter the optimiser left on a bound is a warning naming it (the
  data push it past what physics allows, or do not determine it); a boundary node's outdoor
  conductance at 0 too. One ``ok`` row per zone without any.
* ``sign`` — a negative constant heat gain (heat removed around the clock: a sign the model
  misses a loss) is a warning.
* ``magnitude_per_m2`` — each zone parameter over the zone's floor area against the typical
  office range (:data:`hvacflex.identify.physics.TYPICAL_PER_M2`); without floor areas a
  warning per zone (not checked).
* ``facade_solar`` — sun only through façades the zone has: with the IDF's façades every wall
  aperture is within what faces that way (fixed at 0 where nothing does); without them, a
  fitted wall aperture is a warning (not checked: give ``--idf``).
* ``identifiability`` — a free parameter whose standard error exceeds its value (log
  parameters) or :data:`LINEAR_IDENTIFIABLE_SHARE` of its prior scale and its value (linear
  ones): the data do not determine it; the prior holds it.
* ``validity_range`` — the training data's zone temperatures should reach within
  :data:`FLOAT_MARGIN_K` of the unoccupied bound a controller floats the zones to; else a
  warning per zone (the model would extrapolate).
* ``time_constants`` and ``convergence`` — the fit's own warnings, one row each.

A fit with a warning row says so on the console and in ``fit_report.csv``'s ``warnings``;
``identify fit --strict`` then exits 2.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hvacflex.building.identified import WALL_ORIENTATIONS, IdentifiedValidity
from hvacflex.data.gains import ComfortBand
from hvacflex.identify.fit import LINEAR_PRIOR_SCALE, FitResult
from hvacflex.identify.greybox import ZONE_PARAMETERS, GreyBoxParameters
from hvacflex.identify.model_file import BoundaryNode
from hvacflex.identify.physics import TYPICAL_PER_M2, ZonePhysics

CHECKS_FILE = "checks.csv"
CHECK_COLUMNS = ("check", "zone", "parameter", "status", "detail")
OK, WARNING = "ok", "warning"
LINEAR_IDENTIFIABLE_SHARE = 0.05
"""A linear parameter is undetermined when its standard error exceeds both its |value| and
this share of its prior scale (0.5 m² for an aperture, 0.1 kW for a gain)."""
SOLAR_FITTED_M2 = 0.05
"""A wall aperture above this counts as sun fitted on that façade [m²]."""
UNOCCUPIED_UPPER_DEGC = ComfortBand().unoccupied_degc[1]
"""The unoccupied comfort band's upper bound a controller floats the zones to (30 °C) [°C]."""
FLOAT_MARGIN_K = 2.0
"""A zone's training data should reach within this of that bound [K]."""
BOUNDARY_OUTDOOR_MIN_KW_PER_K = 1e-6
"""A boundary node's outdoor conductance at or below this sits on its bound 0 [kW/K]."""


@dataclass(frozen=True)
class FitContext:
    """What the checks look at besides the fit: ``zones`` (m,) identifiers,
    ``boundaries`` (nb,) names and their nodes, ``physics`` (m,) per zone, ``validity`` the
    training data's range."""

    zones: tuple[str, ...]
    physics: tuple[ZonePhysics, ...]
    boundaries: tuple[str, ...] = ()
    boundary_nodes: tuple[BoundaryNode, ...] = ()
    validity: IdentifiedValidity | None = None


def _row(check: str, zone: str, parameter: str, status: str, detail: str) -> dict[str, str]:
    return dict(zip(CHECK_COLUMNS, (check, zone, parameter, status, detail), strict=True))


def _with_ok_rows(
    rows: list[dict[str, str]], check: str, zones: Sequence[str], detail: str
) -> list[dict[str, str]]:
    """``rows`` of one check followed by an OK row saying ``detail`` for every zone of
    ``zones`` that none of them flags."""
    flagged = {row["zone"] for row in rows}
    return rows + [_row(check, zone, "", OK, detail) for zone in zones if zone not in flagged]


def parameter_rows(p: GreyBoxParameters, context: FitContext) -> list[tuple[str, str, str, float]]:
    """(zone label, parameter, kind, value) of every parameter of ``p`` (values, standard
    errors, bounds …), in ``fit_parameters.csv`` order: the zones', the couplings'
    (``a-b``), the boundary couplings' (``zone-boundary``); kind ``log`` or ``linear``."""
    z = context.zones
    rows = [
        (zone, name, kind, float(p.zone[i, j]))
        for i, zone in enumerate(z)
        for j, (name, kind) in enumerate(ZONE_PARAMETERS)
    ]
    rows += [
        (f"{z[i]}-{z[j]}", "ua_kw_per_k", "log", float(v))
        for (i, j), v in zip(p.couplings, p.coupling_ua_kw_per_k, strict=True)
    ]
    rows += [
        (f"{z[i]}-{context.boundaries[b]}", "ua_kw_per_k", "log", float(v))
        for (i, b), v in zip(p.boundary_couplings, p.boundary_ua_kw_per_k, strict=True)
    ]
    return rows


def bound_checks(fit: FitResult, context: FitContext) -> list[dict[str, str]]:
    """``bound`` rows (module docstring)."""
    assert fit.at_bound is not None and fit.lower is not None and fit.upper is not None
    rows = []
    values = parameter_rows(fit.parameters, context)
    flags, lows, highs = (parameter_rows(p, context) for p in (fit.at_bound, fit.lower, fit.upper))
    for (label, name, _, value), flag, low, high in zip(values, flags, lows, highs, strict=True):
        if flag[3] > 0:
            lower = value - low[3] <= high[3] - value
            side, bound = ("lower", low[3]) if lower else ("upper", high[3])
            why = (
                "the data find none (the bound keeps it non-negative)"
                if lower and bound == 0.0
                else "the data push it past what physics allows, or do not determine it"
            )
            rows.append(
                _row(
                    "bound",
                    label,
                    name,
                    WARNING,
                    f"{value:.4g} at its {side} bound {bound:.4g}: {why}",
                )
            )
    for name, node in zip(context.boundaries, context.boundary_nodes, strict=True):
        if node.ua_out_kw_per_k <= BOUNDARY_OUTDOOR_MIN_KW_PER_K:
            rows.append(
                _row(
                    "bound",
                    name,
                    "ua_out_kw_per_k",
                    WARNING,
                    f"{node.ua_out_kw_per_k:.3g} kW/K at its lower bound 0: the boundary node "
                    "exchanges no heat with the outdoors (its roof and walls do)",
                )
            )
    return _with_ok_rows(rows, "bound", context.zones, "no parameter at a bound")


def sign_checks(fit: FitResult, context: FitContext) -> list[dict[str, str]]:
    """``sign`` rows: the constant gain of each zone."""
    j = [n for n, _ in ZONE_PARAMETERS].index("base_gain_kw")
    rows = []
    for i, zone in enumerate(context.zones):
        value = float(fit.parameters.zone[i, j])
        negative = value < 0.0
        rows.append(
            _row(
                "sign",
                zone,
                "base_gain_kw",
                WARNING if negative else OK,
                f"{value:.3g} kW: "
                + (
                    "a negative constant gain removes heat around the clock (a loss the model "
                    "misses)"
                    if negative
                    else "not negative"
                ),
            )
        )
    return rows


def magnitude_checks(fit: FitResult, context: FitContext) -> list[dict[str, str]]:
    """``magnitude_per_m2`` rows against :data:`TYPICAL_PER_M2`."""
    names = [n for n, _ in ZONE_PARAMETERS]
    rows = []
    for i, (zone, physics) in enumerate(zip(context.zones, context.physics, strict=True)):
        if not physics.area_known:
            rows.append(
                _row(
                    "magnitude_per_m2",
                    zone,
                    "",
                    WARNING,
                    "floor area unknown: magnitudes not checked (give --idf or --floor-area)",
                )
            )
            continue
        found = []
        for name, (low, high) in TYPICAL_PER_M2.items():
            per_m2 = float(fit.parameters.zone[i, names.index(name)]) / physics.floor_area_m2
            if not low <= per_m2 <= high:
                found.append(
                    _row(
                        "magnitude_per_m2",
                        zone,
                        name,
                        WARNING,
                        f"{per_m2:.3g} per m² of {physics.floor_area_m2:.1f} m² outside the "
                        f"typical {low:g} … {high:g}",
                    )
                )
        rows += found or [
            _row("magnitude_per_m2", zone, "", OK, f"typical for {physics.floor_area_m2:.1f} m²")
        ]
    return rows


def facade_checks(fit: FitResult, context: FitContext) -> list[dict[str, str]]:
    """``facade_solar`` rows: wall apertures only on the façades a zone has."""
    names = [n for n, _ in ZONE_PARAMETERS]
    rows = []
    for i, (zone, physics) in enumerate(zip(context.zones, context.physics, strict=True)):
        fitted = {
            orientation: float(fit.parameters.zone[i, names.index(f"solar_wall_{orientation}_m2")])
            for orientation, _ in WALL_ORIENTATIONS
        }
        sunny = [o for o, v in fitted.items() if v > SOLAR_FITTED_M2]
        if physics.wall_solar_max_m2 is None:
            rows.append(
                _row(
                    "facade_solar",
                    zone,
                    "",
                    WARNING if sunny else OK,
                    f"façades unknown (give --idf): sun fitted on {', '.join(sunny)}"
                    if sunny
                    else "no wall sun fitted",
                )
            )
            continue
        tops = dict(zip((o for o, _ in WALL_ORIENTATIONS), physics.wall_solar_max_m2, strict=True))
        faces = [o for o, top in tops.items() if top > 0]
        outside = [o for o, top in tops.items() if fitted[o] > top + SOLAR_FITTED_M2]
        rows.append(
            _row(
                "facade_solar",
                zone,
                "",
                WARNING if outside else OK,
                f"sun fitted beyond the façades on {', '.join(outside)}"
                if outside
                else f"sun only on the façades it has ({', '.join(faces) or 'none'}): "
                + ", ".join(f"{o} {fitted[o]:.2f} m²" for o in sunny),
            )
        )
    return rows


def identifiability_checks(fit: FitResult, context: FitContext) -> list[dict[str, str]]:
    """``identifiability`` rows for the free parameters the data do not determine."""
    assert fit.lower is not None and fit.upper is not None
    values = parameter_rows(fit.parameters, context)
    errors = parameter_rows(fit.standard_errors, context)
    lows, highs = parameter_rows(fit.lower, context), parameter_rows(fit.upper, context)
    rows = []
    for (label, name, kind, value), error, low, high in zip(
        values, errors, lows, highs, strict=True
    ):
        if high[3] <= low[3]:
            continue  # fixed by physics
        se = error[3]
        if kind == "log":
            undetermined = not np.isfinite(se) or se > abs(value)
        else:
            threshold = max(abs(value), LINEAR_IDENTIFIABLE_SHARE * LINEAR_PRIOR_SCALE[name])
            undetermined = not np.isfinite(se) or se > threshold
        if undetermined:
            rows.append(
                _row(
                    "identifiability",
                    label,
                    name,
                    WARNING,
                    f"{value:.4g} ± {se:.3g}: the data do not determine it (its prior holds "
                    "it); excite the zone more (identify collect) or fix it from the design",
                )
            )
    return _with_ok_rows(rows, "identifiability", context.zones, "every free parameter determined")


def validity_checks(context: FitContext) -> list[dict[str, str]]:
    """``validity_range`` rows: a zone whose training data never came within
    :data:`FLOAT_MARGIN_K` of the unoccupied comfort bound (:data:`UNOCCUPIED_UPPER_DEGC`) is a
    warning — the controller will float it there, outside what the model saw."""
    if context.validity is None:
        return []
    rows = []
    for zone, high in zip(context.zones, context.validity.zone_temp_max_degc, strict=True):
        short = high < UNOCCUPIED_UPPER_DEGC - FLOAT_MARGIN_K
        rows.append(
            _row(
                "validity_range",
                zone,
                "",
                WARNING if short else OK,
                f"trained up to {high:.1f} °C"
                + (
                    f": a controller floats it to {UNOCCUPIED_UPPER_DEGC:g} °C, outside the "
                    "data; collect with the float-ups of the default excitation (identify "
                    "collect --excitation range) or trend data with night set-backs"
                    if short
                    else f", within {FLOAT_MARGIN_K:g} K of the {UNOCCUPIED_UPPER_DEGC:g} °C bound"
                ),
            )
        )
    return rows


def fit_checks(fit: FitResult) -> list[dict[str, str]]:
    """``time_constants`` and ``convergence`` rows from the fit's own warnings."""
    taus = [w for w in fit.warnings if w.startswith("time constants")]
    return [
        _row(
            "time_constants",
            "",
            "",
            WARNING if taus else OK,
            taus[0] if taus else "within a minute … four weeks",
        ),
        _row(
            "convergence",
            "",
            "",
            OK if fit.converged else WARNING,
            fit.message,
        ),
    ]


def plausibility_checks(fit: FitResult, context: FitContext) -> pd.DataFrame:
    """``checks.csv``: every check's rows (module docstring), columns :data:`CHECK_COLUMNS`."""
    rows = (
        bound_checks(fit, context)
        + sign_checks(fit, context)
        + magnitude_checks(fit, context)
        + facade_checks(fit, context)
        + identifiability_checks(fit, context)
        + validity_checks(context)
        + fit_checks(fit)
    )
    return pd.DataFrame(rows, columns=list(CHECK_COLUMNS))


def failed(checks: pd.DataFrame) -> pd.DataFrame:
    """The ``warning`` rows of a checks table."""
    return checks[checks["status"] == WARNING]


def warning_lines(checks: pd.DataFrame) -> list[str]:
    """``"<check> <zone> <parameter>: <detail>"`` for each warning row."""
    rows = failed(checks)[list(CHECK_COLUMNS)].astype(str).to_dict("records")
    return [
        " ".join(part for part in (row["check"], row["zone"], row["parameter"]) if part)
        + f": {row['detail']}"
        for row in rows
    ]
