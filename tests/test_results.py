"""The results schema: column builders against the closed loop's frame and hand-written lists,
the zone-column parser on awkward zone names, units for every builder, and the writer/reader
pair (round trip, the bytes of the earlier writer, files without hvacflex metadata)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from hvacflex import kpi
from hvacflex import results as schema
from hvacflex.building.io import load_building
from hvacflex.building.rc import build_network
from hvacflex.errors import DataError, InputError, StoredStateError
from hvacflex.paths import buildings_dir

TZ = "Asia/Singapore"

SUFFIX_UNITS = (
    ("_sgd_per_mwh", "SGD/MWh"),
    ("_sgd_per_kw", "SGD/kW"),
    ("_kelvin_hours", "K·h"),
    ("_kg_per_kg", "kg/kg"),
    ("_w_per_m2", "W/m2"),
    ("_kg_s", "kg/s"),
    ("_degc", "degC"),
    ("_kw", "kW"),
    ("_w", "W"),
    ("_s", "s"),
    ("_k", "K"),
)
"""What the end of a name says about its unit (the house rule), written out independently."""

TRICKY_ZONES = [
    ("north", "core"),
    ("zone_1", "zone_2_east"),
    ("end_a",),
    ("end", "served"),
    ("a", "served_x", "curtailed_y"),
    ("temp", "flow_1", "x_degc"),
    ("level_3_end_zone", "b"),
]
"""Zone names with underscores and with the prefixes of other column kinds in them."""


def _unit_from_suffix(column: str) -> str:
    return next(unit for suffix, unit in SUFFIX_UNITS if column.endswith(suffix))


def _frame(n: int, zones: tuple[str, ...], channels: tuple[str, ...]) -> pd.DataFrame:
    """A results frame of ``n`` 30-min rows with every schema column: 10 kW at 100 SGD/MWh."""
    index = pd.date_range("2014-03-03", periods=n, freq="30min", tz=TZ, name=schema.INDEX_NAME)
    floats = schema.step_columns(zones, channels)
    rng = np.random.default_rng(3)
    frame = pd.DataFrame(rng.uniform(20.0, 30.0, (n, len(floats))), index=index, columns=floats)
    frame["power_kw"] = 10.0
    frame["energy_price_sgd_per_mwh"] = 100.0
    for j, name in enumerate(schema.FLAG_COLUMNS):
        frame[name] = np.arange(n) % (j + 2) == 0
    frame[schema.STATUS_COLUMN] = pd.Series(
        ["optimal", None] * (n // 2) + ["optimal"] * (n % 2), index=index, dtype="string"
    )
    return frame


# ------------------------------------------------------------------------ column builders


def test_step_columns_of_one_zone_and_channel_written_out() -> None:
    assert schema.step_columns(["north_1"], ["outdoor_temp_degc"]) == [
        "energy_price_sgd_per_mwh",
        "reserve_price_sgd_per_mwh",
        "peak_price_sgd_per_kw",
        "power_kw",
        "facility_power_kw",
        "power_served_kw",
        "power_curtailed_kw",
        "planned_power_kw",
        "committed_peak_kw",
        "reserve_kw",
        "offer_meter_ratio",
        "solve_time_s",
        "planned_slack_max_k",
        "delta_max_k",
        "il_allowance_k",
        "il_reference_power_kw",
        "il_penalty_price_sgd_per_mwh",
        "il_forfeited_price_sgd_per_mwh",
        "il_baseline_power_kw",
        "il_delivered_kw",
        "il_shortfall_kw",
        "outdoor_humidity_ratio_kg_per_kg",
        "flow_north_1_kg_s",
        "reserve_flow_north_1_kg_s",
        "temp_north_1_degc",
        "temp_end_north_1_degc",
        "temp_served_north_1_degc",
        "temp_curtailed_north_1_degc",
        "event_worst_north_1_degc",
        "comfort_lower_north_1_degc",
        "comfort_upper_north_1_degc",
        "prediction_error_north_1_k",
        "d_outdoor_temp_degc",
        "w_outdoor_temp_degc",
    ]
    assert schema.step_frame_columns(["z"], ["c_w"])[-8:] == [
        "il_activated",
        "il_curtailed",
        "il_beyond_model",
        "il_event_window",
        "fallback",
        "model_extrapolation",
        "peak_guard_active",
        "solve_status",
    ]


def test_step_columns_are_the_closed_loop_frame_columns() -> None:
    from hvacflex.config import preset
    from hvacflex.sim.closed_loop import ClosedLoop
    from hvacflex.sim.setup import prepare

    loop = ClosedLoop(prepare(preset("thermostat", start="2014-03-03", days=0.25)))
    loop.step()
    loop.step()
    frame = loop.frame()
    zones = loop.setup.zone_names
    channels = [channel.name for channel in loop.setup.model.channels]
    assert list(frame.columns) == schema.step_frame_columns(zones, channels)
    floats = schema.step_columns(zones, channels)
    assert all(frame[c].dtype == np.float64 for c in floats)
    assert all(frame[c].dtype == bool for c in schema.FLAG_COLUMNS)
    assert frame.index.name == schema.INDEX_NAME
    assert schema.zone_names(frame.columns) == list(zones)


def test_step_columns_refuse_names_that_collide_or_are_empty() -> None:
    with pytest.raises(InputError, match="same results column") as info:
        schema.step_columns(["a", "end_a"], ["outdoor_temp_degc"])
    assert info.value.value == "temp_end_a_degc"
    with pytest.raises(InputError, match="zone name is empty"):
        schema.step_columns(["a", ""], [])
    with pytest.raises(InputError, match="channel name is empty"):
        schema.step_columns(["a"], [""])


def test_fleet_columns_are_the_documented_ones_in_file_order() -> None:
    columns = schema.fleet_columns()
    assert columns[:2] == ["planned_fleet_power_kw", "fleet_power_kw"]
    assert columns[-3:] == ["feeder_infeasible", "il_activated", "coordination_iterations"]
    assert len(columns) == len(set(columns)) == 25
    fleet_doc = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "fleet.md").read_text()
    assert all(f"`{c}`" in fleet_doc for c in columns)


# ------------------------------------------------------------------------ zone-column parser


@pytest.mark.parametrize("zones", TRICKY_ZONES)
def test_zone_names_and_parser_recover_every_zone_column(zones: tuple[str, ...]) -> None:
    columns = schema.step_frame_columns(zones, ["outdoor_temp_degc", "internal_gain_end_w"])
    assert schema.zone_names(columns) == list(zones)
    found: dict[str, list[str]] = {zone: [] for zone in zones}
    for column in columns:
        parsed = schema.parse_zone_column(column, zones)
        if parsed is None:
            assert (
                column in schema.STEP_SCALAR_UNITS
                or column[:2] in ("d_", "w_")
                or (column in (*schema.FLAG_COLUMNS, schema.STATUS_COLUMN))
            )
            continue
        kind, zone = parsed
        assert kind.name(zone) == column
        found[zone].append(column)
    for zone in zones:
        assert found[zone] == [kind.name(zone) for kind in schema.ZONE_COLUMNS]


def test_zone_names_of_older_results_with_temperatures_only() -> None:
    # results before the served/curtailed/event columns: temp_ and temp_end_ only
    columns = ["power_kw", "temp_end_degc", "temp_end_end_degc", "temp_b_degc", "temp_end_b_degc"]
    assert schema.zone_names(columns) == ["end", "b"]
    assert schema.zone_names(["power_kw", "flow_a_kg_s"]) == []


def test_parser_names_a_column_of_two_zones() -> None:
    with pytest.raises(DataError, match="two zones") as info:
        schema.parse_zone_column("temp_end_a_degc", {"a", "end_a"})
    assert info.value.field == "temp_end_a_degc"
    assert schema.parse_zone_column("temp_end_a_degc", {"a"}) == (schema.TEMP_END, "a")
    assert schema.parse_zone_column("temp_end_a_degc", {"end_a"}) == (schema.TEMP, "end_a")
    assert schema.parse_zone_column("temp__degc", {"a"}) is None


# ------------------------------------------------------------------------ units


def test_every_column_builder_has_the_unit_its_name_says() -> None:
    for column, unit in (schema.STEP_SCALAR_UNITS | schema.FLEET_FLOAT_UNITS).items():
        if column in ("coordination_gap", "offer_meter_ratio"):  # dimensionless ratios
            assert unit == schema.NO_UNIT
        else:
            assert unit == _unit_from_suffix(column), column
    for kind in schema.ZONE_COLUMNS:
        assert kind.unit == _unit_from_suffix(kind.name("x")), kind
    for name in (*schema.FLAG_COLUMNS, *schema.FLEET_FLAG_COLUMNS):
        assert schema.column_unit(name) == "bool"
    assert schema.column_unit(schema.STATUS_COLUMN) == schema.NO_UNIT
    assert schema.column_unit(schema.FLEET_ITERATIONS_COLUMN) == schema.NO_UNIT


def test_channel_columns_carry_the_building_channels_units() -> None:
    channels = build_network(load_building(buildings_dir() / "office5.toml")).channels
    zones = ("north", "end_east")
    units = schema.column_units(schema.step_frame_columns(zones, [c.name for c in channels]))
    for channel in channels:
        for kind in schema.CHANNEL_COLUMNS:
            assert units[kind.name(channel.name)] == channel.unit, channel.name
    for kind in schema.ZONE_COLUMNS:
        assert units[kind.name("end_east")] == kind.unit
    assert units["power_kw"] == "kW" and units["il_activated"] == "bool"
    assert len(units) == len(schema.step_frame_columns(zones, [c.name for c in channels]))


def test_unknown_columns_and_unitless_channels_are_refused() -> None:
    with pytest.raises(DataError, match="not a results column") as info:
        schema.column_unit("colour")
    assert info.value.field == "colour"
    with pytest.raises(DataError, match="does not end with a unit"):
        schema.column_unit("d_outdoor_temp")
    assert schema.column_unit("temp_core_degc", zones={"core"}) == "degC"
    with pytest.raises(DataError, match="not a results column"):
        schema.column_unit("flow_core_kg_s", zones={"north"})


# ------------------------------------------------------------------------ writer and reader


def test_round_trip_keeps_frame_and_metadata(tmp_path: Path) -> None:
    frame = _frame(5, ("zone_1", "end_a"), ("outdoor_temp_degc", "internal_gain_zone_1_w"))
    path = tmp_path / schema.RESULTS_FILENAME
    meta = {schema.META_RUN_KEY: "0123abcd", schema.META_VERSION: "1.2.3+src.x", "note": "°C"}
    schema.write_results(frame, path, meta)
    assert sorted(p.name for p in tmp_path.iterdir()) == [schema.RESULTS_FILENAME]  # no tmp
    back, stored = schema.read_results(path)
    pd.testing.assert_frame_equal(back, frame, check_freq=False)
    assert stored == meta
    assert schema.read_metadata(path) == meta
    pd.testing.assert_frame_equal(schema.load_results(tmp_path), frame, check_freq=False)
    assert kpi.energy_cost_sgd(back) == pytest.approx(5 * 10.0 * 0.5 * 100.0 / 1000.0)


def test_writer_writes_the_bytes_the_earlier_writers_wrote(tmp_path: Path) -> None:
    """The earlier run and fleet writers (pandas → Arrow, hvacflex.* metadata appended in this
    order, pyarrow's defaults), spelled out, give the same file byte for byte."""
    frame = _frame(4, ("north",), ("outdoor_temp_degc",))
    config = json.dumps({"name": "x", "controller": {"kind": "thermostat"}})
    meta = {"config": config, "config_hash": "h", "run_key": "k", "version": "v"}
    table = pa.Table.from_pandas(frame)
    earlier = dict(table.schema.metadata or {})
    earlier |= {f"hvacflex.{key}".encode(): value.encode() for key, value in meta.items()}
    pq.write_table(table.replace_schema_metadata(earlier), tmp_path / "earlier.parquet")
    schema.write_results(frame, tmp_path / "now.parquet", meta)
    assert (tmp_path / "now.parquet").read_bytes() == (tmp_path / "earlier.parquet").read_bytes()


def test_files_without_hvacflex_metadata_still_read(tmp_path: Path) -> None:
    frame = _frame(3, ("north",), ("outdoor_temp_degc",))
    frame.to_parquet(tmp_path / "plain.parquet")
    back, stored = schema.read_results(tmp_path / "plain.parquet")
    pd.testing.assert_frame_equal(back, frame, check_freq=False)
    assert stored == {}


def test_a_damaged_file_is_a_stored_state_error_naming_the_fix(tmp_path: Path) -> None:
    path = tmp_path / schema.RESULTS_FILENAME
    schema.write_results(_frame(3, ("north",), ("outdoor_temp_degc",)), path, {"version": "v"})
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(StoredStateError, match=r"not a readable results file.*--fresh") as info:
        schema.read_results(path)
    assert str(path) in str(info.value)
    with pytest.raises(StoredStateError, match="not a readable results file"):
        schema.read_metadata(path)


def test_load_results_from_dir_or_file_keeps_the_tz_index(tmp_path: Path) -> None:
    df = _frame(4, ("north", "core"), ("outdoor_temp_degc",))
    df.to_parquet(tmp_path / "results.parquet")
    for path in (tmp_path, tmp_path / "results.parquet"):
        loaded = schema.load_results(path)
        assert loaded.index.equals(df.index)
        assert kpi.energy_cost_sgd(loaded) == pytest.approx(2.0)
    with pytest.raises(DataError, match="results file not found"):
        schema.load_results(tmp_path / "nothing")
    # a time column (index not stored) becomes the index
    df.reset_index().to_parquet(tmp_path / "flat.parquet", index=False)
    assert schema.load_results(tmp_path / "flat.parquet").index.equals(df.index)


def test_load_results_refuses_what_is_not_a_results_file(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="no such file or directory"):
        schema.load_results(tmp_path / "missing_dir")
    with pytest.raises(DataError, match=r"holds no results\.parquet"):
        schema.load_results(tmp_path)
    text = tmp_path / "notes.parquet"
    text.write_text("not parquet at all")
    with pytest.raises(DataError, match="cannot be read as Parquet"):
        schema.load_results(text)
    other = tmp_path / "other.parquet"
    pd.DataFrame({"x": [1.0, 2.0]}).to_parquet(other)
    with pytest.raises(DataError, match="required columns are missing") as info:
        schema.load_results(other)
    assert info.value.field == "power_kw, energy_price_sgd_per_mwh"


def test_the_exogenous_columns_are_float_columns_named_as_the_exogenous_series() -> None:
    from dataclasses import fields

    from hvacflex.data.forecast import Exogenous

    names = {f.name for f in fields(Exogenous)}
    for column in schema.EXOGENOUS_COLUMNS:
        assert column in schema.STEP_SCALAR_UNITS
        assert column in names
