"""A small hand-checkable building (two zones) as TOML text, for the building tests."""

from __future__ import annotations

from pathlib import Path

MINIMAL_TOML = """
name = "two_zone"

[[zones]]
name = "a"
floor_area_m2 = 20.0
height_m = 3.0

[[zones]]
name = "b"
floor_area_m2 = 30.0
height_m = 3.0

[constructions.wall]
r_value_m2k_per_w = 2.0
capacitance_j_per_m2k = 100000.0

[constructions.partition]
r_value_m2k_per_w = 0.5
capacitance_j_per_m2k = 20000.0

[[walls]]
name = "a_ext"
zone = "a"
adjacent = "outside"
construction = "wall"
area_m2 = 15.0
azimuth_deg = 180.0
solar_absorptance = 0.5

[[walls]]
name = "ab"
zone = "a"
adjacent = "b"
construction = "partition"
area_m2 = 10.0

[[windows]]
name = "a_win"
zone = "a"
area_m2 = 5.0
u_value_w_per_m2k = 3.0
shgc = 0.4
azimuth_deg = 180.0

[gains]
occupancy_m2_per_person = 10.0
sensible_w_per_person = 75.0
latent_w_per_person = 55.0
lighting_w_per_m2 = 10.0
equipment_w_per_m2 = 12.0

[hvac]
supply_temp_degc = 13.0
flow_min_kg_s = { a = 0.05, b = 0.05 }
flow_max_kg_s = { a = 0.3, b = 0.3 }
outdoor_air_fraction = 0.3
cop = 4.5
fan_coeff_kw = 0.5
fan_exponent = 2.5
"""


def write_building(tmp_path: Path, text: str, name: str = "building.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path
