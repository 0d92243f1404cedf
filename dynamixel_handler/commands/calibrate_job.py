"""``dynamixel/calibrate_offsets``: joint offsets set from an external measurement.

A job of the ``moves.Book``, carried out by the loop thread after a step, so that the positions it
starts from are those the loop read last and the joint map is replaced between two steps: every
joint door (``joint_states``, ``joint_commands``, trajectories, ``move_to``) speaks the new offsets
from the next step on. It writes nothing to a servo, so an engaged E-stop does not end it; it is
refused while a trajectory runs on a named joint (its remaining points would be read with the new
offsets: the servos would jump)."""
from __future__ import annotations

from ..joints import JointMap, LiveJoints
from ..joints.calibration import Calibration, described
from .move_checks import DONE, ERROR
from .moves import Book, Job
from .trajectory import Follower

__all__ = ["CalibrateJob"]


class CalibrateJob(Job):
    moves = False

    def __init__(self, request: Calibration, joints: LiveJoints, follower: Follower | None, answer_by: float) -> None:
        super().__init__("calibrate_offsets", [], answer_by)
        self.request = request
        self.joints = joints
        self.follower = follower
        #: the joint map after the calibration (the one to save), None until done
        self.calibrated: JointMap | None = None

    def advance(self, book: Book, now: float) -> None:
        if not book.claim(self):
            return
        names = self.request.names
        active = self.follower.active if self.follower is not None else None
        running = [n for n in names if active is not None and n in active.names]
        if running:
            book.finish(self, ERROR, f"refused: a trajectory runs on {', '.join(running)}: calibrate when it has ended "
                        "(its remaining points would be read with the new offsets)")
            return
        before = self.joints.map
        zeros, why = self.request.zeros(before, book.h.table)
        if why:
            book.finish(self, ERROR, f"refused: {why}: no offset changed")
            return
        after = self.calibrated = self.joints.calibrate(zeros)
        book.finish(self, DONE, described(before, after, names), [after.joint(n).zero for n in names])
