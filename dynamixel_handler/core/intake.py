"""The request intake: one queue of request values for the loop thread, and the table from
request type to the one part that takes it.

Any thread ``submit``s a request (a frozen dataclass of ``request_types`` or of the command
side); the loop thread takes them in order (``run_queued``) and hands each to its part's
``handle``. The table is filled when the parts are built (``attach``, once per part). Inside the
loop thread parts call each other through typed methods (``calls.CoreCalls``), not through here. A
part that raises is one ERROR line; the loop goes on."""
from __future__ import annotations

import collections
import threading
from typing import Any, Callable, ClassVar, Protocol

from .request_types import Answer
from .servo_io import Log


class Taker(Protocol):
    """A part that takes queued requests: the types it takes (fixed, a class constant) and its
    ``handle`` (a ``match`` over them)."""

    TAKES: ClassVar[tuple[type, ...]]

    def handle(self, request: Any) -> Answer | None: ...


def label(request: object) -> str:
    """How a request is named in a log line: its ``what``, else its type."""
    return str(getattr(request, "what", "") or type(request).__name__)


class Intake:
    """The queue and the routes. Each part that takes requests is attached once, when the parts
    are built; a type taken by two parts is an error (it would silently replace the first)."""

    def __init__(self, log: Log) -> None:
        self.log = log
        self._routes: dict[type, Taker] = {}
        self._queue: collections.deque[tuple[object, str]] = collections.deque()
        self._lock = threading.Lock()

    def attach(self, part: Taker) -> None:
        """``part`` takes the request types of its ``TAKES`` from now on."""
        taken = [kind for kind in part.TAKES if kind in self._routes]
        if taken:
            raise ValueError(f"{', '.join(k.__name__ for k in taken)} already taken by "
                             f"{type(self._routes[taken[0]]).__name__}: one part per request type")
        for kind in part.TAKES:
            self._routes[kind] = part

    def routes(self) -> dict[type, str]:
        """The table: which request types are taken, and by which part (its class name)."""
        return {kind: type(part).__name__ for kind, part in self._routes.items()}

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
    def run(self, request: object, what: str = "") -> None:
        """``request`` handed to the part that takes it, a failure logged instead of raised (a
        request must never stop the loop)."""
        try:
            part = self._routes.get(type(request))
            if part is None:
                raise TypeError(f"no part takes a {type(request).__name__} request (the part that takes it is "
                                "attached by who builds it: handler.attach(part))")
            part.handle(request)
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
