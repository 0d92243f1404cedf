"""Joint goals by name in SI units -> the Commander's checked writes. ROS-free.

``joint_commands`` (sensor_msgs/JointState, as ros2_control's topic-based hardware interface
publishes) and the trajectory follower name joints, give radians, rad/s and amperes, and leave a
field empty when they do not command it. What a joint is given picks its servo's mode:

======================  ==============================================================
given                   the servo
======================  ==============================================================
position                position control (a servo in extended or current-based position
                        mode keeps its mode: the goal is a position there too)
position + effort       current-based position control (X series): effort = current limit
velocity                velocity control
effort                  current control
======================  ==============================================================

(a velocity given with a position is not a goal of its own: the position governs.) The servo
angle follows the joint's map (``joints.Joint``: ``joint_state.*`` or the ``joints`` block, with
its reduction, offset, direction, or a prismatic joint's stroke in metres); a position beyond the
joint's soft limits is clamped (one line a second per joint), a velocity or effort beyond its
limit is cut to it. Everything
then goes through ``Commander.control`` / ``Commander.goal``: known IDs, series and modes, NaN
refused, limits clamped, mode changes rate-limited, one warning line per cause.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar, Sequence, assert_never, cast, get_args

import numpy as np

from .. import units
from ..control_table import KEPT_POSITION_MODES, ServoFamily
from ..joints import DEG, Coupling, Joint, JointMap, LiveJoints, effort_per_amp, settled, spread
from .command_types import HoldJoints, JointCommand, JointRequest
from .commander import Commander
from .coupled_goals import Given, coupled_goals
from .goal_bounds import goal_position_limits

if TYPE_CHECKING:
    from ..core.api import ServoAccess

#: (series, control, fields) -> (servo IDs, field -> one value per ID): the Commander calls of one command
_Batches = dict[tuple[ServoFamily | None, str, tuple[str, ...]], tuple[list[int], dict[str, list[float]]]]


class JointGoals:
    """Joint commands by name for one handler (``command`` from any thread; work in the loop)."""

    def __init__(self, commander: Commander, joints: JointMap | LiveJoints) -> None:
        self.commander = commander
        self.h = commander.h
        self.joints = LiveJoints.of(joints)  # calibrated on the loop thread (``calibration``)
        #: joints of several servos whose servos disagree now (held when it began)
        self.held: set[str] = set()
        self._paired = [j.name for j in self.mapping.joints if j.partners and j.coupling is None]

    @property
    def mapping(self) -> JointMap:
        return self.joints.map

    TAKES: ClassVar[tuple[type, ...]] = get_args(JointRequest)

    def handle(self, request: JointRequest) -> None:
        """A queued joint command or hold, in the loop thread."""
        match request:
            case JointCommand():
                self._apply(request)
            case HoldJoints():
                self._hold(request)
            case _:
                assert_never(request)

    def check(self, what: str, names: Sequence[str], position: Sequence[float], velocity: Sequence[float],
              effort: Sequence[float]) -> str | None:
        """Why a command cannot be taken (one line, for the log), or None. A field is given for
        every name or empty; names are mapped joints, each named once."""
        if not len(names):
            return f"{what}: no joint names: refused"
        for field, values in (("position", position), ("velocity", velocity), ("effort", effort)):
            if len(values) and len(values) != len(names):
                return f"{what}: {len(values)} {field} values for {len(names)} joint names: refused"
        if not (len(position) or len(velocity) or len(effort)):
            return f"{what}: no position, velocity or effort given: nothing to do"
        return self._names_problem(what, names)

    def _names_problem(self, what: str, names: Sequence[str]) -> str | None:
        """Why the names cannot be taken: unknown joints or a joint named twice; None when they can."""
        unknown = [n for n in names if n not in self.mapping.names]
        if unknown:
            shown = ", ".join(repr(n[:40]) for n in unknown[:5]) + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else "")
            return f"{what}: unknown joint names {shown} (known: {', '.join(self.mapping.names)}): refused"
        if len(set(names)) != len(names):
            return f"{what}: a joint is named twice in {list(names)[:10]}: refused"
        return None

    def command(self, what: str, names: Sequence[str], position: Sequence[float] = (), velocity: Sequence[float] = (),
                effort: Sequence[float] = (), checked: bool = False) -> bool:
        """Queue the command for the loop thread; False (and one warning) when it is refused whole.
        ``checked``: the caller had ``check`` pass already."""
        problem = None if checked else self.check(what, names, position, velocity, effort)
        if problem is not None:
            self.commander.warn(problem)
            return False
        names, position, velocity, effort = list(names), list(position), list(velocity), list(effort)
        self.h.submit(JointCommand(names, position, velocity, effort, what))
        return True

    def _apply(self, request: JointCommand) -> None:
        """Loop thread: joint units -> servo units, grouped by series and control, to the Commander."""
        what, names, position, velocity, effort = (request.what, request.names, request.position, request.velocity,
                                                   request.effort)
        table = self.h.table
        m = self.mapping
        batches: _Batches = {}
        coupled: dict[Coupling, dict[str, Given]] = {}
        unhandled = []
        for k, name in enumerate(names):
            joint = m.joint(name)
            if any(i not in table for i in joint.servo_ids):
                unhandled.append(name)
                continue
            given = (self._within(what, joint, position[k]) if position else None, velocity[k] if velocity else None,
                     effort[k] if effort else None)
            if joint.coupling is not None:  # solved with the other joints of its set, below
                coupled.setdefault(joint.coupling, {})[name] = given
                continue
            self._one_joint(what, joint, given, batches)
        for coupling, of_set in coupled.items():
            for control, dxl_id, fields in coupled_goals(self.h, self.mapping, self.commander.warn, what, coupling, of_set):
                self._batch(batches, control, dxl_id, fields)
        if unhandled:
            self.commander.warn(f"{what}: joints {unhandled} map to servos that are not handled: ignored")
        self._send(what, batches)

    def _profile_cap(self, joint: Joint, dxl_id: int, scale: float) -> dict[str, float]:
        """A position goal's servo at most as fast as the joint's velocity limit: its profile
        velocity lowered to the limit where it is none (0) or faster; nothing otherwise."""
        if not math.isfinite(joint.velocity_limit):
            return {}
        cap = joint.velocity_limit / abs(scale)  # servo deg/s
        table = self.h.table
        profile = table.units("profile_velocity")[table.index[dxl_id]]
        step = float(units.pulse_to_unit([table.model(dxl_id)], "profile_velocity", [1])[0])  # the written value's rounding
        faster = not math.isfinite(profile) or profile == 0 or profile > cap + step
        return {"profile_vel_deg_s": cap} if faster else {}

    def _batch(self, batches: _Batches, control: str, dxl_id: int, fields: dict[str, float]) -> None:
        series = self.h.table.model(dxl_id).family if control != "goal" else None
        ids, cols = batches.setdefault((series, control, tuple(sorted(fields))), ([], {}))  # the same fields each
        ids.append(dxl_id)
        for f, v in fields.items():
            cols.setdefault(f, []).append(v)

    def _within(self, what: str, joint: Joint, position: float) -> float:
        """A position goal inside the joint's soft limits (clamped, one line a second per joint)."""
        clamped = joint.clamped(float(position))
        if clamped != position and math.isfinite(position):
            lo, hi = joint.position_limits
            self.commander.warn(f"{what}: joint {joint.name} goal beyond its limits [{lo:g}, {hi:g}] "
                                f"(joints.{joint.name}.limits.position): clamped")
        return clamped

    def _one_joint(self, what: str, joint: Joint, given: Given, batches: _Batches) -> None:
        """The goals of a joint of one servo, or of several (each in the same write)."""
        pos, vel, eff = given
        amps: list[float | None] = [None] * len(joint.servos)
        if eff is not None:
            per_servo = self._amps(what, joint, eff)
            if per_servo is None and pos is None and vel is None:
                return
            amps = list(per_servo) if per_servo is not None else amps
        for (dxl_id, scale), amp in zip(joint.servos, amps):
            control, fields = self._servo_goal(joint, dxl_id, scale, pos, vel, amp)
            self._batch(batches, control, dxl_id, fields)

    def _amps(self, what: str, joint: Joint, eff: float) -> list[float] | None:
        """The current [A] of each of ``joint``'s servos for its effort (within its limit, shared by
        its servos; in N·m through each model's torque per ampere); None, with one line, where a
        servo's model has no torque figures."""
        share = math.copysign(min(abs(float(eff)), joint.effort_limit), float(eff)) / len(joint.servos)
        per_amp = [effort_per_amp(self.mapping, scale, self.h.model(i)) for i, scale in joint.servos]
        if not all(math.isfinite(k) for k in per_amp):
            models = sorted({self.h.model(i).name for (i, _), k in zip(joint.servos, per_amp) if not math.isfinite(k)})
            self.commander.warn(f"{what}: joint {joint.name}: an effort in N·m needs the torque per ampere of "
                                f"{', '.join(models)}, which is not known: its effort is ignored")
            return None
        return [share / k for k in per_amp]

    def _servo_goal(self, joint: Joint, dxl_id: int, scale: float, pos: float | None, vel: float | None,
                    amps: float | None) -> tuple[str, dict[str, float]]:
        """The control of one of ``joint``'s servos (``dxl_id``, its ``scale``) and its fields in
        servo units, from the joint's position, velocity and the servo's current for its effort
        (``_amps``; None: not given) as the table of the module says; a velocity within the
        joint's limit."""
        if pos is not None:
            fields = {"position_deg": (float(pos) - joint.zero) / scale, **self._profile_cap(joint, dxl_id, scale)}
            if amps is not None:
                fields["current_ma"] = abs(amps) * 1000.0
                return "current_base_position_control", fields
            if self.h.mode(dxl_id) in KEPT_POSITION_MODES:
                return "goal", fields
            return "position_control", fields
        if vel is not None:
            vel = max(-joint.velocity_limit, min(joint.velocity_limit, float(vel)))
            return "velocity_control", {"velocity_deg_s": float(vel) / scale}
        # check() takes no command without a field, so effort is given here
        return "current_control", {"current_ma": float(cast(float, amps)) * 1000.0}

    def _send(self, what: str, batches: _Batches) -> None:
        """One Commander call per (series, control, fields): goals of kept modes as plain goals (the
        goals of one command reach the same sync writes: pending goals merge per item)."""
        for (series, control, _), (ids, cols) in batches.items():
            if series is None:
                self.commander.goal(ids, cols, what=what)
            else:
                self.commander.control(series, control, ids, cols)

    def watch_pairs(self) -> None:
        """Loop thread, after a read of the present positions: a joint of several servos whose
        servos are further apart than its ``disagreement`` is held where each servo is when that
        begins (a trajectory of it ends: ``trajectory.Follower``) and said once a second while it
        lasts; a later command of the joint is taken (it gives every servo the same goal). One
        line when they agree again, each at its goal (servos that meet half-way on their way from
        apart have not settled)."""
        table = self.h.table
        for joint in map(self.mapping.joint, self._paired):
            if any(i not in table for i in joint.servo_ids):
                continue
            apart = spread(joint, table)
            if apart > joint.disagreement:
                self.commander.warn(f"joint {joint.name}: servos {list(joint.servo_ids)} disagree by {apart / DEG:.2f} deg "
                                    f"(more than joints.{joint.name}.disagreement_deg {joint.disagreement / DEG:g}): "
                                    "held where each was")
                if joint.name not in self.held:
                    self.held.add(joint.name)
                    self._hold(HoldJoints(list(joint.servo_ids), f"joint {joint.name} held"))
            elif joint.name in self.held and settled(joint, table):  # not while they pass each other
                self.held.discard(joint.name)
                self.h.log.info(f"joint {joint.name}: servos {list(joint.servo_ids)} agree again")

    def hold(self, what: str, names: Sequence[str]) -> None:
        """Stop the joints where they are: goal position := present position (loop thread next step)."""
        self.h.submit(HoldJoints([i for n in names for i in self.mapping.joint(n).servo_ids], what))

    def _hold(self, request: HoldJoints) -> None:
        table = self.h.table
        present = table.units("present_position")
        keep = [(i, float(present[table.index[i]])) for i in request.ids
                if i in table and math.isfinite(present[table.index[i]])]
        if keep:
            self.commander.goal([i for i, _ in keep], {"position_deg": [p for _, p in keep]}, what=request.what)

    def present(self, names: Sequence[str]) -> tuple[list[float], list[float]]:
        """Joint positions [rad] and velocities [rad/s] as last read (NaN: not handled or not read).
        Loop thread, or any thread that accepts values of one read or the next."""
        table = self.h.table
        pos_deg, vel_deg = table.units("present_position"), table.units("present_velocity")
        pos, vel = [], []
        for name in names:
            joint = self.mapping.joint(name)
            rows = [(table.index.get(i), scale) for i, scale in joint.servos]
            if any(p is None for p, _ in rows):
                pos.append(math.nan)
                vel.append(math.nan)
                continue
            share = 1.0 if joint.coupling is not None else 1.0 / len(rows)  # a row's sum, or the pair's mean
            pos.append(joint.zero + share * sum(scale * float(pos_deg[p]) for p, scale in rows))
            vel.append(share * sum(scale * float(vel_deg[p]) for p, scale in rows))
        return pos, vel

    def position_bounds(self, names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """The joint positions a position command may reach, per joint (lowest, highest): the
        goal position bounds of its servo in the mode a position command leaves it in (its position
        limits in position mode; the multi-turn range in extended and current-based position mode),
        half a pulse wider each way. From the servo table as last read (no bus access: any thread);
        a joint whose servo is not handled gets (-inf, inf)."""
        lo, hi = np.full(len(names), -math.inf), np.full(len(names), math.inf)
        table = self.h.table
        for k, name in enumerate(names):
            joint = self.mapping.joint(name)
            if joint.coupling is not None:
                continue  # a coupled set's servo bounds are no box in joint space: its soft limits only
            for dxl_id, scale in joint.servos:  # a joint of several servos: within every one's bounds
                if dxl_id not in table:
                    continue
                model = table.model(dxl_id)
                mode = model.mode_name(table.value("operating_mode", dxl_id))
                view = _TableView(table, mode if mode in KEPT_POSITION_MODES else "position")
                pulses = goal_position_limits(cast("ServoAccess", view), dxl_id, model)
                deg = units.pulse_to_unit([model, model], "goal_position", list(pulses))
                half = 0.5 * model.position_deg_per_pulse
                ends = sorted(joint.zero + scale * float(d) for d in (deg[0] - half, deg[1] + half))
                lo[k], hi[k] = max(lo[k], ends[0]), min(hi[k], ends[1])
        return lo, hi


class _TableView:
    """What ``goal_position_limits`` asks of a handler, from the servo table only (no bus reads),
    with the servo in ``mode``."""

    def __init__(self, table, mode: str) -> None:
        self.table = table
        self._mode = mode

    def mode(self, dxl_id: int) -> str:
        return self._mode

    def value(self, dxl_id: int, item: str) -> int | None:
        return cast("int | None", self.table.value(item, dxl_id))
