"""The IDF export's geometry and object text (independent of EnergyPlus)."""

from __future__ import annotations

import numpy as np
import pytest

from hvacflex.energyplus import envelope


def _area_and_normal(corners: tuple[tuple[float, float, float], ...]) -> tuple[float, np.ndarray]:
    p = np.array(corners)
    cross = np.cross(p[1] - p[0], p[2] - p[1]) + np.cross(p[3] - p[2], p[0] - p[3])
    return float(np.linalg.norm(cross)) / 2.0, cross / np.linalg.norm(cross)


@pytest.mark.parametrize(
    ("azimuth", "tilt", "normal"),
    [
        (0.0, 90.0, (0.0, 1.0, 0.0)),  # a north wall faces +y
        (90.0, 90.0, (1.0, 0.0, 0.0)),  # east: +x
        (180.0, 90.0, (0.0, -1.0, 0.0)),
        (0.0, 0.0, (0.0, 0.0, 1.0)),  # a roof faces up
    ],
)
def test_rectangles_have_their_area_and_face_outwards(
    azimuth: float, tilt: float, normal: tuple[float, float, float]
) -> None:
    corners = envelope.rectangle(12.0, azimuth, tilt, 3.0, (1.0, 2.0, 0.0))
    area, outward = _area_and_normal(corners)
    assert area == pytest.approx(12.0)
    # counter-clockwise seen from outside: the right-hand normal points out
    np.testing.assert_allclose(outward, normal, atol=1e-9)


def test_surface_types_follow_the_tilt() -> None:
    assert envelope.surface_type(0.0, exterior=True) == "Roof"
    assert envelope.surface_type(0.0, exterior=False) == "Ceiling"
    assert envelope.surface_type(90.0, exterior=True) == "Wall"
    assert envelope.surface_type(180.0, exterior=False) == "Floor"


def test_an_object_is_one_field_a_line_with_empty_defaults() -> None:
    text = envelope.idf_object("Zone", "north", None, 1.0 / 3.0)
    assert text.splitlines() == ["Zone,", "  north,", "  ,", "  0.3333333333;"]
