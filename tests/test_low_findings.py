"""The low findings of issue 25: a signal at the commit, animate's scratch
file, FIFOs, odd --out values, far-away mechanisms, messages."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from kinem import output

ROOT = Path(__file__).resolve().parents[1]
SLIDER = ROOT / "cases" / "slider_crank.toml"


def run(*args, **kw):
    p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], capture_output=True, text=True,
                       cwd=ROOT, **{"timeout": 300, **kw})
    return p.returncode, p.stdout, p.stderr


def test_a_signal_right_after_the_rename_keeps_the_new_file_and_reports_no_failed_write(tmp_path, monkeypatch):
    out = tmp_path / "f.txt"
    out.write_text("old\n")
    replace = os.replace

    def replaced_then_terminated(a, b):   # the SystemExit of SIGTERM, landing as the rename returns
        replace(a, b)
        raise SystemExit(128 + signal.SIGTERM)

    monkeypatch.setattr(output.os, "replace", replaced_then_terminated)
    with pytest.raises(SystemExit) as e:
        output.write_atomic(out, lambda f: f.write(b"new\n"))
    assert e.value.code == 143 and out.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.txt"]


def test_a_signal_between_linking_and_renaming_leaves_no_temporary_name(tmp_path, monkeypatch):
    out = tmp_path / "f.txt"
    out.write_text("old\n")
    link = output._link_fd

    def linked_then_terminated(fd, path):
        link(fd, path)
        if os.path.basename(path).endswith(".tmp"):   # the temporary name, not the target
            raise SystemExit(128 + signal.SIGTERM)

    monkeypatch.setattr(output, "_link_fd", linked_then_terminated)
    with pytest.raises(SystemExit):
        output.write_atomic(out, lambda f: f.write(b"new\n"))
    assert out.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["f.txt"]


def test_sigterm_during_a_commit_is_held_until_it_is_done(tmp_path):
    # a real SIGTERM sent while the commit's signals are held: the rename completes, then the exit
    code = f"""
import os, signal
from kinem import cli, output
signal.signal(signal.SIGTERM, cli._terminate)   # kinem's own handler
replace = os.replace
def rename(a, b):
    os.kill(os.getpid(), signal.SIGTERM)   # pending: held by the commit
    replace(a, b)
output.os.replace = rename
output.write_atomic({str(tmp_path / 'f.txt')!r}, lambda f: f.write(b"new\\n"))
"""
    (tmp_path / "f.txt").write_text("old\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT)] + sys.path)}, timeout=120)
    assert p.returncode == 143, p.stderr
    assert (tmp_path / "f.txt").read_text() == "new\n" and sorted(q.name for q in tmp_path.iterdir()) == ["f.txt"]


def _fds_into(pid, folder):
    try:
        return [os.readlink(f"/proc/{pid}/fd/{fd}") for fd in os.listdir(f"/proc/{pid}/fd")
                if os.readlink(f"/proc/{pid}/fd/{fd}").startswith(str(folder))]
    except OSError:
        return []


def test_sigkill_while_animate_renders_leaves_nothing_in_the_temporary_directory(tmp_path):
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "a.gif"
    p = subprocess.Popen([sys.executable, "-m", "kinem", "animate", str(SLIDER), "--out", str(out),
                          "--engines", "native"], cwd=ROOT, env={**os.environ, "TMPDIR": str(scratch)},
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 300   # a bound on the wait, not a timing assert
        while time.monotonic() < end and p.poll() is None:
            if list(scratch.iterdir()) or _fds_into(p.pid, scratch):   # rendering has started
                break
            time.sleep(0.02)
        assert p.poll() is None, "animate ended before it rendered"
    finally:
        p.kill()
        p.wait()
    assert list(scratch.iterdir()) == [] and not out.exists()
