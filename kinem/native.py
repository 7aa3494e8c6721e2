"""kinem's compiled core (kinem/core, Rust, built with the package as the
extension kinem._core): the one place the rest of kinem imports it from."""
from kinem._core import (DET_FLIP, JUMP, KAPPA, KINDS, MAX_STEP, NEAR_SINGULAR, NOT_CONVERGED, POLISH, REGULAR,  # noqa: F401
                         Core, Lu, Plan, columns, functions, jump_sizes, lagrange, outline_radius, rejected, settle)
