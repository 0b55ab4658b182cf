"""A calibrated uncertainty box: half-widths sized from a training period's errors.

The robust MPC plans for ``|w| ≤ σ`` (:mod:`hvacflex.data.uncertainty`). Instead of a
chosen ±5 % / ±0.5 K, :func:`calibrate_box` sizes σ from errors observed on a training
period, at a stated quantile q (e.g. 0.95):

* **disturbance channels** (one half-width per channel, not per kind): from the forecast
  errors ``e = d − d̂`` of every forecast the controller would have made in the training
  period, at every lead time of its horizon (:func:`forecast_errors`):

  - temperatures (``outdoor_temp``, ``ground_temp``): absolute half-width
    ``σ_i = Q_q(|e_i|)`` [K];
  - heat gains (``solar``, ``internal_gain``): ``σ_i = r_i · |d̂_i| + a_i``. The samples
    with a low forecast, ``|d̂_i| < LOW_FORECAST_FRACTION · max |d̂_i|`` (sunrise and sunset,
    where a climatology says "some sun" and the façade has none or much more), give the
    absolute part ``a_i = Q_q(|e_i|)``; the others the relative part ``r_i = Q_q(max(|e_i|
    − a_i, 0) / |d̂_i|)``. Each group is then covered at q, so the whole is (a channel
    without low forecasts gets ``a_i = 0`` and ``r_i = Q_q(|e_i|/|d̂_i|)``);

* **model error** (one term per zone): ``ε_z = Q_q(|ε_z,k|)`` [K per step] of the one-step
  prediction error ``prediction_error_<zone>_k`` of the results (the error of the
  controller's linear model with the true state, the applied input and the realised
  disturbance, docs/explanation/estimation.md §4). The MPC tightens the comfort band by its
  accumulated effect ``Σ_{j<k} |C A^{k−1−j} Cᵀ| ε`` (docs/explanation/forecast.md).

``Q_q`` is the empirical quantile taking the next-higher sample (``numpy.quantile``,
``method="higher"``), so at least a fraction q of the training samples lies inside.
:func:`coverage` measures the fraction inside on other (out-of-sample) data. The
identification work reuses :func:`calibrate_box` with its own model's prediction errors.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Protocol

import numpy as np

from hvacflex.building.channels import DisturbanceChannel
from hvacflex.data.forecast import Forecast
from hvacflex.data.uncertainty import UncertaintyBox
from hvacflex.errors import ConfigError, DataError

RELATIVE_KINDS = ("solar", "internal_gain")
"""Channel kinds whose calibrated half-width is relative to the forecast."""

LOW_FORECAST_FRACTION = 0.2
"""A heat-gain forecast below this fraction of the channel's largest is "low" (its error is
sized absolutely)."""

COVERAGE_RELATIVE_TOLERANCE = 1e-9
"""An error counts as inside the box up to this relative round-off of σ."""


class ForecastSource(Protocol):
    """What :func:`forecast_errors` reads: a ``Forecaster``'s ``forecast(k, horizon)``."""

    def forecast(self, k: int, horizon: int) -> Forecast: ...


@dataclass(frozen=True)
class Calibration:
    """A box calibrated at a quantile.

    Attributes
    ----------
    box : the per-channel box (``channel_relative`` / ``channel_absolute``).
    model_error_k : zone → one-step model-error half-width ε [K per step] (empty: none
        calibrated).
    quantile : the quantile q the half-widths are sized at.
    samples : number of disturbance error samples (steps × leads) it was sized from.
    """

    box: UncertaintyBox
    model_error_k: Mapping[str, float] = field(default_factory=dict)
    quantile: float = 0.95
    samples: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "model_error_k", MappingProxyType(dict(self.model_error_k)))


def _check_quantile(quantile: float) -> None:
    if not 0.0 < quantile < 1.0:
        raise ConfigError(
            "the calibration quantile must be in (0, 1)",
            field="uncertainty.calibrate.quantile",
            value=quantile,
            hint="e.g. 0.95",
        )


def forecast_errors(
    forecaster: ForecastSource, truth: np.ndarray, steps: range, horizon: int
) -> tuple[np.ndarray, np.ndarray]:
    """The forecast errors of every forecast made at ``steps``, at every lead.

    Parameters
    ----------
    forecaster : serves ``forecast(k, horizon)`` (with ``disturbances`` (horizon, nd)).
    truth : (T, nd) the realised disturbances (what the plant sees), T ≥ max(steps) + horizon.
    steps : the steps k the forecasts are made at.
    horizon : leads per forecast.

    Returns
    -------
    errors, forecasts : (len(steps) · horizon, nd) ``d − d̂`` and ``d̂`` [channel units].
    """
    errors, forecasts = [], []
    for k in steps:
        d_hat = np.asarray(forecaster.forecast(k, horizon).disturbances)
        forecasts.append(d_hat)
        errors.append(truth[k : k + horizon] - d_hat)
    return np.concatenate(errors), np.concatenate(forecasts)


def _quantile(values: np.ndarray, quantile: float) -> float:
    if values.size == 0:
        return 0.0
    return float(np.quantile(values, quantile, method="higher"))


def calibrate_box(
    errors: np.ndarray,
    forecasts: np.ndarray,
    channels: Sequence[DisturbanceChannel],
    quantile: float,
    *,
    prediction_error_k: Mapping[str, np.ndarray] | None = None,
) -> Calibration:
    """Size the box from training errors (module docstring).

    Parameters
    ----------
    errors : (S, nd) forecast errors ``d − d̂`` [channel units].
    forecasts : (S, nd) the forecasts ``d̂`` they belong to.
    channels : (nd,) their channels.
    quantile : q in (0, 1).
    prediction_error_k : zone → (S_z,) one-step prediction errors [K] (NaN ignored); None:
        no model-error term.

    Returns
    -------
    :class:`Calibration`.
    """
    _check_quantile(quantile)
    errors = np.asarray(errors, dtype=float)
    forecasts = np.asarray(forecasts, dtype=float)
    if errors.shape != forecasts.shape or errors.ndim != 2 or errors.shape[1] != len(channels):
        raise DataError(
            "errors and forecasts must both be (S, nd)",
            source="calibrate_box",
            field="errors",
            value=(errors.shape, forecasts.shape),
            hint=f"nd = {len(channels)}",
        )
    relative: dict[str, float] = {}
    absolute: dict[str, float] = {}
    for i, ch in enumerate(channels):
        e, d_hat = np.abs(errors[:, i]), np.abs(forecasts[:, i])
        if ch.box_kind in RELATIVE_KINDS:
            peak = d_hat.max() if d_hat.size else 0.0
            high = (d_hat > 0) & (d_hat >= LOW_FORECAST_FRACTION * peak)
            absolute[ch.name] = _quantile(e[~high], quantile)
            excess = np.maximum(e[high] - absolute[ch.name], 0.0)
            relative[ch.name] = _quantile(excess / d_hat[high], quantile)
        else:
            absolute[ch.name] = _quantile(e, quantile)
    model_error: dict[str, float] = {}
    for zone, values in (prediction_error_k or {}).items():
        finite = np.abs(np.asarray(values, dtype=float))
        model_error[zone] = _quantile(finite[np.isfinite(finite)], quantile)
    box = UncertaintyBox(channel_relative=relative, channel_absolute=absolute)
    return Calibration(box, model_error, quantile, errors.shape[0])


def coverage(
    errors: np.ndarray,
    forecasts: np.ndarray,
    box: UncertaintyBox,
    channels: Sequence[DisturbanceChannel],
) -> np.ndarray:
    """Fraction of the errors inside the box, per channel.

    Parameters
    ----------
    errors, forecasts : (S, nd) ``d − d̂`` and ``d̂`` [channel units].
    box : the box; σ = ``box.sigma(forecasts, channels)``.
    channels : (nd,).

    Returns
    -------
    (nd,) fraction of the S samples with ``|e| ≤ σ`` (NaN where S = 0).
    """
    errors = np.asarray(errors, dtype=float)
    if errors.shape[0] == 0:
        return np.full(len(channels), np.nan)
    sigma = box.sigma(forecasts, channels)
    inside = np.abs(errors) <= sigma * (1.0 + COVERAGE_RELATIVE_TOLERANCE)
    result: np.ndarray = inside.mean(axis=0)
    return result


def model_error_coverage(
    prediction_error_k: Mapping[str, np.ndarray], model_error_k: Mapping[str, float]
) -> dict[str, float]:
    """Per zone, the fraction of finite one-step prediction errors [K] with ``|ε| ≤ ε_z``."""
    result: dict[str, float] = {}
    for zone, values in prediction_error_k.items():
        finite = np.asarray(values, dtype=float)
        finite = finite[np.isfinite(finite)]
        bound = model_error_k.get(zone, 0.0)
        result[zone] = float(np.mean(np.abs(finite) <= bound)) if finite.size else float("nan")
    return result
