"""The command line: a thin layer over the Python API.

Exit codes: 0 success, 1 analysis failure (no convergence, singular
Jacobian), 2 bad input (case file, arguments), 3 internal error. Errors are
one line on standard error, never a traceback (set KINEM_DEBUG=1 for one).
"""
import errno
import os
import sys

from ..errors import AnalysisError, BrokenPipe, CoreError, InputError, KinemError, one_line
from .parser import parser
from .streams import flush, quiet_stdout, standard_streams

__all__ = ["main", "parser"]


def _terminate(signum, frame):
    """SIGTERM, SIGHUP: clean up (temporary files) as for Ctrl-C, then exit
    128 + signal; while an output is being published (output.HOLD) the exit
    waits until it is."""
    from .. import output

    output.STOP["signal"] = signum   # in case the exit below is swallowed where the signal lands
    if output.HOLD["depth"]:
        return
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    import signal

    def unraisable(u, default=sys.unraisablehook):  # our exit, swallowed in a callback: no traceback printed
        from .. import output

        if isinstance(u.exc_value, KeyboardInterrupt):   # Ctrl-C landed in a callback that swallows it (cffi's
            _interrupt_later()                          # collector of a pymunk body): raised again outside it
            return
        if not (output.STOP["signal"] is not None and isinstance(u.exc_value, SystemExit)):
            default(u)

    handled = [s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None]
    try:
        previous = {s: signal.signal(s, _terminate) for s in handled}
    except ValueError:   # not the main thread: leave the signals alone
        previous = {}
    hook, sys.unraisablehook = sys.unraisablehook, unraisable
    try:
        standard_streams()
        code = _main(argv)
        return 130 if _cancel_interrupt() else code   # swallowed at the very end: stopped all the same
    finally:
        _cancel_interrupt()
        sys.unraisablehook = hook
        for s, h in previous.items():
            signal.signal(s, h)
        from .. import output

        output.STOP["signal"] = None
        output.release()   # a FIFO --out opened before the work of a command that failed: its reader sees the end


def _interrupt_later():
    """Ctrl-C again, from another thread 20 ms on: it lands once the
    callback that swallowed the first has returned (raised inside the hook,
    it would be swallowed too)."""
    import _thread
    import threading

    timer = threading.Timer(0.02, _thread.interrupt_main)
    timer.daemon = True
    _PENDING.append(timer)
    timer.start()


_PENDING = []   # _interrupt_later's timers: cancelled when main returns first (no Ctrl-C outside it)


def _cancel_interrupt() -> bool:
    """Cancels the pending timers of _interrupt_later; whether one was pending."""
    pending = False
    while _PENDING:
        timer = _PENDING.pop()
        pending |= timer.is_alive() and not timer.finished.is_set()
        timer.cancel()
    return pending


def _main(argv) -> int:
    a = None
    try:
        p = parser()
        a = p.parse_args(argv)
        if a.command is None:   # bare kinem: the usage
            p.print_help()
            flush()
            return 0
        _threads_note()
        code = a.run(a)
        flush()
        return code
    except InputError as e:
        if getattr(a, "errors", None) == "all":
            for problem in e.problems:
                print(f"kinem: error: {problem}", file=sys.stderr)
        else:
            print(f"kinem: error: {e.summary('--errors all lists them')}", file=sys.stderr)
        return 2
    except AnalysisError as e:
        print(f"kinem: analysis failed: {one_line(e)}", file=sys.stderr)
        return 1
    except CoreError as e:   # a fault of kinem's compiled core: not a verdict on the case
        return _internal(e)
    except BrokenPipe:   # kinem solve CASE | head: quietly, as a Unix tool
        quiet_stdout()
        return 141
    except KinemError as e:   # OutputError among them: a write that failed
        print(f"kinem: error: {one_line(e)}", file=sys.stderr)
        try:
            sys.stdout.flush()
        except OSError:
            quiet_stdout()
        return 1
    except KeyboardInterrupt:
        return 130
    except OSError as e:
        if e.errno == errno.EPIPE:   # print() to standard output, its reader gone: quietly
            quiet_stdout()
            return 141
        if e.errno in (errno.EBADF, errno.ENOSPC, errno.EIO, errno.EDQUOT, errno.EFBIG):  # print() to stdout
            print(f"kinem: error: standard output: write failed: {e.strerror}", file=sys.stderr)
            quiet_stdout()
            return 1
        return _internal(e)
    except Exception as e:  # noqa: BLE001 - one line, never a traceback
        return _internal(e)


def _threads_note():
    """A note on standard error when RAYON_NUM_THREADS asks for more threads
    than the machine has cores: the core's pool is capped at the cores."""
    asked = os.environ.get("RAYON_NUM_THREADS", "").strip()
    if not asked.isdigit():
        return
    from .. import native

    if int(asked) > native.CORES:
        print(f"kinem: note: RAYON_NUM_THREADS={asked} is above this machine's {native.CORES} cores: "
              f"the core uses {native.THREADS} threads", file=sys.stderr)


def _internal(e) -> int:
    if os.environ.get("KINEM_DEBUG"):
        raise e
    print(f"kinem: internal error: {type(e).__name__}: {one_line(e)}", file=sys.stderr)
    return 3
