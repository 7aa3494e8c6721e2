"""Generated mechanisms not in cases/ (issue 24): random slider-cranks,
four-bars and quick-returns, each at a chosen speed factor (the same motion
in 1/f of the time: crank speed x f, end / f, same output instants) and
size factor (every length x k). Used by tests/test_scale_free.py and
benchmarks/verdict_bench.py."""
import math

import numpy as np

from kinem.reference import four_bar_case, quick_return, quick_return_case, slider_crank_case

END, STEPS = 1.0, 100


def slider_crank(rng, f=1.0, k=1.0):
    r = rng.uniform(0.05, 0.2)
    e = rng.uniform(-0.4, 0.4) * r
    rod = r + abs(e) + rng.uniform(0.5, 3.0) * r
    phi0, w = rng.uniform(-math.pi, math.pi), rng.uniform(1.0, 4.0)
    return slider_crank_case(k * r, k * rod, k * e, {"poly": [phi0, w * f]}, phi0, end=END / f, steps=STEPS,
                             name="gen-slider-crank")


def four_bar(rng, f=1.0, k=1.0):
    while True:
        a = rng.uniform(0.05, 0.2)
        b, c, g = (rng.uniform(1.5 * a, 4 * a) for _ in range(3))
        s = sorted([a, b, c, g])
        if s[0] + s[3] <= s[1] + s[2] - 0.1 * a and s[0] == a:
            break
    phi0, w = rng.uniform(-math.pi, math.pi), rng.uniform(1.0, 4.0)
    return four_bar_case(k * a, k * b, k * c, k * g, {"poly": [phi0, w * f]}, phi0, 1.0, end=END / f, steps=STEPS,
                         name="gen-four-bar")


def quick_return_(rng, f=1.0, k=1.0):
    while True:
        rc = rng.uniform(50.0, 150.0)
        oc = rng.uniform(1.5, 4.0) * rc
        rocker = rng.uniform(1.05, 2.0) * (oc + rc)
        link = rng.uniform(0.3, 1.0) * rocker
        by = quick_return(np.linspace(0, 2 * np.pi, 720), oc, rc, rocker, link * 10, 0.0)["B"].imag
        if by.max() - by.min() < 1.8 * link:
            height = rng.uniform(by.max() - 0.9 * link, by.min() + 0.9 * link)
            break
    phi0, w = rng.uniform(-math.pi, math.pi), rng.uniform(1.0, 4.0)
    return quick_return_case(k * oc, k * rc, k * rocker, k * link, k * height, {"poly": [phi0, w * f]}, phi0,
                             end=END / f, steps=STEPS, name="gen-quick-return")


KINDS = {"slider-crank": slider_crank, "four-bar": four_bar, "quick-return": quick_return_}


def generated(kind, seed, f=1.0, k=1.0) -> dict:
    """The case dict of mechanism ``seed`` of ``kind`` at speed x f and size x k."""
    return KINDS[kind](np.random.default_rng(seed), f, k)
