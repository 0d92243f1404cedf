"""Which shortcuts the command side takes: one frozen settings value given to the ``Commander``.

Every shortcut gives the same writes and warnings as the plain path it skips (tests compare the
two); turning one off is for those comparisons and for measuring what it saves.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CommandPaths:
    """The command side's fast paths, all on by default."""

    #: goal positions the servo table shows within their bounds are checked all at once
    #: (``goal_bounds.TableBounds``); False: each servo's bounds one by one
    bounds: bool = True
    #: an ID list every ID of which is handled, once, and of the family is checked once per servo
    #: table version and its goals converted at once (``fast_path.FastGoals``); False: every
    #: command is checked servo by servo
    targets: bool = True
    #: commands for at most this many servos are converted in plain Python, more through numpy
    small: int = 32
    #: the parts of a command bundle (commands/x, ...) with an empty id_list are skipped (they do
    #: nothing); False: each goes through its handler
    skip_empty: bool = True
