"""A test-only engine: everything a new engine needs is this module (an
Adapter subclass with version, defaults, checks, tolerance and simulate,
and ``ADAPTER``) plus one line in adapters.REGISTRY (tests/test_registry.py
adds it for the test's duration).

It "simulates" with the native solver itself, so it supports every type
and agrees with native to round-off: what it shows is the plumbing.
"""
from adapters.base import Adapter, Failure, Status, count_or_none, positive


class DummyAdapter(Adapter):
    name = "dummy"
    tolerance = {"position_error_rel": 1e-9}   # native against itself: round-off, with margin
    checks = {"dt": positive, "substeps": count_or_none}

    def version(self):
        return "0.1"

    def defaults(self):
        return {"dt": 1e-3, "substeps": None}

    def unsupported(self, model):
        return None

    def simulate(self, model, q0, qd0, s, times):
        from kinem.solver import solve

        r = solve(model)
        if not r.success:
            raise Failure(Status.FAILED, r.message)
        return r.q, r.qd, r.wall_time, s["substeps"] * (len(times) - 1)


ADAPTER = DummyAdapter()
