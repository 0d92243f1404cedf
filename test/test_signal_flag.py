"""The signal handler of the node's process and of the virtual bus's command line takes no lock.

A handler runs on the main thread between two Python steps, also while that thread holds a lock for
a moment (``threading.Event.wait`` holds the Event's own lock around its sleep): a handler that took
that lock waited for it forever, and the node ignored its SIGINT. Each case runs in a process of its
own, a signal arriving exactly while the lock is held."""
from __future__ import annotations

import subprocess
import sys
import textwrap

_HELD = textwrap.dedent("""
    import os, signal, threading
    from dynamixel_handler.signal_flag import SignalFlag
    {setup}
    waiting = threading.Event()
    with waiting._cond:  # the moment inside Event.wait/Event.set when the Event's lock is held
        os.kill(os.getpid(), signal.SIGINT)  # the handler runs at the next step, the lock still held
        step = 1
    print("handled", {seen}, flush=True)
""")


def _run(setup: str, seen: str) -> subprocess.CompletedProcess:
    code = _HELD.format(setup=setup, seen=seen)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)


def test_the_flag_is_set_while_the_main_thread_holds_a_lock():
    done = _run("flag = SignalFlag(); flag.install(signal.SIGINT, signal.SIGTERM)", "flag.came, flag.signum")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"handled True {int(__import__('signal').SIGINT)}"


def test_an_event_set_by_the_handler_hangs_there_which_is_why_the_flag_exists():
    # the pattern the node had: the same moment deadlocks the process
    try:
        done = subprocess.run([sys.executable, "-c", _HELD.format(
            setup="", seen="1").replace("with waiting._cond:", "signal.signal(signal.SIGINT, lambda *_: waiting.set())\n"
                                         "with waiting._cond:")], capture_output=True, text=True, timeout=2)
    except subprocess.TimeoutExpired:
        return
    raise AssertionError(f"an Event set from a handler inside its lock returned: {done.stdout!r} {done.stderr!r}")


def test_the_wait_ends_at_the_signal_or_when_done():
    code = textwrap.dedent("""
        import os, signal, threading, time
        from dynamixel_handler.signal_flag import SignalFlag
        flag = SignalFlag(); flag.install(signal.SIGTERM)
        t = time.monotonic()
        assert flag.wait(lambda: False, timeout=0.2) is False and time.monotonic() - t >= 0.19
        ready = threading.Event()
        threading.Timer(0.1, ready.set).start()
        assert flag.wait(ready.is_set) is False
        threading.Timer(0.1, lambda: os.kill(os.getpid(), signal.SIGTERM)).start()
        assert flag.wait() is True and flag.signum == signal.SIGTERM
        print("ok")
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert done.stdout.strip() == "ok", done.stderr
