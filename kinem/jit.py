"""The one decorator of the compiled kernels (constraint families, driving
functions, kinem.dense), and the choice between running them compiled or
interpreted.

A kernel is compiled by numba on its first compiled call and cached beside
its module (``__pycache__``), so a new process loads it instead of compiling.
Loading costs a new process about 0.45 s (importing numba, then its typing
and lowering registries), more than a short run of a small model takes
with the same source run by the interpreter. So ``interpreted()`` runs every
kernel's Python source as it is (kinem.solver.solve uses it for such
runs), and numba is imported only at the first compiled call. Both run the
one implementation; tests/test_jit.py checks that they agree.

error_model="numpy": a division by zero gives inf or nan, as in numpy, for
the callers to test. numba checks a cache against the kernel's own source
file only; ``refresh`` removes every kinem cache when any kernel's source
changes, so a kernel may call (or inline) another module's.
"""
import sys
import types
from contextlib import contextmanager
from functools import update_wrapper

import numpy as np

_interpreted = 0  # depth of interpreted() contexts


class Kernel:
    """A kernel: called compiled, or as Python inside ``interpreted()``.
    Inside another kernel numba types it as its dispatcher, so kernels call
    kernels either way."""

    def __init__(self, fn):
        self.py_func = fn
        self.dispatcher = None
        update_wrapper(self, fn)

    def __call__(self, *args):
        if _interpreted:
            with np.errstate(all="ignore"):  # as error_model="numpy": no warnings
                return self.py_func(*args)
        return (self.dispatcher or self.compiled())(*args)

    def compiled(self):
        """The numba dispatcher (created at the first call, which imports numba)."""
        if self.dispatcher is None:
            from numba import njit

            _ready()
            self.dispatcher = njit(cache=True, nogil=True, error_model="numpy")(self.py_func)
        return self.dispatcher

    @property
    def _numba_type_(self):
        from numba.core import types

        return types.Dispatcher(self.compiled())


_READY = False


def _ready() -> None:
    """Once per process, before numba compiles a kernel: stale caches
    removed (``refresh`` on kinem's folder) and ``trailing_zeros`` given
    to numba."""
    global _READY
    if not _READY:
        _READY = True
        from pathlib import Path

        refresh(Path(__file__).parent)
        _register_trailing_zeros()


def sources(root) -> str:
    """Hash of the sources with kernels in root and root/constraints (a
    generated module's source counts too: kinem.march names its modules
    by it)."""
    import hashlib

    h = hashlib.sha1()
    for p in sorted(root.glob("*.py")) + sorted(root.glob("constraints/*.py")):
        text = p.read_bytes()
        if b"@kernel" in text:
            h.update(p.name.encode() + text)
    return h.hexdigest()


def refresh(root) -> bool:
    """Removes the numba caches (*.nbi, *.nbc) of root's and
    root/constraints' modules when their ``sources`` differ from those of
    the hash kept in root/__pycache__/kernels.stamp (written anew), under a
    lock; returns whether it did. numba checks a cached function against
    its own source file only, but a compiled call of another module's
    kernel (kinem.loop calls kinem.dense) or an inlined one (``inlined``)
    is part of the caller's cached code: an edit there would otherwise
    leave the caller running the old code."""
    import fcntl

    stamp, digest = root / "__pycache__" / "kernels.stamp", sources(root)
    try:
        stamp.parent.mkdir(exist_ok=True)
        with open(stamp.with_suffix(".lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if stamp.exists() and stamp.read_text() == digest:
                return False
            for folder in (root / "__pycache__", root / "constraints" / "__pycache__"):
                for p in list(folder.glob("*.nbi")) + list(folder.glob("*.nbc")):
                    p.unlink(missing_ok=True)
            stamp.write_text(digest)
            return True
    except OSError:  # a read-only install: its caches are the ones it shipped with
        return False


_TWINS = {}


def bound(k: Kernel, **names):
    """k's Python function with the globals ``names`` bound to other objects
    (one source run on other operations: kinem.newton.settle)."""
    fn = k.py_func
    scope = {**fn.__globals__, **names}
    return types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)


def inlined(k: Kernel):
    """k's twin that numba inlines into the compiled function calling it
    (``inline="always"``), with the kernels it calls inlined too: a call of
    a compiled function costs tens of ns beyond its arithmetic (measured:
    the simple constraints' Jacobian kernel 58 ns called, 6 ns inlined), a
    large part of the compiled march's instant (kinem.march). Not cached
    itself: what inlines it is."""
    if k in _TWINS:
        return _TWINS[k]
    from numba import njit

    _ready()
    twin = bound(k)
    scope = twin.__globals__
    for name in twin.__code__.co_names:
        if isinstance(scope.get(name), Kernel):
            scope[name] = inlined(scope[name])
    _TWINS[k] = njit(nogil=True, error_model="numpy", inline="always")(twin)
    return _TWINS[k]


def trailing_zeros(x):
    """The number of trailing zero bits of an unsigned integer x > 0: in a
    compiled kernel numba's intrinsic (``cttz``, replacing this function),
    interpreted this loop."""
    n = 0
    while not x & 1:
        x >>= 1
        n += 1
    return n


def _register_trailing_zeros():
    from numba.core.extending import overload
    from numba.cpython.unsafe.numbers import trailing_zeros as cttz

    @overload(trailing_zeros, inline="always")
    def _overload(x):
        return lambda x: cttz(x)


def kernel(fn) -> Kernel:
    return Kernel(fn)


def loaded() -> bool:
    """Whether numba is imported in this process (compiled calls then cost no start-up)."""
    return "numba" in sys.modules


@contextmanager
def interpreted():
    """Kernels run as Python inside this context (not thread-local: another
    thread's kernels run interpreted too, with the same results)."""
    global _interpreted
    _interpreted += 1
    try:
        yield
    finally:
        _interpreted -= 1
