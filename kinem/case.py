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
from .casefile.drawn import place
from .casefile.keys import COORDS  # noqa: F401
from .casefile.sections import LINEAR_SOLVERS, MAX_ITEMS, SOLVER_KEYS  # noqa: F401
from .constraints.read import constraints
from .errors import InputError
from .spec import Case, frozen_map

MAX_FILE_BYTES = 16 * 2**20
TOP_KEYS = ("name", "description", "parameters", "units", "time", "solver", "bodies", "points", "constraints", "engines",
            "equivalent", "report", "tolerances")


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
    if isinstance(text, bytes):
        if len(text) > MAX_FILE_BYTES:
            raise InputError(f"{source}: {len(text)} bytes; expected at most {MAX_FILE_BYTES}")
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as e:
            raise InputError(f"{source}: not UTF-8 text (byte {e.start}); expected a TOML case file") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{source}: TOML syntax error: {e}") from None
    except RecursionError:
        raise InputError(f"{source}: TOML nested too deeply; expected a case file") from None
    except ValueError as e:  # an integer of more digits than Python converts (sys.get_int_max_str_digits)
        raise InputError(f"{source}: {str(e).split(':')[0]}; expected numbers of magnitude at most "
                         f"{MAX_MAGNITUDE:g}") from None


def load_dict(data, source: str = "<dict>", parameters=None, stacklevel: int = 2) -> Case:
    """Validate a case given as a dict with the case file's structure
    (``parameters`` as for ``load``: {name or design parameter path: value})."""
    ck = Checker(source)
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected a table at the top level")
    if parameters:   # the file's case, then the values set (kinem.parameters.apply: named dimensions and paths)
        import warnings

        from .errors import KinemWarning
        from .parameters import apply

        with warnings.catch_warnings():   # given once, by the case with the values set
            warnings.simplefilter("ignore", KinemWarning)
            case = load_dict(data, source)
        return apply(case, parameters, source)
    ck.keys("top level", data, TOP_KEYS, ("name", "time", "bodies", "constraints"))
    name = ck.string("top level", "name", data.get("name", "case"), NAME_RE,
                     f"an identifier of 1 to {MAX_NAME} characters a-z, 0-9, '_' and '-'")
    description = ck.string("top level", "description", data.get("description", ""),
                            expected=f"a string of at most {MAX_TEXT} characters")
    params = sections.parameters(ck, data.get("parameters", {}))
    units = sections.units(ck, data.get("units", {}))
    end, steps = sections.time(ck, data.get("time"))
    solver = sections.solver(ck, data.get("solver", {}))
    bodies = sections.bodies(ck, data.get("bodies"))
    points, drawn = sections.points(ck, data.get("points", {}), bodies)
    bodies, points = place(ck, bodies, points, drawn, list(data["points"]) if isinstance(data.get("points"), dict) else [])
    cons = constraints(ck, data.get("constraints"), bodies, points, end)
    engines = sections.engines(ck, data.get("engines", {}))
    equivalent = sections.equivalent(ck, data["equivalent"], points) if "equivalent" in data else None
    report = sections.report(ck, data.get("report", {}), points)
    tolerances = sections.tolerances(ck, data.get("tolerances", {}))
    ck.raise_if_any()
    case = Case(name=name, bodies=tuple(bodies.values()), points=tuple(points.values()),
                constraints=tuple(cons), end=end or 1.0, steps=steps, description=description,
                units=frozen_map(units), engines=frozen_map(engines), source=source,
                equivalent=equivalent, report=frozen_map(report), parameters=frozen_map(params),
                tolerances=frozen_map(tolerances), uses=frozen_map(uses(data, params, cons)), **solver)
    if tolerances:   # their paths and sizes need the whole case (kinem.tolerance)
        from .tolerance import tolerances_of

        tolerances_of(case)
    if "sensitivity" in case.report:   # paths of design parameters (kinem.parameters)
        from .parameters import resolve

        resolve(case, case.report["sensitivity"])
    for text in fast_drivers(case):
        import warnings

        from .errors import KinemWarning

        warnings.warn(text, KinemWarning, stacklevel=stacklevel)
    return case


def uses(data, params, cons) -> dict:
    """name -> the paths (kinem.parameters' words: points.A.at.0,
    constraints.B.si.1, bodies.crank.q.2, time.end) of the numbers of the
    file that name a [parameters] entry."""
    from .constraints import REGISTRY
    from .parameters import constraint_id

    out = {}

    def walk(path, v):
        if isinstance(v, str) and v in params:
            out.setdefault(v, []).append(".".join(path))
        elif isinstance(v, dict):
            for k, x in v.items():
                walk(path + [str(k)], x)
        elif isinstance(v, list):
            for k, x in enumerate(v):
                walk(path + [str(k)], x)

    if not params:
        return {}
    for section, keys in (("time", ("end", "dt")), ("bodies", ("q", "mass", "inertia")), ("points", ("at",))):
        table = data.get(section)
        items = [(None, table)] if section == "time" else list(table.items()) if isinstance(table, dict) else []
        for name, t in items:
            for k in keys if isinstance(t, dict) else ():
                if k in t:
                    walk([section] + ([name] if name else []) + [k], t[k])
    by_index = {c.index: c for c in cons}
    for index, table in enumerate(data.get("constraints") or [], 1):
        if index not in by_index or not isinstance(table, dict):
            continue
        c = by_index[index]
        numeric = {k.name for k in REGISTRY[c.type].keys if type(k).__name__ in ("NumberKey", "PositiveKey")}
        for k, v in table.items():
            if k not in ("type", "name") and (not isinstance(v, str) or k in numeric) and k not in c.refs:
                walk(["constraints", constraint_id(c), k], v)
    return {k: tuple(v) for k, v in out.items()}


FAST_TURNS = 50        # turns a second: a crank faster than this looks like degrees per second given as rad/s
MANY_TURNS = 100       # turns over the output span, likewise, when the output instants are too few to follow them
COARSE = 0.25          # turns per output interval: more, and the output does not show the turning


def fast_drivers(case) -> list:
    """A warning for each driver of an angle that turns (a turn or more over
    [0, end]: not a fast small oscillation) faster than FAST_TURNS a second, or more than MANY_TURNS times over [0, end] at more than COARSE
    turns per output interval (a long run sampled to follow it is meant): a
    speed given in degrees per second where radians per second are read
    (units = { angle = "deg" } reads them as degrees)."""
    import math

    import numpy as np

    out = []
    t = np.linspace(0.0, case.end, 1001)
    for c in case.constraints:
        if c.type != "driver" or c.get("coord") != "phi":
            continue
        f = fn.FunctionSet([c["d"]])
        speed = float(np.abs(f(t, 1)).max())
        turns = float(abs(f(case.end)[0] - f(0.0)[0])) / (2 * math.pi)
        if (speed > 2 * math.pi * FAST_TURNS and turns >= 1) or (turns > MANY_TURNS and turns / case.steps > COARSE):
            out.append(f"{case.source}: {c.where}: turns body '{c['body']}' at up to {speed:.4g} rad/s "
                       f"({speed / (2 * math.pi):.3g} turns a second, {turns:.3g} turns in {case.end:g} s, {case.steps} output intervals); if its "
                       f"d(t) is in degrees, that is {math.radians(speed):.4g} rad/s: convert it, or set "
                       "units = { angle = \"deg\" } for the case's angles")
    return out


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
