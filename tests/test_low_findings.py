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
                       **{"cwd": ROOT, "timeout": 300, **kw})
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


def test_a_fifo_case_file_without_a_writer_is_one_line_not_a_hang(tmp_path, monkeypatch, capsys):
    from kinem.cli import main

    fifo = tmp_path / "case.toml"
    os.mkfifo(fifo)
    monkeypatch.setattr(output, "FIFO_WAIT", 0.2)
    assert main(["info", str(fifo)]) == 2
    assert capsys.readouterr().err.strip() == (f"kinem: error: {fifo}: cannot read: a FIFO with no writer "
                                               "(waited 0.2 s)")


def test_a_fifo_case_file_with_a_writer_is_read(tmp_path, capsys):
    import threading

    from kinem.cli import main

    fifo = tmp_path / "case.toml"
    os.mkfifo(fifo)
    writer = threading.Thread(target=lambda: fifo.write_bytes(SLIDER.read_bytes()))
    writer.start()
    try:
        assert main(["info", str(fifo)]) == 0
    finally:
        writer.join()
    assert "case slider_crank" in capsys.readouterr().out


def test_a_fifo_output_without_a_reader_is_one_line_exit_1(tmp_path, monkeypatch, capsys):
    from kinem.cli import main

    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    monkeypatch.setattr(output, "FIFO_WAIT", 0.2)
    assert main(["solve", str(SLIDER), "--steps", "3", "--out", str(fifo)]) == 1
    assert capsys.readouterr().err.strip() == (f"kinem: error: {fifo}: write failed: the FIFO has no reader "
                                               "(waited 0.2 s)")


def test_out_through_a_dangling_link_names_the_missing_folder(tmp_path):
    link = tmp_path / "out.csv"
    link.symlink_to(tmp_path / "missing" / "x.csv")
    code, _, err = run("solve", SLIDER, "--steps", 3, "--out", link)
    assert code == 2 and err.strip() == (f"kinem: error: {link}: cannot write: directory {tmp_path / 'missing'} "
                                         "(where the symbolic link points) does not exist")


@pytest.mark.parametrize("args", [("solve", SLIDER, "--steps", 3, "--out", ""),
                                  ("solve", SLIDER, "--steps", 3, "--diagnostics", "", "--out", os.devnull),
                                  ("export", SLIDER, "--engine", "mujoco", "--out", "")])
def test_an_empty_out_is_a_bad_path(args):
    code, out, err = run(*args)
    assert code == 2 and out == "" and "an empty path" in err and len(err.splitlines()) == 1


def test_a_far_mechanism_is_told_it_is_beyond_double_precision():
    import tomllib

    import kinem

    with open(SLIDER, "rb") as f:
        d = tomllib.load(f)
    for b in d["bodies"].values():
        b["q"][0] += 1e8                       # 1e8 mm from the origin: eps there is 1.5e-8 mm
    next(c for c in d["constraints"] if c["type"] == "ground")["value"][0] += 1e8
    d["time"] = {"end": 0.1, "steps": 2}
    r = kinem.solve(kinem.compile(kinem.load_dict(d)))
    assert not r.success and "the mechanism is 1e+08 mm from the origin" in r.message
    assert "cannot close" not in r.message


def test_a_port_that_is_not_dask_is_named_so():
    import socket
    import threading

    from kinem import parallel

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    held = []

    def answer():   # an HTTP answer where Dask expects a frame length
        c, _ = server.accept()
        c.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello" * 4)
        held.append(c)

    threading.Thread(target=answer, daemon=True).start()
    try:
        with pytest.raises(parallel.InputError) as e:
            parallel.connect(f"tcp://127.0.0.1:{server.getsockname()[1]}")
    finally:
        for c in held:
            c.close()
        server.close()
    assert "not in Dask's protocol" in str(e.value) and "EiB" not in str(e.value)


def test_a_function_table_with_a_stray_key_names_it(tmp_path):
    text = SLIDER.read_text().replace("d = { poly = [5.76, -1.2] }", 'd = { poly = [5.76, -1.2], "type " = 1.0 }')
    assert '"type "' in text
    case = tmp_path / "case.toml"
    case.write_text(text)
    code, _, err = run("info", case)
    assert code == 2 and "key 'd': unknown key 'type ' beside 'poly'" in err


@pytest.mark.parametrize("command", [("info",), ("solve", "--steps", "3", "--out", "o\nx/f.csv"),
                                     ("export", "--engine", "mujoco", "--out", "o\nx/f.xml"),
                                     ("animate", "--engines", "native", "--out", "o\nx/f.svg")])
def test_a_newline_in_a_path_keeps_errors_on_one_line(tmp_path, command):
    folder = tmp_path / "a\nb"
    folder.mkdir()
    case = folder / "case.toml"
    case.write_text(SLIDER.read_text().replace('name = "slider_crank"', 'name = "slider crank"'))
    code, out, err = run(command[0], case, *command[1:], cwd=tmp_path)
    assert code == 2 and len(err.splitlines()) == 1 and "\\n" in err


@pytest.mark.parametrize("command", [("export", "--engine", "mujoco"), ("animate", "--engines", "native")])
def test_the_file_written_is_printed_on_one_line(tmp_path, command):
    folder = tmp_path / "a\nb"
    folder.mkdir()
    out = folder / ("f.xml" if command[0] == "export" else "f.svg")
    code, stdout, err = run(command[0], SLIDER, *command[1:], "--out", out)
    assert code == 0, err
    assert stdout.splitlines() == [str(out).replace("\n", "\\n")] and out.exists()
