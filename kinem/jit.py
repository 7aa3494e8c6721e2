"""The one numba decorator of the compiled kernels (constraint families,
driving functions, kinem.dense).

Compiled on first use and cached beside each module (``__pycache__``), so a
new process loads them instead of compiling. error_model="numpy": a division
by zero gives inf or nan, as in numpy, for the callers to test. numba's cache
is checked against the kernel's own source file only, so a kernel calls
compiled helpers of its own module, never of another one.
"""
from numba import njit

kernel = njit(cache=True, nogil=True, error_model="numpy")
