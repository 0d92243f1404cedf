"""pub_ratio: each group is read (on the wire) and published every `ratio` loops, 0 = at start only;
pub_outdated_present_value decides whether present items not read this loop are published."""
from __future__ import annotations

import math
import re
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support.rig import BASE_PARAMS, FOUR_SERVOS, Rig

# present position every loop: one sync read of it (and one /dynamixel/states) per loop, the loop clock
PRESENT_RATIOS = {"position": 1, "velocity": 2, "current": 3, "pwm": 0, "velocity_trajectory": 0,
                  "position_trajectory": 0, "input_voltage": 5, "temperature": 7}
GROUP_RATIOS = {"status": 4, "goal": 3, "gain": 0, "limit": 6, "error": 5, "extra.dynamic_items": 7,
                "extra.static_items": 0}
# XM430-W350 addresses (e-Manual) of an item each ratio governs, read by itself (method/split_read)
PRESENT_ADDRESS = {"position": 132, "velocity": 128, "current": 126, "pwm": 124, "velocity_trajectory": 136,
                   "position_trajectory": 140, "input_voltage": 144, "temperature": 146}
GROUP_ADDRESS = {"status": 11, "goal": 116, "gain": 84, "limit": 31, "extra.dynamic_items": 65,
                 "extra.static_items": 0}
HARDWARE_ERROR_STATUS = 70  # read for status and for error
PRESENT_FIELDS = {"pwm": "pwm_percent", "current": "current_ma", "velocity": "velocity_deg_s",
                  "position": "position_deg", "velocity_trajectory": "vel_trajectory_deg_s",
                  "position_trajectory": "pos_trajectory_deg", "input_voltage": "input_voltage_v",
                  "temperature": "temperature_degc"}
WARM_UP = 10  # /dynamixel/states messages skipped: loop 0 (where every group is due) is not counted


def near(reads: int, expected: int) -> bool:
    """``reads`` is ``expected``, or one off: on a loaded host a loop whose present-position read got
    no reply in time is re-read or recovered (a ping), so the loop count taken from the position reads
    can be one off the loops that ran; a wrong ratio is many reads off."""
    return abs(reads - expected) <= 1


def due_loops(loops: int, *ratios: int) -> int:
    """Loops among 0..loops-1 where any of ``ratios`` is due (0 = loop 0 only)."""
    return sum(1 for k in range(loops) if any((k % r == 0) if r > 0 else k == 0 for r in ratios))


def ratio_params(outdated: bool) -> list[str]:
    return ([f"pub_ratio/present.{k}:={v}" for k, v in PRESENT_RATIOS.items()]
            + [f"pub_ratio/{k}:={v}" for k, v in GROUP_RATIOS.items()]
            + ["method/split_read:=true", f"pub_outdated_present_value:={'true' if outdated else 'false'}"])


def _drained(bench: Rig, quiet_s: float = 0.3, timeout: float = 10.0) -> dict[str, list]:
    """Every message of each topic once none has come for ``quiet_s`` (the node has stopped)."""
    end = time.monotonic() + timeout
    counts = None
    while time.monotonic() < end:
        now = {name: len(rec) for name, rec in bench.topics.items()}
        if now == counts:
            break
        counts = now
        time.sleep(quiet_s)
    return {name: rec.all() for name, rec in bench.topics.items()}


def run(outdated: bool, loops: int = 150) -> dict:
    """Run the node for about ``loops`` loops after warm-up, stop it, and return every message it
    published (all of them arrived: the test waits until none is still coming) and its reads."""
    # a 16 ms latency timer (the replies of the virtual bus come at once, so the loop keeps its pace): with
    # 1 ms a starved virtual bus on a loaded host misses the ~4 ms reply wait now and then
    bench = Rig(FOUR_SERVOS, *ratio_params(outdated), "latency_timer:=16", base=BASE_PARAMS, state_topics=True)
    try:
        start_count = len(bench.topics["states"])
        bench.wait(lambda: len(bench.topics["states"]) >= max(start_count, WARM_UP) + loops, timeout=30,
                   what=f"{loops} loops")
        # counted once the node has stopped and every message has arrived: a loaded test process takes
        # the topics' messages late and not in loop order, so a window by arrival time cuts each topic
        # at a different loop
        code = bench.stop_node()
        topics = _drained(bench)
        seen = {
            "code": code,
            "states": topics["states"][WARM_UP:],
            "topics": topics,
            "log_reads": {a: len(bench.sync_reads(a, 1)) for a in
                          set(PRESENT_ADDRESS.values()) | set(GROUP_ADDRESS.values()) | {HARDWARE_ERROR_STATUS}},
        }
    finally:
        bench.close()
    return seen


@pytest.fixture(scope="module")
def outdated_on():
    return run(outdated=True)


@pytest.fixture(scope="module")
def outdated_off():
    return run(outdated=False, loops=60)


def test_node_exits_0(outdated_on):
    assert outdated_on["code"] == 0


@pytest.mark.parametrize("key", list(PRESENT_RATIOS))
def test_each_present_item_is_read_on_the_wire_every_ratio_loops(outdated_on, key):
    loops = outdated_on["log_reads"][PRESENT_ADDRESS["position"]]
    assert loops > 100
    assert near(outdated_on["log_reads"][PRESENT_ADDRESS[key]], due_loops(loops, PRESENT_RATIOS[key]))


@pytest.mark.parametrize("group", list(GROUP_ADDRESS))
def test_each_group_is_read_on_the_wire_every_ratio_loops(outdated_on, group):
    loops = outdated_on["log_reads"][PRESENT_ADDRESS["position"]]
    assert near(outdated_on["log_reads"][GROUP_ADDRESS[group]], due_loops(loops, GROUP_RATIOS[group]))


def test_hardware_error_is_read_once_in_loops_where_status_or_error_is_due(outdated_on):
    loops = outdated_on["log_reads"][PRESENT_ADDRESS["position"]]
    want = due_loops(loops, GROUP_RATIOS["status"], GROUP_RATIOS["error"])
    assert near(outdated_on["log_reads"][HARDWARE_ERROR_STATUS], want)


def test_a_zero_ratio_means_one_read_at_start_only(outdated_on):
    reads = outdated_on["log_reads"]
    for address in (GROUP_ADDRESS["gain"], GROUP_ADDRESS["extra.static_items"], PRESENT_ADDRESS["pwm"],
                    PRESENT_ADDRESS["velocity_trajectory"], PRESENT_ADDRESS["position_trajectory"]):
        assert reads[address] == 1, f"address {address}"


STATES_GROUP_RATIO = {"status": [4], "goal": [3], "gain": [0], "limit": [6], "error": [5],
                      "extra": [7, 0]}


@pytest.mark.parametrize("group", list(STATES_GROUP_RATIO))
def test_dxl_states_carries_each_group_every_ratio_loops(outdated_on, group):
    states = outdated_on["states"]
    n = len(states)
    published = sum(1 for m in states if len(getattr(m, group).id_list))
    ratios = [r for r in STATES_GROUP_RATIO[group] if r > 0]
    want = sum(n / r for r in ratios)  # extra: only the dynamic ratio counts after loop 0
    assert abs(published - want) <= 1, f"{group}: {published} of {n} messages, want {want:.1f}"
    for m in states:
        if len(getattr(m, group).id_list):
            assert len(getattr(m, group).id_list) == 4


@pytest.mark.parametrize("group", list(STATES_GROUP_RATIO))
def test_state_topics_are_published_every_ratio_loops(outdated_on, group):
    # in the loops where /dynamixel/states carries the group (its ratio: the test above), and no other
    states = outdated_on["topics"]["states"]
    published = len(outdated_on["topics"][f"state/{group}"])
    carried = sum(1 for m in states if len(getattr(m, group).id_list))
    # a few off at most, all at the start: each state topic starts once the node has seen its
    # subscriber (checked every 0.1 s per topic: 10 loops), and /dynamixel/states messages published
    # before this test's reader matched the node's writer are not received (the loops the bus ran
    # against the states received); a group published in other loops is off by most of its messages
    lost = max(0, outdated_on["log_reads"][PRESENT_ADDRESS["position"]] - len(states))
    ratio = min(r for r in STATES_GROUP_RATIO[group] if r > 0) if any(STATES_GROUP_RATIO[group]) else 1
    skew = 1 + math.ceil(max(lost, 10) / ratio)
    assert abs(published - carried) <= skew, (
        f"/dynamixel/state/{group}: {published} messages, {carried} states carry it ({lost} states not received)")
    want = due_loops(len(states), *STATES_GROUP_RATIO[group])
    assert abs(published - want) <= 2, f"/dynamixel/state/{group}: {published} in {len(states)} loops, want {want}"


def test_present_and_debug_are_published_every_loop(outdated_on):
    n = len(outdated_on["topics"]["states"])
    assert all(len(m.present.id_list) == 4 for m in outdated_on["states"])
    # a few off at most: each topic starts once the node has seen its subscriber (checked every 0.1 s)
    assert abs(len(outdated_on["topics"]["state/present"]) - n) <= 2
    assert abs(len(outdated_on["topics"]["debug"]) - n) <= 2


def test_outdated_present_values_are_published_when_asked(outdated_on):
    # pub_outdated_present_value true: every present item in every message, read this loop or not
    for msg in outdated_on["topics"]["state/present"] + [s.present for s in outdated_on["states"]]:
        for field in PRESENT_FIELDS.values():
            values = getattr(msg, field)
            assert len(values) == 4, field
            assert not any(math.isnan(v) for v in values[:2]), field  # the X servos have every item


def test_present_items_not_read_this_loop_are_empty_without_outdated_values(outdated_off):
    assert outdated_off["code"] == 0
    for source, messages in (("/dynamixel/state/present", outdated_off["topics"]["state/present"][WARM_UP:]),
                             ("/dynamixel/states", [s.present for s in outdated_off["states"]])):
        n = len(messages)
        assert n >= 50
        for key, field in PRESENT_FIELDS.items():
            lengths = [len(getattr(m, field)) for m in messages]
            assert set(lengths) <= {0, 4}, f"{source} {field}: arrays are all or nothing"
            filled = lengths.count(4)
            ratio = PRESENT_RATIOS[key]
            want = n / ratio if ratio else 0
            assert abs(filled - want) <= 1, f"{source} {field}: filled in {filled} of {n} messages, want {want:.1f}"
            for m in messages:
                assert not any(math.isnan(v) for v in getattr(m, field)), f"{source} {field}"


VERBOSE = re.compile(r"time=(\d+\.\d+)ms/loop\((\d+\.\d+)ms/read\), success= *(\d+)%\(full= *(\d+)%\)")


def test_verbose_line_every_verbose_ratio_loops_and_success_drops_with_a_silent_servo():
    # latency_timer 16 (an adapter's default): the node waits ~35 ms for a reply instead of ~5 ms, so a
    # loaded machine holding back the simulator's thread does not make servo 1 miss a read; a servo
    # that missed one is only pinged every 10 loops, and those loops would go uncounted below
    bench = Rig({1: 1020, 3: 2020}, "verbose_ratio:=20", "pub_ratio/present.position:=1", "latency_timer:=16",
                base=BASE_PARAMS, state_topics=True)
    try:
        bench.node_proc.wait_for(VERBOSE.search)
        bench.sim.set_silent(3, True)
        bench.wait(lambda: any(float(m.group(4)) < 100.0 for m in map(VERBOSE.search, bench.output.splitlines())
                               if m), what="a verbose line with full < 100 %")
        bench.wait_new(["debug"], count=40)
        code = bench.stop_node()
        loops = len(bench.sync_reads(132, 1))
    finally:
        bench.close()
    assert code == 0
    lines = [m for m in map(VERBOSE.search, bench.output.splitlines()) if m]
    # one line per 20 loops, but at most one a second (100 loops at 100 Hz, fewer on a loaded host);
    # the stop may fall between a loop's read and its line, and the shutdown reads the present
    # position once more
    assert loops // 100 - 1 <= len(lines) <= loops // 20 + 1, f"{len(lines)} lines in {loops} loops"
    stamps = [float(s) for s in re.findall(r"\] \[(\d+\.\d+)\] .*ms/loop\(", bench.output)]
    assert all(b - a >= 0.95 for a, b in zip(stamps, stamps[1:])), stamps
    for m in lines:
        loop_ms, read_ms, success, full = map(float, m.groups())
        # ms/read averages the loops that read (as the original's t_read/n_any_read), ms/loop every loop
        # of the window: on a loaded host the first can exceed the second
        assert 0 < read_ms and 0 < loop_ms and 0 <= full <= success <= 100
    assert float(lines[0].group(3)) == 100.0  # all servos answering at first


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 12) | st.sampled_from([1009, 1013]), min_size=2 * 15, max_size=2 * 15),
       st.lists(st.integers(0, 3000), min_size=5, max_size=60))
def test_the_items_due_worked_out_once_per_pattern_equal_the_ratios_every_loop(ratios, loops):
    """The loop looks the items due up by which ratios divide the loop number; for any ratios, any
    loop (0 included) and after the parameters are replaced, they are those the ratios give."""
    from dynamixel_handler.bus import DynamixelBus
    from dynamixel_handler.config import GROUP_RATIO_PARAMS, defaults, validate
    from dynamixel_handler.core.handler import Handler
    from dynamixel_handler.core.read_plan import due_items_plain
    from dynamixel_handler.servo.groups import PRESENT

    def config(values: list[int]):
        names = [f"pub_ratio/present.{k}" for k in PRESENT] + list(GROUP_RATIO_PARAMS.values())
        return validate({**defaults(), **dict(zip(names, values))})

    first, second = config(ratios[:15]), config(ratios[15:])
    handler = Handler(DynamixelBus("/dev/null"), first)
    for cfg in (first, second, first):
        handler.settings = cfg.settings
        for loop in (0, *loops, 0):
            want = due_items_plain(cfg.settings.ratios, loop)
            assert handler.reads.due(loop) == want
            items, present, groups = handler.reads.due_items(loop)
            assert (tuple(items), present, groups) == want[:3]
