"""The results schema: column names and their units, the zone-column parser, and the one
writer/reader pair of results files.

A closed-loop run writes one Parquet file (:data:`RESULTS_FILENAME`), one row per control
step, index :data:`INDEX_NAME` (period starts, tz-aware). Its columns
(``docs/reference/results.md``) are, in this order (:func:`step_frame_columns`):

* the per-step floats of :data:`STEP_SCALAR_UNITS`;
* per zone, the :class:`ZoneColumn` kinds of :data:`ZONE_COLUMNS` (``temp_<zone>_degc``, …);
* per disturbance channel, ``d_<channel>`` then, for all channels, ``w_<channel>``
  (:data:`FORECAST_DISTURBANCE`, :data:`DISTURBANCE_ERROR`); a channel's name ends with its
  unit (``outdoor_temp_degc``, ``solar_az180_tilt90_w_per_m2``, ``internal_gain_core_w``);
* the flags :data:`FLAG_COLUMNS` and the text column :data:`STATUS_COLUMN`.

A fleet run writes its own per-step table under the same file name (:data:`FLEET_FLOAT_UNITS`,
:data:`FLEET_FLAG_COLUMNS`, :data:`FLEET_ITERATIONS_COLUMN`; ``docs/guide/fleet.md``) and every
building's rows in long format (:data:`BUILDINGS_FILENAME`, column :data:`BUILDING_COLUMN`).

Units are spelled as :data:`hvacflex.building.channels.CHANNEL_UNITS` spells them (``degC``,
``W/m2``); ``bool`` marks a flag and ``""`` a column without a unit (text, counts, ratios).

Files: :func:`write_results` writes a frame with ``hvacflex.<key>`` entries in the Parquet
metadata (a run: :data:`META_CONFIG`, :data:`META_CONFIG_HASH`, :data:`META_RUN_KEY`,
:data:`META_VERSION`; a fleet: :data:`META_FLEET`, :data:`META_RUN_KEY`, :data:`META_VERSION`),
atomically. :func:`read_results` reads a file hvacflex wrote back with that metadata (for
re-use; a damaged file is a :class:`~hvacflex.errors.StoredStateError`);
:func:`load_results` reads a run's results for analysis (a run folder or a file; what is not
a results file is a :class:`~hvacflex.errors.DataError`).
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from hvacflex.errors import DataError, InputError, StoredStateError
from hvacflex.version import atomic_write

RESULTS_FILENAME = "results.parquet"
"""Name of the results file in a run directory (a closed-loop or a fleet run)."""

BUILDINGS_FILENAME = "buildings.parquet"
"""Name of a fleet run's per-building results (long format) in its directory."""

INDEX_NAME = "time"
"""Name of the index: period starts, tz-aware."""

RESULTS_REQUIRED_COLUMNS = ("power_kw", "energy_price_sgd_per_mwh")
"""Columns every closed-loop results file has; a Parquet file without them is not one."""

METADATA_PREFIX = "hvacflex."
"""Prefix of hvacflex's keys in the Parquet file metadata."""

META_CONFIG = "config"
"""Metadata key: the run's configuration (JSON)."""
META_CONFIG_HASH = "config_hash"
"""Metadata key: the configuration's hash."""
META_RUN_KEY = "run_key"
"""Metadata key: the run key (configuration and input files; a fleet's: file and period)."""
META_VERSION = "version"
"""Metadata key: the code version that wrote the file."""
META_FLEET = "fleet"
"""Metadata key: the fleet's name; marks a fleet run's results."""

# ----------------------------------------------------------------------------- columns

FLAG_UNIT = "bool"
"""Unit of a flag column."""

NO_UNIT = ""
"""Unit of a column without one (text, counts, ratios)."""


STEP_SCALAR_UNITS: dict[str, str] = {
    "energy_price_sgd_per_mwh": "SGD/MWh",
    "reserve_price_sgd_per_mwh": "SGD/MWh",
    "peak_price_sgd_per_kw": "SGD/kW",
    "power_kw": "kW",
    "facility_power_kw": "kW",
    "power_served_kw": "kW",
    "power_curtailed_kw": "kW",
    "planned_power_kw": "kW",
    "committed_peak_kw": "kW",
    "reserve_kw": "kW",
    "offer_meter_ratio": NO_UNIT,
    "solve_time_s": "s",
    "planned_slack_max_k": "K",
    "delta_max_k": "K",
    "il_allowance_k": "K",
    "il_reference_power_kw": "kW",
    "il_penalty_price_sgd_per_mwh": "SGD/MWh",
    "il_forfeited_price_sgd_per_mwh": "SGD/MWh",
    "il_baseline_power_kw": "kW",
    "il_delivered_kw": "kW",
    "il_shortfall_kw": "kW",
    "outdoor_humidity_ratio_kg_per_kg": "kg/kg",
}
"""The per-step float columns that are not per zone or channel, in file order → unit.
``outdoor_humidity_ratio_kg_per_kg`` is the period's realised outdoor humidity ratio (the
weather file's), the moisture term's input when a power model is fitted to a run's meter
(``hvacflex identify power --data RUN``)."""

EXOGENOUS_COLUMNS: tuple[str, ...] = (
    "energy_price_sgd_per_mwh",
    "reserve_price_sgd_per_mwh",
    "outdoor_humidity_ratio_kg_per_kg",
)
"""The per-step float columns copied from the run's exogenous series of the same name
(``hvacflex.data.forecast.Exogenous``: the data, not the controller's forecast of it)."""

FLAG_COLUMNS: tuple[str, ...] = (
    "il_activated",
    "il_curtailed",
    "il_beyond_model",
    "il_event_window",
    "fallback",
    "model_extrapolation",
    "peak_guard_active",
)
"""Boolean per-step columns, in file order (after the float columns)."""

STATUS_COLUMN = "solve_status"
"""Text column: the solver outcome of the step (the last column)."""


@dataclass(frozen=True)
class ZoneColumn:
    """One kind of per-zone column, named ``<prefix><zone><suffix>``.

    Attributes
    ----------
    prefix, suffix : the name around the zone, e.g. ``"temp_end_"`` and ``"_degc"``.
    unit : the values' unit, e.g. ``"degC"``.
    """

    prefix: str
    suffix: str
    unit: str

    def name(self, zone: str) -> str:
        """The column of ``zone``, e.g. ``TEMP_END.name("north") == "temp_end_north_degc"``."""
        return f"{self.prefix}{zone}{self.suffix}"

    def names(self, zones: Iterable[str]) -> list[str]:
        """The columns of ``zones``, in their order."""
        return [self.name(zone) for zone in zones]

    def zone(self, column: str) -> str | None:
        """What stands between prefix and suffix of ``column`` (None if it is not of this
        form). Alone this is ambiguous (``temp_end_a_degc`` is ``TEMP`` of a zone
        ``end_a`` or ``TEMP_END`` of ``a``): use :func:`zone_names` or
        :func:`parse_zone_column`, which know the zones."""
        fixed = len(self.prefix) + len(self.suffix)
        if len(column) > fixed and column.startswith(self.prefix) and column.endswith(self.suffix):
            return column[len(self.prefix) : len(column) - len(self.suffix)]
        return None


FLOW = ZoneColumn("flow_", "_kg_s", "kg/s")
"""Supply flow applied, u_0 [kg/s]."""
RESERVE_FLOW = ZoneColumn("reserve_flow_", "_kg_s", "kg/s")
"""Reserve flow offered, r_0 [kg/s]."""
TEMP = ZoneColumn("temp_", "_degc", "degC")
"""Zone temperature measured at period start [°C]; its columns define the zones."""
TEMP_END = ZoneColumn("temp_end_", "_degc", "degC")
"""Zone temperature at period end [°C]."""
TEMP_SERVED = ZoneColumn("temp_served_", "_degc", "degC")
"""The plan's one-step prediction without IL activation [°C]."""
TEMP_CURTAILED = ZoneColumn("temp_curtailed_", "_degc", "degC")
"""The plan's one-step prediction with IL activation [°C]."""
EVENT_WORST = ZoneColumn("event_worst_", "_degc", "degC")
"""The plan's worst end-of-period temperature over its event set × the box [°C]."""
COMFORT_LOWER = ZoneColumn("comfort_lower_", "_degc", "degC")
"""Lower bound of the comfort band of the period [°C]."""
COMFORT_UPPER = ZoneColumn("comfort_upper_", "_degc", "degC")
"""Upper bound of the comfort band of the period [°C]."""
PREDICTION_ERROR = ZoneColumn("prediction_error_", "_k", "K")
"""One-step prediction error of the controller's model [K]."""

ZONE_COLUMNS: tuple[ZoneColumn, ...] = (
    FLOW,
    RESERVE_FLOW,
    TEMP,
    TEMP_END,
    TEMP_SERVED,
    TEMP_CURTAILED,
    EVENT_WORST,
    COMFORT_LOWER,
    COMFORT_UPPER,
    PREDICTION_ERROR,
)
"""The per-zone kinds, in file order within each zone."""


@dataclass(frozen=True)
class ChannelColumn:
    """One kind of per-channel column, named ``<prefix><channel>``; the unit is the
    channel's, read from the end of its name (:data:`CHANNEL_UNIT_SUFFIXES`)."""

    prefix: str

    def name(self, channel: str) -> str:
        """The column of ``channel``, e.g. ``d_outdoor_temp_degc``."""
        return f"{self.prefix}{channel}"

    def names(self, channels: Iterable[str]) -> list[str]:
        """The columns of ``channels``, in their order."""
        return [self.name(channel) for channel in channels]

    def channel(self, column: str) -> str | None:
        """The channel of ``column``, or None if it is not of this kind."""
        if len(column) > len(self.prefix) and column.startswith(self.prefix):
            return column[len(self.prefix) :]
        return None


FORECAST_DISTURBANCE = ChannelColumn("d_")
"""Forecast disturbance d̂ of the period, in the channel's unit."""
DISTURBANCE_ERROR = ChannelColumn("w_")
"""Realised disturbance error w of the period, in the channel's unit."""
CHANNEL_COLUMNS: tuple[ChannelColumn, ...] = (FORECAST_DISTURBANCE, DISTURBANCE_ERROR)
"""The per-channel kinds, in file order (all ``d_`` columns, then all ``w_`` columns)."""

CHANNEL_UNIT_SUFFIXES: tuple[tuple[str, str], ...] = (
    ("_w_per_m2", "W/m2"),
    ("_degc", "degC"),
    ("_w", "W"),
)
"""End of a disturbance channel's name → its unit (``hvacflex.building.channels`` names)."""

FLEET_FLOAT_UNITS: dict[str, str] = {
    "planned_fleet_power_kw": "kW",
    "fleet_power_kw": "kW",
    "feeder_limit_kw": "kW",
    "fleet_reserve_kw": "kW",
    "fleet_bid_kw": "kW",
    "fleet_min_power_kw": "kW",
    "feeder_excess_kw": "kW",
    "feeder_price_sgd_per_mwh": "SGD/MWh",
    "coordination_gap": NO_UNIT,
    "coordination_time_s": "s",
    "step_time_s": "s",
    "energy_price_sgd_per_mwh": "SGD/MWh",
    "reserve_price_sgd_per_mwh": "SGD/MWh",
    "settled_reserve_kw": "kW",
    "discomfort_kelvin_hours": "K·h",
    "il_baseline_power_kw": "kW",
    "il_delivered_kw": "kW",
    "il_shortfall_kw": "kW",
    "fleet_offer_kw": "kW",
    "il_dispatched_kw": "kW",
    "il_delivered_buildings_kw": "kW",
}
"""A fleet run's per-step float columns, in file order → unit (``docs/guide/fleet.md``)."""

FLEET_FLAG_COLUMNS: tuple[str, ...] = ("bid_accepted", "feeder_infeasible", "il_activated")
"""A fleet run's boolean per-step columns, in file order (after the floats)."""

FLEET_ITERATIONS_COLUMN = "coordination_iterations"
"""A fleet run's integer column (the last): price iterations of the step."""

BUILDING_COLUMN = "building"
"""Column of :data:`BUILDINGS_FILENAME` naming the building of each row."""


def step_columns(zones: Sequence[str], channels: Sequence[str]) -> list[str]:
    """The float columns of a closed-loop results frame, in file order.

    Parameters
    ----------
    zones : (m,) zone names, in the building's order.
    channels : (nd,) disturbance channel names, in the model's channel order.

    Returns
    -------
    ``[*STEP_SCALAR_UNITS, per zone the ZONE_COLUMNS kinds, d_<channel>…, w_<channel>…]``.

    Raises
    ------
    InputError
        When a zone or channel name is empty, or two names would give the same column
        (zones ``a`` and ``end_a`` both give ``temp_end_a_degc``).
    """
    for what, names in (("zone", zones), ("channel", channels)):
        if any(not name for name in names):
            raise InputError(f"a {what} name is empty", field=f"{what}s", value=list(names))
    columns = list(STEP_SCALAR_UNITS)
    for zone in zones:
        columns += [kind.name(zone) for kind in ZONE_COLUMNS]
    for kind in CHANNEL_COLUMNS:
        columns += kind.names(channels)
    _refuse_duplicates(columns, zones, channels)
    return columns


def _refuse_duplicates(columns: list[str], zones: Sequence[str], channels: Sequence[str]) -> None:
    seen: set[str] = set()
    for column in columns:
        if column in seen:
            raise InputError(
                "two zones or channels give the same results column",
                field="zones",
                value=column,
                hint=f"rename a zone of {list(zones)} or a channel of {list(channels)} so "
                "that no zone name is another's with a prefix such as 'end_' or 'served_'",
            )
        seen.add(column)


def step_frame_columns(zones: Sequence[str], channels: Sequence[str]) -> list[str]:
    """Every column of a closed-loop results frame, in file order: :func:`step_columns`,
    :data:`FLAG_COLUMNS`, :data:`STATUS_COLUMN`."""
    return [*step_columns(zones, channels), *FLAG_COLUMNS, STATUS_COLUMN]


def fleet_columns() -> list[str]:
    """Every column of a fleet run's results frame, in file order."""
    return [*FLEET_FLOAT_UNITS, *FLEET_FLAG_COLUMNS, FLEET_ITERATIONS_COLUMN]


# ----------------------------------------------------------------------------- parser


def zone_names(columns: Iterable[object]) -> list[str]:
    """Zone names, in column order, from the ``temp_<zone>_degc`` columns of ``columns``.

    ``temp_end_``, ``temp_served_`` and ``temp_curtailed_`` columns of the same zones are not
    zones themselves: a candidate ``end_<z>`` is dropped when ``<z>`` is a candidate too. A
    zone named ``end_a`` alone is kept (its ``temp_end_`` column is ``temp_end_end_a_degc``).
    Empty when there is no zone temperature column.
    """
    candidates = [zone for col in columns if (zone := TEMP.zone(str(col))) is not None]
    candidate_set = set(candidates)
    derived = [
        kind.prefix[len(TEMP.prefix) :]
        for kind in ZONE_COLUMNS
        if kind != TEMP and kind.prefix.startswith(TEMP.prefix) and kind.suffix == TEMP.suffix
    ]
    return [
        zone
        for zone in candidates
        if not any(
            zone.startswith(prefix) and zone[len(prefix) :] in candidate_set for prefix in derived
        )
    ]


def parse_zone_column(column: str, zones: Collection[str]) -> tuple[ZoneColumn, str] | None:
    """The kind and zone of a per-zone column of one of ``zones``; None for other columns.

    Raises
    ------
    DataError
        When the column is of two zones (names that :func:`step_columns` refuses).
    """
    matches = [
        (kind, zone)
        for kind in ZONE_COLUMNS
        if (zone := kind.zone(column)) is not None and zone in zones
    ]
    if len(matches) > 1:
        raise DataError(
            "results column belongs to two zones",
            source="results",
            field=column,
            value=[zone for _, zone in matches],
            hint="zone names must not be another zone's name with a prefix such as 'end_'",
        )
    return matches[0] if matches else None


def channel_unit(channel: str) -> str:
    """Unit of a disturbance channel from the end of its name (``outdoor_temp_degc`` → degC).

    Raises
    ------
    DataError
        When the name ends with none of :data:`CHANNEL_UNIT_SUFFIXES`.
    """
    for suffix, unit in CHANNEL_UNIT_SUFFIXES:
        if channel.endswith(suffix):
            return unit
    raise DataError(
        "disturbance channel name does not end with a unit",
        source="results",
        field=channel,
        hint="channel names end with " + ", ".join(s for s, _ in CHANNEL_UNIT_SUFFIXES),
    )


def column_unit(column: str, zones: Collection[str] | None = None) -> str:
    """Unit of a results column (closed-loop or fleet), e.g. ``"kW"``, ``"degC"``, ``"bool"``.

    Parameters
    ----------
    column : the column name.
    zones : the zones of the frame; default: any zone (every per-zone kind of one suffix
        shares its unit, so the zone need not be known to tell the unit).

    Raises
    ------
    DataError
        When the column is not in the schema.
    """
    known = STEP_SCALAR_UNITS | FLEET_FLOAT_UNITS
    if column in known:
        return known[column]
    if column in FLAG_COLUMNS or column in FLEET_FLAG_COLUMNS:
        return FLAG_UNIT
    if column in (STATUS_COLUMN, FLEET_ITERATIONS_COLUMN, BUILDING_COLUMN):
        return NO_UNIT
    for kind in ZONE_COLUMNS:
        zone = kind.zone(column)
        if zone is not None and (zones is None or zone in zones):
            return kind.unit
    for channel_kind in CHANNEL_COLUMNS:
        channel = channel_kind.channel(column)
        if channel is not None:
            return channel_unit(channel)
    raise DataError(
        "not a results column",
        source="results",
        field=column,
        hint="see the columns in docs/reference/results.md (fleet runs: docs/guide/fleet.md)",
    )


def column_units(columns: Iterable[object]) -> dict[str, str]:
    """``{column: unit}`` for the columns of a results frame (see :func:`column_unit`)."""
    names = [str(col) for col in columns]
    zones = zone_names(names)
    return {name: column_unit(name, zones or None) for name in names}


# ----------------------------------------------------------------------------- files

_FRESH_HINT = "delete the file or run again with --fresh (hvacflex simulate --fresh)"


def write_results(frame: pd.DataFrame, path: str | Path, metadata: Mapping[str, str]) -> None:
    """Write ``frame`` as Parquet with ``hvacflex.<key>: value`` metadata, atomically.

    Parameters
    ----------
    frame : a results frame (index :data:`INDEX_NAME`).
    path : the file to write (a temporary file beside it is renamed over it).
    metadata : ``{key: value}``, e.g. :data:`META_RUN_KEY`; written in this order after
        pandas' own metadata.
    """
    import pyarrow as pa  # here, not at the top: importing the schema stays cheap
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(frame)
    stored = dict(table.schema.metadata or {})
    for key, value in metadata.items():
        stored[f"{METADATA_PREFIX}{key}".encode()] = value.encode()
    table = table.replace_schema_metadata(stored)
    atomic_write(path, lambda tmp: pq.write_table(table, tmp))


def _read_errors() -> tuple[type[Exception], ...]:
    """What reading a file that is not (a whole) Parquet file raises (pyarrow: ArrowInvalid,
    …); a function so that pyarrow is imported only when a file is read."""
    import pyarrow as pa

    return (OSError, pa.ArrowException, ValueError, TypeError, RuntimeError)


def read_metadata(path: str | Path) -> dict[str, str]:
    """The ``hvacflex.<key>`` metadata of a Parquet file, prefix removed (``{}`` when it has
    none); the file's rows are not read.

    Raises
    ------
    StoredStateError
        When the file is not a readable Parquet file.
    """
    import pyarrow.parquet as pq

    try:
        schema = pq.read_schema(path)
    except _read_errors() as exc:
        raise _unreadable(Path(path), exc) from None
    return _hvacflex_metadata(schema.metadata)


def read_results(path: str | Path) -> tuple[pd.DataFrame, dict[str, str]]:
    """A results file hvacflex wrote and its ``hvacflex.<key>`` metadata (prefix removed).

    Raises
    ------
    StoredStateError
        When the file is not a readable Parquet file (e.g. truncated).
    """
    try:
        return _read_table(Path(path))
    except _read_errors() as exc:
        raise _unreadable(Path(path), exc) from None


def _read_table(path: Path) -> tuple[pd.DataFrame, dict[str, str]]:
    """The one Parquet reading of a results file: (frame, hvacflex metadata)."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    return table.to_pandas(), _hvacflex_metadata(table.schema.metadata)


def _hvacflex_metadata(metadata: Mapping[bytes, bytes] | None) -> dict[str, str]:
    prefix = METADATA_PREFIX.encode()
    return {
        key[len(prefix) :].decode(): value.decode()
        for key, value in (metadata or {}).items()
        if key.startswith(prefix)
    }


def _unreadable(path: Path, exc: Exception) -> StoredStateError:
    return StoredStateError(
        f"not a readable results file (truncated or damaged: {type(exc).__name__})",
        source=path,
        hint=_FRESH_HINT,
    )


def load_results(path: str | Path) -> pd.DataFrame:
    """Read a run's results for analysis: a Parquet file, or a run directory holding
    :data:`RESULTS_FILENAME`.

    A :data:`INDEX_NAME` column (if the index was not stored) becomes the index.

    Raises
    ------
    DataError
        When the path does not exist, the directory holds no results file, or the file is
        not a Parquet file with the results columns (:data:`RESULTS_REQUIRED_COLUMNS`).
    """
    hint = f"pass a run directory holding {RESULTS_FILENAME} (written by hvacflex simulate) or "
    hint += "such a Parquet file"
    given = Path(path)
    if not given.exists():
        raise DataError(
            "results file not found: no such file or directory", source=given, hint=hint
        )
    file = given / RESULTS_FILENAME if given.is_dir() else given
    if not file.is_file():
        raise DataError(
            f"results file not found: the directory holds no {RESULTS_FILENAME}",
            source=given,
            hint=hint,
        )
    try:
        results, _ = _read_table(file)
    except _read_errors() as exc:
        raise DataError(
            f"not a results file: cannot be read as Parquet ({type(exc).__name__})",
            source=file,
            hint=hint,
        ) from None
    missing = [c for c in RESULTS_REQUIRED_COLUMNS if c not in results.columns]
    if missing:
        raise DataError(
            "not a results file: required columns are missing",
            source=file,
            field=", ".join(missing),
            hint=hint + "; see the columns in docs/reference/results.md",
        )
    if not isinstance(results.index, pd.DatetimeIndex) and INDEX_NAME in results.columns:
        results = results.set_index(INDEX_NAME)
    return results
