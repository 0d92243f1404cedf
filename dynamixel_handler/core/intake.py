"""The request intake: one queue of request values for the loop thread, and the table from
request type to the one handler that does it.

Any thread ``submit``s a request (a frozen dataclass of ``request_types`` or of the command
side); the loop thread takes them in order (``run_queued``) and hands each to its handler. In the
loop thread a part or a command ``ask``s for one at once and gets its ``Answer``. A handler that
raises is one ERROR line; the loop goes on."""
from __future__ import annotations

import collections
import threading
from typing import Any, Callable, TypeVar

from .request_types import DONE, Answer
from .servo_io import Log

R = TypeVar("R")
Route = Callable[[Any], "Answer | None"]


def label(request: object) -> str:
    """How a request is named in a log line: its ``what``, else its type."""
    return str(getattr(request, "what", "") or type(request).__name__)


class Intake:
    """The queue and the routes. A request type has one handler: registering a second one is an error
    (it silently replaced the first)."""

    def __init__(self, log: Log, gate: Route = lambda _request: None) -> None:
        self.log = log
        #: a request's answer before its handler runs (the E-stop refuses moving ones), None: go on
        self.gate = gate
        self._routes: dict[type, Route] = {}
        self._queue: collections.deque[tuple[object, str]] = collections.deque()
        self._lock = threading.Lock()

    def register(self, kind: type[R], handler: Callable[[R], Answer | None]) -> None:
        if kind in self._routes:
            raise ValueError(f"{kind.__name__} already has a handler ({self._routes[kind]!r}): one route per request type")
        self._routes[kind] = handler

    def routes(self) -> dict[type, Route]:
        """The table (a copy): which request types are taken, and by what."""
        return dict(self._routes)

    # ---------------------------------------------------------------- any thread
    def submit(self, request: object, what: str = "") -> None:
        """Queue ``request`` for the loop thread (the start of the next step, or between loops)."""
        with self._lock:
            self._queue.append((request, what))

    def drop(self) -> int:
        """Forget the queued requests (the loop does not run); how many there were."""
        with self._lock:
            count = len(self._queue)
            self._queue.clear()
        return count

    # ---------------------------------------------------------------- loop thread
    def ask(self, request: object) -> Answer:
        """Do ``request`` now (loop thread); a handler that answers nothing did it."""
        handler = self._routes.get(type(request))
        if handler is None:
            raise TypeError(f"no part takes a {type(request).__name__} request")
        refused = self.gate(request)
        if refused is not None:
            return refused
        done = handler(request)
        return DONE if done is None else done

    def run(self, request: object, what: str = "") -> None:
        """``ask``, with a failure logged instead of raised (a request must never stop the loop)."""
        try:
            self.ask(request)
        except Exception as exc:
            self.log.error(f"{what or label(request)} failed: {type(exc).__name__}: {exc}")

    def guarded(self, what: str, work: Callable[[], object]) -> None:
        """Loop work that must not stop the loop either (the membership changes of a loop)."""
        try:
            work()
        except Exception as exc:
            self.log.error(f"{what} failed: {type(exc).__name__}: {exc}")

    def run_queued(self) -> None:
        """Every queued request, in the order they came."""
        while True:
            with self._lock:
                if not self._queue:
                    break
                request, what = self._queue.popleft()
            self.run(request, what)
