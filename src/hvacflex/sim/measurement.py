"""What the controller of the closed loop sees, and how well its model predicts the plant.

Under output feedback (``[estimation] mode = "kalman"``, docs/explanation/estimation.md) the MPC
gets only the zone-air temperatures, read as ``C x`` plus uniform sensor error in
±``measurement_noise_k`` drawn from the scenario seed's own stream (:data:`MEASUREMENT_RNG_STREAM`),
so the realised forecast errors do not change with the estimation mode. The one-step prediction
error of the controller's model (:mod:`hvacflex.control.prediction_error`) is recorded in every
mode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hvacflex.config import ScenarioConfig
from hvacflex.control.base import FloatArray
from hvacflex.control.estimation import KalmanConfig, StepModel, measure_zone_temps
from hvacflex.control.prediction_error import one_step_prediction_error

MEASUREMENT_RNG_STREAM = 15
"""Second entropy word of the zone-air sensor-noise generator (first: the scenario seed)."""


def kalman_config(config: ScenarioConfig) -> KalmanConfig | None:
    """The filter settings of ``[estimation]``; None for full-state feedback."""
    estimation = config.estimation
    if estimation.mode != "kalman":
        return None
    return KalmanConfig(measurement_noise_k=estimation.measurement_noise_k)


class Sensors:
    """Reads the plant for the controller, and scores the controller's one-step prediction.

    Parameters
    ----------
    config : the scenario (seed, ``[estimation]``).
    c_matrix : (m, n) zone selection of the controller's model.
    takes_measurements : whether the controller plans from zone-air readings (a filter).
    """

    def __init__(
        self, config: ScenarioConfig, c_matrix: FloatArray, takes_measurements: bool
    ) -> None:
        self.rng = np.random.default_rng([config.seed, MEASUREMENT_RNG_STREAM])
        self.noise_k = config.estimation.measurement_noise_k
        self.c_matrix = c_matrix
        self.measured = config.estimation.mode == "kalman" and takes_measurements

    def read(self, x_degc: FloatArray) -> FloatArray | None:
        """Zone-air readings (m,) [°C] of the plant state (n,), or None under full state."""
        if not self.measured:
            return None
        return measure_zone_temps(self.rng, x_degc, self.c_matrix, self.noise_k)

    @staticmethod
    def prediction_error_k(
        model: StepModel,
        x_degc: FloatArray,
        flow_kg_s: FloatArray,
        d_realised: FloatArray,
        x_next_degc: FloatArray,
    ) -> FloatArray:
        """e (m,) [K] of the model the controller planned the period with against the true
        next state."""
        return one_step_prediction_error(model, x_degc, flow_kg_s, d_realised, x_next_degc)

    def get_state(self) -> dict[str, Any]:
        return {"rng": self.rng.bit_generator.state}

    def set_state(self, state: dict[str, Any]) -> None:
        self.rng.bit_generator.state = state["rng"]
