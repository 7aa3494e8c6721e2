"""Writing outputs without ever harming what is at the target path.

``Output(path)`` is where one output goes:

- a regular file, or a path that does not exist yet: written to an unnamed
  temporary file in the target's directory (Linux ``O_TMPFILE``: it has no
  name, so even SIGKILL leaves nothing behind) and linked into place on
  ``commit`` (a new path: one link; an existing file: a link under a
  temporary name renamed over it, the only moment a name exists); elsewhere a named temporary file beside the target, renamed into
  place, and removed on any error or signal Python can catch (the command line
  turns SIGTERM and SIGHUP into an exit for that). Either way the target holds
  the old content or the new, never a part.
- a device (``/dev/null``, ``/dev/full``), a FIFO or a socket, and ``-``
  (standard output): written in place, never replaced. A FIFO is opened by
  ``check`` before the work, as the shell's ``>`` opens it (its reader waited
  for at most FIFO_WAIT, else OutputError before anything runs).
- a symbolic link: followed; its target is written as above and the link stays.
- a replaced file keeps its permission bits (and owner and group where the
  process may set them); it is a new file all the same, so a hard link to the
  old one is not followed: the other names keep the old content.
- a read-only file (no write permission bit, or none for this user) is
  refused before anything runs, as the shell's ``>`` refuses it
  (``OutputError``: exit code 1); make it writable or remove it first.

Errors name the target path: ``InputError`` (exit code 2) for a bad path
(missing directory, a directory, no permission), ``OutputError`` (exit code 1)
for a write that failed (disk full, broken pipe).

Trajectories: CSV (a header of column names, one row per instant, each number
in the shortest form that reads back to the same double) or NPZ (arrays t,
data, columns; ``partial`` and ``message`` when a failed run's instants were
kept). Both are written chunk by chunk (``TrajectoryWriter``).
"""
import errno
import io
import os
import secrets
import stat
import sys
import zipfile
from contextlib import contextmanager

import numpy as np

from .errors import BrokenPipe, InputError, OutputError

# errno values that mean the path is wrong (exit 2), not that a write failed
_BAD_PATH = {errno.ENOENT, errno.ENOTDIR, errno.EISDIR, errno.EACCES, errno.EPERM, errno.EROFS,
             errno.ENAMETOOLONG, errno.ELOOP, errno.ETXTBSY}


def _reason(e: OSError) -> str:
    return e.strerror or type(e).__name__


def bad_path(path, e: OSError) -> Exception:
    """The error for an OSError about path: InputError for a bad path, else OutputError."""
    cls = InputError if e.errno in _BAD_PATH else OutputError
    return cls(f"{path}: {'cannot write' if cls is InputError else 'write failed'}: {_reason(e)}")


def _temporary_name(path):
    return os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.{secrets.token_hex(4)}.tmp")


def _link_fd(fd, path):
    """Gives the unnamed file open as fd the name path: linkat(2) with
    AT_EMPTY_PATH, else through /proc/self/fd (as open(2) describes)."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    if libc.linkat(fd, b"", _AT_FDCWD, os.fsencode(path), _AT_EMPTY_PATH) == 0:
        return
    code = ctypes.get_errno()
    if code == errno.EEXIST:
        raise FileExistsError(code, os.strerror(code), path)
    os.link(f"/proc/self/fd/{fd}", path, follow_symlinks=True)


_AT_FDCWD, _AT_EMPTY_PATH = -100, 0x1000
_UNNAMED = {}   # st_dev of a directory -> whether unnamed files can be linked there


def _links_unnamed(directory) -> bool:
    """Whether an O_TMPFILE file made in directory can be linked into it:
    Linux, a file system that supports it, and a linkat that works (tried
    once per file system, with a probe file that is unlinked at once)."""
    if not hasattr(os, "O_TMPFILE") or sys.platform != "linux":
        return False
    dev = os.stat(directory).st_dev
    if dev not in _UNNAMED:
        ok = False
        try:
            fd = os.open(directory, os.O_TMPFILE | os.O_WRONLY | os.O_CLOEXEC, 0o600)
        except OSError as e:
            if e.errno in (errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOSPC):
                return False  # about this directory, not the file system: not remembered
            fd = None
        if fd is not None:
            probe = os.path.join(directory, f".kinem-probe.{secrets.token_hex(6)}")
            try:
                with _signals_held():   # the probe's name exists only inside
                    _link_fd(fd, probe)
                    os.unlink(probe)
                ok = True
            except (OSError, AttributeError):
                pass
            finally:
                os.close(fd)
        _UNNAMED[dev] = ok
    return _UNNAMED[dev]


# Set by the command line's SIGTERM/SIGHUP handler. The SystemExit it raises can
# be swallowed where the signal lands (Python ignores exceptions raised in a
# ctypes callback, such as numba's object cache notifier), so a commit checks
# this too and ends the run instead of publishing its output.
STOP = {"signal": None}
HOLD = {"depth": 0}   # > 0 while an output is being published: a signal's exit waits (_signals_held)


@contextmanager
def _signals_held():
    """The few system calls that publish an output happen whole: the command
    line's SIGTERM/SIGHUP handler only records a signal that comes inside
    (HOLD), and its exit is raised here, right after."""
    HOLD["depth"] += 1
    try:
        yield
    finally:
        HOLD["depth"] -= 1
    if not HOLD["depth"] and STOP["signal"] is not None:
        raise SystemExit(128 + STOP["signal"])


def _target(path):
    """(the real path, its stat or None when it does not exist) of a path
    Output may write; the errors it raises about the path itself."""
    real = os.path.realpath(path)
    try:
        st = os.stat(real)
    except FileNotFoundError:
        st = None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise InputError(f"{path}: cannot write: is a directory")
    if path.endswith(os.sep):   # realpath drops the '/': the file would be written without it
        raise InputError(f"{path}: cannot write: a path ending in {os.sep!r} names a directory; "
                         "expected a file name")
    if st is not None and stat.S_ISREG(st.st_mode) and (not st.st_mode & 0o222 or not os.access(real, os.W_OK)):
        raise OutputError(f"{path}: cannot write: the file is read-only (permission denied); "
                          "make it writable or remove it first")
    directory = os.path.dirname(real)
    if st is None and not os.path.isdir(directory):
        where = (f"{directory} (where the symbolic link points)" if os.path.islink(path)
                 else os.path.dirname(path) or ".")
        raise InputError(f"{path}: cannot write: directory {where} does not exist")
    return real, st


def check(path) -> None:
    """Raises what ``Output(path)`` would raise about the path itself (a
    directory, a read-only file, a missing folder, a folder this user may
    not write), without creating anything: for a command that writes only
    after a long run (``kinem report``). A FIFO is opened (its reader waited
    for, FIFO_WAIT at most) and held for Output(path); ``release`` closes it
    when the call fails before writing."""
    path = str(path)
    if path == "-":
        return
    if not path:
        raise InputError("'': cannot write: an empty path (an unset shell variable?); expected a file name")
    try:
        real, st = _target(path)
        if (st is None or stat.S_ISREG(st.st_mode)) and not os.access(os.path.dirname(real), os.W_OK | os.X_OK):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), os.path.dirname(real))
        if st is not None and stat.S_ISFIFO(st.st_mode) and real not in HELD:
            # opened now, as the shell's > opens it before the command runs: a FIFO without a reader (within
            # FIFO_WAIT) is refused before the work, not after it; Output(path) writes through this descriptor
            HELD[real] = _fifo_writer(path, real)
    except OSError as e:
        raise bad_path(path, e) from None


HELD = {}   # a FIFO's real path -> the writing descriptor check opened, for Output (release: the ones unused)


def release() -> None:
    """Closes the FIFOs check opened that no Output took (a call that failed
    between them): their readers see the end of an empty output."""
    while HELD:
        os.close(HELD.popitem()[1])


class Output:
    """One output target; ``file`` is a binary file object. Use as a context
    manager and call ``commit()`` when the content is complete: leaving the
    block without it discards the new content (the target keeps the old)."""

    def __init__(self, path):
        self.path = str(path)
        self.file, self._tmp, self._tmp_name, self._real = None, False, None, None
        if self.path == "-":
            self.file = sys.stdout.buffer
            return
        if not self.path:
            raise InputError("'': cannot write: an empty path (an unset shell variable?); expected a file name")
        try:
            real, st = _target(self.path)
            if st is not None and stat.S_ISFIFO(st.st_mode):   # in place; opened by check before the work, or now
                fd = HELD.pop(real) if real in HELD else _fifo_writer(self.path, real)
                self.file = os.fdopen(fd, "wb", buffering=0)
                return
            if st is not None and not stat.S_ISREG(st.st_mode):
                self.file = open(real, "wb", buffering=0)  # a device or socket: in place
                return
            self._real = real
            self.file = self._temporary(os.path.dirname(real))
        except OSError as e:
            raise bad_path(self.path, e) from None

    def _temporary(self, directory):
        if _links_unnamed(directory):
            fd = os.open(directory, os.O_TMPFILE | os.O_WRONLY | os.O_CLOEXEC, 0o666)  # the umask applies
            self._tmp = True
            return os.fdopen(fd, "wb")
        # portable: a named temporary file, removed on error (see close)
        name = _temporary_name(self._real)
        fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        self._tmp, self._tmp_name = True, name
        return os.fdopen(fd, "wb")

    @property
    def in_place(self) -> bool:
        """Written in place (standard output, a device, a FIFO): what is
        written cannot be taken back."""
        return not self._tmp

    def write(self, data: bytes) -> None:
        if STOP["signal"] is not None:
            self.close()
            raise SystemExit(128 + STOP["signal"])
        try:
            view, done = memoryview(data).cast("B"), 0
            # a write a signal interrupts may take only part of the data and still return (Python's
            # BufferedWriter does: a pipe's reader gone while kinem waits on it): the rest again,
            # whose write then says what went wrong
            while done < len(view):
                n = self.file.write(view[done:])
                if not n:
                    raise OSError(errno.EIO, "no byte written")
                done += n
        except OSError as e:
            raise self.error(e) from None

    def error(self, e: OSError):
        if self.path == "-":
            cls = BrokenPipe if e.errno == errno.EPIPE else OutputError
            return cls(f"standard output: write failed: {_reason(e)}")
        return OutputError(f"{self.path}: write failed: {_reason(e)}")

    def commit(self) -> None:
        """Make the content written so far the target's content."""
        if STOP["signal"] is not None:   # terminated: discard, exit as the signal asked
            self.close()
            raise SystemExit(128 + STOP["signal"])
        try:
            self.file.flush()
            if not self._tmp:
                return
            self._keep_owner_and_mode()
            if self._tmp_name is None:
                self._link(self.file.fileno())
            else:
                with _signals_held():
                    os.replace(self._tmp_name, self._real)
                    self._tmp_name = None
        except OSError as e:
            raise self.error(e) from None
        finally:
            self.close()

    def _keep_owner_and_mode(self):
        """A file being replaced keeps its permission bits, and its owner and
        group where the process may set them (root; a group of the user's):
        the new content gets them before it takes the name. A new path gets
        the umask's mode."""
        try:
            st = os.stat(self._real)
        except FileNotFoundError:
            return
        fd = self.file.fileno()
        if (st.st_uid, st.st_gid) != (os.geteuid(), os.getegid()):
            try:
                os.fchown(fd, st.st_uid, st.st_gid)
            except PermissionError:
                try:
                    os.fchown(fd, -1, st.st_gid)
                except PermissionError:
                    pass
        os.fchmod(fd, stat.S_IMODE(st.st_mode))   # after fchown, which may clear set-id bits

    def _link(self, fd):
        try:  # a new path: one atomic link, nothing else to clean up
            _link_fd(fd, self._real)
            return
        except FileExistsError:
            pass
        # an existing regular file: link under a temporary name, rename over it, with
        # SIGTERM, SIGHUP and SIGINT held meanwhile (their exit comes after the rename)
        name = _temporary_name(self._real)
        with _signals_held():
            try:
                _link_fd(fd, name)
                os.replace(name, self._real)
            except FileExistsError:   # the random name is taken: not ours to remove
                raise
            except BaseException:
                try:
                    os.unlink(name)
                except FileNotFoundError:   # not linked, or renamed already (the new content in place)
                    pass
                raise

    def close(self):
        if self.file is not None and self.path != "-":
            try:
                self.file.close()
            except OSError:
                pass
        if self._tmp_name is not None:
            try:
                os.unlink(self._tmp_name)
            except OSError:
                pass
            self._tmp_name = None
        self.file = None

    discard = close

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.path == "-" and self.file is not None:
            try:
                self.file.flush()
            except OSError as e:
                if exc[0] is None:
                    raise self.error(e) from None
        self.close()
        return False


# Seconds a FIFO is waited for: its reader (an output) or writer (a case file);
# a peer started just before (mkfifo p; reader < p & kinem ... p) comes within milliseconds.
FIFO_WAIT = 10.0


def _fifo_writer(path, real) -> int:
    """A blocking descriptor writing to the FIFO real, once it has a reader
    (within FIFO_WAIT; OutputError otherwise, instead of blocking forever)."""
    import fcntl
    import time

    end = time.monotonic() + FIFO_WAIT
    while True:
        try:
            fd = os.open(real, os.O_WRONLY | os.O_NONBLOCK | os.O_CLOEXEC)
            break
        except OSError as e:
            if e.errno != errno.ENXIO:   # ENXIO: no reader yet
                raise
            if time.monotonic() > end:
                raise OutputError(f"{path}: write failed: the FIFO has no reader (waited {FIFO_WAIT:g} s)") from None
            time.sleep(0.05)
    fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
    return fd


def read_fifo(path, limit) -> bytes:
    """At most limit bytes from the FIFO at path, its writer waited for at most
    FIFO_WAIT at a time (InputError when none comes, instead of blocking forever)."""
    import select

    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        poller, chunks, size = select.poll(), [], 0
        poller.register(fd, select.POLLIN)
        while size < limit:
            if not poller.poll(FIFO_WAIT * 1000):
                what = "no writer" if not size else "its writer stopped"
                raise InputError(f"{path}: cannot read: a FIFO with {what} (waited {FIFO_WAIT:g} s)")
            try:
                chunk = os.read(fd, min(limit - size, 1 << 20))
            except BlockingIOError:
                continue
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


def write_atomic(path, write) -> None:
    """Calls write(binary file object) and commits it (see Output)."""
    with Output(path) as out:
        try:
            write(out.file)
        except OSError as e:
            raise out.error(e) from None
        out.commit()


# -- trajectories ---------------------------------------------------------------------------------

def csv_rows(t, data) -> bytes:
    """CSV rows of t and data, each number in its shortest round-trip form.
    orjson formats a whole numpy array in compiled code (one fifth of
    numpy.savetxt's %.17g cost per row of 48 columns: benchmarks/output_bench.py);
    the rows are cut out of its nested list by the positions of ']'. It writes
    NaN and infinity as null, so arrays with those go through Python's repr."""
    block = np.column_stack([t, data]) if len(data) else np.asarray(t, dtype=float)[:, None]
    if not len(block):
        return b""
    if np.isfinite(block).all():
        import orjson

        text = orjson.dumps(np.ascontiguousarray(block), option=orjson.OPT_SERIALIZE_NUMPY)
        ends = np.flatnonzero(np.frombuffer(text, np.uint8) == ord("]"))[:-1]   # each row's ']'
        starts = np.r_[2, ends[:-1] + 3]                                         # after '[[' or '],['
        return b"\n".join([text[i:j] for i, j in zip(starts.tolist(), ends.tolist())]) + b"\n"
    return "".join(",".join(map(repr, row)) + "\n" for row in block.tolist()).encode()


def csv_header(columns) -> bytes:
    return (",".join(("t",) + tuple(columns)) + "\n").encode()


def csv_text(traj) -> str:
    return (csv_header(traj.columns) + csv_rows(traj.t, traj.data)).decode()


class TrajectoryWriter:
    """Writes a trajectory chunk by chunk to an Output: ``add(t, data)`` per
    chunk, then ``finish(partial_message=None)``. CSV rows go straight out;
    NPZ rows go to an unnamed temporary file first (the .npy header needs the
    row count) and are copied into the archive at the end."""

    def __init__(self, out: Output, columns, fmt="csv"):
        self.out, self.columns, self.fmt, self.rows = out, tuple(columns), fmt, 0
        if fmt == "csv":
            out.write(csv_header(self.columns))
        else:
            import tempfile

            directory = os.path.dirname(out._real) if out._real else None
            self._t, self._data = [], tempfile.TemporaryFile(dir=directory)

    def add(self, t, data) -> None:
        self.rows += len(t)
        if self.fmt == "csv":
            self.out.write(csv_rows(t, data))
        else:
            self._t.append(np.array(t, dtype=float))
            try:
                self._data.write(np.ascontiguousarray(data, dtype=float).tobytes())
            except OSError as e:
                raise self.out.error(e) from None

    def finish(self, partial_message=None) -> None:
        """Completes the content; with partial_message the output is marked as
        holding only the instants solved (CSV: a last line '# partial: ...')."""
        if self.fmt == "csv":
            if partial_message is not None:
                self.out.write(f"# partial: {' '.join(partial_message.split())}\n".encode())
            return
        try:
            self._write_npz(partial_message)
        except OSError as e:
            raise self.out.error(e) from None
        finally:
            self._data.close()

    def _write_npz(self, partial_message):
        fmt = np.lib.format
        arrays = {"t": np.concatenate(self._t) if self._t else np.empty(0),
                  "columns": np.array(self.columns)}
        if partial_message is not None:
            arrays.update(partial=np.array(True), message=np.array(partial_message))
        sink = self.out.file if self.out.path != "-" else io.BytesIO()
        with zipfile.ZipFile(sink, "w", allowZip64=True) as z:
            for name, a in arrays.items():
                with z.open(name + ".npy", "w", force_zip64=True) as f:
                    fmt.write_array(f, a)
            with z.open("data.npy", "w", force_zip64=True) as f:
                header = {"descr": fmt.dtype_to_descr(np.dtype(float)), "fortran_order": False,
                          "shape": (self.rows, len(self.columns))}
                fmt.write_array_header_2_0(f, header)
                self._data.seek(0)
                while chunk := self._data.read(1 << 22):
                    f.write(chunk)
        if sink is not self.out.file:
            self.out.write(sink.getvalue())


def write_trajectory(traj, path, fmt="csv") -> None:
    with Output(path) as out:
        w = TrajectoryWriter(out, traj.columns, fmt)
        w.add(traj.t, traj.data)
        w.finish()
        out.commit()
