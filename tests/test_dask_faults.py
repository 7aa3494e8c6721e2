"""Dask faults (issue 17, item 6): a port that accepts TCP but does not speak
Dask, lost workers and a lost scheduler each end the run with one
KinemError line (exit 2 for the address, 1 for a loss), never a hang or a
traceback. Everything on 127.0.0.1, every wait bounded."""
import json
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from kinem import parallel
from kinem.errors import KinemError

pytest.importorskip("distributed")
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def silent_listener():
    """A TCP listener on 127.0.0.1 that accepts and never answers."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(8)
    held, stop = [], threading.Event()

    def accept():
        s.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(s.accept()[0])
            except OSError:
                pass

    t = threading.Thread(target=accept, daemon=True)
    t.start()
    yield f"tcp://127.0.0.1:{s.getsockname()[1]}"
    stop.set()
    t.join(5)
    for c in held:
        c.close()
    s.close()


def test_listener_that_does_not_speak_dask_is_one_line_exit_2(silent_listener):
    """The real command with the real CONNECT_TIMEOUT (10 s); bounded."""
    p = subprocess.run([sys.executable, "-m", "kinem", "stress", "--quick", "--engines", "native",
                        "--scheduler", silent_listener], capture_output=True, text=True, cwd=ROOT, timeout=90)
    assert p.returncode == 2, p.stderr
    assert p.stderr.count("\n") == 1 and "no Dask handshake within 10 s" in p.stderr, p.stderr


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and one worker (no nanny: a killed worker stays dead) as
    processes of their own, so the test can kill them."""
    file = tmp_path / "scheduler.json"
    py = [sys.executable, "-m"]
    procs = [subprocess.Popen(py + ["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                                    "--dashboard-address", ":0", "--scheduler-file", str(file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(0.2)
        address = json.loads(file.read_text())["address"]
        procs.append(subprocess.Popen(py + ["distributed.cli.dask_worker", "--scheduler-file", str(file),
                                            "--nthreads", "1", "--no-nanny"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        yield address, procs[0], procs[1]
    finally:
        for p in procs:
            p.kill()
            p.wait(30)


@pytest.mark.parametrize("lose", ["worker", "scheduler"])
def test_losing_the_cluster_mid_run_is_one_kinem_error(cluster, lose, monkeypatch):
    address, scheduler, worker = cluster
    monkeypatch.setattr(parallel, "LOST_TIMEOUT", 2.0)
    start = time.monotonic()
    with pytest.raises(KinemError) as e:
        with parallel.executor(scheduler=address) as pool:
            f = pool.submit(time.sleep, 120)
            time.sleep(1.0)
            (worker if lose == "worker" else scheduler).kill()
            f.result(timeout=90)
    text = str(e.value)
    assert "\n" not in text and text.startswith(f"--scheduler {address}: ")
    assert ("no workers left" if lose == "worker" else "lost the scheduler") in text, text
    assert time.monotonic() - start < 60          # bounded: LOST_TIMEOUT plus Dask's reconnect, not minutes


def test_overall_timeout(cluster, monkeypatch):
    address, _, _ = cluster
    monkeypatch.setattr(parallel, "RUN_TIMEOUT", 2.0)
    with pytest.raises(KinemError, match="took longer than 2 s"):
        with parallel.executor(scheduler=address) as pool:
            pool.submit(time.sleep, 120).result(timeout=90)
