"""The loader's problem list and the rules every scalar obeys.

Every problem names the file, the place and the key and says what was
expected; the loader collects them all, then raises one InputError. One
mistake is one problem: a value that refers to a body or point whose own
definition was rejected is not reported again (``rejected``), and an
unknown key that is a near miss of a missing one is reported once, as a
"did you mean".
"""
import difflib
import math
import re
import tomllib
from collections.abc import Iterable

from ..errors import InputError
# HIDDEN: characters that hide or spoof text where shown, refused in a description by the Case itself however it
# is built (kinem.spec), shown as codes by the report (escaping.py); PLAIN: what a description is expected to be
from ..spec import HIDDEN, PLAIN  # noqa: F401

MAX_ARRAY = 100_000
MAX_MAGNITUDE = 1e12  # any length, angle or time beyond this is a mistake, and its squares stay finite
MAX_NAME = 64
MAX_TEXT = 10_000     # characters of a description
MAX_UNIT = 32         # characters of units.length
MAX_STEPS = 10**7
END_RANGE = (1e-6, 1e9)   # s: [time] end, and --end
MIN_SPACING = 1e-9        # of a table's span: the closest two table abscissae (t, theta) may be
NAME_RE = re.compile(r"[a-z0-9_-]{1,%d}" % MAX_NAME)                    # the case's name (fullmatch)
IDENT_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,%d}" % (MAX_NAME - 1))  # bodies, points, constraints
IDENT_TEXT = f"a name of at most {MAX_NAME} letters, digits, '_' and '-' that starts with a letter or '_'"

# The documented ranges (docs/case-format.md, "Limits", is generated from this).
LIMITS = (
    ("file", "at most 16 MiB of UTF-8 TOML (read with a hard cap: a device or pipe is not read past it; one leading byte order mark is read past)"),
    ("case name", f"1 to {MAX_NAME} characters of a-z, 0-9, `_` and `-`"),
    ("body, point and constraint names", f"1 to {MAX_NAME} characters of letters, digits, `_` and `-`, "
                                         "starting with a letter or `_` (the whole name: no trailing newline)"),
    ("numbers", f"finite, magnitude at most {MAX_MAGNITUDE:g} (whole numbers too); booleans are not numbers"),
    ("`[time]` end (and `--end`)", f"{END_RANGE[0]:g} to {END_RANGE[1]:g} s"),
    ("`[time]` steps (and `--steps`)", f"a whole number from 1 to {MAX_STEPS}; `dt` must divide end into "
                                       "as many intervals"),
    ("table abscissae (`t`, `theta`)", f"strictly increasing, consecutive values at least {MIN_SPACING:g} "
                                       "of the table's span apart"),
    ("translation lines (`si`, `qi`; `sj`, `qj`)", "two points at least 1e-12 apart (times their largest "
                                                   "coordinate when that is beyond 1)"),
    ("lists", f"at most {MAX_ARRAY:,} numbers; `poly` at most 32 coefficients; `[engines.*]` lists at most 16"),
    ("bodies, points, constraints", "at most 100,000 each"),
    ("`description`", f"text of at most {MAX_TEXT:,} characters; tab and newline, but no other control or "
                      "invisible formatting character (such as U+0007 or U+202E); a `kinem.Case` built in Python "
                      "refuses them too"),
    ("`units.length`", f"1 to {MAX_UNIT} printable characters, shown as text (never parsed as markup)"),
    ("`[solver]`", "tolerance between 0 and 1; max_iterations 1 to 1000; block 1 to 4096"),
)


class Checker:
    """Collects the problems of one source; checks scalars, lists and names.

    Each check returns the value (converted) or None after recording why not.
    ``failures`` counts problems including the ones not reported because
    their root cause already was."""

    def __init__(self, source):
        self.source = source
        self.problems = []
        self.failures = 0
        self.rejected = set()  # names of bodies and points whose definition was rejected
        self.unknowable = set()  # what (body, point) cannot be checked: its whole section was rejected
        self.parameters = {}     # [parameters]: name -> value, used where a number is expected
        self.rejected_parameters = set()   # names of [parameters] whose value was rejected
        self.named = set()   # names of [parameters] that a number used
        self.degrees = False   # units = { angle = "deg" }: the case's angles are converted once, as parsed
        self.unknown = {}   # (what, name) of an unknown reference -> [its problem's index, text, places]

    def raise_if_any(self):
        if self.problems:
            raise InputError(self.problems)

    def bad(self, where, key, problem, expected=None):
        text = f"{self.source}: {where}" + (f": key '{key}'" if key else "") + f": {problem}"
        if expected:
            text += f"; expected {expected}"
        self.problems.append(text)
        self.failures += 1

    def knock_on(self):
        """A failure whose root cause (a rejected definition) is already reported."""
        self.failures += 1

    def keys(self, where, table, allowed, required=()):
        """Unknown and missing keys; a near miss of a missing key is one problem."""
        ok = True
        missing = [k for k in required if k not in table]
        for k in table:
            if k in allowed:
                continue
            ok = False
            guess = suggest(k, missing) or suggest(k, [a for a in allowed if a not in table])
            if guess is not None:
                self.bad(where, k, f"unknown key; did you mean '{guess}'?")
                if guess in missing:
                    missing.remove(guess)
            else:
                self.bad(where, k, "unknown key", "one of " + ", ".join(allowed))
        for k in missing:
            self.bad(where, k, "missing")
            ok = False
        return ok

    def table(self, where, key, v, allowed, required, form):
        """Whether v is a table with only ``allowed`` keys and every ``required`` one; else the problems."""
        if not isinstance(v, dict):
            self.bad(where, key, f"got {show(v)}", form)
            return False
        return self.keys(f"{where}: key '{key}'", v, allowed, required)

    def choice(self, where, key, v, options, what):
        """v, one of ``options`` (names); else a problem with a "did you mean"."""
        if isinstance(v, str) and v in options:
            return v
        if (isinstance(v, str) and v in self.rejected) or what in self.unknowable:
            self.knock_on()
            return None
        seen = self.unknown.get((what, v)) if isinstance(v, str) else None
        if seen is not None:   # the same unknown name again: one problem, counting its places
            seen[2] += 1
            self.problems[seen[0]] = f"{seen[1]} (the same name in {seen[2]} places)"
            self.knock_on()
            return None
        guess = suggest(v, options) if isinstance(v, str) else None
        if guess is not None:
            self.bad(where, key, f"unknown {what} {show(v)}; did you mean '{guess}'?")
        else:
            self.bad(where, key, f"unknown {what} {show(v)}", "one of " + (names(options) or "(none defined)"))
        if isinstance(v, str):
            self.unknown[(what, v)] = [len(self.problems) - 1, self.problems[-1], 1]
        return None

    def number(self, where, key, v, positive=False, nonneg=False):
        if isinstance(v, str) and v in self.parameters:   # a named dimension: its value, nothing evaluated
            self.named.add(v)
            v = self.parameters[v]
        if isinstance(v, str) and v in self.rejected_parameters:
            self.knock_on()
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            guess = suggest(v, self.parameters) if isinstance(v, str) else None
            if guess is not None:
                self.bad(where, key, f"unknown parameter {show(v)}; did you mean '{guess}'?")
            else:
                named = isinstance(v, str) and self.parameters
                self.bad(where, key, f"got {show(v)}",
                         "a number" + (f" or a name of [parameters] ({names(self.parameters)})" if named else ""))
            return None
        if isinstance(v, int) and abs(v) > MAX_MAGNITUDE:  # before float(): 10**400 has none
            self.bad(where, key, f"got a whole number of {digits(v)} digits",
                     f"a number of magnitude at most {MAX_MAGNITUDE:g}")
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

    def integer(self, where, key, v, lo=1, hi=MAX_STEPS):
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

    def numbers(self, where, key, v, min_len=1, max_len=MAX_ARRAY):
        if not isinstance(v, list) or not min_len <= len(v) <= max_len:
            self.bad(where, key, f"got {show(v)}", f"a list of {min_len} to {max_len} numbers")
            return None
        out = [self.number(where, key, x) for x in v]
        return None if None in out else tuple(out)

    def increasing(self, where, key, x, what):
        """x strictly increasing with gaps of at least MIN_SPACING of its span."""
        gap = min(b - a for a, b in zip(x, x[1:]))
        if gap <= 0:
            self.bad(where, key, "not strictly increasing", f"strictly increasing {what}")
            return False
        if gap < MIN_SPACING * (x[-1] - x[0]):
            self.bad(where, key, f"two values only {gap:.3g} apart",
                     f"strictly increasing {what}, consecutive values at least {MIN_SPACING:g} of the span apart")
            return False
        return True

    def string(self, where, key, v, pattern=None, expected="a string", max_len=MAX_TEXT):
        if (not isinstance(v, str) or len(v) > max_len
                or (pattern is not None and not pattern.fullmatch(v))):
            self.bad(where, key, f"got {show(v)}", expected)
            return None
        return v

    def name(self, where, v, pattern=IDENT_RE, expected=IDENT_TEXT):
        """A name (of a body, point, constraint): the whole string matches."""
        if not isinstance(v, str) or not pattern.fullmatch(v):
            self.bad(where, None, f"bad name {show(v)}", expected)
            return None
        return v


def suggest(word, options):
    """The option closest to a mistyped word, if any is close (difflib's ratio >= 0.6)."""
    if not isinstance(word, str) or len(word) > 200:
        return None
    lower = {}
    for o in options:
        if isinstance(o, str):
            lower.setdefault(o.lower(), o)
    close = difflib.get_close_matches(word.lower(), list(lower), n=1)  # case-blind: 'b' suggests 'B'
    return lower[close[0]] if close else None


def names(d) -> str:
    names = list(d)
    return ", ".join(names[:20]) + (f" and {len(names) - 20} more" if len(names) > 20 else "")


def show(v) -> str:
    """A value of a case file as a problem quotes it: Python's repr, but a TOML date or time as the file writes it
    (not "datetime.date(1979, 5, 27)")."""
    import datetime

    if isinstance(v, (datetime.date, datetime.time)):   # datetime.datetime is a date
        kind = "date-time" if isinstance(v, datetime.datetime) else "date" if isinstance(v, datetime.date) else "time"
        r = f"{v.isoformat()} (a TOML {kind})"
    elif isinstance(v, int) and abs(v).bit_length() > 10_000:   # its repr raises ValueError past 4,300 digits
        r = f"a whole number of {digits(v)} digits"
    else:
        r = repr(v)
    return r if len(r) <= 60 else r[:57] + "..."


def digits(v: int) -> str:
    """How many decimal digits the whole number v has, in words: exact up to some 3,000 digits, else "about N"
    (Python converts no longer one to text: sys.get_int_max_str_digits)."""
    n = abs(v).bit_length()
    if n <= 10_000:
        return f"{len(str(abs(v)))}"
    return f"about {int(n * math.log10(2)) + 1:,}"


def texts(v) -> tuple | None:
    """An API argument of names (columns, parameter paths) as a tuple: one
    text is one name, an iterable its texts; None where it is neither or
    holds something that is no text. (A list or a tuple is told by its
    type first: the Iterable check, an abstract class's, took most of a
    warm kinem.sensitivity call's 3 us here.)"""
    given = (v,) if isinstance(v, str) else tuple(v) if type(v) in (list, tuple) or isinstance(v, Iterable) else None
    return given if given is not None and all(isinstance(x, str) for x in given) else None


def floats(v):
    """An API argument of numbers as a float array (any shape), or None where
    it is not one: a text, a table, a ragged list, booleans (not numbers, as
    in a case file), complex numbers (not cast to their real part), a whole
    number no float holds, a masked array with a masked value (missing, not
    a number: np.asarray would drop the mask and keep what lies under it)."""
    import numpy as np

    if np.ma.is_masked(v):
        return None
    try:
        a = np.asarray(v)
        return a.astype(float) if a.dtype != bool and a.dtype.kind != "c" else None
    except (TypeError, ValueError, OverflowError):
        return None


def number(text):
    """A command-line number as TOML would read it: an int, a float, or the text itself (then rejected)."""
    if not isinstance(text, str):
        return text
    v = toml_number(text)
    if v is None:
        return text
    return int(v) if isinstance(v, float) and v.is_integer() and abs(v) <= 2**53 else v


def toml_number(text: str):
    """A text read as a case file's number is (TOML: 1_000, 1e3, 0x10, inf, nan; not 1__0, .5, 1., 01,
    infinity, NaN or a digit of another script): its int or float as TOML gives it, else None."""
    if not TOML_NUMBER_RE.fullmatch(text.strip()):   # one value alone: no string, table, comment or second line
        return None
    try:
        v = tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return None
    except ValueError:   # a whole number of more digits than Python converts (sys.get_int_max_str_digits)
        count = sum(c.isdigit() for c in text)
        return (-1 if text.strip().startswith("-") else 1) * 10 ** (count - 1)   # as many digits: refused as such
    return v if isinstance(v, (int, float)) and not isinstance(v, bool) else None   # not true, not a date


def toml_float(text: str) -> float:
    """A text read as a case file's number is (``toml_number``: 1e3, 1_000, 0x10; not infinity, 1__0 or
    .5), as a float; a whole number beyond a float's range as infinity (refused where only finite numbers
    are); ValueError when it is no such number."""
    v = toml_number(text)
    if v is None:
        raise ValueError(text)
    if isinstance(v, int) and abs(v) >= 2**1024:
        return math.inf if v > 0 else -math.inf
    return float(v)


TOML_NUMBER_RE = re.compile(r"[0-9a-zA-Z_.+-]+", re.ASCII)
TOML_NUMBERS = "TOML: 0.5, -3, 1e-3, 1_000; not .5, 1., infinity or 1__0"   # for messages
