"""Case files (TOML, format version 1: docs/case-format.md) into a frozen Case.

Every problem is collected, each naming the file, the place and the key and
saying what was expected; then one InputError carries them all. Case files
are data: nothing in them is evaluated, and size limits keep a hostile file
from exhausting memory. The front door: files, text and values set
(kinem.parameters.apply); a dict is checked by kinem.loader (the sections:
kinem.casefile, split by concern) and kinem.parameters.validated.
"""
import os
import tomllib
import warnings
from pathlib import Path

from . import functions as fn
from .casefile import sections
from .casefile.checks import IDENT_RE, MAX_ARRAY, MAX_MAGNITUDE, MAX_NAME, MAX_TEXT, NAME_RE, Checker, number  # noqa: F401
from .casefile.keys import COORDS  # noqa: F401
from .casefile.sections import LINEAR_SOLVERS, MAX_ITEMS, SOLVER_KEYS  # noqa: F401
from .errors import InputError, KinemWarning
from .parameters import apply, validated
from .spec import Case

MAX_FILE_BYTES = 16 * 2**20


def load(path, parameters=None) -> Case:
    """Read and validate a case file; ``parameters``: values instead of the
    file's, of its named dimensions ({"crank": 55} or {"parameters.crank": 55})
    or of any design parameter ({"constraints.B.si.0": 0.31}: kinem.parameters.apply)."""
    return load_dict(read(path), source=str(path), parameters=parameters)


def read(path) -> dict:
    """A case file's TOML as a dict, not yet validated (size-capped; a FIFO's writer waited for)."""
    import stat

    from .output import read_fifo

    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"load: path {path!r:.80}: expected a file path (str or pathlib.Path)")
    path = Path(path)
    try:
        if stat.S_ISFIFO(os.stat(path).st_mode):   # a named pipe or process substitution: its writer waited for
            raw = read_fifo(path, MAX_FILE_BYTES + 1)
        else:
            with open(path, "rb") as f:  # at most one byte past the cap: /dev/zero ends too
                raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise InputError(f"{path}: cannot read: {e.strerror or e}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(f"{path}: more than {MAX_FILE_BYTES} bytes; expected a case file of at most 16 MiB")
    return _toml(raw, str(path))


def loads(text, source: str = "<string>", parameters=None) -> Case:
    """Validate a case given as TOML text (str or bytes)."""
    return load_dict(_toml(text, source), source=source, parameters=parameters)


def _toml(text, source) -> dict:
    if not isinstance(text, (str, bytes)):
        raise InputError(f"{source}: got {type(text).__name__}; expected a case file's TOML text (str or bytes)")
    if isinstance(text, bytes):
        if len(text) > MAX_FILE_BYTES:
            raise InputError(f"{source}: {len(text)} bytes; expected at most {MAX_FILE_BYTES}")
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as e:
            raise InputError(f"{source}: not UTF-8 text (byte {e.start}); expected a TOML case file") from None
    try:   # one leading byte order mark (U+FEFF) is an editor's, not the TOML's: as Python's "utf-8-sig" reads it
        return tomllib.loads(text.removeprefix("\ufeff"))
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{source}: TOML syntax error: {e}") from None
    except RecursionError:
        raise InputError(f"{source}: TOML nested too deeply; expected a case file") from None
    except ValueError as e:  # an integer of more digits than Python converts (sys.get_int_max_str_digits)
        import re

        long = re.search(r"[0-9][0-9_]{4000,}", text)   # the place: tomllib's ValueError gives none
        where = f" line {text.count(chr(10), 0, long.start()) + 1}:" if long else ""
        raise InputError(f"{source}:{where} {str(e).split(':')[0]}; expected numbers of magnitude at most "
                         f"{MAX_MAGNITUDE:g}") from None


def load_dict(data, source: str = "<dict>", parameters=None, stacklevel: int = 2) -> Case:
    """Validate a case given as a dict with the case file's structure
    (``parameters`` as for ``load``: {name or design parameter path: value})."""
    if not parameters:
        return validated(data, source, stacklevel)
    # the file's case, then the values set (kinem.parameters.apply: named dimensions and paths)
    with warnings.catch_warnings():   # given once, by the case with the values set
        warnings.simplefilter("ignore", KinemWarning)
        case = validated(data, source)
    return apply(case, parameters, source)


def check_time(case: Case) -> Case:
    """Re-checks a case whose time span was changed: every table function
    must still cover [0, end]."""
    problems = []
    for c in case.constraints:
        for key, v in c.fields.items():
            if isinstance(v, fn.Table) and (v.t[0] > 0 or v.t[-1] < case.end):
                problems.append(f"{case.source}: {c.where}: key '{key}': table covers [{v.t[0]:g}, {v.t[-1]:g}]; "
                                f"expected a table that covers [0, {case.end:g}]")
    if problems:
        raise InputError(problems)
    return case


def time_options(end=None, steps=None, source="command line"):
    """--end and --steps (text or numbers) checked by the rules of [time]
    end and steps; returns (end, steps), None where not given."""
    ck = Checker(source)
    if end is not None:
        end = sections.end_time(ck, "--end", None, number(end))
    if steps is not None:
        steps = sections.steps(ck, "--steps", None, number(steps))
    ck.raise_if_any()
    return end, steps
