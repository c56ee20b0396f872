"""Progress of a long command on stderr: a live bar on a terminal (`rich`), plain lines otherwise
(`autocable simulate`, `autocable figures`).

In a log file or a pipe a bar redrawn with carriage returns becomes one line of kilobytes; there the
progress is written as whole lines, one per stage (`LineProgress`: at most one line per tenth of the
work, and one at the end), so that ``autocable simulate ... 2> log`` reads line by line."""
from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["progress_for", "LineProgress", "BarProgress", "STAGES"]

#: The lines a non-terminal progress writes over the whole work, at most (plus the last one).
STAGES = 10


class LineProgress:
    """Whole lines: ``label: 30 % (t = ...)`` each time the work crosses another tenth."""

    def __init__(self, label: str, total: float, stream: TextIO):
        self.label, self.total, self.stream = label, float(total), stream
        self._next = 1

    def update(self, done: float, note: str = "") -> None:
        if self.total <= 0:
            return
        stage = int(STAGES * min(done / self.total, 1.0))
        if stage >= self._next:
            self._next = stage + 1
            self.stream.write(f"{self.label}: {100 * stage // STAGES} %{'  ' + note if note else ''}\n")
            self.stream.flush()

    def close(self, note: str = "") -> None:
        self.stream.write(f"{self.label}: done{'  ' + note if note else ''}\n")
        self.stream.flush()


class BarProgress:
    """A `rich` progress bar (terminal only), with the latest note beside it; with ``count`` (work
    counted in tasks) also done / total and an estimate of the time left."""

    def __init__(self, label: str, total: float, stream: TextIO, count: bool = False):
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                                   TimeRemainingColumn)

        columns = [TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f} %")]
        if count:
            columns += [MofNCompleteColumn(), TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn()]
        else:
            columns += [TimeElapsedColumn()]
        self._bar = Progress(*columns, TextColumn("{task.fields[note]}"), console=Console(file=stream),
                             transient=False)
        self._task = self._bar.add_task(label, total=float(total), note="")
        self._bar.start()

    def update(self, done: float, note: str = "") -> None:
        self._bar.update(self._task, completed=float(done), note=note)

    def close(self, note: str = "") -> None:
        if note:
            self._bar.update(self._task, note=note)
        self._bar.stop()


class _Silent:
    def update(self, done: float, note: str = "") -> None:
        pass

    def close(self, note: str = "") -> None:
        pass


def progress_for(label: str, total: float, *, quiet: bool = False, stream: TextIO | None = None,
                 count: bool = False):
    """The progress of a piece of work of size ``total``: nothing when ``quiet``, a bar when
    ``stream`` (default stderr) is a terminal (``count``: the work is ``total`` tasks, shown as
    done / total with the time left), whole lines otherwise. It has ``update(done, note)`` and
    ``close(note)``."""
    stream = sys.stderr if stream is None else stream
    if quiet:
        return _Silent()
    isatty = getattr(stream, "isatty", None)
    if isatty is not None and isatty():
        return BarProgress(label, total, stream, count=count)
    return LineProgress(label, total, stream)
