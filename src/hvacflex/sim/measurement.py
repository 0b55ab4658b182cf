"""What the controller of the closed loop sees, and how well its model predicts the plant.

Under output feedback (``[estimation] mode = "kalman"``, docs/estimation.md) the MPC gets only
the zone-air temperatures, read as ``C x`` plus uniform sensor error in ±``measurement_noise_k``
drawn from the scenario seed's own stream (:data:`MEASUREMENT_RNG_STREAM`), so the realised
forecast errors do not change with the estimation mode. The one-step prediction error of the
controller's model (:mod:`hvacflex.control.prediction_error`) is recorded in every mode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hvacflex.config import ScenarioConfig
from hvacflex.control.base import Action, Controller, FloatArray
from hvacflex.control.estimation import KalmanConfig, StepModel, measure_zone_temps
from hvacflex.control.mpc import MPCController
from hvacflex.control.prediction_error import one_step_prediction_error
from hvacflex.data.forecast import Forecast

MEASUREMENT_RNG_STREAM = 15
"""Second entropy word of the zone-air sensor-noise generator (first: the scenario seed)."""


def kalman_config(config: ScenarioConfig) -> KalmanConfig | None:
    """The filter settings of ``[estimation]``; None for full-state feedback."""
    estimation = config.estimation
    if estimation.mode != "kalman":
        return None
    return KalmanConfig(measurement_noise_k=estimation.measurement_noise_k)


class Sensors:
    """Reads the plant for the controller and drives it one period.

    Parameters
    ----------
    config : the scenario (seed, ``[estimation]``).
    c_matrix : (m, n) zone selection of the controller's model.
    controller : the controller; only an :class:`MPCController` takes measurements.
    """

    def __init__(
        self, config: ScenarioConfig, c_matrix: FloatArray, controller: Controller
    ) -> None:
        self.rng = np.random.default_rng([config.seed, MEASUREMENT_RNG_STREAM])
        self.noise_k = config.estimation.measurement_noise_k
        self.c_matrix = c_matrix
        self.mpc = controller if isinstance(controller, MPCController) else None
        self.measured = config.estimation.mode == "kalman" and self.mpc is not None

    def read(self, x_degc: FloatArray) -> FloatArray | None:
        """Zone-air readings (m,) [°C] of the plant state (n,), or None under full state."""
        if not self.measured:
            return None
        return measure_zone_temps(self.rng, x_degc, self.c_matrix, self.noise_k)

    def act(
        self,
        controller: Controller,
        x_degc: FloatArray,
        forecast: Forecast,
        *,
        peak_floor_kw: float,
        allowance_carry_steps: int,
    ) -> Action:
        """The controller's decision, from the readings under output feedback."""
        measured = self.read(x_degc)
        if measured is None or self.mpc is None:
            return controller.act(
                x_degc,
                forecast,
                peak_floor_kw=peak_floor_kw,
                allowance_carry_steps=allowance_carry_steps,
            )
        return self.mpc.act(
            x_degc,
            forecast,
            peak_floor_kw=peak_floor_kw,
            allowance_carry_steps=allowance_carry_steps,
            measured_zone_temp_degc=measured,
        )

    def hold(self, x_degc: FloatArray, forecast: Forecast, flow_kg_s: FloatArray) -> None:
        """A period of a locked IL event (no decision): the filter still measures and
        predicts (:meth:`MPCController.hold`)."""
        if self.mpc is None:
            return
        self.mpc.hold(forecast, flow_kg_s, self.read(x_degc))

    def applied(self, flow_kg_s: FloatArray) -> None:
        """The flow (m,) [kg/s] the plant ran this period (u − r when curtailed)."""
        if self.mpc is not None:
            self.mpc.note_applied_flow(flow_kg_s)

    def prediction_error_k(
        self,
        default_model: StepModel,
        x_degc: FloatArray,
        flow_kg_s: FloatArray,
        d_realised: FloatArray,
        x_next_degc: FloatArray,
    ) -> FloatArray:
        """e (m,) [K] of the model the controller planned the period with (``default_model``
        for controllers without one) against the true next state."""
        model = self.mpc.step_model if self.mpc is not None else default_model
        return one_step_prediction_error(model, x_degc, flow_kg_s, d_realised, x_next_degc)

    def get_state(self) -> dict[str, Any]:
        return {"rng": self.rng.bit_generator.state}

    def set_state(self, state: dict[str, Any]) -> None:
        self.rng.bit_generator.state = state["rng"]
