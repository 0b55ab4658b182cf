"""Feeder limit windows outside a fleet file: the service's limit schedule.

The service (``POST /v1/signals/feeder-limits``, and the OpenADR VEN's capacity-limit
events) takes the same windows as a fleet file's ``[[feeder_limits]]`` tables
(:class:`~hvacflex.fleet.schema.FeederLimitWindowSpec`: validated there, the period mask
there) and applies them the same way: each window lowers the limit in force to its
``limit_kw`` in its periods, the tighter holding (as ``Fleet.limit_series_kw`` does over the
fleet's constant or CSV limit).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd
from pydantic import ValidationError

from hvacflex.errors import InputError
from hvacflex.fleet.schema import FeederLimitWindowSpec


def limit_schedule_kw(
    base_kw: float | np.ndarray,
    windows: Iterable[FeederLimitWindowSpec],
    index: pd.DatetimeIndex,
) -> np.ndarray:
    """The feeder limit in force at each period start of ``index``.

    Parameters
    ----------
    base_kw : the limit without windows [kW]: a constant or (T,) per period (inf = none).
    windows : the limit windows, applied on top (the tighter holds).
    index : (T,) period starts (local or tz-aware).

    Returns
    -------
    (T,) limit [kW]; inf where no limit holds.
    """
    limit = np.broadcast_to(np.asarray(base_kw, dtype=float), (len(index),)).copy()
    for window in windows:
        limit = np.where(window.mask(index), np.minimum(limit, window.limit_kw), limit)
    return limit


def limit_window(data: Any, *, field: str) -> FeederLimitWindowSpec:
    """A ``[[feeder_limits]]`` window from a mapping (stored or sent), validated.

    Raises
    ------
    InputError : not a valid window (naming ``field`` and pydantic's reason).
    """
    try:
        return FeederLimitWindowSpec.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ()))
        raise InputError(
            str(first.get("msg", exc)),
            field=f"{field}.{where}" if where else field,
            value=first.get("input"),
            hint='e.g. {"start": "10:00", "end": "17:00", "limit_kw": 300.0} or ISO date-times',
        ) from None
