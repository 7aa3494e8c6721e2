"""Case files (TOML, format version 1: docs/case-format.md) into a frozen Case.

Every problem is collected, each naming the file, the place and the key and
saying what was expected; then one InputError carries them all. Case files
are data: nothing in them is evaluated, and size limits keep a hostile file
from exhausting memory.
"""
import math
import re
import tomllib
from pathlib import Path

from . import functions as fn
from .constraints import REGISTRY, implemented_types
from .errors import InputError
from .outline import OPEN_BC, Outline
from .spec import Body, Case, Constraint, Point, frozen_map

MAX_FILE_BYTES = 16 * 2**20
MAX_ARRAY = 100_000
MAX_ITEMS = 100_000
MAX_MAGNITUDE = 1e12  # any length, angle or time beyond this is a mistake, and its squares stay finite
NAME_RE = re.compile(r"^[a-z0-9_-]+$")
IDENT_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*$")

TOP_KEYS = ("name", "description", "units", "time", "solver", "bodies", "points", "constraints", "engines",
            "report")
ENGINES = ("pymunk", "mujoco", "exudyn")  # settings are checked against each adapter when it runs
SOLVER_KEYS = ("tolerance", "max_iterations", "linear_solver", "jacobian_reuse", "block")
LINEAR_SOLVERS = ("auto", "dense", "sparse")
COORDS = ("x", "y", "phi")


def load(path) -> Case:
    """Read and validate a case file."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise InputError(f"{path}: file is {size} bytes; expected at most {MAX_FILE_BYTES}")
        raw = path.read_bytes()
    except OSError as e:
        raise InputError(f"{path}: cannot read: {e.strerror or e}") from None
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
    return load_dict(data, source=source)


def load_dict(data, source: str = "<dict>") -> Case:
    """Validate a case given as a dict with the case file's structure."""
    return _Loader(source).case(data)


class _Loader:
    def __init__(self, source):
        self.source = source
        self.problems = []

    # -- reporting -------------------------------------------------------
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

    # -- scalars ---------------------------------------------------------
    def number(self, where, key, v, positive=False, nonneg=False):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.bad(where, key, f"got {_show(v)}", "a number")
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
            self.bad(where, key, f"got {_show(v)}", f"a whole number from {lo} to {hi}")
            return None
        return v

    def vector(self, where, key, v, n, what=None):
        if not isinstance(v, list) or len(v) != n:
            self.bad(where, key, f"got {_show(v)}", what or f"a list of {n} numbers")
            return None
        out = [self.number(where, key, x) for x in v]
        return None if None in out else tuple(out)

    def numbers(self, where, key, v, min_len=1):
        if not isinstance(v, list) or not min_len <= len(v) <= MAX_ARRAY:
            self.bad(where, key, f"got {_show(v)}", f"a list of {min_len} to {MAX_ARRAY} numbers")
            return None
        out = [self.number(where, key, x) for x in v]
        return None if None in out else tuple(out)

    def string(self, where, key, v, pattern=None, expected="a string"):
        if not isinstance(v, str) or (pattern is not None and not pattern.match(v)):
            self.bad(where, key, f"got {_show(v)}", expected)
            return None
        return v

    # -- the case --------------------------------------------------------
    def case(self, data) -> Case:
        if not isinstance(data, dict):
            raise InputError(f"{self.source}: expected a table at the top level")
        self.keys("top level", data, TOP_KEYS, ("name", "time", "bodies", "constraints"))
        name = self.string("top level", "name", data.get("name", "case"), NAME_RE,
                           "an identifier of a-z, 0-9, '_' and '-'")
        description = data.get("description", "")
        if not isinstance(description, str):
            self.bad("top level", "description", f"got {_show(description)}", "a string")
        units = self.units(data.get("units", {}))
        end, steps = self.time(data.get("time", {}))
        solver = self.solver(data.get("solver", {}))
        bodies = self.bodies(data.get("bodies", {}))
        points = self.points(data.get("points", {}), bodies)
        constraints = self.constraints(data.get("constraints", []), bodies, points, end)
        engines = self.engines(data.get("engines", {}))
        report = self.report(data.get("report", {}), points)
        if self.problems:
            raise InputError(self.problems)
        return Case(name=name, bodies=tuple(bodies.values()), points=tuple(points.values()),
                    constraints=tuple(constraints), end=end, steps=steps, description=description,
                    units=frozen_map(units), engines=frozen_map(engines), source=self.source,
                    report=frozen_map(report), **solver)

    def units(self, u):
        if not isinstance(u, dict):
            self.bad("units", None, f"got {_show(u)}", "a table such as { length = \"mm\" }")
            return {}
        self.keys("units", u, ("length",))
        if "length" in u:
            self.string("units", "length", u["length"])
        return {k: v for k, v in u.items() if k == "length" and isinstance(v, str)}

    def report(self, r, points):
        """[report]: points = the named points the report draws and plots (default: all)."""
        if not isinstance(r, dict):
            self.bad("[report]", None, f"got {_show(r)}", "a table such as { points = [\"B\"] }")
            return {}
        self.keys("[report]", r, ("points",))
        names = r.get("points")
        if names is None:
            return {}
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            self.bad("[report]", "points", f"got {_show(names)}", "a non-empty list of names from [points]")
            return {}
        unknown = [n for n in names if n not in points]
        if unknown:
            self.bad("[report]", "points", f"unknown point {_show(unknown[0])}",
                     "names from [points]: " + (_names(points) or "(none)"))
            return {}
        return {"points": tuple(dict.fromkeys(names))}

    def engines(self, e):
        """[engines.<name>] tables of settings: scalars or short lists of numbers."""
        if not isinstance(e, dict):
            self.bad("[engines]", None, f"got {_show(e)}", "a table of [engines.<name>] tables")
            return {}
        out = {}
        for name, table in e.items():
            where = f"[engines.{name}]"
            if name not in ENGINES:
                self.bad(where, None, f"unknown engine '{name}'", "one of " + ", ".join(ENGINES))
                continue
            if not isinstance(table, dict):
                self.bad(where, None, f"got {_show(table)}", "a table of settings")
                continue
            ok = {}
            for k, v in table.items():
                if isinstance(v, int) and not isinstance(v, bool):
                    v = int(v) if self.number(where, k, v) is not None else None  # counts stay whole
                elif isinstance(v, float):
                    v = self.number(where, k, v)
                elif isinstance(v, list):
                    v = self.numbers(where, k, v)
                    v = None if v is None or len(v) > 16 else v
                elif not isinstance(v, (str, bool)):
                    self.bad(where, k, f"got {_show(v)}", "a number, string, boolean or list of numbers")
                    v = None
                if v is not None:
                    ok[k] = v
            out[name] = frozen_map(ok)
        return out

    def time(self, t):
        where = "[time]"
        if not isinstance(t, dict):
            self.bad(where, None, f"got {_show(t)}", "a table with end and steps (or dt)")
            return 1.0, 1
        self.keys(where, t, ("end", "steps", "dt"), ("end",))
        end = self.number(where, "end", t["end"], positive=True) if "end" in t else None
        if ("steps" in t) == ("dt" in t):
            self.bad(where, "steps", "give exactly one of 'steps' and 'dt'")
            return end or 1.0, 1
        if "steps" in t:
            steps = self.integer(where, "steps", t["steps"])
        else:
            dt = self.number(where, "dt", t["dt"], positive=True)
            steps = None
            if dt is not None and end is not None:
                n = round(end / dt)
                if n < 1 or n > 10**7 or abs(n * dt - end) > 1e-9 * end:
                    self.bad(where, "dt", f"end/dt = {end / dt:g}", "a step that divides end into 1 to 1e7 intervals")
                else:
                    steps = n
        return end or 1.0, steps or 1

    def solver(self, s):
        where = "[solver]"
        if not isinstance(s, dict):
            self.bad(where, None, f"got {_show(s)}", "a table")
            return {}
        self.keys(where, s, SOLVER_KEYS)
        out = {}
        if "tolerance" in s:
            tol = self.number(where, "tolerance", s["tolerance"], positive=True)
            if tol is not None and tol >= 1:
                self.bad(where, "tolerance", f"got {tol:g}", "a number between 0 and 1")
            elif tol is not None:
                out["tolerance"] = tol
        if "max_iterations" in s:
            it = self.integer(where, "max_iterations", s["max_iterations"], 1, 1000)
            if it is not None:
                out["max_iterations"] = it
        if "jacobian_reuse" in s:
            if not isinstance(s["jacobian_reuse"], bool):
                self.bad(where, "jacobian_reuse", f"got {_show(s['jacobian_reuse'])}", "true or false")
            else:
                out["jacobian_reuse"] = s["jacobian_reuse"]
        if "block" in s:
            b = self.integer(where, "block", s["block"], 1, 4096)
            if b is not None:
                out["block"] = b
        if "linear_solver" in s:
            ls = s["linear_solver"]
            if ls not in LINEAR_SOLVERS:
                self.bad(where, "linear_solver", f"got {_show(ls)}", "one of " + ", ".join(LINEAR_SOLVERS))
            else:
                out["linear_solver"] = ls
        return out

    def bodies(self, b):
        if not isinstance(b, dict) or not b:
            self.bad("[bodies]", None, f"got {_show(b)}", "a table with at least one body")
            return {}
        if len(b) > MAX_ITEMS:
            self.bad("[bodies]", None, f"{len(b)} bodies", f"at most {MAX_ITEMS}")
            return {}
        out = {}
        for name, v in b.items():
            where = f"body '{name}'"
            if not IDENT_RE.match(name):
                self.bad(where, None, "bad name", "a name of letters, digits, '_' and '-' that starts with a letter or '_'")
                continue
            if not isinstance(v, dict):
                self.bad(where, None, f"got {_show(v)}", "a table such as { q = [x, y, phi] }")
                continue
            self.keys(where, v, ("q", "mass", "inertia"), ("q",))
            q = self.vector(where, "q", v["q"], 3, "[x, y, phi]") if "q" in v else None
            mass = self.number(where, "mass", v["mass"], positive=True) if "mass" in v else None
            inertia = self.number(where, "inertia", v["inertia"], positive=True) if "inertia" in v else None
            if q is not None:
                out[name] = Body(name, q, mass, inertia)
        return out

    def points(self, p, bodies):
        if not isinstance(p, dict):
            self.bad("[points]", None, f"got {_show(p)}", "a table of points")
            return {}
        if len(p) > MAX_ITEMS:
            self.bad("[points]", None, f"{len(p)} points", f"at most {MAX_ITEMS}")
            return {}
        out = {}
        for name, v in p.items():
            where = f"point '{name}'"
            if not IDENT_RE.match(name):
                self.bad(where, None, "bad name", "a name of letters, digits, '_' and '-'")
                continue
            if name in bodies:
                self.bad(where, None, "has the name of a body", "point names distinct from body names")
                continue
            if not isinstance(v, dict):
                self.bad(where, None, f"got {_show(v)}", "a table such as { body = \"crank\", at = [xi, eta] }")
                continue
            if not self.keys(where, v, ("body", "at"), ("body", "at")):
                continue
            body = v["body"]
            if not isinstance(body, str) or body not in bodies:
                self.bad(where, "body", f"unknown body {_show(body)}", "one of " + _names(bodies))
                continue
            at = self.vector(where, "at", v["at"], 2, "[xi, eta]")
            if at is not None:
                out[name] = Point(name, body, at)
        return out

    def constraints(self, cs, bodies, points, end):
        if not isinstance(cs, list) or not cs:
            self.bad("[[constraints]]", None, f"got {_show(cs)}", "at least one [[constraints]] table")
            return []
        if len(cs) > MAX_ITEMS:
            self.bad("[[constraints]]", None, f"{len(cs)} constraints", f"at most {MAX_ITEMS}")
            return []
        out, names = [], set()
        for index, c in enumerate(cs, 1):
            con = self.constraint(index, c, bodies, points, end)
            if con is None:
                continue
            if con.name in names:
                self.bad(con.where, "name", "duplicate name", "a name used by no other constraint")
            names.add(con.name)
            out.append(con)
        return out

    def constraint(self, index, c, bodies, points, end):
        where = f"constraint {index}"
        if not isinstance(c, dict):
            self.bad(where, None, f"got {_show(c)}", "a table")
            return None
        ctype = c.get("type")
        if ctype is None:
            self.bad(where, "type", "missing", "one of " + ", ".join(REGISTRY))
            return None
        if not isinstance(ctype, str) or ctype not in REGISTRY:
            self.bad(where, "type", f"unknown type {_show(ctype)}", "one of " + ", ".join(REGISTRY))
            return None
        decl = REGISTRY[ctype]
        name = c.get("name", f"{ctype}-{index}")
        if not isinstance(name, str) or not IDENT_RE.match(name):
            self.bad(where, "name", f"got {_show(name)}", "a name of letters, digits, '_' and '-'")
            name = f"{ctype}-{index}"
        where = f"constraint {index} ('{name}', {ctype})"
        if decl.family is None:
            self.bad(where, "type", f"type '{ctype}' (Eqs. {decl.equations}) is not implemented yet",
                     "one of " + ", ".join(implemented_types()))
            return None
        allowed = ("type", "name") + tuple(k.name for k in decl.keys)
        n_before = len(self.problems)
        self.keys(where, c, allowed, tuple(k.name for k in decl.keys if k.required))
        fields = {}
        for key in decl.keys:
            if key.name in c:
                v = self.value(where, key, c[key.name], c, bodies, points, end)
                if v is not None:
                    fields[key.name] = v
        if len(self.problems) > n_before:
            return None
        used = [fields[k.name] for k in decl.keys if k.kind == "body" and k.name in fields]
        if len(set(used)) != len(used):
            self.bad(where, None, "the same body is named twice (" + ", ".join(used) + ")", "distinct bodies")
            return None
        if decl.check is not None:
            for key, problem, expected in decl.check(fields, bodies):
                self.bad(where, key, problem, expected)
            if len(self.problems) > n_before:
                return None
        return Constraint(ctype, name, index, frozen_map(fields))

    def value(self, where, key, v, c, bodies, points, end):
        kind = key.kind
        if kind == "body":
            if not isinstance(v, str) or v not in bodies:
                self.bad(where, key.name, f"unknown body {_show(v)}", "one of " + _names(bodies))
                return None
            return v
        if kind == "local":
            body = c.get(key.of)
            if isinstance(v, str):
                if v not in points:
                    self.bad(where, key.name, f"unknown point {_show(v)}",
                             "[xi, eta] or one of the points " + (_names(points) or "(none defined)"))
                    return None
                if points[v].body != body:
                    self.bad(where, key.name, f"point '{v}' is on body '{points[v].body}', not on '{body}'",
                             f"a point on body '{body}' or [xi, eta]")
                    return None
                return points[v].at
            return self.vector(where, key.name, v, 2, "[xi, eta] or a point name")
        if kind == "number":
            return self.number(where, key.name, v)
        if kind == "positive":
            return self.number(where, key.name, v, positive=True)
        if kind == "direction":
            d = self.vector(where, key.name, v, 2, "[x, y]")
            if d is not None and math.hypot(*d) == 0:
                self.bad(where, key.name, "zero vector", "a non-zero [x, y]")
                return None
            return d
        if kind == "vector3":
            return self.vector(where, key.name, v, 3, "[x, y, phi]")
        if kind == "coord":
            if v not in COORDS:
                self.bad(where, key.name, f"got {_show(v)}", "one of x, y, phi")
                return None
            return v
        if kind == "bool":
            if not isinstance(v, bool):
                self.bad(where, key.name, f"got {_show(v)}", "true or false")
                return None
            return v
        if kind == "function":
            return self.function(where, key.name, v, end)
        if kind == "outline":
            return self.outline(where, key.name, v)
        raise AssertionError(f"unknown key kind {kind}")

    def function(self, where, key, v, end):
        expected = "a number, { poly = [...] }, { harmonic = {...} } or { table = {...} }"
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            c = self.number(where, key, v)
            return None if c is None else fn.constant(c)
        if not isinstance(v, dict) or len(v) != 1:
            self.bad(where, key, f"got {_show(v)}", expected)
            return None
        (kind, body), = v.items()
        if kind == "poly":
            c = self.numbers(where, key, body)
            if c is not None and len(c) > 32:
                self.bad(where, key, f"poly of {len(c)} coefficients", "at most 32")
                return None
            return None if c is None else fn.Poly(c)
        if kind == "harmonic":
            w = f"{where}: key '{key}'"
            if not isinstance(body, dict):
                self.bad(where, key, f"got {_show(body)}", "{ amplitude = A, omega = w, phase = p, offset = c }")
                return None
            if not self.keys(w + " harmonic", body, ("amplitude", "omega", "phase", "offset"), ("amplitude", "omega")):
                return None
            vals = {k: self.number(where, f"{key}.harmonic.{k}", x) for k, x in body.items()}
            return None if None in vals.values() else fn.Harmonic(**vals)
        if kind == "table":
            if not isinstance(body, dict) or not self.keys(f"{where}: key '{key}' table", body, ("t", "value"), ("t", "value")):
                if not isinstance(body, dict):
                    self.bad(where, key, f"got {_show(body)}", "{ t = [...], value = [...] }")
                return None
            t = self.numbers(where, f"{key}.table.t", body["t"], 2)
            val = self.numbers(where, f"{key}.table.value", body["value"], 2)
            if t is None or val is None:
                return None
            if len(t) != len(val):
                self.bad(where, f"{key}.table", f"{len(t)} times and {len(val)} values", "lists of equal length")
                return None
            if any(b <= a for a, b in zip(t, t[1:])):
                self.bad(where, f"{key}.table.t", "not strictly increasing", "strictly increasing times")
                return None
            if t[0] > 0 or t[-1] < end:
                self.bad(where, f"{key}.table.t", f"covers [{t[0]:g}, {t[-1]:g}]", f"a table that covers [0, {end:g}]")
                return None
            return fn.Table(t, val)
        self.bad(where, key, f"unknown function kind {_show(kind)}", expected)
        return None


    def outline(self, where, key, v):
        """{ spline = {...} or circle = {...}, center = [xi, eta] } into an Outline (Sec. 4.2.4)."""
        expected = "{ spline = { theta = [...], s = [...] } or circle = { radius = R }, center = [xi, eta] (optional) }"
        if not isinstance(v, dict) or len([k for k in ("spline", "circle") if k in v]) != 1:
            self.bad(where, key, f"got {_show(v)}", expected)
            return None
        if not self.keys(f"{where}: key '{key}'", v, ("spline", "circle", "center")):
            return None
        center = self.vector(where, f"{key}.center", v["center"], 2, "[xi, eta]") if "center" in v else (0.0, 0.0)
        if center is None:
            return None
        if "circle" in v:
            body = v["circle"]
            if not isinstance(body, dict) or not self.keys(f"{where}: key '{key}.circle'", body, ("radius",),
                                                             ("radius",)):
                if not isinstance(body, dict):
                    self.bad(where, f"{key}.circle", f"got {_show(body)}", "{ radius = R }")
                return None
            r = self.number(where, f"{key}.circle.radius", body["radius"], positive=True)
            return None if r is None else Outline.circle(r, center)
        body = v["spline"]
        w = f"{key}.spline"
        if not isinstance(body, dict) or not self.keys(f"{where}: key '{w}'", body,
                                                         ("theta", "s", "degrees", "periodic", "bc"), ("theta", "s")):
            if not isinstance(body, dict):
                self.bad(where, w, f"got {_show(body)}", "{ theta = [...], s = [...], degrees, periodic, bc }")
            return None
        flags = {}
        for flag in ("degrees", "periodic"):
            flags[flag] = body.get(flag, False)
            if not isinstance(flags[flag], bool):
                self.bad(where, f"{w}.{flag}", f"got {_show(flags[flag])}", "true or false")
                return None
        theta = self.numbers(where, f"{w}.theta", body["theta"], 4)
        s = self.numbers(where, f"{w}.s", body["s"], 4)
        if theta is None or s is None:
            return None
        if len(theta) != len(s):
            self.bad(where, w, f"{len(theta)} angles and {len(s)} radii", "lists theta and s of equal length")
            return None
        if flags["degrees"]:
            theta = tuple(math.radians(x) for x in theta)
        if any(b <= a for a, b in zip(theta, theta[1:])):
            self.bad(where, f"{w}.theta", "not strictly increasing", "strictly increasing angles")
            return None
        if min(s) <= 0:
            self.bad(where, f"{w}.s", f"radius {min(s):g}", "positive polar radii s")
            return None
        bc = body.get("bc", "not-a-knot")
        if flags["periodic"]:
            if "bc" in body:
                self.bad(where, f"{w}.bc", "a periodic outline has no end conditions", "no bc with periodic = true")
                return None
            if s[0] != s[-1]:
                self.bad(where, f"{w}.s", f"first {s[0]:g} and last {s[-1]:g} differ",
                         "the last radius of a periodic table equal to the first")
                return None
            turn = 2 * math.pi
            if abs(theta[-1] - theta[0] - turn) > 1e-9 * turn:  # 2 pi typed to 9 digits passes
                self.bad(where, f"{w}.theta", f"spans {math.degrees(theta[-1] - theta[0]):.9g} degrees",
                         "a periodic table that spans one full turn (360 degrees, 2 pi)")
                return None
            theta = theta[:-1] + (theta[0] + turn,)
        elif bc not in OPEN_BC:
            self.bad(where, f"{w}.bc", f"got {_show(bc)}", "one of " + ", ".join(OPEN_BC))
            return None
        return Outline.spline(theta, s, flags["periodic"], bc, center)


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


def _names(d) -> str:
    names = list(d)
    return ", ".join(names[:20]) + (" ..." if len(names) > 20 else "")


def _show(v) -> str:
    r = repr(v)
    return r if len(r) <= 60 else r[:57] + "..."
