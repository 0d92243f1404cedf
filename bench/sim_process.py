"""The virtual bus served from a process of its own, as hardware would be.

In the bench process the virtual bus would share the interpreter lock with the controller's rclpy
node (its executor wakes for every /dynamixel/states), so the simulated servos would sometimes
answer late because of the bench itself, and the node would be measured against that. Here the
bus thread runs alone in a child process, at real-time priority when allowed. The instruction log
comes back on request; its times are ``time.monotonic()``, one clock for every process.
"""
from __future__ import annotations

import multiprocessing as mp
from typing import Any


def _serve(conn, kwargs: dict[str, Any], exact_physics: bool) -> None:
    import os
    import sys
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from common import coarse_physics, hardware_priority

    from dynamixel_handler.sim import VirtualBus

    physics = "exact servo physics" if exact_physics else coarse_physics()
    sim = VirtualBus(**kwargs)
    path = sim.start()
    conn.send((path, f"{hardware_priority()}, {physics}"))
    try:
        while True:
            what, args = conn.recv()
            if what == "write":
                dxl_id, item, value = args
                sim.servos_at(dxl_id)[0].write(item, value)  # a Protocol 1.0 servo too
                conn.send(None)
            elif what == "clear_log":
                sim.clear_log()
                conn.send(None)
            elif what == "log":
                conn.send(list(sim.log))
            elif what == "close":
                break
    except EOFError:  # the bench went away
        pass
    finally:
        sim.close()
        conn.close()


class BusProcess:
    """``VirtualBus(**kwargs)`` in a child process: ``path``, ``write``, ``clear_log``, ``log``, ``close``."""

    def __init__(self, exact_physics: bool = False, **kwargs: Any) -> None:
        ctx = mp.get_context("spawn")  # no fork of a process that runs DDS threads
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(child, kwargs, exact_physics), daemon=True,
                                 name="dxl-virtual-bus-process")
        self._proc.start()
        child.close()
        if not self._conn.poll(30):
            self._proc.kill()
            raise RuntimeError("the virtual bus process did not start")
        self.path, self.setup = self._conn.recv()
        self.pid = self._proc.pid

    def _call(self, what: str, *args: Any) -> Any:
        self._conn.send((what, args))
        return self._conn.recv()

    def write(self, dxl_id: int, item: str, value: int) -> None:
        self._call("write", dxl_id, item, value)

    def clear_log(self) -> None:
        self._call("clear_log")

    @property
    def log(self) -> list:
        return self._call("log")

    def close(self) -> None:
        try:
            self._conn.send(("close", ()))
        except (BrokenPipeError, OSError):
            pass
        self._proc.join(5)
        if self._proc.is_alive():
            self._proc.kill()
