"""The operating modes as the handler groups them (names of ``OPERATING_MODES``)."""
from __future__ import annotations

#: the modes in which a goal position stays within the position limits (the others are multi-turn)
POSITION_LIMITED_MODES = ("position",)
#: modes whose goal is a position: the speed of the move is a goal field of its own there
POSITION_MODES = ("position", "ex_position")
#: modes whose goal is a position that a move keeps (multi-turn); others switch to position mode
KEPT_POSITION_MODES = ("ex_position", "cur_position")
