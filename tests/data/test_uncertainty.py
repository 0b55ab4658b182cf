"""Uncertainty box and samplers (the worst-case margin δ_k is tested in tests/opt)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hvacflex.building.channels import internal_gain_channel, outdoor_temp_channel, solar_channel
from hvacflex.data.uncertainty import (
    DEFAULT_UNCERTAINTY,
    DisturbanceSampler,
    UncertaintyBox,
    paper_uncertainty,
)
from hvacflex.errors import ConfigError

CHANNELS = (outdoor_temp_channel(), solar_channel(180, 90), internal_gain_channel("core"))


def test_sigma_relative_and_absolute() -> None:
    d = np.array([[30.0, 400.0, 1000.0], [25.0, -0.0, 500.0]])
    sigma = DEFAULT_UNCERTAINTY.sigma(d, CHANNELS)
    np.testing.assert_allclose(sigma, [[0.5, 20.0, 50.0], [0.5, 0.0, 25.0]])
    paper = paper_uncertainty().sigma(d, CHANNELS)
    np.testing.assert_allclose(paper, [[0.0, 200.0, 500.0], [0.0, 0.0, 250.0]])
    both = UncertaintyBox(relative={"solar": 0.1}, absolute={"solar": 5.0}).sigma(d, CHANNELS)
    np.testing.assert_allclose(both[:, 1], [45.0, 5.0])
    assert DEFAULT_UNCERTAINTY.scaled(2.0).sigma(d, CHANNELS)[0, 2] == 100.0
    assert UncertaintyBox().is_zero and not DEFAULT_UNCERTAINTY.is_zero


def test_box_validation() -> None:
    with pytest.raises(ConfigError, match="unknown disturbance channel kind"):
        UncertaintyBox(relative={"sun": 0.2})
    with pytest.raises(ConfigError, match="≥ 0"):
        UncertaintyBox(absolute={"outdoor_temp": -1.0})
    with pytest.raises(ConfigError):
        DEFAULT_UNCERTAINTY.sigma(np.zeros((3, 2)), CHANNELS)


@pytest.mark.parametrize("mode", ["uniform", "ar1", "worst-upper", "worst-lower", "zero"])
def test_samples_stay_inside_the_box(mode: str) -> None:
    sampler = DisturbanceSampler(mode, seed=1)  # type: ignore[arg-type]
    sigma = np.array([0.5, 80.0, 0.0, 200.0])
    draws = np.array([sampler.sample(sigma) for _ in range(500)])
    assert (np.abs(draws) <= sigma + 1e-12).all()
    if mode == "worst-upper":
        np.testing.assert_array_equal(draws, np.tile(sigma, (500, 1)))
    if mode == "worst-lower":
        np.testing.assert_array_equal(draws, -np.tile(sigma, (500, 1)))
    if mode == "zero":
        assert not draws.any()
    if mode in ("uniform", "ar1"):
        unit = draws[:, [0, 1, 3]] / sigma[[0, 1, 3]]
        assert abs(unit.mean()) < 0.1 and 0.5 < np.abs(unit).mean() * 2 < 1.2  # ~uniform
        lag1 = np.corrcoef(unit[:-1, 0], unit[1:, 0])[0, 1]
        assert (lag1 > 0.6) if mode == "ar1" else (abs(lag1) < 0.15)


@pytest.mark.parametrize("mode", ["uniform", "ar1"])
def test_sampler_state_round_trip(mode: str) -> None:
    sampler = DisturbanceSampler(mode, seed=5)  # type: ignore[arg-type]
    sigma = np.array([1.0, 2.0])
    for _ in range(7):
        sampler.sample(sigma)
    state = json.loads(json.dumps(sampler.get_state()))
    expected = [sampler.sample(sigma) for _ in range(5)]
    resumed = DisturbanceSampler(mode, seed=999)  # type: ignore[arg-type]
    resumed.set_state(state)
    np.testing.assert_array_equal([resumed.sample(sigma) for _ in range(5)], expected)
    with pytest.raises(ConfigError, match="another mode"):
        DisturbanceSampler("zero").set_state(state)


def test_sampler_is_seeded() -> None:
    a = DisturbanceSampler("uniform", seed=2).sample(np.ones(4))
    b = DisturbanceSampler("uniform", seed=2).sample(np.ones(4))
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ConfigError, match="unknown disturbance sampler mode"):
        DisturbanceSampler("gaussian")  # type: ignore[arg-type]
