"""kinem's compiled core (kinem/core, Rust, built with the package as the
extension kinem._core): the one place the rest of kinem imports it from."""
from enum import IntEnum

from ._core import (CORES, KAPPA, KINDS, MAX_STEP, MODES, POLISH, REGULAR, SINGULAR, THREADS,  # noqa: F401
                    WHY, Core, Lu, MarchState, Outcome, Plan, columns, functions, increasing, outline_radius, settle,
                    step)


class Why(IntEnum):
    """Why the core does not take a state (kinem/core/src/accept.rs, ``Why``:
    the same codes, checked by tests/test_bounds.py), each with its message."""
    ACCEPTED = 0
    NEAR_SINGULAR = 1
    DET_FLIP = 2
    JUMP = 3
    NOT_CONVERGED = 4
    INTERRUPTED = 5
    OUT_OF_TIME = 6
    BAD_INPUT = 7   # a variant refused before the march (kinem.variants), never the march's own verdict

    @property
    def message(self) -> str:
        return _MESSAGES[self]


class Mode(IntEnum):
    """What a step does (kinem/core/src/step.rs, ``Mode``: the same codes,
    checked by tests/test_bounds.py): TRACK the next instant from the last
    accepted state (the march's; from the estimates when there is none),
    OVER a step over a bifurcation (a det flip accepted), DIRECT an output
    instant near a singular configuration solved directly (Taylor, the same
    det sign, judged on one more correction), ASSEMBLE the tracker's assembly
    (any converged state), RATES the state's own rates."""
    TRACK = 0
    OVER = 1
    DIRECT = 2
    ASSEMBLE = 3
    RATES = 4


_MESSAGES = {
    Why.ACCEPTED: "accepted",
    Why.NEAR_SINGULAR: "near-singular configuration (pivot ratio below the floor, or Newton converged linearly)",
    Why.DET_FLIP: "det(J) changed sign",
    Why.JUMP: "jump from the predictor",
    Why.NOT_CONVERGED: "Newton-Raphson did not converge",
    Why.INTERRUPTED: "interrupted by a signal",
    Why.OUT_OF_TIME: "the time limit is reached",
    Why.BAD_INPUT: "bad input (refused before the march)",
}

NEAR_SINGULAR, DET_FLIP, JUMP, NOT_CONVERGED = Why.NEAR_SINGULAR, Why.DET_FLIP, Why.JUMP, Why.NOT_CONVERGED
