"""The servo side of a move: checks on the loop thread, goals through the Commander, positions as
last read. ROS-free; ``moves.Book`` is one. Every method runs on the loop thread."""
from __future__ import annotations

import math
from typing import Sequence

from .. import units
from ..control_table import KEPT_POSITION_MODES, ServoFamily
from ..core.api import ServoAccess
from ..joints import JointMap, LiveJoints
from .commander import Commander
from .move_checks import Move, MoveError, listed


class MoveIO:
    def __init__(self, handler: ServoAccess, commander: Commander, joints: JointMap | LiveJoints | None) -> None:
        self.h = handler
        self.commander = commander
        #: the joints (None: none configured), calibrated on the loop thread (``calibration``)
        self.joints = None if joints is None else LiveJoints.of(joints)

    @property
    def mapping(self) -> JointMap | None:
        return None if self.joints is None else self.joints.map

    def _command(self, ids: list[int], servo_deg: list[float], velocity: float) -> None:
        """Queue the goals per mode and series (the Commander writes them this step)."""
        table = self.h.table
        batches: dict[tuple[str, ServoFamily], tuple[list[int], list[float]]] = {}
        for i, deg in zip(ids, servo_deg):
            series = table.model(i).family
            kind = "goal" if self.h.mode(i) in KEPT_POSITION_MODES else "position_control"
            batch = batches.setdefault((kind, series), ([], []))
            batch[0].append(i)
            batch[1].append(deg)
        for (kind, series), (batch_ids, degs) in batches.items():
            fields: dict[str, list] = {"position_deg": degs}
            if velocity > 0:
                speed_field = series.behaviour.speed_field if kind == "position_control" else "profile_vel_deg_s"
                fields[speed_field] = [velocity] * len(batch_ids)
            if kind == "goal":
                self.commander.goal(batch_ids, fields, what="move")
            else:
                self.commander.control(series, "position_control", batch_ids, fields)

    def _refuse_unready(self, ids: list[int]) -> None:
        """MoveError for servos that are not handled, do not answer or have no torque."""
        missing = [i for i in ids if i not in self.h.table]
        if missing:
            raise MoveError(f"IDs [{listed(missing)}] are not handled")
        table = self.h.table
        silent = [i for i in ids if not table.ping[table.index[i]]]
        if silent:
            raise MoveError(f"IDs [{listed(silent)}] do not answer")
        off = [i for i in ids if not (table.value("torque_enable", i) or self.h.read_item(i, "torque_enable"))]
        if off:
            raise MoveError(f"torque is off on IDs [{listed(off)}]: enable it first (set_torque)")

    def _goals(self, ids: list[int]) -> list[float]:
        """Goals the servos go to: written ones, or those still waiting for this step's write."""
        table = self.h.table
        goal = table.units("goal_position")
        pending = self.h.pending.peek("goal_position")
        out = []
        for i in ids:
            if i not in table:
                out.append(math.nan)
            elif i in pending:
                out.append(float(units.pulse_to_unit([table.model(i)], "goal_position", [pending[i]])[0]))
            else:
                out.append(float(goal[table.index[i]]))
        return out

    def probe(self, ids: list[int]) -> tuple[list[float], list[bool]]:
        """Present positions [servo deg] and pings of ``ids``, as last read."""
        table = self.h.table
        present = table.units("present_position")
        pos = [table.index.get(i) for i in ids]
        return ([float(present[p]) if p is not None else math.nan for p in pos],
                [bool(table.ping[p]) if p is not None else False for p in pos])

    def hold(self, ids: list[int], present: list[float]) -> None:
        """Stop where the servos are: goal := present position (through the Commander)."""
        keep = [(i, p) for i, p in zip(ids, present) if math.isfinite(p)]
        if keep:
            self.commander.goal([i for i, _ in keep], {"position_deg": [p for _, p in keep]}, what="move cancelled")

    def in_request_frame(self, move: Move, servo_deg: Sequence[float]) -> list[float]:
        mapping = self.mapping
        return [mapping.to_joint_deg(name, d) if name is not None and mapping is not None else d
                for (_, name), d in zip(move.targets, servo_deg)]
