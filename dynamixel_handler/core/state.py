"""The record of one loop step, and how often a silent servo is pinged."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

#: a servo that stopped answering is pinged every RECHECK_LOOPS loops, or every RECHECK_S at loop
#: rates under RECHECK_LOOPS / RECHECK_S (a glitch at 2 Hz then costs one loop's read, not ten)
RECHECK_LOOPS = 10
RECHECK_S = 0.1


def recheck_loops(loop_rate: float) -> int:
    """Loops between pings of a servo that stopped answering at ``loop_rate`` [Hz]."""
    return max(1, min(RECHECK_LOOPS, round(RECHECK_S * loop_rate)))


@dataclass
class StepReport:
    loop: int
    stamp: float = 0.0                       # wall-clock time of the reads (time.time())
    groups: set[str] = field(default_factory=set)        # groups read: status, goal, gain, ...
    present: set[str] = field(default_factory=set)       # present keys read: pwm, current, ...
    read_s: float = 0.0
    # the step's work between its phases (Handler.begin_step ... Handler.finish_step)
    reads: list[list[Any]] = field(default_factory=list, repr=False)  # [read_plan.Read, GroupRead, data or None]
    recheck: list[int] = field(default_factory=list, repr=False)  # silent IDs pinged after the reads
    silent: list[int] = field(default_factory=list, repr=False)   # IDs addressed that did not answer
    seq: int = 0                                                  # ServoTable.seq when the reads went out
    phase: int = 0                                                # 1 begun, 2 sent, 3 complete, 4 finished
