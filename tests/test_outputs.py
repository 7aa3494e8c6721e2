"""Outputs (issue 17, item 1): never replace what the command does not own,
one-line errors that name the target, nothing left behind; streamed output
equal to the whole-run output (item 4); --partial (item 3).

Devices are made with mknod inside the test's temporary directory (as root),
never /dev/null or /dev/full themselves: on code that renames over its target
the test must not harm the machine."""
import errno
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import kinem
from kinem import cli, output

ROOT = Path(__file__).resolve().parents[1]
SLIDER = ROOT / "cases" / "slider_crank.toml"
ROCKER = ROOT / "cases" / "stress" / "rocker_toggle.toml"   # stops at a limit position at t = 0.5


def run(*args, stdout=subprocess.PIPE, **kw):
    p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], stdout=stdout, stderr=subprocess.PIPE,
                       text=True, cwd=ROOT, **{"timeout": 300, **kw})
    return p.returncode, p.stdout, p.stderr


def leftovers(directory, keep=()):
    return sorted(p.name for p in Path(directory).iterdir() if p.name not in keep)


def one_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def device(path, minor):
    """A character device node like /dev/null (1, 3) or /dev/full (1, 7) at path."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        with open(path, "wb") as f:
            f.write(b"")
    except (PermissionError, OSError) as e:
        pytest.skip(f"cannot make a device node here ({e})")
    return path


def test_null_device_is_written_through_never_replaced(tmp_path):
    null = device(tmp_path / "null", 3)
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", null)
    assert code == 0, err
    assert stat.S_ISCHR(os.stat(null).st_mode)          # still the device
    assert leftovers(tmp_path) == ["null"]


def test_real_dev_null_survives(tmp_path):
    """The benchmark's old target itself (safe only with the fix in place)."""
    before = os.stat(os.devnull)
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", os.devnull)
    after = os.stat(os.devnull)
    assert code == 0, err
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev and after.st_ino == before.st_ino


def test_full_device_is_one_line_exit_1_naming_it(tmp_path):
    full = device(tmp_path / "full", 7)
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", full)
    assert code == 1
    line = one_line(err)
    assert str(full) in line and "No space left" in line
    assert stat.S_ISCHR(os.stat(full).st_mode) and leftovers(tmp_path) == ["full"]


def test_fifo_is_written_in_place(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    reader = subprocess.Popen(["cat", str(fifo)], stdout=subprocess.PIPE)
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", fifo)
    text = reader.communicate(timeout=60)[0].decode()
    assert code == 0, err
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and len(text.splitlines()) == 7
    assert leftovers(tmp_path) == ["fifo"]


def test_symlink_is_followed_and_kept(tmp_path):
    (tmp_path / "real.csv").write_text("old\n")
    (tmp_path / "link.csv").symlink_to("real.csv")
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", tmp_path / "link.csv")
    assert code == 0, err
    assert (tmp_path / "link.csv").is_symlink()
    assert (tmp_path / "real.csv").read_text().startswith("t,ground.x")
    assert leftovers(tmp_path) == ["link.csv", "real.csv"]


@pytest.mark.parametrize("where, expect", [("missing/x.csv", "does not exist"), (".", "is a directory")])
def test_bad_output_path_is_one_line_exit_2_naming_the_target(tmp_path, where, expect):
    target = tmp_path / where
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", target)
    assert code == 2
    line = one_line(err)
    assert str(target) in line and expect in line and ".tmp" not in line
    assert leftovers(tmp_path) == []


def test_read_only_directory_names_the_target(tmp_path, monkeypatch, capsys):
    """Permission denied in the target's directory (simulated: the suite runs
    as root, which no directory mode stops): exit 2, the target named."""
    real_open = os.open

    def denied(path, flags, *a, **kw):
        if str(path).startswith(str(tmp_path)) and flags & (os.O_WRONLY | os.O_RDWR):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *a, **kw)

    monkeypatch.setattr(os, "open", denied)
    target = tmp_path / "x.csv"
    assert cli.main(["solve", str(SLIDER), "--steps", "3", "--out", str(target)]) == 2
    line = one_line(capsys.readouterr().err)
    assert line == f"kinem: error: {target}: cannot write: Permission denied"


def test_standard_output_to_a_full_device(tmp_path):
    full = device(tmp_path / "full", 7)
    with open(full, "wb") as sink:
        code, _, err = run("solve", SLIDER, "--steps", 5, stdout=sink)
        assert code == 1
    assert one_line(err) == "kinem: error: standard output: write failed: No space left on device"
    with open(full, "wb") as sink:
        code, _, err = run("info", SLIDER, stdout=sink)
    assert code == 1 and "standard output: write failed" in one_line(err)


def test_failed_write_leaves_no_temporary_file(tmp_path, monkeypatch):
    """A write that fails part-way (disk full, simulated) in both the unnamed
    (O_TMPFILE) and the named-temporary-file ways: OutputError naming the
    target, old content kept, nothing else in the directory."""
    target = tmp_path / "x.csv"
    for unnamed in (True, False):
        target.write_text("old\n")
        if not unnamed:
            monkeypatch.setattr(output, "_links_unnamed", lambda d: False)

        def write(f):
            f.write(b"some")
            raise OSError(errno.ENOSPC, "No space left on device")

        with pytest.raises(kinem.KinemError, match=f"{target}: write failed: No space left on device"):
            output.write_atomic(target, write)
        assert target.read_text() == "old\n" and leftovers(tmp_path) == ["x.csv"]
        output.write_atomic(target, lambda f: f.write(b"new\n"))
        assert target.read_text() == "new\n" and leftovers(tmp_path) == ["x.csv"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_signal_while_writing_leaves_nothing(tmp_path, sig):
    """Killed while the output is open in the target's directory: no file at
    the target, no temporary file beside it (SIGTERM: cleaned up, exit 143;
    SIGKILL: the output was an unnamed O_TMPFILE file)."""
    if sig == signal.SIGKILL and not getattr(output, "_links_unnamed", lambda d: True)(str(tmp_path)):
        pytest.skip("no O_TMPFILE + linkat here: only signals Python can catch are covered")
    target = tmp_path / "x.csv"
    p = subprocess.Popen([sys.executable, "-m", "kinem", "solve", str(SLIDER), "--steps", "400000",
                          "--out", str(target)], cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline and p.poll() is None:   # until it has a file open there
            fds = Path(f"/proc/{p.pid}/fd")
            try:
                if any(os.readlink(fds / fd).startswith(str(tmp_path)) for fd in os.listdir(fds)):
                    break
            except OSError:
                pass
            time.sleep(0.05)
        assert p.poll() is None, "the run ended before it could be interrupted"
        time.sleep(0.3)
        p.send_signal(sig)
        err = p.communicate(timeout=60)[1].decode()
    finally:
        if p.poll() is None:
            p.kill()
    assert leftovers(tmp_path) == []
    assert p.returncode == (143 if sig == signal.SIGTERM else -9), err
    assert "Traceback" not in err


def test_a_swallowed_termination_still_discards_the_output(tmp_path, monkeypatch):
    """The handler's SystemExit can be swallowed where the signal lands (seen:
    inside numba's ctypes object-cache callback, and the run then finished with
    exit 0 and its file); the flag it sets stops the next write or the commit."""
    monkeypatch.setitem(output.STOP, "signal", signal.SIGTERM)
    for act in (lambda out: out.write(b"t\n"), lambda out: out.commit()):
        with pytest.raises(SystemExit) as e:
            with output.Output(tmp_path / "x.csv") as out:
                act(out)
        assert e.value.code == 143 and leftovers(tmp_path) == []


def test_format_and_suffix_must_agree(tmp_path):
    code, _, err = run("solve", SLIDER, "--steps", 3, "--out", tmp_path / "f.npz", "--format", "csv")
    assert code == 2 and "--format csv does not match --out" in one_line(err)
    assert leftovers(tmp_path) == []
    code, _, err = run("solve", SLIDER, "--steps", 3, "--out", tmp_path / "f.csv", "--format", "npz")
    assert code == 2


def test_streamed_chunks_equal_one_solve():
    """kinem.stream cuts the run into chunks, each started from the previous
    chunk's last state; the result is the single solve's to the Newton
    tolerance (1e-12 scaled residual: differences of a few 1e-12 of the
    mechanism's size, 1e-9 relative allows for the velocities' conditioning)."""
    from kinem import stream

    model = kinem.compile(kinem.load(SLIDER).with_time(steps=2500))
    whole = kinem.solve(model).trajectory
    parts = []
    o = stream.run(model, kinem.OUTPUTS, parts.append, size=700)
    assert o.success and o.value.instants == 2501 and len(parts) == 4
    t = np.concatenate([p.t for p in parts])
    data = np.concatenate([p.data for p in parts])
    assert np.array_equal(t, whole.t) and parts[0].columns == whole.columns
    scale = np.abs(whole.data).max(axis=0) + 1.0
    assert np.abs(data - whole.data).max(axis=0).max() / scale.min() < 1e-9


def test_csv_round_trips_every_double():
    """The shortest round-trip form reads back to the same doubles (incl.
    -0.0, subnormals, huge); NaN and infinity too (through repr)."""
    rng = np.random.default_rng(1)
    data = rng.standard_normal((50, 5)) * 10.0 ** rng.integers(-300, 300, (50, 5))
    data[0, :4] = [-0.0, 5e-324, 1.7976931348623157e308, 1 / 3]
    t = np.arange(50) * 0.1
    for t, d in ((t, data), (t, np.where(np.arange(5) == 2, np.nan, data)), (t[:1], data[:1])):
        rows = output.csv_rows(t, d).decode().splitlines()
        assert len(rows) == len(t)
        back = np.array([[float(v) for v in r.split(",")] for r in rows])
        assert np.array_equal(back[:, 0], t) and np.array_equal(back[:, 1:], d, equal_nan=True)
        assert np.array_equal(np.signbit(back[:, 1:]), np.signbit(d))


def test_partial_writes_the_instants_solved_marked(tmp_path):
    """A failed solve writes nothing unless --partial; with it, the instants
    solved and a last line saying why (CSV), or partial/message arrays (NPZ)."""
    out = tmp_path / "r.csv"
    code, _, err = run("solve", ROCKER, "--out", out)
    assert code == 1 and "singular" in one_line(err) and leftovers(tmp_path) == []
    code, text, err = run("solve", ROCKER)                  # standard output: nothing either
    assert code == 1 and text == ""
    code, text, _ = run("solve", ROCKER, "--partial")
    assert code == 1 and text.splitlines()[-1].startswith("# partial: ") and len(text.splitlines()) == 52
    code, _, err = run("solve", ROCKER, "--out", out, "--partial")
    assert code == 1 and "marked partial" in one_line(err)
    lines = out.read_text().splitlines()
    assert lines[0].startswith("t,") and lines[-1].startswith("# partial: step to t = 0.5")
    assert len(lines) == 1 + 50 + 1                     # header, instants 0..49, the mark
    assert np.loadtxt(out, delimiter=",", skiprows=1).shape[0] == 50   # '#' lines are comments to readers
    code, _, err = run("solve", ROCKER, "--out", tmp_path / "r.npz", "--partial")
    z = np.load(tmp_path / "r.npz")
    assert code == 1 and bool(z["partial"]) and "singular" in str(z["message"]) and z["data"].shape[0] == 50
    code, _, _ = run("solve", SLIDER, "--steps", 4, "--out", tmp_path / "ok.npz")
    assert code == 0 and "partial" not in np.load(tmp_path / "ok.npz").files


def test_work_limit_refuses_with_a_clear_error():
    code, _, err = run("solve", SLIDER, "--steps", 1000, "--max-work", 1000)
    line = one_line(err)
    assert code == 2 and "1,001 output instants x 12 coordinates" in line and "--max-work" in line
    code, _, err = run("solve", ROOT / "cases" / "quick_return_1.toml", "--steps", 10_000_000, timeout=60)
    assert code == 2 and "exceeds the work limit 5e+07" in one_line(err)   # refused before any work


def on_a_terminal(args, timeout):
    """``kinem ARGS`` with its standard error on a pseudo-terminal (stdout
    discarded): (exit code, every byte written to the terminal)."""
    import pty

    master, slave = pty.openpty()
    try:
        p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], stderr=slave,
                           stdout=subprocess.DEVNULL, cwd=ROOT, timeout=timeout)
        os.close(slave)
        seen = b""
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:
                break
            if not chunk:
                break
            seen += chunk
    finally:
        os.close(master)
    return p.returncode, seen


def test_progress_only_on_a_terminal():
    args = ["solve", SLIDER, "--steps", 30_000, "--outputs", "positions", "--out", os.devnull]
    code, _, err = run(*args)
    assert code == 0 and err == ""                    # not a terminal: nothing
    code, seen = on_a_terminal(args, timeout=300)
    assert code == 0 and b"/30001" in seen and b"t = " in seen


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o200])   # a read-only one is refused (tests/test_bounds.py)
def test_a_replaced_file_keeps_its_mode_and_owner(tmp_path, mode):
    out = tmp_path / "f.csv"
    out.write_text("old\n")
    os.chmod(out, mode)
    owner = (os.stat(out).st_uid, os.stat(out).st_gid)
    if os.geteuid() == 0:   # as root: a file of another user and group stays theirs
        owner = (12345, 23456)
        os.chown(out, *owner)
    code, _, err = run("solve", SLIDER, "--steps", 5, "--out", out)
    assert code == 0, err
    st = os.stat(out)
    assert stat.S_IMODE(st.st_mode) == mode and (st.st_uid, st.st_gid) == owner
    assert out.read_text().startswith("t,")
    assert leftovers(tmp_path) == ["f.csv"]


def test_a_hard_link_is_not_followed(tmp_path):
    # documented (README, "Command line"): the name gets a new file, the other name keeps the old one
    out, other = tmp_path / "f.csv", tmp_path / "g.csv"
    out.write_text("old\n")
    os.link(out, other)
    assert run("solve", SLIDER, "--steps", 5, "--out", out)[0] == 0
    assert other.read_text() == "old\n" and out.read_text().startswith("t,")


def test_the_named_temporary_fallback_keeps_the_mode_too(tmp_path, monkeypatch):
    monkeypatch.setattr(output, "_links_unnamed", lambda directory: False)   # no O_TMPFILE
    out = tmp_path / "f.txt"
    out.write_text("old\n")
    os.chmod(out, 0o600)
    output.write_atomic(out, lambda f: f.write(b"new\n"))
    assert out.read_text() == "new\n" and stat.S_IMODE(os.stat(out).st_mode) == 0o600
    assert leftovers(tmp_path) == ["f.txt"]
