"""The replay client: a building played over HTTP by the plant of ``simulate``.

``hvacflex serve replay`` registers the building (operator key), then runs the closed loop of
:mod:`hvacflex.sim.closed_loop` with a :class:`RemoteControl` in place of its
:class:`~hvacflex.sim.step.ControlStep`: each period it posts the scenario's IL activation
starts and ends as the operator (the activation schedule of ``simulate``), then the measured
node temperatures (and the previous period's power) as the building, and applies the plan the
service returns to the plant. The decision — controller and IL event rules — is made only in
the service, by its own ``ControlStep``; :class:`RemoteControl` hands back the service's
action, role and outcome. The clock is accelerated: a period lasts as long as the service
takes to plan it. The results files are those of ``simulate`` (``results.parquet``,
``summary.json``, ``config.json``).
"""

from __future__ import annotations

import json
import math
import os
import time as time_module
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hvacflex.config import ScenarioConfig, preset
from hvacflex.control.base import Action, FloatArray, PeriodInputs
from hvacflex.errors import HvacflexError, InputError
from hvacflex.paths import resolve_building
from hvacflex.results import RESULTS_FILENAME
from hvacflex.service.schemas import MAX_WAIT_S
from hvacflex.sim.closed_loop import ClosedLoop
from hvacflex.sim.events import PeriodOutcome, Role
from hvacflex.sim.run_files import CONFIG_FILE, SUMMARY_FILE, write_results, write_summary
from hvacflex.sim.setup import prepare
from hvacflex.sim.step import Decision, decision_status
from hvacflex.version import atomic_write_text

TIMEOUT_S = 120.0
PLAN_TIMEOUT_S = 600.0
"""How long the replay waits for one period's plan in all (``wait_s`` at a time) [s]."""
KEY_ENV = "HVACFLEX_KEY"
"""The environment variable a client command reads its key from (unless ``--key-file``)."""


class ServiceError(HvacflexError):
    """The service answered with an error (its status and message)."""

    def __init__(self, status: int, message: str) -> None:
        self.status = status
        super().__init__(f"service answered {status}: {message}")


def check_service_url(url: str) -> str:
    """``url`` if it is an http(s) URL with a host (and a valid port), else refused.

    Raises
    ------
    InputError : another scheme, no host, or a port that is not 1–65535.
    """
    hint = "e.g. --url http://127.0.0.1:8000 or --url https://service.example:8443"
    try:
        parts = urllib.parse.urlsplit(url)
        port = parts.port
    except ValueError as exc:
        raise InputError(f"not a URL ({exc})", field="--url", value=url, hint=hint) from None
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise InputError("not an http(s) URL with a host", field="--url", value=url, hint=hint)
    if port == 0:
        raise InputError("port must be 1–65535", field="--url", value=url, hint=hint)
    return url


def read_key(key_file: Path | None) -> str:
    """The client's key: the first line of ``key_file``, else ``$HVACFLEX_KEY``.

    Raises
    ------
    InputError : the file is missing, unreadable or empty, or neither is given.
    """
    if key_file is not None:
        try:
            text = key_file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            reason = getattr(exc, "strerror", None) or exc
            raise InputError(
                f"cannot read the key file ({reason})", field="--key-file", value=str(key_file)
            ) from None
        key = text.strip().splitlines()[0].strip() if text.strip() else ""
        if not key:
            raise InputError("the key file is empty", field="--key-file", value=str(key_file))
        return key
    key = os.environ.get(KEY_ENV, "").strip()
    if not key:
        raise InputError(
            "no key given",
            field="--key-file",
            hint=f"set {KEY_ENV} to an operator key, or pass --key-file FILE "
            "(a file made by `hvacflex serve key create --role operator --key-file FILE`)",
        )
    return key


@dataclass
class Client:
    """A minimal JSON client of the service (stdlib only; 127.0.0.1 in the tests)."""

    url: str
    key: str

    def call(self, method: str, path: str, body: Any = None) -> Any:
        """The ``payload`` of the envelope; raises :class:`ServiceError` on 4xx/5xx."""
        return self.call_status(method, path, body)[1]

    def call_status(self, method: str, path: str, body: Any = None) -> tuple[int, Any]:
        """The HTTP status and the ``payload`` of the envelope; raises
        :class:`ServiceError` on 4xx/5xx."""
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(
            self.url.rstrip("/") + path,
            data=data,
            method=method,
            headers={"X-API-Key": self.key, "Content-Type": "application/json"},
        )
        try:
            with urllib.request.urlopen(request, timeout=TIMEOUT_S) as response:
                status = int(response.status)
                envelope = json.loads(response.read())
        except urllib.error.HTTPError as exc:
            try:
                message = json.loads(exc.read()).get("message", "")
            except (ValueError, AttributeError):
                message = exc.reason
            raise ServiceError(exc.code, str(message)) from None
        except (OSError, ValueError) as exc:  # URLError, a refused or reset connection
            reason = getattr(exc, "reason", None) or exc
            raise InputError(
                f"cannot reach the service ({reason})",
                field="--url",
                value=self.url,
                hint="start it with `hvacflex serve`, or check the URL and port",
            ) from None
        return status, envelope["payload"]


def _nan(values: Any) -> FloatArray:
    return np.array([math.nan if v is None else float(v) for v in values], dtype=float)


def action_from_plan(plan: dict[str, Any]) -> Action:
    """The :class:`Action` a plan of the service stands for (flows in zone order)."""
    return Action(
        flow_kg_s=_nan(plan["flow_kg_s"]),
        reserve_flow_kg_s=_nan(plan["reserve_flow_kg_s"]),
        reserve_kw=float(plan["reserve_kw"]),
        planned_power_kw=math.nan if plan["planned_power_kw"] is None else plan["planned_power_kw"],
        status=str(plan["status"]),
        fallback=bool(plan["fallback"]),
        solve_time_s=float(plan["solve_time_s"]),
        planned_slack_max_k=_none_nan(plan["planned_slack_max_k"]),
        delta_max_k=_none_nan(plan["delta_max_k"]),
        predicted_served_degc=_nan(plan["predicted_served_degc"]),
        predicted_curtailed_degc=_nan(plan["predicted_curtailed_degc"]),
        predicted_event_worst_degc=None
        if plan.get("predicted_event_worst_degc") is None
        else _nan(plan["predicted_event_worst_degc"]),
        offer_meter_ratio=_none_nan(plan.get("offer_meter_ratio")),
    )


def _none_nan(value: Any) -> float:
    return math.nan if value is None else float(value)


class RemoteController:
    """The building's side of the exchange: posts the measurement, returns the plan."""

    def __init__(
        self,
        client: Client,
        building_id: str,
        on_plan: Callable[[dict[str, Any]], None] | None = None,
    ) -> None:
        self.client = client
        self.building_id = building_id
        self.on_plan = on_plan
        self.previous_power_kw: float | None = None
        self.plans: list[dict[str, Any]] = []

    def exchange(
        self, x_degc: FloatArray, time: str, delivered_flow_kg_s: FloatArray | None = None
    ) -> dict[str, Any]:
        """Post the measurement of the period starting at ``time`` (and the air system's
        delivered input (m,) [kg/s] of the period before, where the plant reports one); the
        service's plan."""
        body: dict[str, Any] = {
            "time": time,
            "node_temperatures_degc": [float(v) for v in x_degc],
            "previous_power_kw": self.previous_power_kw,
        }
        if delivered_flow_kg_s is not None:
            body["previous_delivered_flow_kg_s"] = [float(v) for v in delivered_flow_kg_s]
        path = f"/v1/buildings/{self.building_id}/measurements?wait_s={MAX_WAIT_S:g}"
        status, plan = self.client.call_status("POST", path, body)
        plan = dict(plan)
        deadline = time_module.monotonic() + PLAN_TIMEOUT_S
        while status == 202:  # not planned within wait_s: the same body again waits on
            if time_module.monotonic() > deadline:
                raise ServiceError(202, f"no plan for {time} within {PLAN_TIMEOUT_S:g} s")
            status, answer = self.client.call_status("POST", path, body)
            plan = dict(answer)
        self.plans.append(plan)
        if self.on_plan is not None:
            self.on_plan(plan)
        return plan


class RemoteControl:
    """The closed loop's control step, answered by the service.

    Each period it posts the activation start or end the schedule has there (operator key)
    and the building's measurement, and returns the service's decision: its plan, role and
    IL outcome (the rules run only in the service's :class:`~hvacflex.sim.step.ControlStep`).
    """

    takes_measurements = True
    """The closed loop reads the zone air for the service (its sensors do so only for a
    controller with a filter, ``estimation.mode = "kalman"``); the reading is posted in the
    zone rows of the node temperatures, where the service's filter reads it."""

    def __init__(self, remote: RemoteController, operator: Client, zone_rows: FloatArray) -> None:
        self.remote = remote
        self.operator = operator
        self.zone_rows = np.asarray(zone_rows, dtype=int)
        """(m,) the zone nodes' positions in the state (the model's C)."""
        self.active = False

    def decide(self, k: int, inputs: PeriodInputs, *, activated: Callable[[int], bool]) -> Decision:
        """Post period ``k``'s activation change and measurement (``inputs.x_degc``, and the
        plant's delivered input of k − 1 where it reports one); the service's decision (its
        forecast, peak floor, recovery allowance, settlement baselines and meter history are
        its own)."""
        time = inputs.forecast.index[0].isoformat()
        if activated(k) != self.active:
            self.active = activated(k)
            body = {
                "event": "start" if self.active else "end",
                "time": time,
                "building_ids": [self.remote.building_id],
            }
            self.operator.call("POST", "/v1/activations", body)
        x = np.array(inputs.x_degc, dtype=float)
        if inputs.measured_zone_temp_degc is not None:
            x[self.zone_rows] = inputs.measured_zone_temp_degc
        answer = self.remote.exchange(x, time, inputs.delivered_flow_kg_s)
        action = action_from_plan(answer)
        role = Role(answer["il_role"])
        outcome = PeriodOutcome(
            curtailed=bool(answer["il_curtailed"]),
            beyond_model=bool(answer["il_beyond_model"]),
            event_window=bool(answer["il_event_window"]),
            allowance_k=float(answer["il_allowance_k"]),
            reference_power_kw=_none_nan(answer["il_reference_power_kw"]),
        )
        applied = action.applied_flow_kg_s(curtailed=outcome.curtailed)
        status = decision_status(role, action)
        return Decision(action, status, role, outcome, applied, None, None)

    def restart_warm(self) -> None:
        return None  # the service keeps the controller

    def get_state(self) -> dict[str, Any]:
        return {"active": self.active}

    def set_state(self, state: dict[str, Any]) -> None:
        self.active = bool(state["active"])


def registration(config: ScenarioConfig, building_id: str) -> dict[str, Any]:
    """The registration body of ``config``: its building as TOML content, its settings."""
    base = preset(config.name) if config.name in _preset_names() else preset("rmpc")
    settings: dict[str, Any] = {}
    flat_new, flat_base = _flatten(config.to_dict()), _flatten(base.to_dict())
    for key, value in flat_new.items():
        if key in ("name", "building", "start", "days") or flat_base.get(key) == value:
            continue
        settings[key] = value
    return {
        "building_id": building_id,
        "building": {"toml": resolve_building(config.building).read_text(encoding="utf-8")},
        "scenario": {
            "preset": base.name,
            "start": config.start,
            "days": config.days,
            "settings": settings,
        },
    }


def _preset_names() -> tuple[str, ...]:
    from hvacflex.config import PRESET_NAMES

    return PRESET_NAMES


def _flatten(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict) and key not in ("relative", "absolute"):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


@dataclass(frozen=True)
class ReplayResult:
    out_dir: Path
    summary: dict[str, float]
    plans: list[dict[str, Any]]


def replay(
    url: str,
    operator_key: str,
    config: ScenarioConfig,
    out_dir: str | Path,
    *,
    building_id: str = "replay",
    building_key: str | None = None,
    stop_after_steps: int | None = None,
    on_plan: Callable[[dict[str, Any]], None] | None = None,
) -> ReplayResult:
    """Register ``config``'s building (unless ``building_key`` is given: it is registered
    already) and play the plant against the service; write the results files of
    ``simulate`` into ``out_dir`` once every period is played. ``on_plan`` is called with
    each plan as it is acknowledged.

    A replay may be started again after an interruption (with ``building_key``): the
    periods measured already are posted again unchanged, and the service answers them with
    the plans it stored (measurements are idempotent).
    """
    from hvacflex.kpi import summary as kpi_summary

    check_service_url(url)
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # a file there or above it, no permission
        raise InputError(
            f"cannot create the folder ({exc.strerror or exc})", field="--out", value=str(out)
        ) from None
    if building_key is None:
        registered = Client(url, operator_key).call(
            "POST", "/v1/buildings", registration(config, building_id)
        )
        building_key = str(registered["key"])
    remote = RemoteController(Client(url, building_key), building_id, on_plan)
    setup = prepare(config)
    control = RemoteControl(remote, Client(url, operator_key), setup.model.c.argmax(axis=1))
    loop = ClosedLoop(setup, control=control)
    column = loop.recorder.column_index["power_kw"]
    last = loop.steps if stop_after_steps is None else min(loop.steps, stop_after_steps)
    while loop.k < last:
        k = loop.k
        remote.previous_power_kw = None if k == 0 else float(loop.recorder.values[k - 1, column])
        loop.step()
    frame = loop.frame()
    summary = kpi_summary(frame)
    if loop.k == loop.steps:
        write_results(frame, out / RESULTS_FILENAME, config)
        write_summary(out / SUMMARY_FILE, summary)
        atomic_write_text(out / CONFIG_FILE, json.dumps(config.to_dict(), indent=2))
    return ReplayResult(out, summary, remote.plans)
