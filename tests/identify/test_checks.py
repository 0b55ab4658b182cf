"""The plausibility checks of a fit (``checks.csv``) on hand-made fits whose findings are
known."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.building.identified import IdentifiedValidity
from hvacflex.identify.checks import (
    CHECK_COLUMNS,
    FitContext,
    failed,
    plausibility_checks,
    warning_lines,
)
from hvacflex.identify.fit import FitResult
from hvacflex.identify.greybox import ZONE_PARAMETERS, GreyBoxParameters
from hvacflex.identify.model_file import BoundaryNode
from hvacflex.identify.physics import ZonePhysics

NAMES = [n for n, _ in ZONE_PARAMETERS]
PAIRS = np.array([[0, 1]], dtype=np.int64)


def _zone(**values: float) -> list[float]:
    typical = {  # a plausible 100 m² office zone
        "c_air_kj_per_k": 1000.0,
        "c_mass_kj_per_k": 2.0e4,
        "ua_out_kw_per_k": 0.1,
        "ua_air_mass_kw_per_k": 1.0,
        "ua_mass_out_kw_per_k": 0.01,
        "solar_air_m2": 0.5,
        "solar_mass_m2": 0.5,
        "solar_wall_north_m2": 0.0,
        "solar_wall_east_m2": 0.0,
        "solar_wall_south_m2": 2.0,
        "solar_wall_west_m2": 0.0,
        "occupied_gain_kw": 2.0,
        "base_gain_kw": 0.5,
    }
    return [values.get(n, typical[n]) for n in NAMES]


def _params(zone: list[list[float]], coupling: float) -> GreyBoxParameters:
    return GreyBoxParameters(np.array(zone), PAIRS, np.array([coupling]))


def _fit(values: GreyBoxParameters, at_bound: dict[tuple[int, str], float]) -> FitResult:
    flags = np.zeros_like(values.zone)
    for (i, name), flag in at_bound.items():
        flags[i, NAMES.index(name)] = flag
    errors = _params((0.1 * np.abs(values.zone)).tolist(), 0.1 * values.coupling_ua_kw_per_k[0])
    low = _params(np.zeros_like(values.zone).tolist(), 1e-4)
    high = _params(np.full_like(values.zone, 1e6).tolist(), 20.0)
    return FitResult(
        zones=("A", "B"),
        parameters=values,
        standard_errors=errors,
        converged=True,
        message="ok",
        warnings=(),
        prior=values,
        lower=low,
        upper=high,
        at_bound=GreyBoxParameters(flags, PAIRS, np.array([0.0])),
    )


def _context(area_m2: float = 100.0, facades: tuple[float, ...] | None = None) -> FitContext:
    physics = ZonePhysics(area_m2, facades)
    return FitContext(("a", "b"), (physics, physics))


def test_a_plausible_fit_passes_every_check_with_its_columns() -> None:
    fit = _fit(_params([_zone(), _zone()], 0.05), {})
    checks = plausibility_checks(fit, _context(facades=(0.0, 0.0, 5.0, 0.0)))
    assert tuple(checks.columns) == CHECK_COLUMNS
    assert failed(checks).empty, warning_lines(checks)
    assert {"bound", "sign", "magnitude_per_m2", "facade_solar", "identifiability"} <= set(
        checks["check"]
    )


def test_a_parameter_at_a_bound_has_a_warning_row_naming_it() -> None:
    fit = _fit(_params([_zone(), _zone(occupied_gain_kw=0.0)], 0.05), {(1, "occupied_gain_kw"): 1})
    rows = failed(plausibility_checks(fit, _context()))
    bound = rows[rows["check"] == "bound"]
    assert list(zip(bound["zone"], bound["parameter"], strict=True)) == [("b", "occupied_gain_kw")]
    assert "lower bound 0" in bound["detail"].iloc[0]


def test_each_check_says_ok_for_the_zones_it_does_not_flag() -> None:
    fit = _fit(_params([_zone(), _zone(occupied_gain_kw=0.0)], 0.05), {(1, "occupied_gain_kw"): 1})
    rows = plausibility_checks(fit, _context())
    for check in ("bound", "identifiability"):
        ok = rows[(rows["check"] == check) & (rows["status"] == "ok")]
        flagged = set(rows[(rows["check"] == check) & (rows["status"] != "ok")]["zone"])
        assert set(ok["zone"]) == {"a", "b"} - flagged, check
        assert (ok["parameter"] == "").all()
    assert set(rows[(rows["check"] == "bound") & (rows["status"] == "ok")]["zone"]) == {"a"}


def test_a_negative_constant_gain_and_an_implausible_size_are_warnings() -> None:
    fit = _fit(_params([_zone(base_gain_kw=-1.5), _zone(c_air_kj_per_k=50.0)], 0.05), {})
    rows = failed(plausibility_checks(fit, _context()))
    found = set(zip(rows["check"], rows["zone"], rows["parameter"], strict=True))
    assert ("sign", "a", "base_gain_kw") in found
    # 50 kJ/K over 100 m² = 0.5 kJ/(K m²): below the air's own
    assert ("magnitude_per_m2", "b", "c_air_kj_per_k") in found
    assert ("magnitude_per_m2", "a", "base_gain_kw") in found  # −0.015 kW/m²


def test_sun_through_a_facade_the_zone_lacks_or_unknown_facades_is_a_warning() -> None:
    north_sun = _params([_zone(solar_wall_north_m2=1.3), _zone()], 0.05)
    checks = plausibility_checks(_fit(north_sun, {}), _context(facades=(0.0, 0.0, 5.0, 0.0)))
    rows = failed(checks)
    assert list(rows[rows["check"] == "facade_solar"]["zone"]) == ["a"]
    unknown = failed(plausibility_checks(_fit(north_sun, {}), _context()))
    assert (unknown["check"] == "facade_solar").sum() == 2  # both zones fitted wall sun


def test_an_undetermined_parameter_is_a_warning_and_unknown_areas_are_said() -> None:
    fit = _fit(_params([_zone(), _zone()], 0.05), {})
    errors = fit.standard_errors.zone.copy()
    errors[0, NAMES.index("c_mass_kj_per_k")] = 3.0e4  # ± 150 %
    fit = FitResult(**{**vars(fit), "standard_errors": _params(errors.tolist(), 0.005)})
    rows = failed(plausibility_checks(fit, _context(area_m2=float("nan"))))
    pairs = set(zip(rows["check"], rows["zone"], rows["parameter"], strict=True))
    assert ("identifiability", "a", "c_mass_kj_per_k") in pairs
    assert {("magnitude_per_m2", "a", ""), ("magnitude_per_m2", "b", "")} <= pairs


def test_a_boundary_node_without_outdoor_conductance_is_a_warning() -> None:
    fit = _fit(_params([_zone(), _zone()], 0.05), {})
    context = FitContext(
        ("a", "b"),
        (ZonePhysics(100.0), ZonePhysics(100.0)),
        ("Attic",),
        (BoundaryNode(500.0, 0.0, 1.0, 0.0, 28.0),),
    )
    rows = failed(plausibility_checks(fit, context))
    assert ("Attic", "ua_out_kw_per_k") in set(zip(rows["zone"], rows["parameter"], strict=True))


@pytest.mark.parametrize("converged", [True, False])
def test_a_fit_that_did_not_converge_fails_a_check(converged: bool) -> None:
    fit = _fit(_params([_zone(), _zone()], 0.05), {})
    fit = FitResult(**{**vars(fit), "converged": converged, "message": "max evaluations"})
    rows = failed(plausibility_checks(fit, _context()))
    assert ("convergence" in set(rows["check"])) is not converged


def test_a_zone_never_trained_near_the_float_bound_is_a_warning() -> None:
    fit = _fit(_params([_zone(), _zone()], 0.05), {})
    validity = IdentifiedValidity((23.0, 23.0), (25.6, 29.4), 24.0, 33.0)
    context = FitContext(("a", "b"), (ZonePhysics(100.0), ZonePhysics(100.0)), validity=validity)
    checks = plausibility_checks(fit, context)
    rows = checks[checks["check"] == "validity_range"]
    # zone a reached 25.6 °C only: more than 2 K below the 30 °C the controller floats to
    assert dict(zip(rows["zone"], rows["status"], strict=True)) == {"a": "warning", "b": "ok"}
    assert "--excitation range" in rows["detail"].iloc[0]
