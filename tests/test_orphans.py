"""Local workers die with their parent (issue 25, item 2): SIGKILL of a
process running a pool (kinem report --jobs N, the stress suite) leaves no
worker behind holding memory and the caller's pipes."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

POOL = """
import threading, time
from kinem import parallel

def run():
    with parallel.executor(2) as pool:
        futures = [pool.submit(time.sleep, 600) for _ in range(2)]
        print("ready", flush=True)
        [f.result() for f in futures]

if THREAD:   # a pool made off the main thread: the fallback watch, not prctl
    t = threading.Thread(target=run)
    t.start()
    t.join()
else:
    run()
"""


def processes(field, value):
    """PIDs of the live processes whose /proc stat field ``field`` (counted
    after the command name: 1 the parent, 3 the session) equals value."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[field]) == value and fields[0] != "Z":
                out.append(int(d.name))
    return out


def children(pid):
    """PIDs of the live processes whose parent is pid (from /proc)."""
    return processes(1, pid)


def alive(pid):
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def until(condition, seconds):
    """Polls condition until it holds or seconds pass; its last value."""
    end = time.monotonic() + seconds
    while not condition() and time.monotonic() < end:
        time.sleep(0.05)
    return condition()


@pytest.mark.parametrize("thread", [False, True])
def test_sigkill_of_the_parent_leaves_no_worker(thread):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    p = subprocess.Popen([sys.executable, "-c", POOL.replace("THREAD", str(thread))], stdout=subprocess.PIPE, cwd=ROOT, env=env)
    try:
        assert p.stdout.readline() == b"ready\n"
        # the two workers are forked at the first submit (the fork start method)
        assert until(lambda: len(children(p.pid)) >= 2, 60)
        workers = children(p.pid)
    finally:
        p.kill()
        p.wait()
    # 5 s: the bound; the kernel's SIGKILL comes at once, the fallback watch within WATCH
    gone = until(lambda: not any(alive(w) for w in workers), 5)
    survivors = [w for w in workers if alive(w)]
    for w in survivors:   # the test's own processes: not left running when it fails
        os.kill(w, signal.SIGKILL)
    assert gone, f"workers {survivors} outlived their parent"
    assert p.stdout.read() == b""   # end of file: no worker holds the pipe
