"""Hostile parameters files: each is one FATAL line and exit code 2, no traceback and no line of
rcl's own, long before rcl's parser would have finished with it: a file over 1 MiB (a 10 MB
string), nesting deeper than 32 levels, more than 20,000 keys and list entries (checked on the text
before any YAML parser reads it), a YAML alias, an integer beyond ROS's 64-bit range; a long value
is echoed cut short. The node runs as a process with each file, generated here; a file within the
limits starts as before. The text scan's rules (quotes, comments, block scalars) are checked on
strings."""
from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from dynamixel_handler.ros.params_file import MAX_BYTES, MAX_DEPTH, MAX_ENTRIES, MAX_TOTAL_ENTRIES, scan_problem

from support.ros import NodeProcess, node_command

HEAD = "dynamixel_handler:\n  ros__parameters:\n    device_name: /dev/null\n"
#: the node must have exited by then; a node that does not is killed and the test fails
EXIT_WAIT_S = 60.0
#: the longest line any of these runs may log
LINE_MAX = 600


def _refused(path: Path) -> str:
    """The node's one FATAL line for the params file ``path`` (exit code 2, nothing else said)."""
    proc = NodeProcess(node_command(params_file=path))
    code = proc.wait_exit(timeout=EXIT_WAIT_S)
    out = proc.output
    assert code == 2, out[:2000]
    assert "Traceback" not in out and "[rcl]" not in out, out[:2000]
    assert all(len(line) < LINE_MAX for line in proc.lines), [len(line) for line in proc.lines]
    fatal = [line for line in proc.lines if line.startswith("[FATAL]")]
    assert len(fatal) == 1 and len([line for line in proc.lines if line.strip()]) == 1, out[:2000]
    return fatal[0]


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_file_over_the_size_limit_is_refused_before_it_is_read(tmp_path):
    path = _write(tmp_path, "string.yaml", HEAD + "    loop_rate: '" + "x" * 10_000_000 + "'\n")
    line = _refused(path)
    assert str(path) in line and f"more than the {MAX_BYTES:,} a params file may have" in line, line
    assert f"{path.stat().st_size:,} bytes" in line, line
    many = _write(tmp_path, "keys.yaml", HEAD + "".join(f"    k{i}: {i}\n" for i in range(330_000)))
    assert "refused before reading it" in _refused(many)


@pytest.mark.parametrize("nest", ["flow", "block"])
def test_nesting_500_deep_is_one_line_naming_where(tmp_path, nest):
    if nest == "flow":
        text = HEAD + "    loop_rate: " + "[" * 500 + "]" * 500 + "\n"
    else:
        text = HEAD + "    deep:\n" + "".join("  " * (k + 3) + f"k{k}:\n" for k in range(500)) + "  " * 503 + "1\n"
    line = _refused(_write(tmp_path, "deep.yaml", text))
    assert f"nests deeper than {MAX_DEPTH} levels at line" in line and "refused before parsing it" in line, line


def test_more_keys_or_list_entries_than_the_limit_are_refused_before_parsing(tmp_path):
    ints = _write(tmp_path, "ints.yaml", HEAD + "    table: [" + ", ".join("7" for _ in range(300_000)) + "]\n")
    assert ints.stat().st_size < MAX_BYTES  # the count, not the size, refuses it
    line = _refused(ints)
    assert f"more than {MAX_ENTRIES:,} keys and list entries (line 4)" in line, line
    keys = _write(tmp_path, "keys.yaml", HEAD + "".join(f"    k{i}: 1\n" for i in range(30_000)))
    assert keys.stat().st_size < MAX_BYTES
    assert f"more than {MAX_ENTRIES:,} keys and list entries" in _refused(keys)
    listed = _write(tmp_path, "list.yaml", HEAD + "    table:\n" + "      - 1\n" * 30_000)
    assert f"more than {MAX_ENTRIES:,} keys and list entries" in _refused(listed)


def test_an_alias_bomb_is_refused_before_parsing(tmp_path):
    lines = ["    a: &a [x, x, x, x, x, x, x, x, x]"] + [
        f"    {chr(98 + k)}: &{chr(98 + k)} [{', '.join([f'*{chr(97 + k)}'] * 9)}]" for k in range(8)]
    line = _refused(_write(tmp_path, "bomb.yaml", HEAD + "\n".join(lines) + "\n"))
    assert "a YAML alias (*name) at line 5: ROS does not read aliases" in line, line


@pytest.mark.parametrize("value", ["1e20", "100000000000000000000", "-1e19"])
def test_an_integer_beyond_64_bits_is_one_line_naming_the_parameter(tmp_path, value):
    line = _refused(_write(tmp_path, "big.yaml", HEAD + f"    baudrate: {value}\n"))
    assert "bad parameter: parameter 'baudrate' must be int" in line and "beyond the range of a ROS integer" in line, line
    assert "SystemError" not in line


def test_a_long_value_of_the_wrong_type_is_echoed_cut_short(tmp_path):
    line = _refused(_write(tmp_path, "long.yaml", HEAD + "    loop_rate: '" + "x" * 900_000 + "'\n"))
    assert "parameter 'loop_rate' must be int" in line and "(900002 characters)" in line, line


def test_many_unknown_names_are_named_twenty_and_counted(tmp_path):
    path = _write(tmp_path, "unknown.yaml", HEAD + "".join(f"    unknown_{i:04d}: 1\n" for i in range(500))
                  + "    " + "k" * 1000 + ": 1\n")
    proc = NodeProcess(node_command(params_file=path))
    assert proc.wait_exit(timeout=EXIT_WAIT_S) == 1, proc.output  # /dev/null: not a serial port
    unknown = [line for line in proc.lines if "unknown parameter" in line]
    assert len(unknown) == 21 and unknown[-1].endswith("481 more unknown parameters ignored"), proc.output[:3000]
    assert "unknown parameter 'kkkk" in unknown[0] and "(1000 characters)" in unknown[0], unknown[0]
    assert all(len(line) < LINE_MAX for line in proc.lines)


def test_a_large_file_within_the_limits_starts_as_before(tmp_path):
    """A table of 15,000 numbers for another node and 500 keys: read; the node goes on to its device."""
    text = (HEAD + "    loop_rate: 50\nother_node:\n  ros__parameters:\n    table: ["
            + ", ".join("1.5" for _ in range(15_000)) + "]\n" + "".join(f"    k{i}: {i}\n" for i in range(500)))
    proc = NodeProcess(node_command(params_file=_write(tmp_path, "large.yaml", text)))
    assert proc.wait_exit(timeout=EXIT_WAIT_S) == 1, proc.output
    assert "params file" not in proc.output and "loop_rate=50" in proc.output, proc.output
    assert "/dev/null is not a serial port" in proc.output, proc.output


def _many_keys(tmp_path: Path, name: str, keys: int) -> Path:
    return _write(tmp_path, name, HEAD + "".join(f"    k{i}: {i}\n" for i in range(keys)))


@pytest.mark.parametrize("same", [False, True], ids=["three files", "one file three times"])
def test_files_within_the_limits_one_by_one_are_refused_when_their_sum_is_not(tmp_path, same):
    files = [_many_keys(tmp_path, f"part{k}.yaml", 15_000) for k in range(1 if same else 3)] * (3 if same else 1)
    proc = NodeProcess(node_command(params_file=None) + [a for f in files for a in ("--params-file", str(f))])
    assert proc.wait_exit(timeout=EXIT_WAIT_S) == 2, proc.output[:2000]
    fatal = [line for line in proc.lines if line.startswith("[FATAL]")]
    assert len(fatal) == 1 and "the 3 params files given add up to" in fatal[0], proc.output[:2000]
    assert f"more than the 2,097,152 bytes and {MAX_TOTAL_ENTRIES:,} entries" in fatal[0], fatal[0]
    assert "Traceback" not in proc.output and "[rcl]" not in proc.output


def _open_in(pid: int, path: Path) -> bool:
    """Whether process ``pid`` has ``path`` open now."""
    try:
        return any(os.readlink(f"/proc/{pid}/fd/{fd}") == str(path) for fd in os.listdir(f"/proc/{pid}/fd"))
    except OSError:
        return False


def _sigint_while_reading(files: list[Path]) -> tuple[bool, NodeProcess]:
    """The node with ``files``, SIGINT as soon as one of them is seen open (the node's own check of
    their sizes, then rcl's parser: a signal in either is one and the same case); (whether the node
    was alive and had said nothing yet when the signal went, the process)."""
    proc = NodeProcess(node_command(params_file=None) + [a for f in files for a in ("--params-file", str(f))])
    pid = proc.proc.pid
    deadline = time.monotonic() + EXIT_WAIT_S
    while proc.proc.poll() is None and time.monotonic() < deadline:
        if any(_open_in(pid, f) for f in files):
            break
        time.sleep(0.002)
    quiet = not proc.lines and proc.proc.poll() is None  # its first line comes once rcl has read the files
    proc.proc.send_signal(signal.SIGINT)
    return quiet, proc


def test_sigint_while_rcl_reads_the_params_files_ends_the_node_with_one_line(tmp_path):
    """Two files of 19,000 keys (within every limit): rcl reads them for a second or so, with
    SIGINT held until it returns; the node then exits (code 0) in one line, no traceback. Whether a
    signal landed inside the reading shows only afterwards (rcl may return between the look at the
    files and the signal): one that lands after must end the node as cleanly, code 0 (the signal)
    or 1 (its device, /dev/null, is no serial port, found first). Up to five tries to land one inside."""
    files = [_many_keys(tmp_path, f"part{k}.yaml", 19_000) for k in range(2)]
    for _ in range(5):
        quiet, proc = _sigint_while_reading(files)
        code = proc.wait_exit(timeout=15)
        assert "Traceback" not in proc.output, proc.output[:3000]
        if quiet and proc.output.strip().endswith("interrupted while reading the parameters: exiting"):
            assert code == 0 and len(proc.lines) == 1, proc.output[:2000]
            return
        assert code in (0, 1), proc.output[:2000]
    pytest.fail("no SIGINT landed while rcl read the files in five tries")


# ---------------------------------------------------------------------- the text scan's rules
@pytest.mark.parametrize("text", [
    "a: '[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[['\n",  # brackets in a quoted scalar
    'a: "\\" [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\n  [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["\n',  # over two lines
    "a: 'it''s [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[['\n",
    "a: it's [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x [x\n",
    "a: 1  # [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\n",
    "a: |\n  [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\n  {{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{{\nb: 2\n",
    "url: http://x:8080/a\nname: '*star'\nc: x*y\nanchored: &here [1, 2]\n",
], ids=["quoted", "two-lines", "doubled-quote", "plain", "comment", "block-scalar", "no-alias"])
def test_the_scan_counts_structure_not_text(text):
    assert scan_problem(text) is None


def test_the_scan_finds_depth_entries_and_aliases_where_they_are():
    assert scan_problem("a: &x " + "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1)) == \
        f"nests deeper than {MAX_DEPTH} levels at line 1"
    assert scan_problem("a: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)) is None  # the mapping is a level
    assert scan_problem("".join(" " * k + f"k{k}:\n" for k in range(MAX_DEPTH + 1))) == \
        f"nests deeper than {MAX_DEPTH} levels at line {MAX_DEPTH + 1}"
    assert scan_problem("- " * (MAX_DEPTH + 1) + "x") == f"nests deeper than {MAX_DEPTH} levels at line 1"
    assert scan_problem("t: {" + ", ".join(f"k{i}: 1" for i in range(MAX_ENTRIES)) + "}") is not None
    assert scan_problem("t: [" + ", ".join("1" for _ in range(MAX_ENTRIES - 10)) + "]") is None
    assert scan_problem("a: 1\nb: *x\n") == "a YAML alias (*name) at line 2: ROS does not read aliases"
    crlf = "".join(f"k{i}:\r\n  v: 1\r\n" for i in range(MAX_ENTRIES // 2 + 1))  # Windows line ends
    assert scan_problem(crlf) == f"more than {MAX_ENTRIES:,} keys and list entries (line {MAX_ENTRIES + 1})"


def test_the_baud_rate_tool_refuses_a_hostile_file_the_same_way(tmp_path):
    """dynamixel_unify_baudrate reads its parameters through rcl too: the same checks run first."""
    path = _write(tmp_path, "deep.yaml", "dynamixel_unify_baudrate:\n  ros__parameters:\n    target_baudrate: "
                  + "[" * 500 + "]" * 500 + "\n")
    proc = NodeProcess(["dynamixel_unify_baudrate", "--ros-args", "--params-file", str(path)])
    assert proc.wait_exit(timeout=EXIT_WAIT_S) == 2, proc.output[:2000]
    fatal = [line for line in proc.lines if line.startswith("[FATAL]")]
    assert len(fatal) == 1 and f"nests deeper than {MAX_DEPTH} levels" in fatal[0], proc.output[:2000]
    assert "Traceback" not in proc.output and "[rcl]" not in proc.output
