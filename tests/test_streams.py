"""Closed and broken standard streams (issue 25, item 4): never exit 3; exit 0
when the named output is complete, 1 when what was to be printed on a closed
standard output could not be, and a quiet 141 when standard output's reader
goes away (``kinem solve CASE | head``)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SLIDER = ROOT / "cases" / "slider_crank.toml"


def closed(redirect, *args):
    """kinem ARGS run by sh with its descriptors redirected (">&-" closes standard output)."""
    p = subprocess.run(["sh", "-c", f'"$@" {redirect}', "sh", sys.executable, "-m", "kinem", *map(str, args)],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT, timeout=300)
    return p.returncode, p.stdout, p.stderr


@pytest.mark.parametrize("redirect", [">&-", "2>&-", ">&- 2>&-", "<&- >&- 2>&-"])
def test_solve_to_a_file_with_closed_standard_streams_exits_0_and_writes_it_whole(redirect, tmp_path):
    out = tmp_path / "f.csv"
    reference = tmp_path / "ref.csv"
    assert closed("", "solve", SLIDER, "--steps", 50, "--out", reference)[0] == 0
    code, _, err = closed(redirect, "solve", SLIDER, "--steps", 50, "--out", out)
    assert code == 0, err
    assert out.read_bytes() == reference.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.csv", "ref.csv"]


@pytest.mark.parametrize("args", [("info", SLIDER), ("engines",), ("solve", SLIDER, "--steps", 5)])
def test_printing_to_a_closed_standard_output_is_one_line_exit_1(args):
    code, _, err = closed(">&-", *args)
    assert code == 1 and "Traceback" not in err
    assert err.strip().splitlines() == ["kinem: error: standard output: write failed: Bad file descriptor"]


def test_errors_with_standard_error_closed_keep_their_exit_code(tmp_path):
    assert closed("2>&-", "info", tmp_path / "missing.toml")[0] == 2
    assert closed(">&- 2>&-", "info", SLIDER)[0] == 1
    out = tmp_path / "f.csv"
    code, stdout, _ = closed("2>&-", "solve", tmp_path / "missing.toml", "--out", out)
    assert code == 2 and stdout == "" and not out.exists()   # the message went nowhere, not into a file


def test_animate_with_closed_standard_output_exits_0(tmp_path):
    out = tmp_path / "a.svg"
    code, _, err = closed(">&-", "animate", SLIDER, "--out", out, "--engines", "native")
    assert code == 0, err
    assert out.read_text().rstrip().endswith("</svg>")


def test_broken_pipe_on_standard_output_ends_quietly_with_141():
    # 300 kB of CSV: more than a pipe holds, so kinem is still writing when the reader goes
    p = subprocess.Popen([sys.executable, "-m", "kinem", "solve", str(SLIDER)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, cwd=ROOT)
    assert p.stdout.readline().startswith(b"t,")
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=300) == 141 and err == ""


def test_reader_gone_while_kinem_waits_on_a_full_pipe_ends_with_141():
    # kinem blocked in a write to a full pipe when its reader goes: that write returns having taken
    # only part of the data (Python's BufferedWriter then returns, not raises); the rest must still
    # be written, and fail, not be dropped with exit code 0
    import fcntl
    import termios
    import time

    p = subprocess.Popen([sys.executable, "-m", "kinem", "solve", str(SLIDER)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, cwd=ROOT)
    fd = p.stdout.fileno()
    # F_GETPIPE_SZ: the pipe's capacity, less a page (the header's short write holds one of its pages)
    size = fcntl.fcntl(fd, 1032) - os.sysconf("SC_PAGE_SIZE")
    held = bytearray(4)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:   # until the pipe is full: kinem, with more to write, waits
        fcntl.ioctl(fd, termios.FIONREAD, held)
        if int.from_bytes(held, sys.byteorder) >= size or p.poll() is not None:
            break
        time.sleep(0.01)
    assert int.from_bytes(held, sys.byteorder) >= size   # the 333 kB of CSV fill it
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=300) == 141 and err == ""
