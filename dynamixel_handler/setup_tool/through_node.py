"""The set-up tool on a port a running handler holds: the verbs that can go through the node do
(``node_verbs.py``: ``get``, ``set``, ``info``, ``backup``; ``node_monitor.py``: ``monitor``;
``node_mode.py``: ``set-mode``; ``node_reboot.py``: ``reboot``; ``node_restore.py``: ``restore``),
the others are refused with what to do.

The node is found from the device with no flag: the port's lock names the pid that holds it
(``bus/lock_holder.py``), the owner record the node keeps beside it names the node, its namespace
and its ROS domain (``bus/owner_record.py``). ``--direct`` skips this: the port is opened as on a
bus without a handler (and refused while one holds it). rclpy is imported only when a verb goes
through the node."""
from __future__ import annotations

import argparse
import os

from ..bus.lock_holder import lock_holder, locks_readable
from ..bus.owner_record import Owner, find_owner
from ..errors import StartupError
from ..serial_ports import resolve
from .errors import StepFailed
from .output import Output

__all__ = ["THROUGH", "BUS_CHANGING", "owner_of", "run"]

#: the verbs that go through the node
THROUGH = ("get", "set", "info", "backup", "monitor", "set-mode", "reboot", "restore")
#: the verbs that change the bus under the node (IDs, baud rates, the servos it handles)
BUS_CHANGING = ("scan", "set-id", "set-baud", "assign-ids", "factory-reset")


def owner_of(device: str) -> Owner | None:
    """The running handler node that holds ``device`` (None: none does, or another program does)."""
    try:
        path, _ = resolve(device)
    except StartupError:
        return None
    owner = find_owner(path)
    if owner is None or not os.path.exists(path):
        return owner  # the device gone (unplugged): the node still owns it and reconnects to it
    holder = lock_holder(path)
    if holder is None:
        # nobody holds the device: the node lost it (and this path may be another device now, as a
        # tty number is given again); it is not the node's until the node opens it again
        return owner if not locks_readable() else None
    return owner if holder[0] == owner.pid else None


def _refusal(owner: Owner, device: str, verb: str) -> str:
    held = f"{device} is held by the running node {owner.node} (pid {owner.pid})"
    stop = f"stop the node first (Ctrl-C where it runs, or kill {owner.pid}), then run {verb} again"
    if verb in BUS_CHANGING:
        return (f"{held}: {verb} changes the bus under it (IDs, baud rates, the servos it handles): refused; {stop} "
                "(--direct cannot open the port while the node holds it)")
    return (f"{held}: {verb} does not go through the node yet ({', '.join(THROUGH)} do): refused; {stop} (with the "
            "node stopped the tool opens the port itself, as --direct does)")


def run(owner: Owner, device: str, out: Output, args: argparse.Namespace) -> None:
    """``args``'s verb through ``owner``; StepFailed (exit 1) for a verb that cannot go through it."""
    if args.verb_name not in THROUGH:
        raise StepFailed(_refusal(owner, device, args.verb_name))
    from . import node_client, node_mode, node_monitor, node_reboot, node_restore, node_verbs  # rclpy

    out.say(f"through the running node {owner.node} (pid {owner.pid}, ROS_DOMAIN_ID {owner.domain_id}), which holds "
            f"{device}")
    out.document["through_node"] = owner.node
    client = node_client.NodeClient(owner)
    try:
        ctx = node_verbs.NodeContext(client, out, args.yes, device, torque_off=args.torque_off, force=args.force,
                                     raw=args.raw)
        verbs = {**node_verbs.VERBS, "monitor": node_monitor.monitor_verb, "set-mode": node_mode.set_mode_verb,
                 "reboot": node_reboot.reboot_verb, "restore": node_restore.restore_verb}
        verbs[args.verb_name](ctx, args)
    finally:
        client.close()
