"""The least a loop can cost in Python: rclpy and the serial line's system calls alone, no handler.

    source env.sh && python bench/floor.py [--n 12] [--loops 3000]

Measures, with this thread's CPU clock, what every loop of the node pays at the least whatever
its own code does: publishing one ``/dynamixel/states`` message (already encoded, as the node's
raw path publishes it) to a subscriber in another process, taking one ``/dynamixel/commands/x``
message as bytes and looking at the other 14 command topics, one wait on the command topics that
finds a message waiting, and the system calls of one write and one read exchange on a
pseudo-terminal (``os.write``, ``select``, ``os.read``, the input count ``ioctl``). Their sum is
the floor under the handler's per-loop host time; the rest of ``bench/profile_step.py``'s figure
is the handler's own Python.
"""
from __future__ import annotations

import argparse
import fcntl
import os
import select
import subprocess
import sys
import termios
import time
import tty

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from bench_loop import claim_domain  # noqa: E402,F401  (importing it claims the ROS domain)

#: the subscriber of /dynamixel/states, in a process of its own as a controller would be
LISTENER = """
import rclpy, sys
from rclpy.node import Node
from dynamixel_handler_msgs.msg import DxlStates
rclpy.init()
node = Node("floor_listener")
node.create_subscription(DxlStates, "/dynamixel/states", lambda raw: None, 10, raw=True)
print("ready", flush=True)
try:
    rclpy.spin(node)
except Exception:
    pass
"""


def per_call_us(fn, loops: int, pause_s: float = 0.0) -> float:
    """CPU µs of this thread per call of ``fn`` (a pause between calls, subtracted, lets DDS deliver)."""
    for _ in range(100):
        fn()
    spent = 0.0
    for _ in range(loops):
        t = time.thread_time()
        fn()
        spent += time.thread_time() - t
        if pause_s:
            time.sleep(pause_s)
    return 1e6 * spent / loops


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=12, help="servos in the messages")
    ap.add_argument("--loops", type=int, default=3000)
    a = ap.parse_args(argv)

    import rclpy
    from rclpy.node import Node
    from rclpy.serialization import serialize_message

    from dynamixel_handler.ros import fastpath
    from dynamixel_handler_msgs.msg import DxlCommandsX, DxlStates

    rclpy.init()
    listener = subprocess.Popen([sys.executable, "-c", LISTENER], stdout=subprocess.PIPE, text=True)
    try:
        assert listener.stdout is not None and listener.stdout.readline().strip() == "ready"
        node, other = Node("floor_node"), Node("floor_controller")
        ids = list(range(1, a.n + 1))
        states = DxlStates()
        states.present.id_list = ids
        states.present.current_ma = states.present.velocity_deg_s = states.present.position_deg = [0.0] * a.n
        states_bytes = serialize_message(states)
        publisher = node.create_publisher(DxlStates, "/dynamixel/states", 10)
        command = DxlCommandsX()
        command.position_control.id_list = ids
        command.position_control.position_deg = [1.0] * a.n
        command_bytes = serialize_message(command)
        commander = other.create_publisher(DxlCommandsX, "/dynamixel/commands/x", 10)
        subs = [node.create_subscription(DxlCommandsX, "/dynamixel/commands/x", lambda raw: None, 10, raw=True)]
        subs += [node.create_subscription(DxlCommandsX, f"/floor/idle_{k}", lambda raw: None, 10, raw=True)
                 for k in range(14)]
        for sub in subs:
            fastpath.detach(node, sub)
        waiter = fastpath.Waiter(node)
        deadline = time.monotonic() + 10
        while (publisher.get_subscription_count() < 1 or commander.get_subscription_count() < 1) \
                and time.monotonic() < deadline:
            time.sleep(0.05)

        rows: list[tuple[str, float]] = []
        rows.append((f"publish /dynamixel/states ({a.n} servos, encoded) to a subscriber in another process",
                     per_call_us(lambda: publisher.publish(states_bytes), a.loops, 0.0003)))
        takes = [sub.handle.take_message for sub in subs]

        def take_one() -> None:
            commander.publish(command_bytes)
            time.sleep(0.0003)

        spent = 0.0
        for _ in range(a.loops):
            take_one()
            t = time.thread_time()
            for take in takes:
                take(DxlCommandsX, True)
            spent += time.thread_time() - t
        rows.append(("take one command as bytes, and look at 14 idle command topics", 1e6 * spent / a.loops))
        spent = 0.0
        for _ in range(a.loops):
            take_one()
            t = time.thread_time()
            waiter.wait(subs, 0.01)
            spent += time.thread_time() - t
            subs[0].handle.take_message(DxlCommandsX, True)
        rows.append(("one wait on the 15 command topics that finds a message", 1e6 * spent / a.loops))

        master, slave = os.openpty()
        tty.setraw(slave)  # as a serial port is used: no line discipline, no echo
        os.set_blocking(slave, False)
        request, reply = bytes(26), bytes(21 * a.n)
        count = bytes(4)

        spent = 0.0
        for _ in range(a.loops):  # the host's side of one read: flush check, write, wait, count, read
            t = time.thread_time()
            fcntl.ioctl(slave, termios.TIOCINQ, count)
            os.write(slave, request)
            spent += time.thread_time() - t
            os.read(master, 4096)          # the servos' side, not counted
            os.write(master, reply)
            t = time.thread_time()
            select.select([slave], [], [], 0.01)
            fcntl.ioctl(slave, termios.TIOCINQ, count)
            os.read(slave, 4096)
            spent += time.thread_time() - t
        rows.append(("a sync read's system calls on a pseudo-terminal (ioctl, write, select, ioctl, read)",
                     1e6 * spent / a.loops))
        os.close(master)
        os.close(slave)
    finally:
        listener.terminate()
        listener.wait(5)
    width = max(len(label) for label, _ in rows)
    print(f"CPU of this thread per call, {a.loops} calls each (µs):")
    for label, value in rows:
        print(f"  {label:{width}s} {value:7.1f}")
    print(f"  {'sum: the floor of one loop':{width}s} {sum(v for _, v in rows):7.1f}")
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
