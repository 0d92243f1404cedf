"""The one place that goes beyond rclpy's public API, and the switch back to it.

Three fast paths, each chosen at start-up and named in one INFO line:

- ``raw_intake``: command topics are taken as CDR bytes and decoded by ``cdr.Codec`` straight into
  numpy arrays, instead of rclpy turning every field of every sub-message into Python objects;
- ``raw_publish``: state messages are encoded by ``cdr.Codec`` and published as bytes, instead of
  being built through rclpy's per-field setters (each topic's bytes are kept and only what changed
  is written over them: ``lean.Patcher``, ``publishers.Frame``);
- ``detached_intake``: the command subscriptions are kept out of the executor (removed from the
  node's private subscription list) and taken by the loop thread itself, which waits on them with
  rclpy's private ``WaitSet``; without it they are ordinary executor callbacks.

Both raw paths need the middleware to agree with ``cdr.py`` (``cdr.self_check`` on every message
they handle); the detached intake needs the private names it uses (``Node._subscriptions`` as a
list, ``_rclpy.WaitSet``, ``Subscription.handle.take_message``). A path whose check fails is left
off, with the reason in the INFO line. ``DYNAMIXEL_HANDLER_FAST_PATH`` chooses among them:
unset or ``all``: every path that passes its check; ``none`` (or ``0``): public rclpy API only;
a comma-separated list (``raw_intake,detached_intake``): only those. The older
``DYNAMIXEL_HANDLER_RAW_CDR=0`` turns both raw paths off.

The lifecycle node's guard against transitions the state machine does not have also reads private
names of ``LifecycleNode``; ``lifecycle_guard`` installs it only where they exist.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from functools import partial
from importlib import metadata
from typing import Any, Callable, Sequence

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.subscription import Subscription

from .cdr import self_check

#: environment variable: which fast paths the node may use (see the module's doc)
FAST_ENV = "DYNAMIXEL_HANDLER_FAST_PATH"
#: environment variable: "0" turns both raw CDR paths off (rclpy message objects)
RAW_ENV = "DYNAMIXEL_HANDLER_RAW_CDR"
#: the fast paths, in the order the start-up line names them
PATHS = ("raw_intake", "raw_publish", "detached_intake")
#: what the node does instead of a path that is off (the public API)
INSTEAD = {"raw_intake": "commands go through rclpy message objects",
           "raw_publish": "states go through rclpy message objects",
           "detached_intake": "command subscriptions run in the executor"}

#: rcl's error type (a RuntimeError), for one clear line on bad ROS arguments
RCLError: type[Exception] = getattr(_rclpy, "RCLError", RuntimeError)


@dataclass(frozen=True)
class FastPaths:
    raw_intake: bool = False
    raw_publish: bool = False
    detached_intake: bool = False

    def line(self, why_off: dict[str, str]) -> str:
        used = [p for p in PATHS if getattr(self, p)]
        head = f"fast paths: {', '.join(used)}" if used else "public rclpy API only"
        off = [f"{p} off ({why_off[p]}): {INSTEAD[p]}" for p in PATHS if p in why_off]
        return head + (f"; {'; '.join(off)}" if off else "") + f" (rclpy {_rclpy_version()})"


def _rclpy_version() -> str:
    try:
        return metadata.version("rclpy")
    except metadata.PackageNotFoundError:
        return "of unknown version"


def _wanted() -> tuple[set[str], dict[str, str]]:
    """The paths the environment allows, and why the others are off."""
    value = os.environ.get(FAST_ENV, "all").strip().lower()
    if value in ("", "all", "1"):
        wanted = set(PATHS)
    elif value in ("none", "0"):
        wanted = set()
    else:
        wanted = {p.strip() for p in value.split(",")} & set(PATHS)
    off = {p: f"{FAST_ENV}={value}" for p in PATHS if p not in wanted}
    if os.environ.get(RAW_ENV, "1").strip() == "0":
        for p in ("raw_intake", "raw_publish"):
            if p in wanted:
                wanted.discard(p)
                off[p] = f"{RAW_ENV}=0"
    return wanted, off


def detach_supported(node: Node) -> str | None:
    """Why the detached intake cannot be used with this rclpy (None: it can)."""
    if not isinstance(getattr(node, "_subscriptions", None), list):
        return "Node._subscriptions is not a list"
    if not hasattr(_rclpy, "WaitSet"):
        return "no _rclpy.WaitSet"
    if not isinstance(getattr(Subscription, "handle", None), property):
        return "no Subscription.handle"
    return None


def choose(node: Node, msg_classes: Sequence[type], log: Any) -> FastPaths:
    """The start-up check: which fast paths this node uses; logs one INFO line saying so."""
    wanted, off = _wanted()
    if wanted & {"raw_intake", "raw_publish"}:
        reason = self_check(msg_classes)
        if reason is not None:
            log.warning(f"raw CDR disabled, messages go through rclpy message objects ({reason})")
            for p in ("raw_intake", "raw_publish"):
                if p in wanted:
                    wanted.discard(p)
                    off[p] = f"the middleware's CDR differs: {reason}"
    if "detached_intake" in wanted:
        reason = detach_supported(node)
        if reason is not None:
            wanted.discard("detached_intake")
            off["detached_intake"] = reason
    paths = FastPaths(**{p: p in wanted for p in PATHS})
    log.info(paths.line(off))
    return paths


# ---------------------------------------------------------------------- the detached intake
def detach(node: Node, sub: Subscription) -> None:
    """Keep ``sub`` out of the executor's sight (it stays a subscription of the node)."""
    node._subscriptions.remove(sub)


def taker(sub: Subscription, raw: bool) -> Callable[[], Any]:
    """Takes one waiting message of ``sub``: None, or the message and its info (``got[0]``,
    ``got[1]``: ``source_timestamp``...). One call without arguments, straight to rclpy (the loop
    takes every command topic every step)."""
    return partial(sub.handle.take_message, sub.msg_type, raw)


class Waiter:
    """Blocks, without the interpreter lock, until one of the subscriptions has a message."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._wait_set: Any = None
        self._size = 0

    def wait(self, subs: Sequence[Subscription], timeout_s: float) -> bool:
        """The caller keeps the subscriptions alive meanwhile; True if one has a message."""
        context = self.node.context.handle
        if context is None:  # rclpy shut down
            return False
        with context:
            handles = [sub.handle for sub in subs]
            if self._wait_set is None or self._size != len(handles):
                self._wait_set = _rclpy.WaitSet(len(handles), 0, 0, 0, 0, 0, context)
                self._size = len(handles)
            wait_set = self._wait_set
            wait_set.clear_entities()
            for handle in handles:
                wait_set.add_subscription(handle)
            wait_set.wait(max(0, int(timeout_s * 1e9)))
            return bool(wait_set.get_ready_entities("subscription"))

    def close(self) -> None:
        self._wait_set = None


# ---------------------------------------------------------------------- the lifecycle node
Transitions = Callable[[], list[tuple[int, str]]]


def lifecycle_guard(node: Any, wrap: Callable[[Callable[..., Any], Callable[[], str], Transitions],
                                               Callable[..., Any]]) -> bool:
    """Wrap the lifecycle node's change_state service callback with ``wrap(serve, state, transitions)``:
    ``state()`` the current state's label, ``transitions()`` the (id, label) of the transitions from
    it. False (nothing installed) if this rclpy's LifecycleNode lacks the names it needs."""
    service = getattr(node, "_service_change_state", None)
    machine = getattr(node, "_state_machine", None)
    if service is None or machine is None or not hasattr(machine, "available_transitions"):
        return False

    def state() -> str:
        return str(machine.current_state[1])

    def transitions() -> list[tuple[int, str]]:
        # each description: (id, label, start id, start label, goal id, goal label)
        return [(int(d[0]), str(d[1])) for d in machine.available_transitions]
    service.callback = wrap(service.callback, state, transitions)
    return True


def lifecycle_state(node: Any) -> str:
    """The lifecycle node's current state label ("unknown" if this rclpy hides it)."""
    machine = getattr(node, "_state_machine", None)
    return str(machine.current_state[1]) if machine is not None else "unknown"
