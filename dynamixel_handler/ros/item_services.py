"""``dynamixel/get_items`` and ``dynamixel/set_items`` (GetItems, SetItems): any control-table item of
the handled servos read or written through the running node, by the set-up tool's item names and
with its checks (``commands/items_job.py``: a job of the loop, a few transactions a step, so the
loop keeps its rate). A request is checked for its shape at once (IDs or joint names, items named,
one value per item or per servo and item) and refused with one line, limited to one a second per
cause; the answer has one entry per servo and item, each with its value in its unit and raw, or
why it was not read or written.

``dynamixel/reboot_servos`` (RebootServos): the servos named rebooted by the loop, one a step
(``commands/reboot_job.py``), a servo holding torque only with ``torque_off`` (its torque back on
with goal := present after), every servo checked before the first reboot."""
from __future__ import annotations

import time

from dynamixel_handler_msgs.srv import GetItems, RebootServos, SetItems

from ..commands.items_job import ItemsJob, Writes
from ..commands.move_checks import DONE
from ..commands.moves import LOOP_TIMEOUT_S, MoveError
from ..commands.reboot_job import RebootServosJob
from ..logs import cut
from .services import QOS, MotionServices

#: the most servo-item pairs one request may name
MAX_PAIRS = 2000
#: time allowed per servo-item pair beyond the loop's usual answer time [s]
PER_PAIR_S = 0.05
#: time allowed per servo rebooted (the core waits up to 1 s for it to answer, then sets it up) [s]
PER_REBOOT_S = 2.0


class ItemServices:
    def __init__(self, node, motion: MotionServices) -> None:
        self.node = node
        self.motion = motion
        node.create_service(GetItems, "dynamixel/get_items", self._on_get, qos_profile=QOS,
                            callback_group=motion.group)
        node.create_service(SetItems, "dynamixel/set_items", self._on_set, qos_profile=QOS,
                            callback_group=motion.group)
        node.create_service(RebootServos, "dynamixel/reboot_servos", self._on_reboot, qos_profile=QOS,
                            callback_group=motion.group)

    def _job(self, req, writes: Writes | None) -> ItemsJob:
        """The job of a request; MoveError (answered at once) when it cannot be right."""
        targets = self.motion.targets(req.ids, req.joint_names, moves=False, positions=False)
        ids = list(dict.fromkeys(i for i, _ in targets))
        items = [str(n) for n in req.items]
        if not items:
            raise MoveError("no item named")
        if len(ids) * len(items) > MAX_PAIRS:
            raise MoveError(f"{len(ids)} servos x {len(items)} items: at most {MAX_PAIRS} in one request")
        twice = sorted({n for n in items if items.count(n) > 1})
        if twice:
            raise MoveError(f"item {cut(twice[0])} named twice")
        if writes is not None and len(writes.values) not in (len(items), len(ids) * len(items)):
            raise MoveError(f"{len(writes.values)} values for {len(items)} items of {len(ids)} servos: one per item, "
                            "or one per servo and item")
        return ItemsJob(ids, items, writes, time.monotonic() + LOOP_TIMEOUT_S + PER_PAIR_S * len(ids) * len(items))

    async def _on_get(self, req: GetItems.Request, res: GetItems.Response) -> GetItems.Response:
        try:
            job = self._job(req, None)
            await self.motion.settle(job)
            res.success, res.message = job.outcome == DONE, job.message
            self._fill(res, job)
            res.units = [r.unit for r in job.results]
        except MoveError as err:
            res.success, res.message = False, f"refused: {err}"
        if not res.success:
            self.motion.warn(f"get_items: {res.message}")
        return res

    async def _on_set(self, req: SetItems.Request, res: SetItems.Response) -> SetItems.Response:
        try:
            writes = Writes(tuple(float(v) for v in req.values), bool(req.raw), bool(req.force), bool(req.torque_off))
            job = self._job(req, writes)
            await self.motion.settle(job)
            res.success, res.message = job.outcome == DONE, job.message
            self._fill(res, job)
        except MoveError as err:
            res.success, res.message = False, f"refused: {err}"
        (self.node.get_logger().info if res.success else self.motion.warn)(f"set_items: {res.message}")
        return res

    async def _on_reboot(self, req: RebootServos.Request, res: RebootServos.Response) -> RebootServos.Response:
        try:
            targets = self.motion.targets(req.ids, req.joint_names, moves=False, positions=False)
            ids = list(dict.fromkeys(i for i, _ in targets))
            job = RebootServosJob(ids, bool(req.torque_off), time.monotonic() + LOOP_TIMEOUT_S + PER_REBOOT_S * len(ids))
            await self.motion.settle(job)
            res.success, res.message = job.outcome == DONE, job.message
            res.id_list = [r.dxl_id for r in job.results]
            res.torque_on = [r.torque_on for r in job.results]
            res.errors = [r.error for r in job.results]
        except MoveError as err:
            res.success, res.message = False, f"refused: {err}"
        (self.node.get_logger().info if res.success else self.motion.warn)(f"reboot_servos: {res.message}")
        return res

    @staticmethod
    def _fill(res, job: ItemsJob) -> None:
        res.id_list = [r.dxl_id for r in job.results]
        res.item_list = [r.item for r in job.results]
        res.values = [r.value for r in job.results]
        res.raw = [r.raw if r.raw is not None else 0 for r in job.results]
        res.errors = [r.error for r in job.results]


def attach(node, motion: MotionServices) -> ItemServices:
    return ItemServices(node, motion)
