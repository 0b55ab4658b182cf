"""The disturbance uncertainty box and realisation samplers.

Box
---
The realised disturbance is ``d_k = d̂_k + w_k`` with ``|w_k| ≤ σ_k`` elementwise
(paper eq. 4, docs/explanation/model.md §3). :class:`UncertaintyBox` sets ``σ`` per channel *kind*
(``outdoor_temp``, ``solar``, ``internal_gain``, ``ground_temp``) as a fraction of the
forecast and/or an absolute value in the channel's unit::

    σ_k,i = relative[kind_i] · |d̂_k,i| + absolute[kind_i]

Worst-case margin
-----------------
For ``x_{k+1} = A x_k + … + E (d̂_k + w_k)`` and outputs ``y = C x``, the largest effect of the
box on ``y_k`` (k = 1…N steps ahead) is (docs/explanation/model.md §3)::

    δ_k = Σ_{j<k} |C A^{k−1−j} E| σ_j        (elementwise absolute value)

:func:`hvacflex.opt.robust.comfort_margins` evaluates it (the one home of δ; ``hvacflex data
show`` prints it); compare ``max_k δ_k`` with the comfort half-band (1.5 K for 23–26 °C) to
see whether a σ is satisfiable at all.

Default level
-------------
:data:`DEFAULT_UNCERTAINTY` (±5 % of solar and internal gains, ±0.5 K outdoor temperature) is
the largest level whose worst-case margin ``max_k δ_k`` stays well inside the occupied
half-band of the default building (0.87 K of 1.5 K; basis and table in ``docs/reference/data.md``).
:func:`paper_uncertainty` gives the paper's ±50 % of heat gains, which can make the
open-loop robust problem infeasible for a perimeter zone (docs/explanation/model.md §3 "Uncertainty
level").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal, get_args

import numpy as np

from hvacflex.building.channels import CHANNEL_UNITS, DisturbanceChannel
from hvacflex.constants import AR1_COEFFICIENT as AR1_COEFFICIENT
from hvacflex.errors import ConfigError

SamplerMode = Literal["zero", "uniform", "worst-upper", "worst-lower", "ar1"]


def check_ar1_coefficient(ar1_coefficient: float) -> None:
    """Raise :class:`ConfigError` unless the AR(1) coefficient φ per step is in [0, 1)."""
    if not 0.0 <= ar1_coefficient < 1.0:
        raise ConfigError(
            "AR(1) coefficient must be in [0, 1)",
            field="ar1_coefficient",
            value=ar1_coefficient,
        )


def _frozen_mapping(
    values: Mapping[str, float], name: str, *, by_kind: bool = True
) -> Mapping[str, float]:
    checked: dict[str, float] = {}
    for kind, value in dict(values).items():
        if by_kind and kind not in CHANNEL_UNITS:
            raise ConfigError(
                "unknown disturbance channel kind",
                source="UncertaintyBox",
                field=f"{name}.{kind}",
                value=kind,
                hint=f"kinds are {sorted(CHANNEL_UNITS)}",
            )
        number = float(value)
        if not math.isfinite(number) or number < 0:
            raise ConfigError(
                "uncertainty must be a finite number ≥ 0",
                source="UncertaintyBox",
                field=f"{name}.{kind}",
                value=value,
                hint="relative values are fractions (0.2 = ±20 %), absolute ones in the "
                "channel's unit",
            )
        checked[kind] = number
    return MappingProxyType(checked)


def _by_kind(values: Mapping[str, float], channel: DisturbanceChannel) -> float:
    """The value for ``channel``'s kind, else for its box kind (a window's solar gain is
    ``solar``), else 0."""
    return values.get(channel.kind, values.get(channel.box_kind, 0.0))


@dataclass(frozen=True)
class UncertaintyBox:
    """Half-widths σ of the disturbance box, per channel kind.

    Attributes
    ----------
    relative : kind → fraction of the forecast's magnitude (0.2 = ±20 %).
    absolute : kind → half-width in the channel's unit (K for temperatures, W/m² for solar,
        W for internal gains).
    channel_relative, channel_absolute : channel *name* → the same, for one channel; a
        channel named in either replaces its kind's two values by these (a missing one is
        0). A calibrated box (:func:`hvacflex.data.calibration.calibrate_box`) is per channel.
    """

    relative: Mapping[str, float] = field(default_factory=dict)
    absolute: Mapping[str, float] = field(default_factory=dict)
    channel_relative: Mapping[str, float] = field(default_factory=dict)
    channel_absolute: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "relative", _frozen_mapping(self.relative, "relative"))
        object.__setattr__(self, "absolute", _frozen_mapping(self.absolute, "absolute"))
        for name in ("channel_relative", "channel_absolute"):
            values = _frozen_mapping(getattr(self, name), name, by_kind=False)
            object.__setattr__(self, name, values)

    def coefficients(self, channels: Sequence[DisturbanceChannel]) -> tuple[np.ndarray, np.ndarray]:
        """Per-channel (relative (nd,), absolute (nd,)) coefficients, for precomputation."""
        relative = np.array([_by_kind(self.relative, ch) for ch in channels], dtype=float)
        absolute = np.array([_by_kind(self.absolute, ch) for ch in channels], dtype=float)
        for i, ch in enumerate(channels):
            if ch.name in self.channel_relative or ch.name in self.channel_absolute:
                relative[i] = self.channel_relative.get(ch.name, 0.0)
                absolute[i] = self.channel_absolute.get(ch.name, 0.0)
        return relative, absolute

    def sigma(self, d_forecast: np.ndarray, channels: Sequence[DisturbanceChannel]) -> np.ndarray:
        """Box half-widths for a forecast.

        Parameters
        ----------
        d_forecast : (N, nd) or (nd,) forecast disturbances, channel units.
        channels : (nd,) their channels.

        Returns
        -------
        σ, same shape as ``d_forecast``, ≥ 0, channel units.
        """
        relative, absolute = self.coefficients(channels)
        d = np.asarray(d_forecast, dtype=float)
        if d.shape[-1] != len(channels):
            raise ConfigError(
                "forecast and channels disagree",
                field="d_forecast",
                value=d.shape,
                hint=f"expected last dimension {len(channels)}",
            )
        result: np.ndarray = relative * np.abs(d) + absolute
        return result

    def scaled(self, factor: float) -> UncertaintyBox:
        """The box with every half-width multiplied by ``factor`` ≥ 0 (for sweeps)."""
        return UncertaintyBox(
            {k: v * factor for k, v in self.relative.items()},
            {k: v * factor for k, v in self.absolute.items()},
            {k: v * factor for k, v in self.channel_relative.items()},
            {k: v * factor for k, v in self.channel_absolute.items()},
        )

    def describe(self) -> str:
        """Human-readable summary, e.g. ``"solar ±20 %, outdoor_temp ±0.5 degC"``."""
        parts = [f"{k} ±{v * 100:g} %" for k, v in self.relative.items() if v]
        parts += [f"{k} ±{v:g} {CHANNEL_UNITS[k]}" for k, v in self.absolute.items() if v]
        parts += [f"{k} ±{v * 100:.3g} %" for k, v in self.channel_relative.items() if v]
        parts += [f"{k} ±{v:.3g}" for k, v in self.channel_absolute.items() if v]
        return ", ".join(parts) or "none"

    @property
    def is_zero(self) -> bool:
        """True if the box is a point (nominal MPC)."""
        values = (self.relative, self.absolute, self.channel_relative, self.channel_absolute)
        return not any(any(v.values()) for v in values)


DEFAULT_UNCERTAINTY = UncertaintyBox(
    relative={"solar": 0.05, "internal_gain": 0.05}, absolute={"outdoor_temp": 0.5}
)
"""Default box: ±5 % of solar and internal gains, ±0.5 K outdoor temperature — on office5
its open-loop ``max_k δ_k`` is 0.87 K, 58 % of the occupied half-band (docs/reference/data.md)."""


def paper_uncertainty(level: float = 0.5) -> UncertaintyBox:
    """The paper's box: ±``level`` (default 50 %) of the heat gains (solar and internal)."""
    return UncertaintyBox(relative={"solar": level, "internal_gain": level})


class DisturbanceSampler:
    """Draws realised disturbance errors ``w_k`` inside the box, one step at a time.

    Modes
    -----
    ``zero``        w = 0 (the forecast is exact).
    ``uniform``     w ~ U[−σ, σ], independent across steps and channels (seeded; default).
    ``worst-upper`` w = +σ (every disturbance at its upper corner: hottest).
    ``worst-lower`` w = −σ.
    ``ar1``         w = σ · erf(a / √2) with a standard-normal AR(1) state
                    ``a_k = φ a_{k−1} + √(1−φ²) ε_k``: uniform marginals like ``uniform``
                    but correlated in time (φ = ``ar1_coefficient``).

    ``get_state()`` / ``set_state()`` capture the generator and AR(1) state (JSON-compatible),
    so an interrupted simulation resumes with the same draws.
    """

    def __init__(
        self,
        mode: SamplerMode = "uniform",
        seed: int = 2014,
        *,
        ar1_coefficient: float = AR1_COEFFICIENT,
    ) -> None:
        if mode not in get_args(SamplerMode):
            raise ConfigError(
                "unknown disturbance sampler mode",
                field="mode",
                value=mode,
                hint=f"use one of {list(get_args(SamplerMode))}",
            )
        check_ar1_coefficient(ar1_coefficient)
        self.mode: SamplerMode = mode
        self.seed = seed
        self.ar1_coefficient = ar1_coefficient
        self._rng = np.random.default_rng(seed)
        self._ar1_state: np.ndarray | None = None

    def sample(self, sigma: np.ndarray) -> np.ndarray:
        """One realisation.

        Parameters
        ----------
        sigma : (nd,) box half-widths for this step, ≥ 0.

        Returns
        -------
        (nd,) w with ``|w| ≤ σ``.
        """
        sigma = np.asarray(sigma, dtype=float)
        if self.mode == "zero":
            return np.zeros_like(sigma)
        if self.mode == "worst-upper":
            return sigma.copy()
        if self.mode == "worst-lower":
            return -sigma
        if self.mode == "uniform":
            unit = self._rng.uniform(-1.0, 1.0, size=sigma.shape)
        else:
            phi = self.ar1_coefficient
            innovation = self._rng.standard_normal(sigma.shape)
            if self._ar1_state is None or self._ar1_state.shape != sigma.shape:
                state = innovation
            else:
                state = phi * self._ar1_state + math.sqrt(1.0 - phi * phi) * innovation
            self._ar1_state = state
            unit = np.array([math.erf(v / math.sqrt(2.0)) for v in state.ravel()]).reshape(
                sigma.shape
            )
        result: np.ndarray = sigma * unit
        return result

    def get_state(self) -> dict[str, Any]:
        """Everything needed to continue the sequence (JSON-serialisable)."""
        return {
            "mode": self.mode,
            "seed": self.seed,
            "ar1_coefficient": self.ar1_coefficient,
            "bit_generator": self._rng.bit_generator.state,
            "ar1_state": None if self._ar1_state is None else self._ar1_state.tolist(),
        }

    def set_state(self, state: Mapping[str, Any]) -> None:
        """Restore a state from :meth:`get_state`."""
        if state.get("mode") != self.mode:
            raise ConfigError(
                "sampler state is for another mode",
                field="mode",
                value=state.get("mode"),
                hint=f"this sampler's mode is {self.mode!r}",
            )
        self.seed = int(state["seed"])
        self.ar1_coefficient = float(state["ar1_coefficient"])
        self._rng.bit_generator.state = dict(state["bit_generator"])
        ar1 = state.get("ar1_state")
        self._ar1_state = None if ar1 is None else np.asarray(ar1, dtype=float)
