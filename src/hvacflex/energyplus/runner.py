"""Co-simulation: EnergyPlus advanced one 30-min period at a time, driven from Python.

Why a worker thread. EnergyPlus's C API has no "advance by Δt" call: ``energyplus()`` runs
the whole simulation and calls back at fixed points of every time step. Inverted control
(doing the controller's work inside the callback) would turn the closed loop inside out and
tie every caller — the closed loop, the validation, the live service — to EnergyPlus's call
stack. Instead :class:`CoSimulation` runs ``energyplus()`` in a worker thread, and the
callback at the end of each 30-min period hands the period's readings to the caller through
a queue and blocks until the caller sends the next period's actuator values through another
queue. The caller sees an ordinary steppable object (:meth:`CoSimulation.start`,
:meth:`CoSimulation.advance`); exactly one side runs at any time, so nothing is shared
unsafely. ``ctypes`` releases the GIL while the engine computes.

Timing. Callbacks fire during sizing and warm-up too: the runner acts only after
``apiDataFullyReady``, in the weather run period (``kindOfSim`` 3) and after warm-up. Period
ends are found from ``hour()`` and ``zoneTimeStepNum()`` (``currentTime`` overshoots when
EnergyPlus shortens the system time step). Variables and meters are read at
``callbackEndOfZoneTimeStepAfterZoneReporting`` (meters update after zone reporting);
actuator values are applied at the start of every zone time step
(``callbackBeginTimeStepBeforePredictor``), after an optional per-time-step rule
(:attr:`CoSimSpec.timestep_rule`) has adjusted them from the latest variables and the meters'
totals over the last zone time step.

Errors. A Python exception inside a ctypes callback would be printed and swallowed while
EnergyPlus ran on to "Completed Successfully": every callback body is guarded, the exception
stops the simulation (``stopSimulation``) and is re-raised in the caller. A run that ends
with a fatal error becomes an :class:`EnergyPlusError` quoting the severe and fatal lines of
``eplusout.err``.
"""

from __future__ import annotations

import ctypes
import queue
import shutil
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from hvacflex.energyplus.api import KIND_OF_SIM_RUN_PERIOD_WEATHER, EnergyPlusAPI, load_api
from hvacflex.errors import InputError

FloatArray = npt.NDArray[np.float64]


ERR_LINES_QUOTED = 12
"""At most this many lines of ``eplusout.err`` go into an :class:`EnergyPlusError`."""

EXPAND_TIMEOUT_S = 120.0
"""Longest ExpandObjects may take [s]."""

JOIN_TIMEOUT_S = 60.0
"""How long :meth:`CoSimulation.close` waits for the engine to wind down [s]."""


class EnergyPlusError(InputError):
    """EnergyPlus refused the model or stopped with a fatal error (the message quotes
    ``eplusout.err``), or a co-simulation was used past its end."""


@dataclass(frozen=True)
class Variable:
    """An EnergyPlus output variable: ``name`` (e.g. "Zone Mean Air Temperature") for ``key``
    (e.g. a zone name, "Environment")."""

    name: str
    key: str


@dataclass(frozen=True)
class Actuator:
    """An EnergyPlus actuator: component type, control type and the component's name."""

    component: str
    control: str
    key: str


TimestepRule = Callable[[FloatArray, FloatArray, FloatArray], FloatArray]
"""``rule(variables_now (nv,), commanded (na,), meters_last_step_j (nmeter,)) -> applied
(na,)``: run at the start of every zone time step with the latest variable values and each
meter's total over the last zone time step [J] (NaN before the first step of the run and for
an absent meter); NaN in ``applied`` releases the actuator. A plant's in-period peak guard
reads its meter so (:mod:`hvacflex.sim.energyplus_plant`)."""


@dataclass(frozen=True)
class CoSimSpec:
    """What one co-simulation reads and actuates.

    Attributes
    ----------
    idf_text : the model (EnergyPlus 25.2 IDF text, prepared for the run).
    epw_path : the weather file.
    source : where the model came from (named in errors).
    timesteps_per_hour : the IDF's ``Timestep`` (even, so that periods hold whole steps).
    variables : (nv,) output variables read every zone time step.
    meters : (nmeter,) meters summed over each period; a meter EnergyPlus does not have
        reads NaN.
    actuators : (na,) actuators set every zone time step (NaN: left to the IDF).
    timestep_rule : optional per-time-step adjustment of the actuator values.
    """

    idf_text: str
    epw_path: Path
    source: str
    timesteps_per_hour: int
    variables: tuple[Variable, ...]
    meters: tuple[str, ...]
    actuators: tuple[Actuator, ...]
    timestep_rule: TimestepRule | None = None


@dataclass(frozen=True)
class PeriodReading:
    """Readings over one period.

    Attributes
    ----------
    variables_end : (nv,) variable values at the end of the period.
    variables_mean : (nv,) mean over the period's zone time steps.
    meters_j : (nmeter,) meter totals over the period [J] (NaN for an absent meter).
    """

    variables_end: FloatArray
    variables_mean: FloatArray
    meters_j: FloatArray


@dataclass
class _Handles:
    variables: list[int] = field(default_factory=list)
    meters: list[int] = field(default_factory=list)
    actuators: list[int] = field(default_factory=list)


class CoSimulation:
    """One EnergyPlus run in a worker thread, advanced period by period.

    Parameters
    ----------
    spec : what to run, read and actuate.
    work_dir : folder for EnergyPlus's files; ``None``: a temporary folder, removed by
        :meth:`close` unless the run failed (the error names it).
    """

    def __init__(self, spec: CoSimSpec, work_dir: Path | None = None) -> None:
        if spec.timesteps_per_hour % 2:
            raise InputError(
                "timesteps_per_hour must be even to tile 30-min periods",
                field="plant.timesteps_per_hour",
                value=spec.timesteps_per_hour,
            )
        self.spec = spec
        self._api: EnergyPlusAPI = load_api()
        self._own_dir = work_dir is None
        self.work_dir = (
            Path(tempfile.mkdtemp(prefix="hvacflex-eplus-")) if work_dir is None else Path(work_dir)
        )
        self.work_dir.mkdir(parents=True, exist_ok=True)
        self._steps_per_period = spec.timesteps_per_hour // 2
        self._to_caller: queue.Queue[tuple[str, Any]] = queue.Queue()
        self._to_engine: queue.Queue[tuple[str, Any]] = queue.Queue()
        self._handles = _Handles()
        self._commanded = np.full(len(spec.actuators), np.nan)
        self._latest = np.full(len(spec.variables), np.nan)
        self._sums = np.zeros(len(spec.variables))
        self._meter_sums = np.zeros(len(spec.meters))
        self._last_meters_j = np.full(len(spec.meters), np.nan)
        self._steps_seen = 0
        self._started = False
        self._stopping = False
        self._failed = False
        self._thread: threading.Thread | None = None
        self._state: ctypes.c_void_p | None = None
        self._keep: list[object] = []
        self.engine_time_s = 0.0
        """Wall time the caller spent waiting for the engine in :meth:`advance` [s]."""
        self.callback_time_s = 0.0
        """CPU time spent in this module's Python callbacks (engine thread) [s]."""

    # ---- caller side -------------------------------------------------------------------

    @property
    def missing_meters(self) -> tuple[str, ...]:
        """The meters of the spec EnergyPlus has no handle for in this IDF (read as NaN);
        known once :meth:`start` has returned, empty before."""
        return tuple(
            meter
            for meter, handle in zip(self.spec.meters, self._handles.meters, strict=False)
            if handle < 0
        )

    def start(self) -> PeriodReading:
        """Launch EnergyPlus (sizing, warm-up) and return the readings just before the first
        period (``variables_end`` = ``variables_mean`` = the current values, meters 0)."""
        if self._thread is not None:
            raise EnergyPlusError(
                "this co-simulation has already started",
                hint="make a new CoSimulation for a new run",
            )
        idf = self.work_dir / "in.idf"
        idf.write_text(self.spec.idf_text, encoding="utf-8")
        self._state = self._api.new_state()
        self._api.lib.setConsoleOutputState(self._state, 0)
        for variable in self.spec.variables:
            self._api.request_variable(self._state, variable.name, variable.key)
        self._keep = [
            self._api.register(
                self._state,
                "callbackBeginTimeStepBeforePredictor",
                self._guard(self._on_begin_timestep),
            ),
            self._api.register(
                self._state,
                "callbackEndOfZoneTimeStepAfterZoneReporting",
                self._guard(self._on_end_zone_timestep),
            ),
        ]
        args = ["-d", str(self.work_dir), "-w", str(self.spec.epw_path), str(idf)]
        self._thread = threading.Thread(
            target=self._engine, args=(args,), daemon=True, name="hvacflex-energyplus"
        )
        self._thread.start()
        return self._receive()

    def advance(self, actuator_values: FloatArray) -> PeriodReading:
        """Run one period with ``actuator_values`` (na,) held (NaN: the IDF's own control)
        and return its readings."""
        values = np.asarray(actuator_values, dtype=np.float64)
        if values.shape != (len(self.spec.actuators),):
            raise ValueError(
                f"expected {len(self.spec.actuators)} actuator values, got shape {values.shape}"
            )
        if self._thread is None or not self._thread.is_alive():
            raise EnergyPlusError(
                "the EnergyPlus run is not running (not started, ended or closed)",
                source=self.spec.source,
                hint="the run period is over; start a new plant",
            )
        began = time.perf_counter()
        self._to_engine.put(("advance", values.copy()))
        reading = self._receive()
        self.engine_time_s += time.perf_counter() - began
        return reading

    def close(self) -> None:
        """Stop the run (if it is still going), wait for the engine, remove the temporary
        folder (unless the run failed)."""
        if self._thread is not None and self._thread.is_alive():
            self._to_engine.put(("stop", None))
            self._thread.join(JOIN_TIMEOUT_S)
        if self._state is not None and (self._thread is None or not self._thread.is_alive()):
            self._api.lib.stateDelete(self._state)
            self._state = None
        if self._own_dir and not self._failed:
            shutil.rmtree(self.work_dir, ignore_errors=True)

    def __enter__(self) -> CoSimulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _receive(self) -> PeriodReading:
        kind, payload = self._to_caller.get()
        if kind == "reading":
            assert isinstance(payload, PeriodReading)
            return payload
        self._failed = kind == "error" or int(payload) != 0  # keep the files of a failed run
        if self._thread is not None:
            self._thread.join(JOIN_TIMEOUT_S)
        if kind == "error":
            assert isinstance(payload, BaseException)
            raise payload
        raise self._ended_error(int(payload))

    def _ended_error(self, rc: int) -> EnergyPlusError:
        err = self.work_dir / "eplusout.err"
        lines = err.read_text(errors="replace").splitlines() if err.is_file() else []
        quoted = _why(lines)
        if rc == 0 and not quoted:
            return EnergyPlusError(
                "the EnergyPlus run period ended before this period",
                source=self.spec.source,
                hint="the plant cannot step past the scenario's last day; start a new plant",
            )
        body = (
            "\n".join(f"  {line}" for line in quoted)
            if quoted
            else ("  (no severe or fatal line in eplusout.err)")
        )
        return EnergyPlusError(
            f"EnergyPlus stopped with an error (exit code {rc})",
            source=self.spec.source,
            hint=f"fix the model as EnergyPlus's eplusout.err says (the whole file: {err}):\n"
            + body,
        )

    # ---- engine side (worker thread) -------------------------------------------------

    def _engine(self, args: list[str]) -> None:
        assert self._state is not None
        try:
            rc = self._api.run(self._state, args)
        except BaseException as error:  # pragma: no cover - ctypes does not raise here
            self._to_caller.put(("error", error))
            return
        self._to_caller.put(("ended", rc))

    def _guard(self, body: Callable[[ctypes.c_void_p], None]) -> Callable[[Any], None]:
        def callback(state: Any) -> None:
            if self._stopping:
                return
            began = time.thread_time()
            try:
                body(state)
            except BaseException as error:
                self._stopping = True
                self._api.lib.stopSimulation(state)
                self._to_caller.put(("error", error))
            self.callback_time_s += time.thread_time() - began

        return callback

    def _in_run_period(self, state: Any) -> bool:
        lib = self._api.lib
        return bool(
            lib.apiDataFullyReady(state)
            and lib.kindOfSim(state) == KIND_OF_SIM_RUN_PERIOD_WEATHER
            and not lib.warmupFlag(state)
        )

    def _resolve_handles(self, state: Any) -> None:
        api = self._api
        for variable in self.spec.variables:
            handle = api.variable_handle(state, variable.name, variable.key)
            if handle < 0:
                raise InputError(
                    "EnergyPlus has no such output variable",
                    source=self.spec.source,
                    field=f"{variable.name} [{variable.key}]",
                    hint="the IDF lacks the object this variable belongs to",
                )
            self._handles.variables.append(handle)
        self._handles.meters = [api.meter_handle(state, m) for m in self.spec.meters]
        for actuator in self.spec.actuators:
            handle = api.actuator_handle(state, actuator.component, actuator.control, actuator.key)
            if handle < 0:
                raise InputError(
                    "the IDF offers no such actuator",
                    source=self.spec.source,
                    field=f"{actuator.component} / {actuator.control} [{actuator.key}]",
                    hint="see docs/guide/energyplus.md for what each actuation needs",
                )
            self._handles.actuators.append(handle)

    def _read_variables(self, state: Any) -> FloatArray:
        get = self._api.lib.getVariableValue
        return np.array([get(state, h) for h in self._handles.variables], dtype=np.float64)

    def _wait_for_command(self, state: Any) -> None:
        kind, payload = self._to_engine.get()
        if kind == "stop":
            self._stopping = True
            self._api.lib.stopSimulation(state)
            return
        self._commanded = payload

    def _on_begin_timestep(self, state: Any) -> None:
        if not self._in_run_period(state):
            return
        if not self._started:
            self._started = True
            self._resolve_handles(state)
            self._latest = self._read_variables(state)
            now = self._latest.copy()
            self._to_caller.put(
                ("reading", PeriodReading(now, now.copy(), np.zeros(len(self.spec.meters))))
            )
            self._wait_for_command(state)
            if self._stopping:
                return
        values = self._commanded
        if self.spec.timestep_rule is not None:
            values = self.spec.timestep_rule(
                self._latest.copy(), values.copy(), self._last_meters_j.copy()
            )
        lib = self._api.lib
        for handle, value in zip(self._handles.actuators, values, strict=True):
            if np.isnan(value):
                lib.resetActuator(state, handle)
            else:
                lib.setActuatorValue(state, handle, float(value))

    def _on_end_zone_timestep(self, state: Any) -> None:
        if not self._started or not self._in_run_period(state):
            return
        lib = self._api.lib
        self._latest = self._read_variables(state)
        self._sums += self._latest
        self._last_meters_j = np.array(
            [lib.getMeterValue(state, h) if h >= 0 else np.nan for h in self._handles.meters],
            dtype=np.float64,
        )
        self._meter_sums += self._last_meters_j
        self._steps_seen += 1
        step_of_day = lib.hour(state) * self.spec.timesteps_per_hour + lib.zoneTimeStepNum(state)
        if step_of_day % self._steps_per_period:
            return
        if self._steps_seen != self._steps_per_period:
            raise EnergyPlusError(
                f"a period held {self._steps_seen} zone time steps, expected "
                f"{self._steps_per_period}",
                source=self.spec.source,
                hint="the IDF's Timestep must be the plant's timesteps_per_hour",
            )
        reading = PeriodReading(
            self._latest.copy(), self._sums / self._steps_seen, self._meter_sums.copy()
        )
        self._sums[:] = 0.0
        self._meter_sums[:] = 0.0
        self._steps_seen = 0
        self._to_caller.put(("reading", reading))
        self._wait_for_command(state)


def expand_hvac_templates(idf_text: str, source: str) -> str:
    """The IDF with its ``HVACTemplate:*`` objects expanded by EnergyPlus's ExpandObjects.

    ExpandObjects reads ``in.idf`` and ``Energy+.idd`` from its working folder and writes
    ``expanded.idf`` (``energyplus -x`` through the API finds no ``Energy+.idd`` there), so
    it runs in a temporary folder.

    Raises
    ------
    EnergyPlusError
        quoting ``expandedidf.err`` when the expansion fails.
    """
    root = load_api().root
    with tempfile.TemporaryDirectory(prefix="hvacflex-expand-") as folder:
        work = Path(folder)
        (work / "in.idf").write_text(idf_text, encoding="utf-8")
        (work / "Energy+.idd").symlink_to(root / "Energy+.idd")
        subprocess.run(
            [str(root / "ExpandObjects")],
            cwd=work,
            capture_output=True,
            check=False,
            timeout=EXPAND_TIMEOUT_S,
        )
        expanded, err = work / "expanded.idf", work / "expandedidf.err"
        lines = err.read_text(errors="replace").splitlines() if err.is_file() else []
        errors = [ln.strip() for ln in lines if "error" in ln.lower()]
        if not expanded.is_file() or errors:
            raise EnergyPlusError(
                "ExpandObjects could not expand the IDF's HVACTemplate objects",
                source=source,
                hint="fix them as ExpandObjects says:\n"
                + ("\n".join(f"  {ln}" for ln in errors[:ERR_LINES_QUOTED]) or "  (no message)"),
            )
        return expanded.read_text(encoding="utf-8", errors="replace")


def _why(lines: list[str]) -> list[str]:
    """The severe and fatal lines of ``eplusout.err`` with their continuation lines: the
    first :data:`ERR_LINES_QUOTED` of them, and the fatal ones always."""
    blocks: list[list[str]] = []
    for line in lines:
        text = line.strip()
        if "** Severe  **" in text or "**  Fatal  **" in text:
            blocks.append([text])
        elif "** Warning **" in text or "~~~" not in text:
            if blocks and blocks[-1][0] != "":
                blocks.append([""])  # a gap: what follows is not part of the last block
        elif blocks and blocks[-1][0] != "":
            blocks[-1].append(text)
    kept = [b for b in blocks if b[0]]
    quoted = [line for block in kept for line in block]
    if len(quoted) <= ERR_LINES_QUOTED:
        return quoted
    fatal = [line for block in kept if "Fatal" in block[0] for line in block]
    head = quoted[: max(ERR_LINES_QUOTED - len(fatal), 2)]
    return [*head, f"... ({len(quoted) - len(head) - len(fatal)} more lines)", *fatal]
