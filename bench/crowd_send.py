#!/usr/bin/env python3
"""What one service answer costs the answering process, by the number of clients of the service:
a server (this process, no handler node) and N clients in K other processes, each client calling
once or more (800 calls in all, the last ones answered); the server takes each request and answers it
with rclpy's ``Service.send_response``, timed, while a thread of its own sleeps 1 ms over and over.
How late that thread wakes is how long the answer held Python's interpreter lock (a thread of the
node, the loop's, would wait as long).

    source env.sh && python bench/crowd_send.py --clients 1000 --processes 4 [--nice 19]

Prints the median and longest ``send_response`` time, their sum, and the ticker's longest and
99th-percentile lateness. Figures in docs/reliability.md ("A crowd at every door"). Not part of the
test suite.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(30 + os.getpid() % 30))

CALLS = 800  # answers timed


def _qos():
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def clients(count: int, calls: int) -> None:
    """A client process: ``count`` clients; 'ready' once each found the server, then ``calls``
    requests spread over them; spins until answered (at most 60 s)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_srvs.srv import Trigger
    rclpy.init()
    node = Node(f"crowd_send_{os.getpid()}")
    made = [node.create_client(Trigger, "crowd_send", qos_profile=_qos()) for _ in range(count)]
    print("ready", sum(c.wait_for_service(60.0) for c in made), flush=True)
    futures = [made[k % count].call_async(Trigger.Request()) for k in range(calls)]
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    end = time.monotonic() + 60.0
    while time.monotonic() < end and not all(f.done() for f in futures):
        executor.spin_once(timeout_sec=0.05)
    print("answered", sum(f.done() for f in futures), flush=True)
    rclpy.shutdown()


def _child(nice: int) -> None:
    if nice:
        os.nice(nice)


def server(count: int, processes: int, nice: int) -> None:
    import rclpy
    from rclpy.node import Node
    from std_srvs.srv import Trigger
    rclpy.init()
    node = Node("crowd_send_server")
    srv = node.create_service(Trigger, "crowd_send", lambda _q, r: r, qos_profile=_qos())
    per = CALLS // processes
    procs = [subprocess.Popen([sys.executable, __file__, "--client", str(count // processes), str(per)],
                              stdout=subprocess.PIPE, text=True, preexec_fn=lambda: _child(nice))
             for _ in range(processes)]
    ready = [p.stdout.readline().split()[-1] for p in procs]  # type: ignore[union-attr]
    time.sleep(3.0)  # the requests are all in
    lates: list[float] = []
    running = [True]

    def tick() -> None:
        while running[0]:
            t = time.monotonic()
            time.sleep(0.001)
            lates.append(time.monotonic() - t - 0.001)
    ticker = threading.Thread(target=tick)
    ticker.start()
    costs: list[float] = []
    end = time.monotonic() + 120.0
    while len(costs) < per * processes and time.monotonic() < end:
        with srv.handle:
            got = srv.handle.service_take_request(Trigger.Request)  # the executor's own take, by hand
        if got is None or got[1] is None:
            time.sleep(0.001)
            continue
        t = time.perf_counter()
        srv.send_response(Trigger.Response(), got[1])
        costs.append(time.perf_counter() - t)
    running[0] = False
    ticker.join()
    answered = [p.stdout.readline().split()[-1] for p in procs]  # type: ignore[union-attr]
    for p in procs:
        p.wait(30)
    costs.sort()
    lates.sort()
    print(f"{count} clients in {processes} process(es), nice {nice} (found {'+'.join(ready)}): send_response "
          f"median {1e3 * costs[len(costs) // 2]:.2f} ms, longest {1e3 * costs[-1]:.1f} ms, sum {sum(costs):.2f} s "
          f"for {len(costs)}; ticker late longest {1e3 * lates[-1]:.1f} ms, p99 {1e3 * lates[int(0.99 * len(lates))]:.1f} "
          f"ms; answered {'+'.join(answered)}", flush=True)
    rclpy.shutdown()


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] == "--client":
        clients(int(sys.argv[2]), int(sys.argv[3]))
        return 0
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clients", type=int, default=1000)
    ap.add_argument("--processes", type=int, default=4)
    ap.add_argument("--nice", type=int, default=0, help="nice value of the client processes")
    args = ap.parse_args()
    server(args.clients, args.processes, args.nice)
    return 0


if __name__ == "__main__":
    sys.exit(main())
