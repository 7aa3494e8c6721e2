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
the callers to test. numba's cache is checked against the kernel's own
source file only, so a kernel calls compiled helpers of its own module,
never of another one.
"""
import sys
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

            self.dispatcher = njit(cache=True, nogil=True, error_model="numpy")(self.py_func)
        return self.dispatcher

    @property
    def _numba_type_(self):
        from numba.core import types

        return types.Dispatcher(self.compiled())


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
