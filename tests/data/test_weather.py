"""EPW reader, 30-min resampling and façade irradiance, on the shipped files and broken ones."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hvacflex.data.solar import surface_irradiance_w_per_m2
from hvacflex.data.weather import (
    EpwLocation,
    humidity_ratio_kg_per_kg,
    night_hours,
    parse_epw_text,
    read_epw,
    saturation_pressure_pa,
    weather_30min,
)
from hvacflex.errors import DataError

TMYX = "SGP_SG_Singapore-Changi.Intl.AP.486980_TMYx.2009-2023.epw"


@pytest.fixture(scope="module")
def tmyx(shared_data_dir: Path) -> tuple[pd.DataFrame, EpwLocation]:
    return read_epw(shared_data_dir / "weather" / TMYX)


@pytest.fixture(scope="module")
def tmyx_2014(tmyx: tuple[pd.DataFrame, EpwLocation]) -> pd.DataFrame:
    return weather_30min(*tmyx, year=2014)


@pytest.mark.parametrize(
    ("name", "t_min", "t_mean", "t_max", "ghi_kwh"),
    [(TMYX, 22.4, 28.0, 34.0, 1787)],
)
def test_shipped_files_match_provenance(
    shared_data_dir: Path, name: str, t_min: float, t_mean: float, t_max: float, ghi_kwh: float
) -> None:
    hourly, location = read_epw(shared_data_dir / "weather" / name)
    assert len(hourly) == 8760
    assert location.latitude_deg == pytest.approx(1.37, abs=0.01)
    assert location.longitude_deg == pytest.approx(103.98, abs=0.01)
    assert location.tz_offset_h == 8.0
    assert len(location.ground_temp_monthly_degc) == 12
    temp = hourly["outdoor_temp_degc"]
    assert (temp.min(), round(temp.mean(), 1), temp.max()) == (t_min, t_mean, t_max)
    assert hourly["ghi_w_per_m2"].sum() / 1000 == pytest.approx(ghi_kwh, abs=1)


def test_30min_grid_preserves_means_and_energy(
    tmyx: tuple[pd.DataFrame, EpwLocation], tmyx_2014: pd.DataFrame
) -> None:
    hourly, _ = tmyx
    assert len(tmyx_2014) == 17_520 and str(tmyx_2014.index.tz) == "Asia/Singapore"
    for column in ("ghi_w_per_m2", "dni_w_per_m2", "dhi_w_per_m2"):
        # every hour's energy is kept: the two halves average to the EPW hour value
        halves = tmyx_2014[column].to_numpy().reshape(-1, 2).mean(axis=1)
        np.testing.assert_allclose(halves, hourly[column].to_numpy(), atol=1e-9)
    assert tmyx_2014["outdoor_temp_degc"].mean() == pytest.approx(
        hourly["outdoor_temp_degc"].mean()
    )
    # EPW hour 1 of 1 Jan (a reading at 01:00): period [00:30, 01:00) is 3/4 of the way from
    # the previous instant (hour 24 of 31 Dec, wrapped) to it.
    first, last = hourly["outdoor_temp_degc"].iloc[0], hourly["outdoor_temp_degc"].iloc[-1]
    assert tmyx_2014["outdoor_temp_degc"].iloc[1] == pytest.approx(last + 0.75 * (first - last))
    assert {"humidity_ratio_kg_per_kg", "ground_temp_degc", "wind_speed_m_s"} <= set(tmyx_2014)


def test_leap_year_repeats_28_february(tmyx: tuple[pd.DataFrame, EpwLocation]) -> None:
    weather = weather_30min(*tmyx, year=2016)
    assert len(weather) == 17_568
    feb28 = weather.loc["2016-02-28", "ghi_w_per_m2"].to_numpy()
    feb29 = weather.loc["2016-02-29", "ghi_w_per_m2"].to_numpy()
    np.testing.assert_allclose(feb29, feb28, rtol=0.05, atol=5.0)  # same EPW day, sun ±1 day
    mar1_2016 = weather.loc["2016-03-01", "outdoor_temp_degc"].to_numpy()
    mar1_2014 = weather_30min(*tmyx, year=2014).loc["2014-03-01", "outdoor_temp_degc"].to_numpy()
    np.testing.assert_allclose(mar1_2016, mar1_2014)


def test_psychrometrics_against_ashrae_table() -> None:
    # ASHRAE Fundamentals 2017 ch. 1 table 3: p_ws(25 °C) = 3.1699 kPa, p_ws(10 °C) = 1.2282 kPa
    np.testing.assert_allclose(
        saturation_pressure_pa(np.array([25.0, 10.0])), [3169.9, 1228.2], rtol=1e-3
    )
    # W = 0.621945 p_w / (p − p_w) by hand at dew point 25 °C and sea-level pressure
    expected = 0.621945 * 3169.9 / (101325.0 - 3169.9)
    assert humidity_ratio_kg_per_kg(np.array([25.0]), np.array([101325.0]))[0] == pytest.approx(
        expected, rel=1e-3
    )


def test_sunrise_sunset_and_facade_peaks(
    tmyx: tuple[pd.DataFrame, EpwLocation], tmyx_2014: pd.DataFrame
) -> None:
    """21 March 2014, Singapore: sunrise 07:10, sunset 19:13 local (solar noon 13:11, pvlib)."""
    _, location = tmyx
    day = tmyx_2014.loc["2014-03-21"]
    sun_up = day.index[day["ghi_w_per_m2"] > 5.0]
    assert sun_up[0] == pd.Timestamp("2014-03-21 07:00", tz="Asia/Singapore")
    assert sun_up[-1] + pd.Timedelta(minutes=30) == pd.Timestamp(
        "2014-03-21 19:00", tz="Asia/Singapore"
    )
    assert (day.loc[:"2014-03-21 06:30", "ghi_w_per_m2"] == 0).all()
    assert (day.loc["2014-03-21 19:30":, "ghi_w_per_m2"] < 5.0).all()  # twilight at most
    facades = surface_irradiance_w_per_m2(day, location, [(90, 90), (270, 90), (180, 90), (0, 0)])
    east, west = facades["solar_az90_tilt90_w_per_m2"], facades["solar_az270_tilt90_w_per_m2"]
    assert east.idxmax().hour < 12 and west.idxmax().hour >= 14
    assert east.loc[:"2014-03-21 11:30"].sum() > 1.2 * east.loc["2014-03-21 13:30":].sum()
    assert west.loc["2014-03-21 13:30":].sum() > 1.2 * west.loc[:"2014-03-21 11:30"].sum()
    # horizontal plane: DNI·cos θz + DHI; equals GHI over the day up to the file's closure error
    roof = facades["solar_az0_tilt0_w_per_m2"]
    assert roof.sum() == pytest.approx(day["ghi_w_per_m2"].sum(), rel=0.02)
    assert (facades.to_numpy() >= 0).all()
    assert (facades.loc[:"2014-03-21 06:30"].to_numpy() == 0).all()


def test_sun_geometry_sunrise_sunset(tmyx: tuple[pd.DataFrame, EpwLocation]) -> None:
    import pvlib

    _, location = tmyx
    minutes = pd.date_range("2014-03-21", periods=24 * 60, freq="1min", tz="Asia/Singapore")
    elevation = pvlib.solarposition.get_solarposition(
        minutes, location.latitude_deg, location.longitude_deg
    )["apparent_elevation"]
    up = elevation.index[elevation > 0]
    assert (
        pd.Timestamp("2014-03-21 06:55", tz="Asia/Singapore")
        <= up[0]
        <= pd.Timestamp("2014-03-21 07:15", tz="Asia/Singapore")
    )
    assert (
        pd.Timestamp("2014-03-21 19:00", tz="Asia/Singapore")
        <= up[-1]
        <= pd.Timestamp("2014-03-21 19:25", tz="Asia/Singapore")
    )


# ------------------------------------------------------------------ malformed files


def _epw_lines(shared_data_dir: Path) -> list[str]:
    return (shared_data_dir / "weather" / TMYX).read_text(encoding="latin-1").splitlines()


def _write(tmp_path: Path, lines: list[str]) -> Path:
    path = tmp_path / "bad.epw"
    path.write_text("\n".join(lines) + "\n", encoding="latin-1")
    return path


def test_bad_header(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    lines[0] = "PLACE,SINGAPORE"
    with pytest.raises(DataError, match="bad EPW header") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 1


def test_bad_location_line(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    lines[0] = "LOCATION,SINGAPORE,-,SGP,IWEC Data,486980,north,103.98,8.0,16.0"
    with pytest.raises(DataError, match="LOCATION"):
        read_epw(_write(tmp_path, lines))


def test_truncated_file(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)[:-100]
    with pytest.raises(DataError, match="8660 hourly rows, expected 8760"):
        read_epw(_write(tmp_path, lines))


def test_truncated_last_line(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    lines[-1] = lines[-1][:30]
    with pytest.raises(DataError, match="fields") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 8 + 8760


def test_missing_field(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    fields = lines[8 + 99].split(",")
    fields[13] = ""  # GHI of hour 100
    lines[8 + 99] = ",".join(fields)
    with pytest.raises(DataError, match="missing or non-numeric") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 108 and "ghi_w_per_m2" in str(info.value)


def test_missing_value_code(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    fields = lines[8 + 5].split(",")
    fields[6] = "99.9"  # EPW code for a missing dry bulb
    lines[8 + 5] = ",".join(fields)
    with pytest.raises(DataError, match="outdoor_temp_degc") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 14


def _set_field(lines: list[str], row: int, index: int, value: str) -> None:
    """Set field ``index`` (0-based) of data row ``row`` (0-based) to ``value``."""
    fields = lines[8 + row].split(",")
    fields[index] = value
    lines[8 + row] = ",".join(fields)


@pytest.mark.parametrize(
    ("index", "value", "column", "message"),
    [
        (6, "-273", "outdoor_temp_degc", "outside the physical range -70…70 °C"),
        (6, "inf", "outdoor_temp_degc", "missing or non-numeric"),
        (7, "nan", "dewpoint_degc", "missing or non-numeric"),
        (8, "999", "relative_humidity_percent", "missing-value code"),
        (9, "-5", "pressure_pa", "outside the physical range 31000…120000 Pa"),
        (9, "5000000", "pressure_pa", "missing-value code"),
        (9, "200000", "pressure_pa", "outside the physical range"),
        (13, "-10", "ghi_w_per_m2", "outside the physical range 0…1500 Wh/m²"),
        (14, "9999", "dni_w_per_m2", r"missing-value code \(≥ 9999\)"),
        (15, "5000", "dhi_w_per_m2", "outside the physical range"),
        (21, "1e308", "wind_speed_m_s", "missing-value code"),
        (21, "60", "wind_speed_m_s", "outside the physical range 0…40 m/s"),
        (3, "25", "hour", "outside the physical range 1…24"),
        (1, "1.5", "month", "whole number"),
    ],
)
def test_values_outside_their_physical_range_name_line_and_field(
    tmp_path: Path, shared_data_dir: Path, index: int, value: str, column: str, message: str
) -> None:
    lines = _epw_lines(shared_data_dir)
    _set_field(lines, 41, index, value)
    with pytest.raises(DataError, match=message) as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 8 + 42
    assert info.value.field is not None and column in info.value.field
    assert info.value.value == value


@pytest.mark.parametrize(
    ("index", "value", "field"),
    [
        (8, "100", "time zone"),
        (8, "nan", "time zone"),
        (8, "inf", "time zone"),
        (8, "-13", "time zone"),
        (9, "1e6", "elevation"),
        (6, "91", "latitude"),
        (7, "x", "longitude"),
    ],
)
def test_bad_location_values_name_the_field(
    tmp_path: Path, shared_data_dir: Path, index: int, value: str, field: str
) -> None:
    lines = _epw_lines(shared_data_dir)
    location = lines[0].split(",")
    location[index] = value
    lines[0] = ",".join(location)
    with pytest.raises(DataError, match="must be a number in") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 1 and info.value.field is not None and field in info.value.field


def test_bad_ground_temperature_names_line_4(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    ground = lines[3].split(",")
    ground[8] = "1e300"
    lines[3] = ",".join(ground)
    with pytest.raises(DataError, match="GROUND TEMPERATURES month 3") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 4


def test_a_deleted_field_says_the_row_has_too_few_fields(
    tmp_path: Path, shared_data_dir: Path
) -> None:
    lines = _epw_lines(shared_data_dir)
    fields = lines[8 + 200].split(",")
    del fields[6]  # the dry bulb: every later field would shift left by one
    lines[8 + 200] = ",".join(fields)
    with pytest.raises(DataError, match="too few fields: 34, an EPW row has 35") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 8 + 201


def test_an_added_field_says_the_row_has_too_many_fields(
    tmp_path: Path, shared_data_dir: Path
) -> None:
    lines = _epw_lines(shared_data_dir)
    lines[8 + 7] = lines[8 + 7].replace(",", ",,", 1)
    with pytest.raises(DataError, match="too many fields: 36") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 8 + 8


def test_rows_out_of_calendar_order_name_the_first_wrong_line(
    tmp_path: Path, shared_data_dir: Path
) -> None:
    lines = _epw_lines(shared_data_dir)
    lines[8 + 30], lines[8 + 31] = lines[8 + 31], lines[8 + 30]
    with pytest.raises(DataError, match="hour by hour") as info:
        read_epw(_write(tmp_path, lines))
    assert info.value.line == 8 + 31
    assert info.value.value == (1, 2, 8)  # hour 8 of 2 January where hour 7 belongs


def test_a_duplicated_row_is_refused(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    lines.insert(8 + 500, lines[8 + 500])
    with pytest.raises(DataError, match="8761 hourly rows, expected 8760"):
        read_epw(_write(tmp_path, lines))


def test_an_edited_file_is_read_again(tmp_path: Path, shared_data_dir: Path) -> None:
    lines = _epw_lines(shared_data_dir)
    path = _write(tmp_path, lines)
    assert read_epw(path)[0]["outdoor_temp_degc"].iloc[0] != 31.5
    _set_field(lines, 0, 6, "31.5")  # above the dew point: a valid row
    path.write_text("\n".join(lines) + "\n", encoding="latin-1")
    assert read_epw(path)[0]["outdoor_temp_degc"].iloc[0] == 31.5


def test_irradiance_same_on_a_regular_index_cached_or_not(
    tmyx: tuple[pd.DataFrame, EpwLocation], tmyx_2014: pd.DataFrame
) -> None:
    """The sun's geometry of a regular index is cached (fleets share it); a copy of the
    frame without one row (an irregular index, computed without the cache) gives the same
    irradiance on the rows they share, and a second call the same as the first."""
    _, location = tmyx
    days = tmyx_2014.loc["2014-03-20":"2014-03-21"]
    surfaces = [(90.0, 90.0), (225.0, 60.0)]
    first = surface_irradiance_w_per_m2(days, location, surfaces)
    again = surface_irradiance_w_per_m2(days, location, surfaces)
    gappy = surface_irradiance_w_per_m2(days.drop(days.index[30]), location, surfaces)
    np.testing.assert_array_equal(first.to_numpy(), again.to_numpy())
    assert first.loc["2014-03-20 12:00"].min() > 0.0
    np.testing.assert_allclose(gappy.to_numpy(), first.drop(first.index[30]).to_numpy(), atol=1e-9)


# ------------------------------------------------ fields that contradict each other
# A hand-made day (1 January, Singapore Changi, UTC+8): sunrise 07:07, sunset 19:13 local;
# at 07:00 the sun is 2.3° below the horizon, at 19:00 1.6° above it (pvlib SPA).

_HAND_HEADER = [
    "LOCATION,Hand-made,SG,SGP,test,486980,1.3678,103.9826,8.0,6.7",
    "DESIGN CONDITIONS,0",
    "TYPICAL/EXTREME PERIODS,0",
    "GROUND TEMPERATURES,0",
    "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
    "COMMENTS 1,hand-made test file",
    "COMMENTS 2,",
    "DATA PERIODS,1,1,Data,Wednesday,1/ 1,1/ 1",
]
_SUN_HOURS = range(8, 21)  # EPW hours 8 … 20 cover 07:00 … 20:00 local


def _hand_row(hour: int, **fields: float) -> str:
    """One EPW row of 1 January (35 fields); ``fields`` override dry bulb, dew point, GHI,
    DNI, DHI (by column name)."""
    sun = hour in _SUN_HOURS
    values = {
        "outdoor_temp_degc": 27.0,
        "dewpoint_degc": 24.0,
        "ghi_w_per_m2": 300.0 if sun else 0.0,
        "dni_w_per_m2": 200.0 if sun else 0.0,
        "dhi_w_per_m2": 150.0 if sun else 0.0,
    } | fields
    row = ["2001", "1", "1", str(hour), "0", "?"] + ["0"] * 29
    row[6], row[7] = f"{values['outdoor_temp_degc']:g}", f"{values['dewpoint_degc']:g}"
    row[8], row[9], row[21] = "84", "101000", "2.0"
    for index, column in ((13, "ghi_w_per_m2"), (14, "dni_w_per_m2"), (15, "dhi_w_per_m2")):
        row[index] = f"{values[column]:g}"
    return ",".join(row)


def _hand_day(edits: dict[int, dict[str, float]] | None = None, tz_h: float = 8.0) -> str:
    header = list(_HAND_HEADER)
    header[0] = header[0].replace(",8.0,", f",{tz_h:g},")
    rows = [_hand_row(h, **(edits or {}).get(h, {})) for h in range(1, 25)]
    return "\n".join(header + rows) + "\n"


def _parse_day(text: str) -> pd.DataFrame:
    return parse_epw_text(text, "hand.epw", hours=24)[0]


def test_a_consistent_hand_made_day_loads() -> None:
    frame = _parse_day(_hand_day())
    assert len(frame) == 24
    assert frame["ghi_w_per_m2"].sum() == 300.0 * len(_SUN_HOURS)


@pytest.mark.parametrize(
    ("edits", "line", "field", "value", "message"),
    [
        # dew point 0.5 K above the dry bulb at 03:00–04:00
        ({4: {"dewpoint_degc": 27.5}}, 12, "dewpoint_degc", 27.5, "dew point above the dry bulb"),
        # diffuse 20 Wh/m² above global at noon
        ({13: {"dhi_w_per_m2": 320.0}}, 21, "dhi_w_per_m2", 320.0, "diffuse horizontal above"),
        # global irradiance at 01:00–02:00
        ({2: {"ghi_w_per_m2": 40.0, "dhi_w_per_m2": 40.0}}, 10, "ghi_w_per_m2", 40.0, "below the"),
        # beam at 05:00–06:00 (the sun 16° below the horizon at 06:00)
        ({6: {"dni_w_per_m2": 12.0}}, 14, "dni_w_per_m2", 12.0, "sun is below the horizon"),
        # an hour after sunset: 20:00–21:00 (the sun 5.7° below at 19:30, 12.6° at 20:00)
        ({21: {"ghi_w_per_m2": 3.0, "dhi_w_per_m2": 3.0}}, 29, "ghi_w_per_m2", 3.0, "horizon"),
    ],
)
def test_contradicting_fields_name_file_line_field_and_value(
    edits: dict[int, dict[str, float]], line: int, field: str, value: float, message: str
) -> None:
    with pytest.raises(DataError, match=message) as info:
        _parse_day(_hand_day(edits))
    assert info.value.source == "hand.epw"
    assert info.value.line == line  # 8 header lines + EPW hour
    assert info.value.field is not None and info.value.field.startswith(field)
    assert info.value.value == value


@pytest.mark.parametrize(
    "edits",
    [
        {4: {"dewpoint_degc": 27.1}},  # 0.1 K above: one unit of the file's resolution
        {13: {"dhi_w_per_m2": 301.0}},  # 1 Wh/m² above global: one unit
        {8: {"ghi_w_per_m2": 60.0, "dni_w_per_m2": 250.0, "dhi_w_per_m2": 40.0}},  # sunrise hour
        {20: {"ghi_w_per_m2": 20.0, "dni_w_per_m2": 90.0, "dhi_w_per_m2": 15.0}},  # sunset hour
        {4: {"dewpoint_degc": 27.0}},  # saturated air
    ],
)
def test_tolerances_accept_rounding_and_the_sunrise_and_sunset_hours(
    edits: dict[int, dict[str, float]],
) -> None:
    frame = _parse_day(_hand_day(edits))
    ((hour, fields),) = edits.items()
    for column, value in fields.items():
        assert frame.loc[hour - 1, column] == value


def test_a_wrong_time_zone_puts_the_sun_at_night() -> None:
    """The same day labelled UTC+0: its hours 8 … 20 become 15:00 … 04:00 Singapore time, and
    the first of them at night is hour 13 (12:00–13:00 UTC = 20:00–21:00 SGT)."""
    with pytest.raises(DataError, match="below the horizon") as info:
        _parse_day(_hand_day(tz_h=0.0))
    assert info.value.line == 8 + 13


def test_night_hours_of_the_shipped_files_have_no_irradiance(shared_data_dir: Path) -> None:
    """Both shipped EPW files load under the new rules; their night hours (sun > 1° below
    the horizon all hour) are dark and they are a little under half of the year."""
    for path in (
        shared_data_dir / "weather" / TMYX,
        shared_data_dir / "bestest" / "725650TYCST.epw",
    ):
        hourly, location = read_epw(path)
        night = night_hours(location, len(hourly))
        assert 0.40 < night.mean() < 0.50
        assert (hourly.loc[night, ["ghi_w_per_m2", "dni_w_per_m2"]].to_numpy() == 0).all()
        assert (hourly["dewpoint_degc"] <= hourly["outdoor_temp_degc"]).all()
        assert (hourly["dhi_w_per_m2"] <= hourly["ghi_w_per_m2"]).all()


@pytest.mark.parametrize("value", ["9999", "", "-5", "2000"])
def test_a_bad_sky_infrared_is_nan_not_an_error(
    tmp_path: Path, shared_data_dir: Path, value: str
) -> None:
    """Field 13 is optional: only a building with emissive exterior surfaces needs it
    (``tests/data/test_weather_channels.py``), so a bad value is NaN, the rest of the row is
    read."""
    lines = _epw_lines(shared_data_dir)
    _set_field(lines, 5, 12, value)
    frame, _ = read_epw(_write(tmp_path, lines))
    sky = frame["sky_infrared_w_per_m2"].to_numpy()
    assert np.isnan(sky[5]) and np.isfinite(np.delete(sky, 5)).all()
    assert np.isfinite(frame["outdoor_temp_degc"]).all()
