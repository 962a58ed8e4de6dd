"""Progress of many runs on stderr: a bar on a terminal, and a line per finished group (e.g. per
estimator) always, so a redirected or CI log shows where a long job is."""

from __future__ import annotations

import time

from rich.console import Console
from rich.progress import Progress


class RunProgress:
    """Counts finished runs by group. ``groups`` maps each group's name to its number of runs;
    use as a context manager and call :meth:`done` once per finished run."""

    def __init__(self, label: str, groups: dict[str, int], console: Console | None = None) -> None:
        self.label = label
        self.remaining = dict(groups)
        self.failed = {name: 0 for name in groups}
        self.console = console or Console(stderr=True, highlight=False)
        self._bar = Progress(console=self.console, transient=True,
                             disable=not self.console.is_terminal)
        self._task = self._bar.add_task(label, total=sum(groups.values()))
        self._start = time.monotonic()

    def __enter__(self) -> RunProgress:
        self._bar.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self._bar.__exit__(*exc)

    def done(self, group: str, ok: bool = True) -> None:
        """One run of ``group`` finished (``ok`` False if it failed its check)."""
        self._bar.advance(self._task)
        self.remaining[group] -= 1
        self.failed[group] += 0 if ok else 1
        if self.remaining[group] == 0:
            verdict = "ok" if not self.failed[group] else f"{self.failed[group]} FAILED"
            self.console.print(f"{self.label} {group}: {verdict} "
                               f"({time.monotonic() - self._start:.0f} s)")
