"""Where independent runs go (``kinem report``, ``stress``, ``compare``): this
process, a local process pool (the default: one worker per core), or the
workers of an existing Dask distributed cluster (``--scheduler ADDRESS``).

``executor`` yields a concurrent.futures executor, or None for "run in this
process", so a caller can submit, wait(FIRST_COMPLETED) and submit more;
``map`` is the plain case. Tasks and results must pickle. Dask is imported
only when a scheduler is given.

On a cluster nothing waits without bound: reaching the scheduler (and its
answering as one: a TCP listener that does not speak Dask is caught) and
seeing a worker each take at most CONNECT_TIMEOUT; while the run goes on, a
watchdog ends it with one error line (exit 1) when the scheduler has been
unreachable for LOST_TIMEOUT, when no worker has been left for LOST_TIMEOUT
(a worker restarted by its nanny is back well within it; tasks of a lost
worker are re-run by Dask on the others, which is its documented retry), or
when the run has taken longer than RUN_TIMEOUT (``--timeout``). Dask's own
log messages are silenced during the run: its errors reach the user as that
one line.
"""
import os
import threading
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager

from .errors import InputError, KinemError

CONNECT_TIMEOUT = 10.0   # seconds to reach the scheduler, and again to see a worker
LOST_TIMEOUT = 30.0      # seconds without the scheduler, or without any worker, that end a run
RUN_TIMEOUT = 6 * 3600.0  # seconds a whole run on a cluster may take (--timeout)


def workers(jobs=None) -> int:
    """Local worker processes: jobs, or the core count when None."""
    return (os.cpu_count() or 1) if jobs is None else jobs


@contextmanager
def executor(jobs=None, scheduler=None):
    """A scheduler's executor when one is given, else a pool of ``workers(jobs)``
    processes, else (jobs 0 or 1) None."""
    if scheduler is not None:
        client = connect(scheduler)
        pool = _Watched(client, scheduler)
        try:
            yield pool
        except KinemError:
            raise
        except Exception as e:  # noqa: BLE001 - a result lost with the cluster: one line
            if pool.error is not None:
                raise pool.error from None
            if not _lost(e):
                raise
            reason = " ".join(str(e).split()) or type(e).__name__
            raise KinemError(f"--scheduler {scheduler}: lost the cluster ({reason}); the run was stopped") from None
        finally:
            pool.stop()
            _close(client)
    elif workers(jobs) <= 1:
        yield None
    else:
        pdeathsig = threading.current_thread() is threading.main_thread()
        with ProcessPoolExecutor(max_workers=workers(jobs), initializer=_die_with_parent,
                                 initargs=(os.getpid(), pdeathsig)) as pool:
            yield pool


PR_SET_PDEATHSIG = 1   # prctl(2)


def _die_with_parent(parent, pdeathsig):
    """A local worker's initializer: the worker ends when the process that
    made it does, so that SIGKILL of kinem leaves no worker holding memory and
    the caller's pipes. On Linux the kernel sends it SIGKILL (prctl
    PR_SET_PDEATHSIG; only when the pool was made on the main thread, as the
    signal follows the thread that forked); elsewhere, and besides, a daemon
    thread checks every WATCH seconds that the parent is still its parent."""
    import signal
    import sys

    if pdeathsig and sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            pass
    maker = os.getppid()   # kinem itself (fork), or a fork server that ends with it
    try:
        os.kill(parent, 0)   # kinem died before the prctl above
    except ProcessLookupError:
        os._exit(1)
    except PermissionError:
        pass

    def watch():
        while os.getppid() == maker:
            time.sleep(WATCH)
        os._exit(1)

    threading.Thread(target=watch, name="kinem-parent-watch", daemon=True).start()


WATCH = 1.0   # seconds between a worker's checks that its parent lives (where prctl is not used)


def map(fn, tasks, jobs=None, scheduler=None) -> list:
    """[fn(t) for t in tasks], run where ``executor`` says; results in task order."""
    tasks = list(tasks)
    with executor(jobs, scheduler) as pool:
        if pool is None:
            return [fn(t) for t in tasks]
        return list(pool.map(fn, tasks))


def connect(address):
    """A dask.distributed Client of the scheduler at address, with at least one
    worker; InputError (exit 2) when there is none within CONNECT_TIMEOUT."""
    check_address(address)
    from distributed import Client

    _quiet()
    if address.startswith("tcp://") or "://" not in address:
        _probe(address)
    client = Client.__new__(Client)   # kept to close it when it fails to start: else it hangs on exit
    try:
        client.__init__(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except Exception as e:  # noqa: BLE001 - OSError, TimeoutError, TLS configuration, ...
        _close(client)
        raise InputError(f"--scheduler {address}: cannot connect to a Dask scheduler: {_why(e)}") from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except Exception:  # noqa: BLE001 - a timeout
        _close(client)
        raise InputError(f"--scheduler {address}: the scheduler has no workers "
                         f"(waited {CONNECT_TIMEOUT:g} s)") from None
    _quiet()   # the loggers the client made
    return client


def check_address(address):
    """InputError (exit 2) unless address has a scheduler address's form:
    nothing is connected to (a command checks it before its own work, then
    connects when its runs begin)."""
    try:
        from distributed.comm.addressing import get_address_host_port
    except ImportError as e:
        raise InputError(f"--scheduler needs dask.distributed ({e}); pip install 'dask[distributed]'") from None
    if not address:   # an unset shell variable ("" would start a local cluster)
        raise InputError("--scheduler '': an empty address (an unset shell variable?); expected e.g. tcp://host:8786")
    try:  # a malformed address fails here
        port = get_address_host_port(address)[1]
    except Exception as e:  # noqa: BLE001 - ValueError, NotImplementedError, ...
        raise InputError(f"--scheduler {address}: not a scheduler address ({e}); "
                         "expected e.g. tcp://host:8786") from None
    if not 0 < port < 65536:   # else a connection attempt of CONNECT_TIMEOUT to no port at all
        raise InputError(f"--scheduler {address}: not a scheduler address (port {port}: expected 1 to 65535); "
                         "expected e.g. tcp://host:8786")


def _lost(e) -> bool:
    """Whether an exception from a future means the cluster lost it (not a
    task's own error)."""
    import asyncio
    from concurrent.futures import CancelledError

    from distributed.comm import CommClosedError

    names = {"FutureCancelledError", "KilledWorker", "CommClosedError"}
    return isinstance(e, (CancelledError, asyncio.CancelledError, CommClosedError, OSError, TimeoutError)) \
        or type(e).__name__ in names


def _probe(address):
    """Connects and reads the handshake within CONNECT_TIMEOUT: distributed's
    own connect waits for the handshake without a limit, so a port that
    accepts TCP but does not speak Dask would hang the Client."""
    import asyncio

    from distributed.comm import connect as comm_connect

    async def probe():
        comm = await asyncio.wait_for(comm_connect(address, timeout=CONNECT_TIMEOUT), CONNECT_TIMEOUT)
        await comm.close()

    try:
        asyncio.run(probe())
    except (asyncio.TimeoutError, TimeoutError):
        raise InputError(f"--scheduler {address}: cannot connect to a Dask scheduler: no Dask handshake "
                         f"within {CONNECT_TIMEOUT:g} s (is it a scheduler's address?)") from None
    except Exception as e:  # noqa: BLE001 - OSError, a garbled handshake, ...
        raise InputError(f"--scheduler {address}: cannot connect to a Dask scheduler: {_why(e)}") from None


def _why(e) -> str:
    """An exception from connecting, in the user's terms: a port that answers in
    another protocol makes Dask read its bytes as a frame length (MemoryError,
    "Unable to allocate 3.07 EiB")."""
    if isinstance(e, MemoryError) or "Unable to allocate" in str(e):
        return "the port answered, but not in Dask's protocol (is it a scheduler's address, not e.g. its dashboard?)"
    return " ".join(str(e).split()) or type(e).__name__


def _quiet():
    """Dask logs connection losses and worker deaths at length (tracebacks of
    its event loop); here they end the run with one line instead."""
    import logging

    names = [n for n in logging.root.manager.loggerDict if n.split(".")[0] in ("distributed", "tornado", "asyncio")]
    for name in names + ["distributed", "tornado", "asyncio"]:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _close(client):
    try:
        client.close(timeout=CONNECT_TIMEOUT)
    except Exception:  # noqa: BLE001 - a scheduler already gone: nothing to close
        pass


class _Watched(Executor):
    """The client's executor, with a watchdog that fails every pending future
    with one KinemError when the scheduler or every worker is lost for
    LOST_TIMEOUT, or the run exceeds RUN_TIMEOUT."""

    def __init__(self, client, address):
        self.client, self.address = client, address
        self.inner = client.get_executor(pure=False)   # every submission runs: no result is shared or cached
        self.pending, self.error, self.lock = set(), None, threading.Lock()
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._watch, name="kinem-dask-watchdog", daemon=True)
        self.thread.start()

    def submit(self, fn, /, *args, **kwargs):
        """A future of our own that mirrors Dask's: the watchdog can fail it
        without touching the one Dask still owns."""
        from concurrent.futures import Future

        if self.error is not None:
            raise self.error
        outer = Future()
        outer.set_running_or_notify_cancel()
        with self.lock:
            self.pending.add(outer)

        def copy(inner):
            try:
                error = inner.exception()
            except BaseException:  # noqa: BLE001 - cancelled: the cluster dropped it
                what = "lost the cluster" if self.client.status == "running" else "lost the scheduler"
                error = KinemError(f"--scheduler {self.address}: {what} (a task was cancelled); "
                                   "the run was stopped")
            try:
                if error is None:
                    outer.set_result(inner.result())
                else:
                    outer.set_exception(error)
            except BaseException:  # noqa: BLE001 - already failed by the watchdog
                pass
            finally:
                with self.lock:
                    self.pending.discard(outer)

        self.inner.submit(fn, *args, **kwargs).add_done_callback(copy)
        return outer

    def _watch(self):
        start = time.monotonic()
        last_scheduler = last_worker = start
        while not self.done.wait(0.5):
            now = time.monotonic()
            try:
                if self.client.status == "running":
                    last_scheduler = now
                if self.client.scheduler_info().get("workers"):
                    last_worker = now
            except Exception:  # noqa: BLE001 - the client is going down: judged by the times below
                pass
            if now - last_scheduler > LOST_TIMEOUT:
                problem = f"lost the scheduler (unreachable for {LOST_TIMEOUT:g} s)"
            elif now - last_worker > LOST_TIMEOUT:
                problem = f"no workers left (none for {LOST_TIMEOUT:g} s)"
            elif now - start > RUN_TIMEOUT:
                problem = f"the run took longer than {RUN_TIMEOUT:g} s (--timeout)"
            else:
                continue
            self._fail(KinemError(f"--scheduler {self.address}: {problem}; the run was stopped"))
            return

    def _fail(self, error):
        self.error = error
        with self.lock:
            pending = list(self.pending)
        for f in pending:
            try:
                f.set_exception(error)
            except Exception:  # noqa: BLE001 - finished meanwhile
                pass

    def stop(self):
        self.done.set()

    def shutdown(self, wait=True, *, cancel_futures=False):
        self.stop()
