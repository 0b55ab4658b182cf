"""Dates the user writes: ISO 8601 only, on the 30-min grid, in Singapore local time.

Every command and the scenario file take a start as ``YYYY-MM-DD`` (midnight) or
``YYYY-MM-DDTHH:MM`` (a period start, minutes 00 or 30; ``:00`` seconds may follow). Nothing
else is guessed: ``04/03/2014`` could be 4 March or 3 April, so it is refused rather than
read one way silently. The normalised spelling (:func:`normalise_start`) is what
configurations store and hash.
"""

from __future__ import annotations

import re
from datetime import datetime

from hvacflex.constants import DEFAULT_START

ISO_START_FORMS = "YYYY-MM-DD or YYYY-MM-DDTHH:MM"
"""The two spellings of a start date, as the error messages name them."""

START_EXAMPLE = f"{DEFAULT_START} or {DEFAULT_START}T08:30"
"""An example of each form."""

_ISO_START = re.compile(r"(\d{4})-(\d{2})-(\d{2})(?:T(\d{2}):(\d{2})(?::00)?)?")
"""The two forms; zero seconds (``T08:30:00``, what the service's schema allows) are read too."""


class StartDateError(ValueError):
    """A start date that is not ``YYYY-MM-DD`` or ``YYYY-MM-DDTHH:MM`` on a 30-min period.

    ``problem`` says what is wrong in a phrase (the callers add the field and the value).
    """

    def __init__(self, problem: str) -> None:
        self.problem = problem
        super().__init__(problem)


def normalise_start(text: str) -> str:
    """The canonical spelling of a start date: ``YYYY-MM-DD`` at midnight, else
    ``YYYY-MM-DDTHH:MM``.

    >>> normalise_start("2014-03-04T00:00"), normalise_start("2014-03-04T08:30")
    ('2014-03-04', '2014-03-04T08:30')

    Raises
    ------
    StartDateError
        When ``text`` is not in one of the two ISO 8601 forms, is not a calendar date, or does
        not start a 30-min period.
    """
    match = _ISO_START.fullmatch(text.strip())
    if match is None:
        raise StartDateError(f"must be an ISO 8601 date, {ISO_START_FORMS}")
    year, month, day, hour, minute = (int(g) if g is not None else 0 for g in match.groups())
    try:
        moment = datetime(year, month, day, hour, minute)
    except ValueError as exc:
        raise StartDateError(f"not a calendar date and time ({exc})") from None
    if minute not in (0, 30):
        raise StartDateError("must start a 30-min period (minutes 00 or 30)")
    if hour == 0 and minute == 0:
        return moment.strftime("%Y-%m-%d")
    return moment.strftime("%Y-%m-%dT%H:%M")
