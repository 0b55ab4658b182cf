"""The weather's channels: the sky's long-wave loss and angle-dependent windows, filled from
the weather file for every scenario (not only the BESTEST validation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from hvacflex.building.io import load_building
from hvacflex.building.rc import build_network
from hvacflex.cli import app
from hvacflex.data.forecast import default_weather_file, load_exogenous
from hvacflex.data.solar import surface_irradiance_components, surface_irradiance_w_per_m2
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.data.weather import weather_on
from hvacflex.data.weather_channels import sky_longwave_w_per_m2, weather_channel_values
from hvacflex.data.weather_forecast import fit_weather_forecaster
from hvacflex.errors import DataError

START = pd.Timestamp("2014-03-03", tz="Asia/Singapore")


def _room_with_sky_and_angular_window(shipped_buildings_dir: Path, tmp_path: Path) -> Path:
    """room1 with emissive exterior walls and windows, and window2 angle dependent."""
    text = (shipped_buildings_dir / "room1.toml").read_text()
    text = text.replace(
        "solar_absorptance = 0.2", "solar_absorptance = 0.2\nthermal_emissivity = 0.9"
    )
    text = text.replace(
        "shgc = 0.5\nazimuth_deg = 180.0",
        "shgc = 0.45\nshgc_normal = 0.5\nazimuth_deg = 180.0\nthermal_emissivity = 0.84",
    )
    path = tmp_path / "room_sky.toml"
    path.write_text(text)
    return path


def test_sky_longwave_is_sigma_t4_less_the_sky() -> None:
    # σ (300.15 K)⁴ = 460.0 W/m²: a 27 °C horizontal black body under a 400 W/m² sky
    loss = sky_longwave_w_per_m2(np.array([27.0]), np.array([400.0]))
    np.testing.assert_allclose(loss, [5.670374419e-8 * 300.15**4 - 400.0])
    assert 59.0 < loss[0] < 61.0


def test_every_weather_channel_is_filled_from_the_file(
    shipped_buildings_dir: Path, tmp_path: Path
) -> None:
    building = load_building(_room_with_sky_and_angular_window(shipped_buildings_dir, tmp_path))
    channels = build_network(building).channels
    kinds = [ch.kind for ch in channels]
    assert "sky_longwave" in kinds and "window_solar_gain" in kinds
    index = pd.date_range(START, periods=96, freq="30min")
    weather, site = weather_on(index, default_weather_file())
    values = weather_channel_values(channels, weather, site)
    assert sorted(values) == [i for i, k in enumerate(kinds) if k not in ("internal_gain",)]
    sky = values[kinds.index("sky_longwave")]
    expected_sky = sky_longwave_w_per_m2(
        weather["outdoor_temp_degc"].to_numpy(), weather["sky_infrared_w_per_m2"].to_numpy()
    )
    np.testing.assert_allclose(sky, expected_sky)
    assert 0.0 < sky.mean() < 150.0  # humid tropics: a warm, cloudy sky
    window = next(w for w in building.windows if w.shgc_normal is not None)
    gain = values[kinds.index("window_solar_gain")]
    parts = surface_irradiance_components(weather, site, window.azimuth_deg, window.tilt_deg)
    total = surface_irradiance_w_per_m2(weather, site, [(window.azimuth_deg, window.tilt_deg)])
    np.testing.assert_allclose(parts.total_w_per_m2, total.iloc[:, 0].to_numpy())
    modifier = np.interp(parts.incidence_deg, *zip(*window.incidence_angle_modifier, strict=True))
    np.testing.assert_allclose(
        gain, 0.5 * modifier * parts.beam_w_per_m2 + 0.45 * parts.diffuse_w_per_m2
    )
    # the angular SHGC never exceeds the normal one, and admits less than it at noon
    assert (gain <= 0.5 * total.iloc[:, 0].to_numpy() + 1e-9).all()
    assert gain.max() > 0.0


def test_a_scenario_runs_on_them_with_a_box_and_a_statistical_forecast(
    shipped_buildings_dir: Path, tmp_path: Path
) -> None:
    building = load_building(_room_with_sky_and_angular_window(shipped_buildings_dir, tmp_path))
    channels = build_network(building).channels
    exo = load_exogenous(
        channels, [z.floor_area_m2 for z in building.zones], building.gains,
        start=START, steps=48, horizon_steps=0,
    )  # fmt: skip
    d = np.asarray(exo.disturbances)
    assert np.isfinite(d).all()
    window_i = [i for i, ch in enumerate(channels) if ch.kind == "window_solar_gain"]
    # the box sizes a window's gain as solar; a kind of its own would take precedence
    rel, _ = UncertaintyBox(relative={"solar": 0.1}).coefficients(channels)
    assert rel[window_i].tolist() == [0.1]
    rel, _ = UncertaintyBox(relative={"solar": 0.1, "window_solar_gain": 0.3}).coefficients(
        channels
    )
    assert rel[window_i].tolist() == [0.3]
    weather = fit_weather_forecaster(channels, START, weather_file=default_weather_file())
    assert set(window_i) <= set(weather.columns)
    assert weather.model.nonnegative[weather.columns.index(window_i[0])]
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(
        f'preset = "rmpc"\nbuilding = "{tmp_path / "room_sky.toml"}"\n'
        'start = "2014-03-03"\ndays = 1\n[forecast]\nweather = "statistical"\n'
    )
    result = CliRunner().invoke(
        app, ["simulate", "--config", str(scenario), "--out", str(tmp_path / "run")]
    )
    assert result.exit_code == 0, result.output
    frame = pd.read_parquet(tmp_path / "run" / "results.parquet")
    assert len(frame) == 48 and np.isfinite(frame["power_kw"]).all()


def test_a_weather_file_without_the_sky_infrared_names_the_field(
    shipped_buildings_dir: Path, tmp_path: Path
) -> None:
    lines = default_weather_file().read_text(encoding="latin-1").splitlines()
    for row in range(8, len(lines)):
        fields = lines[row].split(",")
        fields[12] = "9999"  # the EPW's missing code
        lines[row] = ",".join(fields)
    epw = tmp_path / "no_sky.epw"
    epw.write_text("\n".join(lines) + "\n", encoding="latin-1")
    # a building without emissive surfaces does not need it
    office = load_building(shipped_buildings_dir / "office5.toml")
    plain = load_exogenous(
        build_network(office).channels, [z.floor_area_m2 for z in office.zones], office.gains,
        start=START, steps=4, horizon_steps=0, weather_file=epw,
    )  # fmt: skip
    assert np.isfinite(np.asarray(plain.disturbances)).all()
    building = load_building(_room_with_sky_and_angular_window(shipped_buildings_dir, tmp_path))
    with pytest.raises(DataError, match="no sky infrared") as info:
        load_exogenous(
            build_network(building).channels, [z.floor_area_m2 for z in building.zones],
            building.gains, start=START, steps=4, horizon_steps=0, weather_file=epw,
        )  # fmt: skip
    message = str(info.value)
    assert "field 13" in message and "no_sky.epw" in message and "thermal_emissivity" in message
