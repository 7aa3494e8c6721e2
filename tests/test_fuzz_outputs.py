"""The commands part 2 left uncovered keep the command line's contract
(docs/benchmarks.md, "Fuzz campaign, session 24"): ``kinem animate`` to
.svg, .gif and .mp4 whatever its output is (a regular file, a directory, a
symbolic link, a dangling one, a read-only file, a name with no or an
unknown suffix, a trailing '/') and its engines: exit 0 with the whole
animation where the path asked for it (a link written through and kept),
or exit 1 or 2 with one line and the old content and nothing else left;
an mp4 stopped by Ctrl-C is exit 130, not ffmpeg's error; the scratch file
that cannot be written is a failed write naming the output; ``kinem engines``
refuses what it would ignore; ``engines.update`` writes as every output.

CI runs a small derandomised budget (tests/conftest.py); KINEM_FUZZ_EXAMPLES
raises it, HYPOTHESIS_PROFILE=dev randomises it. The examples below the fuzz
test are the failures the campaign found, each fixed."""
import contextlib
import errno
import io
import os
import signal
import stat
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from kinem import engines
from kinem.cli import main
from kinem.errors import InputError, OutputError
from kinem.report import animate
from test_fuzz import SHORT, budget, run_main

ROOT = Path(__file__).resolve().parents[1]
OLD = b"old content"
KINDS = ("new", "file", "read-only", "directory", "link-to-file", "dangling-link", "link-to-directory",
         "link-to-read-only", "missing-directory", "trailing-slash")
SUFFIXES = (".svg", ".gif", ".GIF", ".mp4", "", ".png", ".svg.tmp")


def _target(tmp, kind, suffix):
    """An output path of ``kind``; returns (path to pass, the file the old content is in or None)."""
    out, real = tmp / f"out{suffix}", tmp / "real"
    if kind == "file":
        out.write_bytes(OLD)
        return str(out), out
    if kind == "read-only":
        out.write_bytes(OLD)
        out.chmod(0o444)
        return str(out), out
    if kind == "directory":
        out.mkdir()
        return str(out), None
    if kind.startswith("link-to"):
        if kind == "link-to-directory":
            real.mkdir()
        else:
            real.write_bytes(OLD)
            if kind == "link-to-read-only":
                real.chmod(0o444)
        out.symlink_to(real)
        return str(out), None if kind == "link-to-directory" else real
    if kind == "dangling-link":
        out.symlink_to(real)
        return str(out), None
    if kind == "missing-directory":
        return str(tmp / "nowhere" / f"out{suffix}"), None
    if kind == "trailing-slash":
        return str(out) + "/", None
    return str(out), None


@budget(14)
@given(kind=st.sampled_from(KINDS), suffix=st.sampled_from(SUFFIXES),
       engines_=st.sampled_from(["native", "", ",", "native,native", "nope", "NATIVE"]))
def test_animate_outputs(tmp_path_factory, kind, suffix, engines_):
    """Exit 0 writes the whole animation where the path points (a link kept
    as a link); any other exit leaves the old content and no new file."""
    tmp = tmp_path_factory.mktemp("animate")
    case = tmp / "case.toml"
    case.write_text(SHORT)
    out, old = _target(tmp, kind, suffix)
    before = {p.name for p in tmp.iterdir()}
    code, line = run_main(["animate", str(case), "--out", out, "--engines", engines_])
    if code == 0:
        written = Path(os.path.realpath(out))
        assert written.is_file() and stat.S_ISREG(written.stat().st_mode)
        head = written.read_bytes()[:12]
        assert head.startswith({".svg": b"<?xml", ".gif": b"GIF8"}.get(suffix.lower(), b"")) and \
            (suffix.lower() != ".mp4" or head[4:8] == b"ftyp")
        assert kind not in ("read-only", "link-to-read-only", "directory", "link-to-directory", "trailing-slash")
        if kind.endswith("link"):
            assert os.path.islink(out)
        return
    assert code in (1, 2) and line
    if old is not None:
        assert old.read_bytes() == OLD
    assert {p.name for p in tmp.iterdir()} == before     # nothing beside the named outputs
    if kind in ("read-only", "link-to-read-only") and suffix.lower() in animate.FORMATS and engines_ not in (
            "nope", "NATIVE", "", ","):
        assert code == 1 and "read-only" in line


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
@pytest.mark.parametrize("kind", ["directory", "trailing-slash"])
def test_found_animate_to_a_directory_refused_before_the_run(tmp_path, monkeypatch, suffix, kind):
    """--out x.gif/ wrote the file x.gif (exit 0); --out of an existing
    directory was refused only after the runs and the drawing. Both are
    refused at once now (the solve is never reached)."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    out = tmp_path / f"x{suffix}"
    if kind == "directory":
        out.mkdir()
    monkeypatch.setattr(animate, "frames", lambda *a: pytest.fail("the case was run"))
    code, line = run_main(["animate", str(case), "--out", str(out) + ("/" if kind == "trailing-slash" else ""),
                           "--engines", "native"])
    assert code == 2 and "a directory" in line
    assert out.is_dir() if kind == "directory" else not out.exists()


def test_found_solve_to_a_path_ending_in_a_slash(tmp_path):
    """kinem solve --out y.csv/ wrote the file y.csv (exit 0): the '/' was
    dropped by realpath. A path ending in '/' names a directory: exit 2."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    code, line = run_main(["solve", str(case), "--out", str(tmp_path / "y.csv") + "/"])
    assert code == 2 and "names a directory" in line
    assert not (tmp_path / "y.csv").exists()


@contextlib.contextmanager
def _scratch_in(folder):
    yield str(Path(folder) / "scratch"), str(folder)


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_found_scratch_file_that_cannot_be_written(tmp_path, monkeypatch, suffix):
    """The scratch file the GIF or MP4 is drawn into could not be written
    (a full or missing temporary folder): a GIF's OSError was read as a
    write to standard output ("standard output: write failed", or exit 3
    for ENOENT), an MP4's ffmpeg failure was an internal error (exit 3,
    CalledProcessError) after matplotlib's multi-line log. Now exit 1, one
    line naming the output and the temporary folder."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    monkeypatch.setattr(animate, "_scratch", lambda ext: _scratch_in(tmp_path / "gone"))
    out = tmp_path / f"a{suffix}"
    code, line = run_main(["animate", str(case), "--out", str(out), "--engines", "native"])
    assert code == 1 and line.startswith(f"kinem: error: {out}: write failed: ") and str(tmp_path / "gone") in line
    assert not out.exists()


def test_found_gif_scratch_disk_full_is_not_standard_output(tmp_path, monkeypatch):
    """ENOSPC from the GIF's scratch file was reported as 'standard output: write failed'."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)

    def full(path, images, fps):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(animate, "_save_gif", full)
    code, line = run_main(["animate", str(case), "--out", str(tmp_path / "a.gif"), "--engines", "native"])
    assert code == 1 and "standard output" not in line and "a.gif: write failed: No space left on device" in line


@pytest.mark.parametrize("sig, stop", [(signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, SystemExit)])
def test_found_ctrl_c_stops_an_mp4_cleanly(tmp_path, sig, stop):
    """Ctrl-C reaches the whole process group: ffmpeg stops too, and the
    movie writer's finish raised CalledProcessError over the
    KeyboardInterrupt (exit 3, 'internal error: ... died with SIGINT', in 4
    of 8 tries by hand). Now the interrupt goes on (exit 130; SIGTERM's
    SystemExit alike)."""
    import numpy as np
    from matplotlib import animation

    assert animate.ffmpeg()
    writer = animation.FFMpegWriter(fps=10, extra_args=["-f", "mp4"])
    images = [np.zeros((40, 40, 3), np.uint8)] * 5
    grab, count = writer.grab_frame, [0]

    def grab_then_interrupt():
        grab()
        count[0] += 1
        if count[0] == 2:   # the terminal's signal to both: ffmpeg ends (here killed: its own SIGINT
            os.kill(writer._proc.pid, signal.SIGKILL)   # handler may wait for the rest of a frame), then
            writer._proc.wait()                         # kinem's handler raises
            raise stop(128 + sig) if stop is SystemExit else stop()
    writer.grab_frame = grab_then_interrupt
    with pytest.raises(stop):
        animate._save_frames(writer, images, 100, str(tmp_path / "x.mp4"))


def test_ctrl_c_exit_of_an_mp4(tmp_path, monkeypatch):
    """The same through the command line: exit 130, nothing on standard error, no file."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    save = animate._save_frames

    def interrupted(writer, images, dpi, path):
        grab = writer.grab_frame

        def once():
            grab()
            os.kill(writer._proc.pid, signal.SIGKILL)
            writer._proc.wait()
            raise KeyboardInterrupt
        writer.grab_frame = once
        save(writer, images, dpi, path)
    monkeypatch.setattr(animate, "_save_frames", interrupted)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["animate", str(case), "--out", str(tmp_path / "a.mp4"), "--engines", "native"])
    assert code == 130 and err.getvalue() == "" and not (tmp_path / "a.mp4").exists()


@pytest.mark.parametrize("args", [
    ["engines", "--tune", ","], ["engines", "--tune", ",,"], ["engines", "--quick"], ["engines", "--json"],
    ["engines", "--quick", "--json"], ["engines", "--tune", "pymunk", "--quick", "--update-docs"],
])
def test_found_engines_options_that_did_nothing(args):
    """--tune ',' swept no engine and printed an empty line (exit 0);
    --quick and --json without --tune were ignored (the support matrix
    printed); --update-docs with --tune was ignored (the sweep ran, the docs
    were not updated). Each is refused now, exit 2, before any sweep."""
    code, line = run_main(args)
    assert code == 2 and line.startswith("kinem: error: --")


@pytest.mark.parametrize("tune", ["nope", "native", "Pymunk", "pymunk mujoco", "pymunk,nope", "x" * 3000])
def test_engines_tune_names_refused(tune):
    code, line = run_main(["engines", "--tune", tune, "--quick"])
    assert code == 2 and line.startswith("kinem: error: --tune: got ")


def _stale(path):
    text = (ROOT / "docs" / "engines.md").read_text()
    head, _, rest = text.partition(engines.BEGIN)
    path.write_text(head + engines.BEGIN + "\nstale\n" + engines.END + rest.partition(engines.END)[2])


def test_found_update_docs_writes_as_every_output(tmp_path, monkeypatch):
    """engines.update (kinem engines --update-docs) wrote with
    Path.write_text: a read-only file was overwritten where the process may
    (root), a failure left a truncated file, a missing file or a directory
    was exit 3, and a file without the generated section got one appended.
    Now a read-only file is refused and kept, the others are bad input,
    and a symbolic link is written through."""
    monkeypatch.setattr(engines, "markdown", lambda: "generated\n")   # the section's content is not the point
    ro = tmp_path / "ro.md"
    _stale(ro)
    ro.chmod(0o444)
    with pytest.raises(OutputError, match="read-only"):
        engines.update(ro)
    assert "\nstale\n" in ro.read_text()
    for bad in (tmp_path / "missing.md", tmp_path):
        with pytest.raises(InputError, match="cannot read"):
            engines.update(bad)
    plain = tmp_path / "plain.md"
    plain.write_text("no section\n")
    with pytest.raises(InputError, match="no generated section"):
        engines.update(plain)
    assert plain.read_text() == "no section\n"
    real, link = tmp_path / "real.md", tmp_path / "link.md"
    _stale(real)
    link.symlink_to(real)
    assert engines.update(link) is True and link.is_symlink()
    assert engines.markdown() in real.read_text() and engines.update(link) is False


def test_found_report_into_a_dangling_link(tmp_path, monkeypatch):
    """kinem report --out LINK, LINK a symbolic link to nothing: every case
    ran (27 s for one four-bar), then "--out LINK: cannot write: File
    exists" (exit 2). Now refused before the runs, naming the link's target."""
    from kinem.report import execute

    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "nowhere")
    monkeypatch.setattr(execute, "execute", lambda *a, **k: pytest.fail("the cases were run"))
    code, line = run_main(["report", str(case), "--out", str(link), "--engines", "pymunk", "--baseline", "none",
                           "--jobs", "1"])
    assert code == 2 and "nowhere, which does not exist" in line
    assert link.is_symlink() and not (tmp_path / "nowhere").exists()


@pytest.mark.parametrize("after", [5.0, 0.0])
def test_found_ctrl_c_swallowed_by_a_callback(monkeypatch, after):
    """Ctrl-C during kinem engines --tune landed in cffi's collector of a
    pymunk body (1 of 10 tries by hand): "Exception ignored from callback
    for ffi.gc ... Traceback ... KeyboardInterrupt" on standard error, and
    the sweep went on to exit 0. Now the interrupt is raised again outside
    the callback: exit 130, nothing printed; swallowed as the command ends
    (``after`` 0), exit 130 too and no Ctrl-C after main returned."""
    import importlib
    import time

    import cffi

    cli_parser = importlib.import_module("kinem.cli.parser")   # the module (kinem.cli.parser is its function)

    def command(a):
        ffi = cffi.FFI()

        def collect(_):
            raise KeyboardInterrupt   # where the signal lands
        thing = ffi.gc(ffi.new("int *"), collect)
        del thing
        end = time.monotonic() + after
        while time.monotonic() < end:
            time.sleep(0.001)
        return 0
    monkeypatch.setattr(cli_parser, "cmd_engines", command)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["engines"])
    time.sleep(0.1)   # a Ctrl-C raised again after main returned would land here
    assert code == 130 and err.getvalue() == "", err.getvalue()


def test_found_report_of_a_case_that_fails_with_a_design_section(tmp_path):
    """A case whose native run fails (it cannot assemble) and whose file
    asks for [report] sensitivity: the report ran every case, then the
    design section's kinem.sensitivity raised "the nominal solve failed"
    out of the whole report (exit 1, nothing written, the good cases' page
    lost). Now the page is written, the case's failure in it, the design
    section said not computed: exit 1 as for any native failure."""
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    apart = text.replace('name = "four_bar"', 'name = "apart"').replace(
        'O4 = { body = "ground", at = [0.2, 0.0] }', 'O4 = { body = "ground", at = [20.0, 0.0] }').replace(
        "end = 2.5\nsteps = 250", "end = 0.1\nsteps = 4")
    assert apart.count("20.0, 0.0") == 1 and "steps = 4" in apart and "sensitivity = [" in apart
    case, out = tmp_path / "apart.toml", tmp_path / "out"
    case.write_text(apart)
    err, said = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(said):
        code = main(["report", str(case), "--engines", "native", "--quick", "--baseline", "none", "--jobs", "0",
                     "--out", str(out)])
    assert code == 1 and err.getvalue() == "", err.getvalue()   # the report's own line is on standard output
    assert "1 failed" in said.getvalue() and "FAILED" in said.getvalue()
    assert "Not computed: native's run of the case failed" in (out / "index.html").read_text()
    assert (out / "manifest.json").is_file()


# -- part 4: what part 3 found and left ------------------------------------------------------------

def _old_report(out):
    from kinem import report

    report.write_outputs(out, {"results.json": "old", "summary.md": "old", "index.html": "old", "junit.xml": "old"})
    (out / "baseline.json").write_text("old")
    assert report.complete(out)


@pytest.mark.parametrize("name, kind", [("results.json", "read-only"), ("summary.md", "read-only"),
                                        ("index.html", "directory"), ("junit.xml", "directory"),
                                        ("manifest.json", "directory"), ("results.json", "dangling-link"),
                                        ("manifest.json", "read-only"), ("baseline.json", "read-only")])
def test_found_report_outputs_checked_before_the_runs(tmp_path, monkeypatch, name, kind):
    """kinem report found a read-only file or a directory among its outputs in
    --out only when it wrote, after every run; by then the old manifest.json
    was gone, so the old report no longer read as whole. Now every output
    (junit.xml with --junit, the baseline with --update-baseline) is checked
    first: exit 2, one line naming the file, nothing run, the old report kept."""
    from kinem import report
    from kinem.report import execute

    case, out = tmp_path / "case.toml", tmp_path / "out"
    case.write_text(SHORT)
    _old_report(out)
    path = out / name
    if kind == "read-only":
        path.chmod(0o444)
    else:
        path.unlink()
        if kind == "directory":
            path.mkdir()
        else:
            path.symlink_to(tmp_path / "nowhere" / name)
    monkeypatch.setattr(execute, "execute", lambda *a, **k: pytest.fail("the cases were run"))
    code, line = run_main(["report", str(case), "--out", str(out), "--engines", "native", "--jobs", "0", "--junit",
                           *(["--update-baseline"] if name == "baseline.json" else ["--baseline", "none"])])
    assert code == 2 and str(path) in line, line
    assert {"read-only": "read-only", "directory": "is a directory", "dangling-link": "does not exist"}[kind] in line
    assert report.complete(out) is (kind == "read-only")   # a directory or link: the old report lacks a file
    assert (out / "manifest.json").is_file() is (name != "manifest.json" or kind == "read-only")


def test_found_report_out_under_a_file(tmp_path, monkeypatch):
    """--out a path under a regular file: every run, then "cannot write: Not
    a directory" at the end. Now refused first."""
    from kinem.report import execute

    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    monkeypatch.setattr(execute, "execute", lambda *a, **k: pytest.fail("the cases were run"))
    code, line = run_main(["report", str(case), "--out", str(case / "out"), "--engines", "native", "--baseline", "none",
                           "--jobs", "0"])
    assert code == 2 and f"{case} is not a directory" in line, line


def test_report_output_gone_bad_during_the_runs(tmp_path):
    """A file made read-only while the cases ran is refused when the report
    writes (exit 1, as any refused output) before the old manifest is
    removed: the old report stays whole, no new file mixed into it; a write
    that fails part-way leaves no manifest (test_report.py)."""
    from kinem import report

    out = tmp_path / "out"
    _old_report(out)
    (out / "summary.md").chmod(0o444)
    with pytest.raises(OutputError, match="summary.md: cannot write: the file is read-only"):
        report.write_outputs(out, {"results.json": "new", "summary.md": "new", "index.html": "new"})
    assert report.complete(out) and (out / "results.json").read_text() == "old"


@pytest.mark.parametrize("command", ["compare", "report", "stress"])
def test_found_timeout_without_a_scheduler(tmp_path, monkeypatch, command):
    """--timeout without --scheduler was accepted and did nothing (it bounds
    a run on a Dask cluster only). Now refused: exit 2, one line, nothing run."""
    from adapters import compare

    from kinem import parallel, stress
    from kinem.report import execute

    monkeypatch.setattr(parallel, "RUN_TIMEOUT", parallel.RUN_TIMEOUT)   # --timeout sets it while parsing
    for module, name in ((compare, "run_case"), (execute, "execute"), (stress, "run")):
        monkeypatch.setattr(module, name, lambda *a, **k: pytest.fail("ran"))
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    args = {"compare": [str(case)], "report": [str(case), "--out", str(tmp_path / "out"), "--baseline", "none"],
            "stress": ["--quick"]}[command]
    code, line = run_main([command, *args, "--timeout", "5"])
    assert code == 2 and "--timeout 5: only with --scheduler" in line, line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("engines_", ["", ",", " , "])
def test_found_animate_empty_engines_refused_as_compare(tmp_path, engines_):
    """kinem animate --engines '' (or ',') drew native alone where kinem
    compare refused the same value. Now both refuse it with the same line
    (exit 2); --engines native draws native alone."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    code, line = run_main(["animate", str(case), "--out", str(tmp_path / "a.svg"), "--engines", engines_])
    assert (code, line) == run_main(["compare", str(case), "--engines", engines_])
    assert code == 2 and "--engines: got" in line and not (tmp_path / "a.svg").exists()


# -- session 26, part 7 (docs/benchmarks.md, "Fuzz campaign, session 26") ----------------------------------

NAMED = ROOT / "tests" / "data" / "four_bar_named.toml"
FIFO_COMMANDS = {
    "sweep": (["sweep", str(NAMED), "--set", "crank=0.1,0.11", "--outputs", "B.x"], "kinem.sweep",
              "sweep"),
    "tolerance": (["tolerance", str(ROOT / "cases" / "four_bar.toml"), "--samples", "2", "--steps", "3"],
                  "kinem.tolerance", "tolerance"),
    "sensitivity": (["sensitivity", str(NAMED), "--parameters", "crank", "--steps", "3"], "kinem.sensitivity",
                    "sensitivity"),
}


@pytest.mark.parametrize("command", sorted(FIFO_COMMANDS))
def test_found_a_fifo_without_a_reader_after_the_work(tmp_path, monkeypatch, command):
    """An --out that is a FIFO no one reads was found only when written, after every variant or sample was
    solved (then 10 s more). Now it is opened before the work, as the shell's > opens it (its reader waited
    for, FIFO_WAIT at most): without one, exit 1 in one line and nothing run; never a wait without end."""
    import importlib

    from kinem import output

    args, module, name = FIFO_COMMANDS[command]
    monkeypatch.setattr(importlib.import_module(module), name, lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(output, "FIFO_WAIT", 0.2)
    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    code, line = run_main([*args, "--out", str(fifo)])
    assert (code, line) == (1, f"kinem: error: {fifo}: write failed: the FIFO has no reader (waited 0.2 s)")
    assert not output.HELD


def _read_fifo_while(tmp_path, args, **run):
    """run_main(args + --out FIFO) with a reader of the FIFO on a thread: (code, line, what it read)."""
    import threading

    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    try:
        code, line = run_main([*args, "--out", str(fifo)], **run)
    finally:
        reader.join(60)
    return code, line, got


@pytest.mark.parametrize("command", sorted(FIFO_COMMANDS))
def test_a_fifo_with_a_reader_is_written_through_after_the_work(tmp_path, command):
    from kinem import output

    code, line, got = _read_fifo_while(tmp_path, FIFO_COMMANDS[command][0], notes=command == "tolerance")
    assert code == 0, line
    assert got and got[0].count(b"\n") >= 3 and not output.HELD, got
    assert sorted(os.listdir(tmp_path)) == ["out.csv"]


def test_a_fifo_opened_before_a_failed_call_is_closed(tmp_path):
    """A FIFO opened before the work of a call that then fails (a bad --set after the output was checked):
    closed when the command ends, its reader sees an empty output at once instead of waiting for the
    process to exit."""
    from kinem import output

    code, line, got = _read_fifo_while(tmp_path, ["sweep", str(NAMED), "--set", "crank=x"])
    assert code == 2 and "--set: got 'crank=x'" in line, line
    assert got == [b""] and not output.HELD


# -- session 26, part 7, part B: kinem compare's options and the report's text ------------------------------

@pytest.mark.parametrize("args, said", [
    (["--engines", "pymunk", "--set", "pymunk.dt=0.001", "--set", "pymunk.dt=0.002"],
     "--set: 'pymunk.dt' given twice; expected each setting once"),
    (["--engines", "pymunk", "--set", "pymunk.dt=0.001", "--dt", "0.002"],
     "--dt and --set pymunk.dt: give one (--dt sets every engine's dt)"),
    (["--engines", "native", "--set", "pymunk.dt=0.001"],
     "--set: got 'pymunk.dt=0.001', but pymunk does not run (--engines native)"),
    (["--engines", "native", "--dt", "0.001"], "--dt: no engine runs (--engines native)"),
    (["--engines", "native", "--sensitivity", ""], "--sensitivity: got ''; expected design parameter paths"),
    (["--engines", "native", "--sensitivity", ","], "--sensitivity: got ','; expected design parameter paths"),
])
def test_found_compare_options_ignored_unseen(tmp_path, monkeypatch, args, said):
    """kinem compare took the later of a setting given twice, ignored --dt for an engine whose dt --set gave,
    ignored a setting or --dt of an engine that does not run, and read --sensitivity '' (an unset shell
    variable) or ',' as the case's [report] sensitivity: each ran something else than asked, exit 0.
    Now each is refused in one line before anything runs (--sensitivity alone still means the case's list)."""
    import adapters.compare
    import adapters.sensitivity

    monkeypatch.setattr(adapters.compare, "run_case", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(adapters.sensitivity, "check", lambda *a, **k: pytest.fail("ran"))
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    code, line = run_main(["compare", str(case), *args])
    assert code == 2 and said in line, line


def test_found_compare_engines_given_twice_run_twice(tmp_path, capsys):
    """kinem compare --engines pymunk,pymunk ran pymunk twice (two rows, twice the time; the report ran it
    once). Now each engine once, in the order first given."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    assert main(["compare", str(case), "--engines", "native,native", "--json"]) == 0
    import json

    assert list(json.loads(capsys.readouterr().out)["engines"]) == ["native"]
    from kinem.cli.args import engine_list

    assert engine_list("pymunk, native,pymunk") == ["pymunk", "native"]


def test_found_hidden_characters_in_the_report(tmp_path):
    """A case's description (any TOML string: "\\u0000", "\\u0007", "\\u202e", a right-to-left override that
    reorders what the reader sees) and its file's path (any bytes but '/') reached index.html escaped for
    HTML but with their control characters raw (a NUL in the page), and summary.md and junit.xml take
    messages quoting paths (a '|' ends a table cell, a newline a list item, a control character makes
    junit.xml invalid XML). Now every report text not kinem's own shows such a character as its \\uXXXX code,
    and summary.md escapes '|' and '<'."""
    import xml.dom.minidom

    from kinem.report import Options, run
    from kinem.report.escaping import escape, md, xml_attr, xml_text

    hostile = "<script>x</script> | a\x07b\x00c\u202ed\n- e\x1b[31m"
    assert escape(hostile) == ("&lt;script&gt;x&lt;/script&gt; | a\\u0007b\\u0000c\\u202ed\n- e\\u001b[31m")
    assert md(hostile) == "\\<script>x\\</script> \\| a\\u0007b\\u0000c\\u202ed - e\\u001b[31m"
    xml.dom.minidom.parseString(f"<a b={xml_attr(hostile)}>{xml_text(hostile)}</a>")
    case = tmp_path / "a|<b>\x1b[31m\u202e.toml"
    case.write_text(SHORT.replace('description = "', 'description = "<script>x</script>', 1))   # its controls:
    # refused by the loader since session 27 (test_found_description_with_control_characters); the path keeps them
    outcome = run(Options(cases=(str(case),), engines=(), out=str(tmp_path / "r"), quick=True, junit=True,
                          workers=0, progress=False))
    assert outcome.exit_code == 0, outcome.detail
    page = (tmp_path / "r" / "index.html").read_text(encoding="utf-8")
    for text in (page, (tmp_path / "r" / "summary.md").read_text(encoding="utf-8")):
        assert not [c for c in text if (ord(c) < 32 and c not in "\n\t") or 0x7f <= ord(c) < 0xa0 or c == "\u202e"]
    assert "&lt;script&gt;x&lt;/script&gt;" in page and "a|&lt;b&gt;\\u001b[31m\\u202e.toml" in page
    xml.dom.minidom.parse(str(tmp_path / "r" / "junit.xml"))


@pytest.mark.parametrize("args, said", [
    (["--out", ""], "--out '': an empty path (an unset shell variable?); expected a directory"),
    (["--baseline", ""], "--baseline '': an empty path (an unset shell variable?); expected a results.json, or "
                         "--baseline none for no gate"),
])
def test_found_report_empty_out_or_baseline(tmp_path, monkeypatch, args, said):
    """kinem report --out '' (an unset shell variable) wrote the report into the working folder (Path('') is
    '.'), over any index.html there; --baseline '' ran without a gate, exit 0, as --baseline none. Now
    each is refused in one line before any case is read."""
    monkeypatch.chdir(tmp_path)
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    code, line = run_main(["report", str(case), "--engines", "native", "--quick", *args]
                          + (["--out", str(tmp_path / "r")] if args[0] != "--out" else []))
    assert code == 2 and said in line, line
    assert sorted(os.listdir(tmp_path)) == ["case.toml"]


@pytest.mark.parametrize("field, value, said", [
    ("cases", "case.toml", "expected a list of case file paths"),             # its characters as paths
    ("engines", "pymunk", "expected a list of engine names"),                # its characters: 6 failed runs
    ("engines", ("nope",), "expected a list of engine names"),               # a failed run, exit 1
    ("engines", None, "expected a list of engine names"),                    # TypeError
    ("workers", "2", "expected None (the core count) or a whole number"),    # TypeError
    ("workers", -1, "expected None (the core count) or a whole number"),     # RuntimeError: the schema, after the runs
    ("workers", True, "expected None (the core count) or a whole number"),
    ("quick", "no", "expected True or False"),                               # RuntimeError after the runs
    ("junit", None, "expected True or False"),
    ("stress", "yes", "expected True, False or None"),
    ("out", None, "expected a path"),                                        # TypeError
    ("baseline", 3, "expected a path or None"),                              # TypeError
    ("scheduler", 3, "expected None or a Dask scheduler address"),
])
def test_found_report_options_unchecked(tmp_path, monkeypatch, field, value, said):
    """kinem.report.run(Options(...)) checked none of its fields (the command line checks its options):
    a text for cases or engines was read character by character, an unknown engine was a failed run, and
    workers=-1 or quick='no' a RuntimeError (results.json against its schema) after every run. Now each
    is an InputError naming the field, before any case is read or run."""
    from kinem.report import Options, execute, run

    monkeypatch.setattr(execute, "execute", lambda *a, **k: pytest.fail("ran"))
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    given = dict(cases=(str(case),), engines=(), out=str(tmp_path / "r"), progress=False, workers=0)
    with pytest.raises(InputError) as e:
        run(Options(**dict(given, **{field: value})))
    assert f"report: Options({field}={value!r}): {said}" in str(e.value) and "\n" not in str(e.value), str(e.value)
    assert sorted(os.listdir(tmp_path)) == ["case.toml"]


def test_report_options_native_and_engines_once(tmp_path):
    """Options(engines=("native",)) ran native twice (two rows of one case); now native always runs once
    and each engine once, as the command line's --engines gives them."""
    from kinem.report import Options, run

    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    out = run(Options(cases=[case], engines=["native", "native"], out=str(tmp_path / "r"), quick=np.True_,
                      workers=np.int64(0), progress=np.False_))   # numpy's scalars as Python's
    assert out.exit_code == 0 and len(out.value.doc["cases"][0]["runs"]) == 1, out.detail
    assert out.value.doc["options"]["workers"] == 0 and out.value.doc["options"]["quick"] is True


def test_found_compare_too_long_for_memory(tmp_path, monkeypatch):
    """kinem compare --steps 10000000 (a four-bar): "internal error: MemoryError: Unable to allocate 2.68 GiB"
    under a 3 GB limit, exit 3 (native's positions, velocities and accelerations, and each engine's, are
    held whole). Now refused before the solve by the bound sweep, sensitivity and tolerance obey
    (kinem.budget.MAX_HELD), naming the sizes; compare --sensitivity was bounded already."""
    import kinem.solver

    monkeypatch.setattr(kinem.solver, "solve", lambda *a, **k: pytest.fail("ran"))
    code, line = run_main(["compare", str(ROOT / "cases" / "four_bar.toml"), "--engines", "native,pymunk",
                           "--steps", "5000000"])
    assert code == 2 and ("compare: 5,000,001 instants x 12 coordinates x 3 (positions, velocities, accelerations)"
                          " x 2 solution(s) = 3.6e+08 numbers exceeds") in line, line


ENGINE_TEXTS = ["native", "pymunk", "native,pymunk", "native,native", "pymunk,pymunk", "", ",", "nope", "NATIVE",
                "native,\x00", " native ", "mujoco", "exudyn"]
SET_TEXTS = ["pymunk.dt=0.001", "pymunk.dt=nan", "pymunk.dt=Infinity", "pymunk.dt=1e400", "pymunk.dt=[1]",
             "pymunk.iterations=true", "pymunk.iterations=1e18", "pymunk.nope=1", "nope.dt=1", "pymunk.=1", "=",
             "pymunk.dt", "mujoco.dt=0.001", "pymunk.dt=0", "pymunk.substeps=2000000000", "pymunk.dt=\"auto\""]
DT_TEXTS = ["0.001", "0", "-1", "nan", "inf", "1e-300", "1_0", "x", "1e400", "0x10"]
SENSITIVITY_TEXTS = [None, "", ",", "points.A.at.0", "points.A.at.0,points.A.at.0", "nope", "bodies.crank.q.0",
                     "crank", "\x1b[31m", "points.A.at.0,constraints.crank-drive.d.poly.1"]


@budget(20)
@given(st.data())
def test_compare_options_keep_the_contract(data):
    """kinem compare with odd --engines, --set, --dt and --sensitivity texts (alone: the case's list) on a
    short four-bar: exit 0, 1 or 2 with one line, never an internal error."""
    draw = data.draw
    args = ["compare", str(ROOT / "cases" / "four_bar.toml"), "--steps", "2",
            "--engines", draw(st.sampled_from(ENGINE_TEXTS))]
    for item in draw(st.lists(st.sampled_from(SET_TEXTS), max_size=2)):
        args += ["--set", item]
    if draw(st.booleans()):
        args += ["--dt", draw(st.sampled_from(DT_TEXTS))]
    sens = draw(st.sampled_from(SENSITIVITY_TEXTS + ["(alone)"]))
    if sens == "(alone)":
        args.append("--sensitivity")
    elif sens is not None:
        args += ["--sensitivity", sens]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(args)
    lines = [line for line in err.getvalue().splitlines() if not line.startswith("kinem: warning: ")]
    assert code in (0, 1, 2) and "Traceback" not in err.getvalue() and "internal error" not in err.getvalue(), lines
    # 2: one line; 0 and 1 (an engine or a check outside its tolerance: the table says which) none
    assert len(lines) == (code == 2) and all(line.startswith("kinem: ") for line in lines), (code, lines)


class _Ran(Exception):
    pass


@budget(40)
@given(st.fixed_dictionaries({}, optional={
    "cases": st.sampled_from([None, (), "x.toml", ["nope.toml"], [3], ("CASE",)]),
    "engines": st.sampled_from([None, (), "pymunk", ("native",), ("nope",), ["pymunk", "pymunk"], [None]]),
    "workers": st.sampled_from([None, 0, 1, -1, 2000, "2", True, 2.0]),
    "quick": st.sampled_from([True, False, None, "no", 1]),
    "junit": st.sampled_from([True, False, None, "yes"]),
    "progress": st.sampled_from([True, False, None, 3, "no"]),
    "stress": st.sampled_from([True, False, None, "no"]),
    "out": st.sampled_from(["", None, 3, "OUT"]),
    "baseline": st.sampled_from([None, "", 3, "none.json"]),
    "scheduler": st.sampled_from([None, 3, "", "tcp://127.0.0.1:1"]),
}))
def test_report_options_keep_the_contract(given_options):
    """kinem.report.run(Options(...)) with fields of any type: an InputError of one line, or the runs begin
    (replaced here by an exception of the test's own), never another exception."""
    import tempfile

    from kinem.report import Options, execute, run

    with tempfile.TemporaryDirectory(prefix="fuzz-report-") as tmp, pytest.MonkeyPatch.context() as mp:
        mp.setattr(execute, "execute", lambda *a, **k: (_ for _ in ()).throw(_Ran()))
        case = Path(tmp) / "case.toml"
        case.write_text(SHORT)
        o = dict(cases=(str(case),), engines=(), out=str(Path(tmp) / "r"), progress=False, workers=0)
        o.update({k: v for k, v in given_options.items()})
        o = {k: (str(case) if v == "CASE" else (str(case),) if v == ("CASE",) else
                 str(Path(tmp) / "r") if v == "OUT" else v) for k, v in o.items()}
        try:
            run(Options(**o))
        except _Ran:
            pass
        except InputError as e:
            assert "\n" not in str(e), str(e)


# -- session 27, part 9 (docs/benchmarks.md, "Fuzz campaign, session 27") --------------------------------------

@pytest.mark.parametrize("old", [True, False])
def test_found_update_baseline_with_baseline_none(tmp_path, monkeypatch, old):
    """kinem report --update-baseline --baseline none ran every case, then wrote OUT/baseline.json: --baseline
    says where the baseline is ('none': there is none, no gate), --update-baseline writes the run there.
    Together they contradict (docs/report.md): now refused in one line before any case is read, exit 2,
    the old baseline (if any) untouched; --update-baseline alone still writes OUT/baseline.json."""
    from kinem.report import execute

    case, out = tmp_path / "case.toml", tmp_path / "out"
    case.write_text(SHORT)
    if old:
        out.mkdir()
        (out / "baseline.json").write_text("old")
    monkeypatch.setattr(execute, "execute", lambda *a, **k: pytest.fail("the cases were run"))
    code, line = run_main(["report", str(case), "--out", str(out), "--engines", "native", "--jobs", "0",
                           "--update-baseline", "--baseline", "none"])
    assert code == 2 and "--update-baseline with --baseline none: none is no baseline" in line, line
    assert (out / "baseline.json").read_text() == "old" if old else not out.exists()


# -- session 27, part 9, part B: kinem animate's options ---------------------------------------------------------

def test_found_animate_fifo_and_read_only_after_the_work(tmp_path, monkeypatch):
    """kinem animate checked its --out's name (suffix, folder) but not the file: a FIFO no one reads was
    found after the runs (then 10 s more), a read-only file after them too, as sweep's were before part 7.
    Now kinem.output.check first, as sweep, sensitivity and tolerance: exit 1, one line, nothing run; with
    a reader, the FIFO is written through after the runs."""
    import threading

    from kinem import output
    from kinem.report import animate

    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    frames = animate.frames
    monkeypatch.setattr(animate, "frames", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(output, "FIFO_WAIT", 0.2)
    fifo = tmp_path / "a.svg"
    os.mkfifo(fifo)
    code, line = run_main(["animate", str(case), "--out", str(fifo), "--engines", "native"])
    assert (code, line) == (1, f"kinem: error: {fifo}: write failed: the FIFO has no reader (waited 0.2 s)")
    assert not output.HELD
    locked = tmp_path / "locked.svg"
    locked.write_text("old")
    locked.chmod(0o444)
    code, line = run_main(["animate", str(case), "--out", str(locked), "--engines", "native"])
    assert code == 1 and "read-only" in line and locked.read_text() == "old", line
    monkeypatch.setattr(animate, "frames", frames)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    try:
        code, line = run_main(["animate", str(case), "--out", str(fifo), "--engines", "native"])
    finally:
        reader.join(60)
    assert code == 0 and got and got[0].startswith(b"<?xml") and not output.HELD, (line, got)


def test_found_animate_beyond_memory(tmp_path):
    """kinem animate of a case whose [time] steps are 10,000,000: "internal error: MemoryError: Unable to
    allocate 2.68 GiB", exit 3 under a 3 GB limit (native's solution is held whole, then each engine's).
    Now refused before the solve, with compare's bound and words (kinem.budget.MAX_HELD), exit 2."""
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    case = tmp_path / "case.toml"
    case.write_text(text.replace("end = 2.5\nsteps = 250", "end = 2.5\nsteps = 10000000"))
    assert "steps = 10000000" in case.read_text()
    code, line = run_main(["animate", str(case), "--out", str(tmp_path / "a.svg"), "--engines", "native"])
    assert code == 2 and "animate: 10,000,001 instants x 12 coordinates x 3 (positions, velocities, " \
                         "accelerations) x 1 solution(s) = 3.6e+08 numbers exceeds" in line, line
    assert not (tmp_path / "a.svg").exists()


def test_found_animate_out_empty(tmp_path):
    """--out '' (an unset shell variable) read "--out : expected a file ending in .svg, .gif, .mp4"; now
    named as report's --out '' is."""
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    code, line = run_main(["animate", str(case), "--out", "", "--engines", "native"])
    assert code == 2 and "--out '': an empty path (an unset shell variable?)" in line, line


# -- session 27, part 9, part B: compare --scheduler with hostile values ------------------------------------------

@pytest.mark.parametrize("address, said", [
    ("nope", "--scheduler nope: not a scheduler address (missing port number"),
    ("", "--scheduler '': an empty address (an unset shell variable?); expected e.g. tcp://host:8786"),
    ("tcp://127.0.0.1:99999", "--scheduler tcp://127.0.0.1:99999: not a scheduler address (port 99999: expected 1 "
                              "to 65535)"),
])
def test_found_compare_scheduler_checked_after_the_solve(monkeypatch, address, said):
    """compare --scheduler checked the address only when the engines' runs began, after native's solve (a
    long case: its whole solve, then exit 2); '' read "--scheduler : not a scheduler address", and a port
    beyond 65535 waited CONNECT_TIMEOUT (10 s) for "Timed out trying to connect". Now the address's form is
    checked before the solve (nothing connected to yet), '' named as an unset variable, the port's range
    checked: exit 2 at once."""
    import kinem.solver

    monkeypatch.setattr(kinem.solver, "solve", lambda *a, **k: pytest.fail("native was solved"))
    code, line = run_main(["compare", str(ROOT / "cases" / "four_bar.toml"), "--engines", "native,pymunk",
                           "--scheduler", address])
    assert code == 2 and said in line, line


def test_found_compare_sensitivity_ignored_the_scheduler(monkeypatch):
    """compare --sensitivity --scheduler ADDRESS ran every check in this process, the address unread (any
    text, exit 0). Now refused, as an option that would be ignored is (part 7's --dt and --set)."""
    import adapters.sensitivity

    monkeypatch.setattr(adapters.sensitivity, "check", lambda *a, **k: pytest.fail("ran"))
    code, line = run_main(["compare", str(ROOT / "cases" / "four_bar.toml"), "--engines", "native", "--sensitivity",
                           "--scheduler", "nope"])
    assert code == 2 and "--scheduler with --sensitivity: the sensitivity checks run in this process" in line, line


# -- session 27, part 9, part B: Ctrl-C during kinem report ---------------------------------------------------------

def interrupt_when_ready(p):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) once p says READY on standard error: p
    ends within the wait's bound (30 s, a hang's; not a timing) with exit 130 and nothing said, its whole
    group gone."""
    try:
        assert p.stderr.readline() == "READY\n"
        os.killpg(p.pid, signal.SIGINT)
        said, err = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    assert (p.returncode, said, err) == (130, "", ""), (p.returncode, said, err)
    with pytest.raises(ProcessLookupError):
        os.killpg(p.pid, 0)


REPORT_CTRL_C = """
import sys, time
import kinem.report as r
from kinem.report import execute
from kinem.cli import main

phase = sys.argv[1]
write, run = r._write, execute.execute
def ready():
    sys.stderr.write("READY\\n"); sys.stderr.flush(); time.sleep(30)
def slow_write(path, body):   # the second file: the old manifest gone, one new file written
    if path.name == "summary.md":
        ready()
    return write(path, body)
def slow_execute(*a, **k):
    ready()
    return run(*a, **k)
r._write, execute.execute = slow_write, slow_execute if phase == "runs" else run
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.parametrize("phase", ["runs", "writing"])
def test_ctrl_c_during_report(tmp_path, phase):
    """Ctrl-C (SIGINT to the process group of a command started in its own session, as a terminal sends it)
    during kinem report's runs or while it writes its files: exit 130 at once, nothing printed, no process of
    the group left, no temporary file in --out; during the runs the old report stays whole, while writing
    the old manifest is gone, so the mix never reads as a report (kinem.report.complete). Found sound."""
    import subprocess
    import sys

    from kinem import report

    out = tmp_path / "out"
    report.write_outputs(out, {"results.json": "old", "summary.md": "old", "index.html": "old"})
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    p = subprocess.Popen([sys.executable, "-c", REPORT_CTRL_C, phase, "report", str(case), "--engines", "native",
                          "--quick", "--baseline", "none", "--jobs", "0", "--out", str(out)], cwd=ROOT,
                         start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    interrupt_when_ready(p)
    names = sorted(x.name for x in out.iterdir())
    if phase == "runs":
        assert report.complete(out) and (out / "summary.md").read_text() == "old", names
    else:
        assert not report.complete(out) and names == ["index.html", "results.json", "summary.md"], names
        assert (out / "results.json").read_text() != "old" and (out / "summary.md").read_text() == "old"


# -- session 28, part 10 (docs/benchmarks.md, "Fuzz campaign, session 28"): animate's mp4 and Ctrl-C --------------

def test_mp4_without_ffmpeg(tmp_path):
    """animate to .mp4 where no ffmpeg runs (imageio-ffmpeg's binary pointed at a missing file, none on PATH):
    one line, exit 2, before the case is solved, nothing written, an old file kept. Found sound."""
    import subprocess
    import sys

    out = tmp_path / "a.mp4"
    for old in (False, True):
        if old:
            out.write_bytes(OLD)
        env = dict(os.environ, IMAGEIO_FFMPEG_EXE=str(tmp_path / "no-ffmpeg"), PATH=str(tmp_path))
        p = subprocess.run([sys.executable, "-m", "kinem", "animate", str(ROOT / "cases" / "four_bar.toml"), "--out",
                            str(out), "--engines", "native"], cwd=ROOT, env=env, capture_output=True, text=True,
                           timeout=120)
        assert (p.returncode, p.stdout) == (2, ""), p
        assert p.stderr == f"kinem: error: --out {out}: mp4 needs ffmpeg, which is not installed; write .svg or " \
                           ".gif instead\n", p.stderr
        assert (out.read_bytes() == OLD) if old else not out.exists()
        assert sorted(x.name for x in tmp_path.iterdir()) == (["a.mp4"] if old else [])


def test_ffmpeg_failing_on_its_own_is_not_the_temporary_file(tmp_path, monkeypatch):
    """An ffmpeg that fails for a reason of its own (here an encoder it lacks) was reported as the temporary
    file's fault: "write failed: ffmpeg: Unknown encoder 'h264' (its temporary file, in /tmp)". Now its own line,
    exit 1, nothing written (session 28, found after part 10)."""
    fake = tmp_path / "ffmpeg"   # answers matplotlib's probe, then fails as an ffmpeg without the encoder does
    fake.write_text("#!/bin/sh\nfor a in \"$@\"; do [ \"$a\" = -version ] && echo 'ffmpeg version 6' && exit 0; done\n"
                    "cat > /dev/null\necho \"Unknown encoder 'h264'\" >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("IMAGEIO_FFMPEG_EXE", str(fake))
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    out = tmp_path / "a.mp4"
    code, line = run_main(["animate", str(case), "--out", str(out), "--engines", "native"])
    assert code == 1 and line == f"kinem: error: {out}: write failed: ffmpeg: Unknown encoder 'h264'", line
    assert not out.exists()


ANIMATE_CTRL_C = """
import sys, time
from kinem.report import animate
from kinem import output
from kinem.cli import main

phase = sys.argv[1]
def ready():
    sys.stderr.write("READY\\n"); sys.stderr.flush(); time.sleep(30)
frames, gif, atomic = animate.frames, animate._save_gif, output.write_atomic
def slow_frames(*a, **k):
    ready()
    return frames(*a, **k)
def slow_gif(path, images, fps):   # half the frames in the scratch file, then the signal
    gif(path, images[:len(images) // 2], fps)
    ready()
def slow_atomic(path, write):   # half the GIF written into the output's temporary file, then the signal
    def half(f):
        class Half:
            def write(self, data):
                f.write(data[:len(data) // 2]); f.flush(); ready()
        write(Half())
    return atomic(path, half)
if phase == "solve":
    animate.frames = slow_frames
elif phase == "gif":
    animate._save_gif = slow_gif
else:
    output.write_atomic = slow_atomic
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.parametrize("phase", ["solve", "gif", "save"])
@pytest.mark.parametrize("old", [False, True])
def test_ctrl_c_during_animate_gif(tmp_path, phase, old):
    """Ctrl-C (SIGINT to the process group of a command started in its own session) during kinem animate to a
    GIF: in the solve, with half the frames in the scratch file, and with half the GIF in the output's
    temporary file: exit 130 at once, nothing printed, no process of the group left, nothing partial left
    beside the output and none in the temporary folder it drew in; an old file kept whole. Found sound."""
    import subprocess
    import sys

    out = tmp_path / "out" / "a.gif"
    out.parent.mkdir()
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    if old:
        out.write_bytes(OLD)
    case = tmp_path / "case.toml"
    case.write_text(SHORT)
    env = dict(os.environ, TMPDIR=str(scratch))
    p = subprocess.Popen([sys.executable, "-c", ANIMATE_CTRL_C, phase, "animate", str(case), "--out", str(out),
                          "--engines", "native"], cwd=ROOT, env=env, start_new_session=True, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    interrupt_when_ready(p)
    assert sorted(x.name for x in out.parent.iterdir()) == (["a.gif"] if old else []), list(out.parent.iterdir())
    assert not old or out.read_bytes() == OLD
    assert not list(scratch.iterdir()), list(scratch.iterdir())
