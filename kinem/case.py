"""Case files (TOML, format version 1: docs/case-format.md) into a frozen Case.

Every problem is collected, each naming the file, the place and the key and
saying what was expected; then one InputError carries them all. Case files
are data: nothing in them is evaluated, and size limits keep a hostile file
from exhausting memory. The checks live in kinem.casefile, split by concern.
"""
import os
import tomllib
from pathlib import Path

from . import functions as fn
from .casefile import sections
from .casefile.checks import IDENT_RE, MAX_ARRAY, MAX_MAGNITUDE, MAX_NAME, MAX_TEXT, NAME_RE, Checker  # noqa: F401
from .casefile.constraints import constraints
from .casefile.keys import COORDS  # noqa: F401
from .casefile.sections import LINEAR_SOLVERS, MAX_ITEMS, SOLVER_KEYS  # noqa: F401
from .errors import InputError
from .spec import Case, frozen_map

MAX_FILE_BYTES = 16 * 2**20
TOP_KEYS = ("name", "description", "units", "time", "solver", "bodies", "points", "constraints", "engines",
            "equivalent", "report", "tolerances")


def load(path) -> Case:
    """Read and validate a case file."""
    import stat

    from .output import read_fifo

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
    return loads(raw, source=str(path))


def loads(text, source: str = "<string>") -> Case:
    """Validate a case given as TOML text (str or bytes)."""
    if isinstance(text, bytes):
        if len(text) > MAX_FILE_BYTES:
            raise InputError(f"{source}: {len(text)} bytes; expected at most {MAX_FILE_BYTES}")
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as e:
            raise InputError(f"{source}: not UTF-8 text (byte {e.start}); expected a TOML case file") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{source}: TOML syntax error: {e}") from None
    except RecursionError:
        raise InputError(f"{source}: TOML nested too deeply; expected a case file") from None
    except ValueError as e:  # an integer of more digits than Python converts (sys.get_int_max_str_digits)
        raise InputError(f"{source}: {str(e).split(':')[0]}; expected numbers of magnitude at most "
                         f"{MAX_MAGNITUDE:g}") from None
    return load_dict(data, source=source)


def load_dict(data, source: str = "<dict>") -> Case:
    """Validate a case given as a dict with the case file's structure."""
    ck = Checker(source)
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a table at the top level")
    ck.keys("top level", data, TOP_KEYS, ("name", "time", "bodies", "constraints"))
    name = ck.string("top level", "name", data.get("name", "case"), NAME_RE,
                     f"an identifier of 1 to {MAX_NAME} characters a-z, 0-9, '_' and '-'")
    description = ck.string("top level", "description", data.get("description", ""),
                            expected=f"a string of at most {MAX_TEXT} characters")
    units = sections.units(ck, data.get("units", {}))
    end, steps = sections.time(ck, data.get("time"))
    solver = sections.solver(ck, data.get("solver", {}))
    bodies = sections.bodies(ck, data.get("bodies"))
    points = sections.points(ck, data.get("points", {}), bodies)
    cons = constraints(ck, data.get("constraints"), bodies, points, end)
    engines = sections.engines(ck, data.get("engines", {}))
    equivalent = sections.equivalent(ck, data["equivalent"], points) if "equivalent" in data else None
    report = sections.report(ck, data.get("report", {}), points)
    tolerances = sections.tolerances(ck, data.get("tolerances", {}))
    ck.raise_if_any()
    case = Case(name=name, bodies=tuple(bodies.values()), points=tuple(points.values()),
                constraints=tuple(cons), end=end or 1.0, steps=steps, description=description,
                units=frozen_map(units), engines=frozen_map(engines), source=source,
                equivalent=equivalent, report=frozen_map(report), tolerances=frozen_map(tolerances), **solver)
    if tolerances:   # their paths and sizes need the whole case (kinem.tolerance)
        from .tolerance import tolerances_of

        tolerances_of(case)
    if "sensitivity" in case.report:   # paths of design parameters (kinem.parameters)
        from .parameters import resolve

        resolve(case, case.report["sensitivity"])
    return case


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
        end = sections.end_time(ck, "--end", None, _number(end))
    if steps is not None:
        steps = sections.steps(ck, "--steps", None, _number(steps))
    ck.raise_if_any()
    return end, steps


def _number(text):
    """A command-line number as TOML would read it: an int, a float, or the text itself (then rejected)."""
    if not isinstance(text, str):
        return text
    for convert in (int, float):
        try:
            v = convert(text.replace("_", ""))
        except (ValueError, OverflowError):
            continue
        return int(v) if isinstance(v, float) and v.is_integer() and abs(v) <= 2**53 else v
    return text
