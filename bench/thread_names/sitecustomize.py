"""Bench only: each Python thread (but the main one) gives its name to the kernel (prctl
PR_SET_NAME, 15 characters), so /proc/<pid>/task/*/comm tells the node's loop, executor and pool
threads apart from outside. Put on PYTHONPATH of the process measured (bench/crowd_probe.py)."""
import ctypes
import threading

try:
    _prctl = ctypes.CDLL(None).prctl
except (OSError, AttributeError):  # not Linux: nothing named
    _prctl = None
_inner = threading.Thread._bootstrap_inner  # type: ignore[attr-defined]


def _named(self: threading.Thread) -> None:
    if _prctl is not None:
        try:
            _prctl(15, self.name.encode()[:15], 0, 0, 0)  # PR_SET_NAME
        except Exception:  # a name the kernel refuses: the thread runs unnamed
            pass
    _inner(self)


threading.Thread._bootstrap_inner = _named  # type: ignore[attr-defined]


def _stalls(path: str) -> None:
    """With DXL_BENCH_STALLS=<file>: a thread that sleeps 5 ms over and over; each time it wakes
    over 50 ms late it writes how late, its own run-queue wait meanwhile (no core free) and where
    every other thread was when it got the interpreter lock back, one line each."""
    import os
    import sys
    import time
    import traceback

    def runq() -> int:
        try:
            with open(f"/proc/self/task/{threading.get_native_id()}/schedstat") as handle:
                return int(handle.read().split()[1])
        except OSError:
            return 0

    with open(path, "a", buffering=1) as out:
        while True:
            t, q = time.monotonic(), runq()
            time.sleep(0.005)
            late = time.monotonic() - t - 0.005
            if late < 0.05:
                continue
            names = {th.ident: th.name for th in threading.enumerate()}
            where = []
            for ident, frame in sys._current_frames().items():
                if ident == threading.get_ident():
                    continue
                top = traceback.extract_stack(frame, limit=3)
                where.append(f"{names.get(ident, ident)}: " + " < ".join(
                    f"{os.path.basename(f.filename)}:{f.lineno} {f.name}" for f in reversed(top)))
            out.write(f"{time.time():.3f} late {1000 * late:.0f} ms runq {(runq() - q) / 1e6:.0f} ms | "
                      + " | ".join(where) + "\n")


if __import__("os").environ.get("DXL_BENCH_STALLS"):
    threading.Thread(target=_stalls, args=(__import__("os").environ["DXL_BENCH_STALLS"],), name="bench_stalls",
                     daemon=True).start()


def _trim(path: str) -> None:
    """With DXL_BENCH_TRIM=<file>: when <file>.go appears, write to <file> the RSS before and after
    glibc's malloc_trim(0) (memory freed but kept by the allocator, given back) and the Python
    allocator's blocks in use, and how long the call took."""
    import ctypes as c
    import os
    import sys
    import time

    def rss() -> float:
        with open("/proc/self/status") as handle:
            return next(int(s.split()[1]) for s in handle if s.startswith("VmRSS:")) / 1024

    while True:
        time.sleep(0.2)
        if not os.path.exists(path + ".go"):
            continue
        os.remove(path + ".go")
        before, blocks = rss(), sys.getallocatedblocks()
        t = time.perf_counter()
        c.CDLL("libc.so.6").malloc_trim(0)
        took = time.perf_counter() - t
        with open(path, "w") as out:
            out.write(f"{before:.0f} {rss():.0f} {blocks} {1000 * took:.1f} {_arenas_mib(path)}\n")


def _arenas_mib(path: str) -> str:
    """MiB in the Python allocator's arenas now (sys._debugmallocstats, which writes to fd 2:
    sent to a file for the moment), or '-'."""
    import os
    import re
    import sys
    try:
        with open(path + ".stats", "w+b") as tmp:
            saved = os.dup(2)
            try:
                os.dup2(tmp.fileno(), 2)
                sys._debugmallocstats()
            finally:
                os.dup2(saved, 2)
                os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode(errors="replace")
        os.remove(path + ".stats")
        arenas = re.search(r"# arenas allocated current\s*=\s*([\d,]+)", text)
        size = re.search(r"# bytes in allocated blocks\s*=\s*([\d,]+)", text)
        return (f"{int(arenas.group(1).replace(',', ''))}/"  # an arena is 1 MiB (64-bit CPython 3.10+)
                f"{int(size.group(1).replace(',', '')) / 2**20:.0f}") if arenas and size else "-"
    except OSError:
        return "-"


if __import__("os").environ.get("DXL_BENCH_TRIM"):
    threading.Thread(target=_trim, args=(__import__("os").environ["DXL_BENCH_TRIM"],), name="bench_trim",
                     daemon=True).start()
