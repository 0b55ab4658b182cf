"""IDF schedules evaluated on days: hand-written Schedule:Compact texts, and the shipped
5ZoneAirCooled's cooling-coil schedule as its IDF states it (weekdays 06:00–20:00), and the
shipped reference small office's fans (``HVACOperationSchd``)."""

from __future__ import annotations

import datetime

import numpy as np

from hvacflex.energyplus.idf import parse_idf
from hvacflex.energyplus.schedules import cooling_coil_available, day_profile, fan_available
from hvacflex.paths import resolve_idf

COMPACT = """
Schedule:Compact, Avail, Fraction,
    Through: 3/31, For: Weekdays, Until: 7:30, 0, Until: 19:00, 1, Until: 24:00, 0.5,
    For: AllOtherDays, Until: 24:00, 0,
    Through: 12/31, For: Saturday, Until: 12:00, 1, Until: 24:00, 0,
    For: AllOtherDays, Until: 24:00, 1;
Schedule:Constant, Always, Fraction, 1;
Schedule:Year, Yearly, Fraction, Week1, 1, 1, 12, 31;
Coil:Cooling:Water, Coil A, Avail;
Coil:Cooling:DX:SingleSpeed, Coil B, Always;
"""


def _objects(text: str = COMPACT) -> tuple:  # type: ignore[type-arg]
    return parse_idf(text, "test.idf")


def test_a_compact_schedule_takes_the_block_and_day_type_in_force() -> None:
    objects = _objects()
    tuesday = day_profile(objects, "avail", datetime.date(2014, 3, 25))  # any case
    assert tuesday is not None
    expected = np.r_[np.zeros(15), np.ones(23), np.full(10, 0.5)]  # 07:30 = period 15
    np.testing.assert_array_equal(tuesday, expected)
    saturday_march = day_profile(objects, "Avail", datetime.date(2014, 3, 29))
    assert saturday_march is not None and not saturday_march.any()
    saturday_april = day_profile(objects, "Avail", datetime.date(2014, 4, 5))
    assert saturday_april is not None
    np.testing.assert_array_equal(saturday_april, np.r_[np.ones(24), np.zeros(24)])
    monday_april = day_profile(objects, "Avail", datetime.date(2014, 4, 7))
    assert monday_april is not None and monday_april.all()
    constant = day_profile(objects, "Always", datetime.date(2014, 4, 7))
    assert constant is not None and (constant == 1.0).all()


def test_schedules_not_read_here_give_none() -> None:
    objects = _objects()
    assert day_profile(objects, "Yearly", datetime.date(2014, 4, 7)) is None
    assert day_profile(objects, "missing", datetime.date(2014, 4, 7)) is None
    text = COMPACT.replace("Coil:Cooling:DX:SingleSpeed, Coil B, Always;", "")
    yearly = text.replace("Coil A, Avail;", "Coil A, Yearly;")
    assert cooling_coil_available(_objects(yearly), [datetime.date(2014, 4, 7)]) is None
    no_coil = "Schedule:Constant, Always, Fraction, 1;"
    assert cooling_coil_available(_objects(no_coil), [datetime.date(2014, 4, 7)]) is None


def test_some_coil_available_is_the_union_of_the_coils_schedules() -> None:
    text = COMPACT.replace("Coil B, Always;", "Coil B, Avail;")
    days = [datetime.date(2014, 3, 25), datetime.date(2014, 3, 29)]
    table = cooling_coil_available(_objects(text), days)
    assert table is not None and table.shape == (2, 48)
    np.testing.assert_array_equal(table[0], np.r_[np.zeros(15), np.ones(33)].astype(bool))
    assert not table[1].any()
    always = cooling_coil_available(_objects(), days)  # Coil B is always available
    assert always is not None and always.all()


def test_the_shipped_5zone_coils_run_on_weekdays_from_6_to_20() -> None:
    path = resolve_idf("5ZoneAirCooled")
    objects = parse_idf(path.read_text(encoding="utf-8"), path)
    days = [datetime.date(2014, 3, 25), datetime.date(2014, 3, 29), datetime.date(2014, 3, 30)]
    table = cooling_coil_available(objects, days)
    assert table is not None
    period = np.arange(48)
    np.testing.assert_array_equal(table[0], (period >= 12) & (period < 40))
    assert not table[1:].any()


def test_the_shipped_small_office_fans_run_on_working_days_6_to_22_and_saturday_6_to_18() -> None:
    """``HVACOperationSchd`` of its five PSZ-AC fans (``Fan:ConstantVolume`` and one
    ``Fan:SystemModel``); its DX coils are always available."""
    path = resolve_idf("RefBldgSmallOfficeNew2004_Chicago")
    objects = parse_idf(path.read_text(encoding="utf-8"), path)
    days = [datetime.date(2014, 3, 25), datetime.date(2014, 3, 29), datetime.date(2014, 3, 30)]
    table = fan_available(objects, days)
    assert table is not None and table.shape == (3, 48)
    period = np.arange(48)
    np.testing.assert_array_equal(table[0], (period >= 12) & (period < 44))
    np.testing.assert_array_equal(table[1], (period >= 12) & (period < 36))
    assert not table[2].any()
    coils = cooling_coil_available(objects, days)
    assert coils is not None and coils.all()


def test_fans_without_a_readable_schedule_or_no_fan_give_none() -> None:
    text = COMPACT + "Fan:ConstantVolume, Fan A, Yearly;"
    assert fan_available(_objects(text), [datetime.date(2014, 4, 7)]) is None
    assert fan_available(_objects(), [datetime.date(2014, 4, 7)]) is None  # no fan
    day = [datetime.date(2014, 4, 7)]
    unscheduled = fan_available(_objects(COMPACT + "Fan:OnOff, Fan B, ;"), day)
    assert unscheduled is not None and unscheduled.all()
