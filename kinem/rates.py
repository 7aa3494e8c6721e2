"""The drivers' rates, for what a run out of its budget is told
(kinem.budget): the fastest driver and the output step that would need none."""

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
