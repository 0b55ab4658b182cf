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
