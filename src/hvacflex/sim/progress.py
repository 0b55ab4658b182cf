"""A progress bar for long runs (steps/s and ETA), or nothing when quiet."""

from __future__ import annotations

import time
from collections.abc import Callable


class progress_bar:
    """A rich progress bar with steps/s and ETA, or nothing when quiet."""

    def __init__(self, enabled: bool, name: str, total: int, done: int) -> None:
        self.enabled = enabled and total > 1
        self.name, self.total, self.done = name, total, done

    def __enter__(self) -> Callable[[], None]:
        if not self.enabled:
            return lambda: None
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeRemainingColumn,
        )

        self._progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]}"),
            TimeRemainingColumn(),
            transient=False,
        )
        self._progress.start()
        self._task = self._progress.add_task(
            self.name, total=self.total, completed=self.done, rate=""
        )
        self._t0 = time.perf_counter()
        self._n = 0

        def advance() -> None:
            self._n += 1
            if self._n % 10 == 0:
                rate = self._n / (time.perf_counter() - self._t0)
                self._progress.update(self._task, advance=10, rate=f"{rate:6.1f} steps/s")

        return advance

    def __exit__(self, *exc: object) -> None:
        if self.enabled:
            self._progress.update(self._task, completed=self.done + self._n)
            self._progress.stop()


def clock_text(seconds: float) -> str:
    """A duration as ``M:SS``, or ``H:MM:SS`` from an hour on (rounded down to the second)."""
    minutes, secs = divmod(int(max(seconds, 0.0)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


HEARTBEAT_S = 10.0
"""Least time between two lines of :meth:`task_progress.beat` on output that is not a
terminal [s] (a line per model evaluation would flood a log)."""


class task_progress:
    """A rich progress bar for work of ``total`` units (runs, fleet steps): description,
    bar, done/total, elapsed time, ETA and a free text (``info``); nothing when disabled.

    ``with task_progress(True, "sweep", 12) as update: update(completed=3, info="…")``;
    ``update.note(text)`` prints a line above the bar, ``update.warn(text)`` a warning there
    (both plainly when the bar is off). When the output is not a terminal (piped, logged)
    the bar cannot redraw, so each stage also prints a line with the elapsed time (a disabled
    bar prints nothing but its notes and warnings).
    """

    def __init__(self, enabled: bool, description: str, total: int, completed: int = 0) -> None:
        self.enabled = enabled and total > 0
        self.description, self.total, self.completed = description, total, completed
        self._stages = 0
        self._t0 = time.perf_counter()
        self._last_beat = self._t0

    @property
    def elapsed_s(self) -> float:
        """Seconds since the work started (the ``with`` block was entered) [s]."""
        return time.perf_counter() - self._t0

    @property
    def live(self) -> bool:
        """True when the bar redraws in place (enabled, on a terminal)."""
        return self.enabled and bool(self._progress.console.is_terminal)

    def __enter__(self) -> task_progress:
        self._t0 = self._last_beat = time.perf_counter()
        if self.enabled:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self._progress = Progress(
                TextColumn("[bold]{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("elapsed"),
                TimeElapsedColumn(),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                TextColumn("{task.fields[info]}"),
            )
            self._progress.start()
            self._task = self._progress.add_task(
                self.description, total=self.total, completed=self.completed, info=""
            )
        return self

    def __call__(self, *, completed: int | None = None, info: str | None = None) -> None:
        """Set the units done (default: one more) and the free text."""
        self.completed = self.completed + 1 if completed is None else completed
        if self.enabled:
            self._progress.update(self._task, completed=self.completed)
            if info is not None:
                self._progress.update(self._task, info=info)

    def stage(self, message: str) -> None:
        """Start a stage of staged work (``total`` stages): the stages before it are done,
        ``message`` names the one running (a ``progress`` callback of the validations)."""
        self._stages += 1
        self(completed=self._stages - 1, info=message)
        if self.enabled and not self.live:
            self.note(
                f"{self.description}: [{self._stages}/{self.total}] {message} "
                f"(elapsed {clock_text(self.elapsed_s)})"
            )

    def beat(self, text: str) -> None:
        """Progress inside the running stage: the bar's free text; when the output is not a
        terminal, a line at most every :data:`HEARTBEAT_S` seconds (nothing when disabled)."""
        if self.enabled:
            self._progress.update(self._task, info=text)
        now = time.perf_counter()
        if self.enabled and not self.live and now - self._last_beat >= HEARTBEAT_S:
            self._last_beat = now
            self.note(f"{self.description}: {text} (elapsed {clock_text(self.elapsed_s)})")

    def note(self, text: str) -> None:
        """A line of its own: above the bar (which keeps its place), or plainly on stdout
        when the bar is off or the output is not a terminal (printed at once)."""
        if self.enabled:
            self._progress.console.print(text, markup=False, highlight=False, soft_wrap=True)
        else:
            print(text, flush=True)

    def warn(self, text: str) -> None:
        """A warning line above the bar (on stderr when the bar is off)."""
        if self.enabled:
            from rich.markup import escape

            self._progress.console.print(f"[yellow]warning:[/yellow] {escape(text)}")
        else:
            import sys

            print(f"warning: {text}", file=sys.stderr)

    def __exit__(self, exc_type: object, *exc: object) -> None:
        if self.enabled:
            if exc_type is None and self._stages:
                self._progress.update(self._task, completed=self.total, info="done")
            self._progress.stop()
