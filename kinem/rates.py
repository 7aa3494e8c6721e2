"""What a run that needs too many sub-steps is told (kinem.tracking): the
fastest driver and the output step that would need none."""
import math

import numpy as np

from .functions import Harmonic, Poly, Table, value_at

SAMPLES = 64   # instants of the interval where the drivers' rates are sampled


def fastest_driver(model, t0, t1):
    """(name, |d'| at most, unit) of the driver that moves fastest over [t0, t1]
    for its kind (an angle in rad/s; a length over the model's length L), or None."""
    best, unit = None, model.case.length_unit or "length units"
    for c in model.case.constraints:
        f = c.get("d")
        if not isinstance(f, (Poly, Harmonic, Table)):
            continue
        rate = max(abs(value_at(f, t, 1)) for t in np.linspace(t0, t1, SAMPLES))
        angle = c.get("coord") == "phi"
        size = rate if angle else rate / model.length
        if best is None or size > best[0]:
            best = (size, c.name, rate, "rad/s" if angle else f"{unit}/s")
    return None if best is None else best[1:]


def too_many_substeps(model, t0, t, taken, h_out, limit) -> str:
    """The message: ``taken`` sub-steps from the output instant t0 to t, over
    ``limit`` in the run."""
    step = (t - t0) / max(taken, 1)
    steps = math.ceil(model.case.end / step) if step > 0 else 0
    driver = fastest_driver(model, t0, t0 + h_out)
    fast = f"driver '{driver[0]}' moves at up to {driver[1]:.3g} {driver[2]}; " if driver else ""
    return (f"more than the limit of {limit:,} sub-steps in the run (kinem solve --max-work, "
            f"Options.max_substeps): {fast}"
            f"the output interval of {h_out:.3g} s needs steps of about {step:.2g} s "
            f"(--steps {steps:,} or more would need none)")
