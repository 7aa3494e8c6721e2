"""The loader's problem list and the rules every scalar obeys.

Every problem names the file, the place and the key and says what was
expected; the loader collects them all, then raises one InputError.
"""
import math
import re

from ..errors import InputError

MAX_ARRAY = 100_000
MAX_MAGNITUDE = 1e12  # any length, angle or time beyond this is a mistake, and its squares stay finite
NAME_RE = re.compile(r"^[a-z0-9_-]+$")
IDENT_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*$")


class Checker:
    """Collects the problems of one source; checks scalars, lists and names.

    Each check returns the value (converted) or None after recording why not."""

    def __init__(self, source):
        self.source = source
        self.problems = []

    def raise_if_any(self):
        if self.problems:
            raise InputError(self.problems)

    def bad(self, where, key, problem, expected=None):
        text = f"{self.source}: {where}" + (f": key '{key}'" if key else "") + f": {problem}"
        if expected:
            text += f"; expected {expected}"
        self.problems.append(text)

    def keys(self, where, table, allowed, required=()):
        ok = True
        for k in table:
            if k not in allowed:
                self.bad(where, k, "unknown key", "one of " + ", ".join(allowed))
                ok = False
        for k in required:
            if k not in table:
                self.bad(where, k, "missing")
                ok = False
        return ok

    def number(self, where, key, v, positive=False, nonneg=False):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.bad(where, key, f"got {show(v)}", "a number")
            return None
        v = float(v)
        if not math.isfinite(v):
            self.bad(where, key, f"got {v}", "a finite number")
            return None
        if abs(v) > MAX_MAGNITUDE:
            self.bad(where, key, f"got {v:g}", f"a number of magnitude at most {MAX_MAGNITUDE:g}")
            return None
        if positive and v <= 0:
            self.bad(where, key, f"got {v:g}", "a positive number")
            return None
        if nonneg and v < 0:
            self.bad(where, key, f"got {v:g}", "a number >= 0")
            return None
        return v

    def integer(self, where, key, v, lo=1, hi=10**7):
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            self.bad(where, key, f"got {show(v)}", f"a whole number from {lo} to {hi}")
            return None
        return v

    def vector(self, where, key, v, n, what=None):
        if not isinstance(v, list) or len(v) != n:
            self.bad(where, key, f"got {show(v)}", what or f"a list of {n} numbers")
            return None
        out = [self.number(where, key, x) for x in v]
        return None if None in out else tuple(out)

    def numbers(self, where, key, v, min_len=1):
        if not isinstance(v, list) or not min_len <= len(v) <= MAX_ARRAY:
            self.bad(where, key, f"got {show(v)}", f"a list of {min_len} to {MAX_ARRAY} numbers")
            return None
        out = [self.number(where, key, x) for x in v]
        return None if None in out else tuple(out)

    def string(self, where, key, v, pattern=None, expected="a string"):
        if not isinstance(v, str) or (pattern is not None and not pattern.match(v)):
            self.bad(where, key, f"got {show(v)}", expected)
            return None
        return v


def names(d) -> str:
    names = list(d)
    return ", ".join(names[:20]) + (" ..." if len(names) > 20 else "")


def show(v) -> str:
    r = repr(v)
    return r if len(r) <= 60 else r[:57] + "..."
