"""The command side, ROS-free: commands in physical units -> checked requests to the core through
``core.api.ServoAccess``.

``commander.Commander`` (goals and control topics; ``servo_settings``: status, gains, limits,
shortcuts; ``extra``: the DynamixelExtra fields) checks every command by the ``rules`` (known IDs,
finite values, bounds and clamping, each in one place); ``fast_path.FastGoals`` applies the same
rules to many servos at once; ``goal_bounds`` is the table maths both use; ``tables`` says what
the message fields mean; ``paths.CommandPaths`` switches the fast paths. ``joint_goals`` (joint
commands by name in SI units), ``trajectory`` (points, interpolation, the follower) and the moves of
the services and the MoveJoints action (``move_checks``: a request checked at arrival; ``moves``:
the jobs the loop thread advances; ``move_io``: a move's goals and positions) speak through the
``Commander`` and ``ServoAccess`` only.
"""
from .commander import Commander, take_fields
from .paths import CommandPaths

__all__ = ["CommandPaths", "Commander", "take_fields"]
