"""Where independent runs go (``kinem report``, ``stress``, ``compare``): this
process, a local process pool (the default: one worker per core), or the
workers of an existing Dask distributed cluster (``--scheduler ADDRESS``).

``executor`` yields a concurrent.futures executor, or None for "run in this
process", so a caller can submit, wait(FIRST_COMPLETED) and submit more;
``map`` is the plain case. Tasks and results must pickle. Dask is imported
only when a scheduler is given.
"""
import os
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

from .errors import InputError

CONNECT_TIMEOUT = 10.0   # seconds to reach the scheduler, and again to see a worker


def workers(jobs=None) -> int:
    """Local worker processes: jobs, or the core count when None."""
    return (os.cpu_count() or 1) if jobs is None else jobs


@contextmanager
def executor(jobs=None, scheduler=None):
    """A scheduler's executor when one is given, else a pool of ``workers(jobs)``
    processes, else (jobs 0 or 1) None."""
    if scheduler is not None:
        client = connect(scheduler)
        try:
            yield client.get_executor(pure=False)   # every submission runs: no result is shared or cached
        finally:
            client.close()
    elif workers(jobs) <= 1:
        yield None
    else:
        with ProcessPoolExecutor(max_workers=workers(jobs)) as pool:
            yield pool


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
    try:
        from distributed import Client
    except ImportError as e:
        raise InputError(f"--scheduler needs dask.distributed ({e}); pip install 'dask[distributed]'") from None
    from distributed.comm.addressing import get_address_host_port

    try:  # a malformed address fails here (and "", which would start a local cluster)
        get_address_host_port(address)
    except Exception as e:  # noqa: BLE001 - ValueError, NotImplementedError, ...
        raise InputError(f"--scheduler {address}: not a scheduler address ({e}); "
                         "expected e.g. tcp://host:8786") from None
    client = Client.__new__(Client)   # kept to close it when it fails to start: else it hangs on exit
    try:
        client.__init__(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except Exception as e:  # noqa: BLE001 - OSError, TimeoutError, TLS configuration, ...
        client.close()
        reason = " ".join(str(e).split()) or type(e).__name__
        raise InputError(f"--scheduler {address}: cannot connect to a Dask scheduler: {reason}") from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except Exception:  # noqa: BLE001 - a timeout
        client.close()
        raise InputError(f"--scheduler {address}: the scheduler has no workers "
                         f"(waited {CONNECT_TIMEOUT:g} s)") from None
    return client
