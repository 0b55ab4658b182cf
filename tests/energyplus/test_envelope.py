"""The IDF export's geometry and object text (independent of EnergyPlus)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hvacflex.building.io import load_building
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


def test_a_wall_on_an_adiabatic_plane_is_written_mirrored(shipped_buildings_dir: Path) -> None:
    """EnergyPlus's ``Adiabatic`` boundary gives the far face the inside face's temperature;
    only a construction symmetric about the far face keeps hvacflex's half slab: the layers
    inside → outside → inside, each one twice."""
    office5 = load_building(shipped_buildings_dir / "office5.toml")
    slab = next(w for w in office5.walls if w.adjacent == "adiabatic")
    variant = envelope.wall_variant(slab)
    name, count = slab.construction.name, len(slab.construction.layers)
    layers = [f"{name} layer {i + 1}" for i in range(count)]
    assert variant.material_names() == layers[::-1] + layers
    text = "\n".join(envelope.construction_objects(office5) + envelope.surface_objects(office5))
    assert f"Construction,\n  {variant.name},\n  " + ",\n  ".join(layers[::-1] + layers) in text
    surface = text[text.index(f"BuildingSurface:Detailed,\n  {slab.name},") :]
    assert surface.splitlines()[3].strip() == f"{variant.name},"
    exterior = next(w for w in office5.walls if w.adjacent == "outside")
    assert not envelope.wall_variant(exterior).mirrored
