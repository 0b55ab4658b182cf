"""Start dates: ISO 8601 only, on the 30-min grid, normalised."""

from __future__ import annotations

import pytest

from hvacflex.dates import StartDateError, normalise_start


@pytest.mark.parametrize(
    ("text", "normal"),
    [
        ("2014-03-04", "2014-03-04"),
        ("2014-03-04T00:00", "2014-03-04"),
        ("2014-03-04T08:30", "2014-03-04T08:30"),
        (" 2014-12-31T23:30 ", "2014-12-31T23:30"),
        ("2014-03-04T08:30:00", "2014-03-04T08:30"),  # zero seconds, as the service allows
    ],
)
def test_iso_dates_are_normalised(text: str, normal: str) -> None:
    assert normalise_start(text) == normal


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("04/03/2014", "ISO 8601"),  # 4 March or 3 April: never guessed
        ("2014/03/04", "ISO 8601"),
        ("4 March 2014", "ISO 8601"),
        ("2014-03-04 08:00", "ISO 8601"),
        ("2014-03-04T08:00+08:00", "ISO 8601"),
        ("2014-03-04T08:00:15", "ISO 8601"),
        ("2014-3-4", "ISO 8601"),
        ("2014-02-30", "calendar"),
        ("2014-03-04T24:00", "calendar"),
        ("2014-03-04T08:10", "30-min period"),
    ],
)
def test_other_spellings_are_refused(text: str, problem: str) -> None:
    with pytest.raises(StartDateError, match=problem):
        normalise_start(text)
