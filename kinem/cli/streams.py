"""The command line's standard streams: closed ones reopened, failed writes
reported in one line, notes that never fail a command."""
import os
import sys

from ..errors import one_line


def flush():
    """Standard output flushed here, where its errors (a closed pipe, a full
    device) are reported in one line, not at interpreter exit."""
    try:
        sys.stdout.flush()
    except OSError:
        quiet_stdout()
        raise


def quiet_stdout():
    """After a failed write to standard output, the interpreter's own flush
    at exit would print a traceback: point the descriptor at /dev/null (dup2
    onto descriptor 1; the device is opened, never replaced)."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError):
        pass


def standard_streams():
    """Standard descriptors closed by the caller (``>&-``, ``2>&-``) are
    reopened on /dev/null before anything else is opened, so that no output
    file takes their number: standard output read-only (printing to it fails
    with EBADF, exit code 1, where the output was to be printed there),
    standard error writable (its messages are lost, the exit code stays)."""
    for fd, flags in ((0, os.O_RDONLY), (1, os.O_RDONLY), (2, os.O_WRONLY)):
        try:
            os.fstat(fd)
            continue
        except OSError:
            pass
        new = os.open(os.devnull, flags)
        if new != fd:
            os.dup2(new, fd)
            os.close(new)
        if fd == 1:
            sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - the process's standard output
        elif fd == 2:
            sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115


def note(text):
    """Prints a note on standard output after the named output is complete
    (the file written): a closed or broken standard output does not fail the
    command."""
    try:
        print(one_line(text), flush=True)   # a path with a newline stays one line
    except (OSError, ValueError):
        quiet_stdout()

