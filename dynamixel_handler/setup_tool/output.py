"""What the tool prints: rich tables and a progress bar on a terminal, plain columns when piped,
one JSON document with ``--json``. Errors are one line on stderr."""
from __future__ import annotations

import json
import sys
from contextlib import contextmanager
from typing import Any, Iterator, Protocol, Sequence, TextIO

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn
from rich.table import Table

__all__ = ["Output", "Ticker", "plain_table"]

#: columns of a recorded terminal (``--svg``)
_SVG_WIDTH = 118


class Ticker(Protocol):
    def __call__(self, steps: float = 1.0, what: str | None = None) -> None: ...


def plain_table(columns: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """Columns aligned with spaces, no colours or box characters (for pipes, logs, tests)."""
    cells = [[str(c) for c in columns]] + [[str(v) for v in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(columns))]
    return "\n".join("  ".join(v.ljust(w) for v, w in zip(r, widths)).rstrip() for r in cells)


class Output:
    """Where results go. ``human``: a terminal (rich); else plain text; ``as_json``: one document."""

    def __init__(self, as_json: bool = False, stream: TextIO | None = None, err: TextIO | None = None,
                 svg: str | None = None) -> None:
        self.stream = stream if stream is not None else sys.stdout
        self.err = err if err is not None else sys.stderr
        self.as_json = as_json
        #: ``--svg FILE``: the terminal output (tables, colours) recorded and saved as a picture
        self.svg = svg
        self.human = not as_json and (self.stream.isatty() or svg is not None)
        self.console: Console | None = None
        if svg is not None:
            self.console = Console(file=self.stream, highlight=False, record=True, force_terminal=True, width=_SVG_WIDTH)
        elif self.human:
            self.console = Console(file=self.stream, highlight=False)
        #: what ``--json`` prints at the end (verbs fill it)
        self.document: dict[str, Any] = {}

    def say(self, text: str) -> None:
        """A line for the person at the terminal (stderr in JSON mode, so stdout stays parseable)."""
        if self.as_json:
            print(text, file=self.err, flush=True)
        elif self.console is not None:
            self.console.print(text, markup=False)
        else:
            print(text, file=self.stream, flush=True)

    def error(self, text: str) -> None:
        print(f"error: {text}", file=self.err, flush=True)

    def warn(self, text: str) -> None:
        """A warning line on stderr, kept in the JSON document's ``warnings``."""
        print(f"warning: {text}", file=self.err, flush=True)
        self.document.setdefault("warnings", []).append(text)

    def table(self, title: str, columns: Sequence[str], rows: Sequence[Sequence[object]],
              styles: Sequence[str | None] | None = None) -> None:
        if self.as_json:
            return
        if self.console is None:
            if title:
                print(title, file=self.stream)
            print(plain_table(columns, rows), file=self.stream, flush=True)
            return
        self.console.print(rich_table(title, columns, rows, styles))

    def finish(self, title: str = "dynamixel_handler_setup") -> None:
        if self.svg is not None and self.console is not None:
            self.console.save_svg(self.svg, title=title)
        if self.as_json:
            print(json.dumps(self.document, indent=1, sort_keys=True), file=self.stream, flush=True)

    @contextmanager
    def progress(self, total: float, what: str) -> Iterator[Ticker]:
        """A progress bar with the time left on a terminal (nothing when piped); yields ``tick``."""
        if not self.human or self.console is None or self.svg is not None:
            yield lambda steps=1.0, what=None: None
            return
        columns = (TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(),
                   TextColumn("left"), TimeRemainingColumn())
        with Progress(*columns, console=self.console, transient=True) as bar:
            task = bar.add_task(what, total=total)

            def tick(steps: float = 1.0, what: str | None = None) -> None:
                bar.update(task, advance=steps, description=what if what is not None else bar.tasks[0].description)

            yield tick


def rich_table(title: str, columns: Sequence[str], rows: Sequence[Sequence[object]],
               styles: Sequence[str | None] | None = None) -> Table:
    """A rich table; ``styles`` gives a row style each (None: plain)."""
    table = Table(title=title or None, title_justify="left", header_style="bold")
    for name in columns:
        table.add_column(name)
    for k, row in enumerate(rows):
        table.add_row(*(str(v) for v in row), style=styles[k] if styles else None)
    return table
