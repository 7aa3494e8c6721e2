"""results.json: every figure of a report, the engines' versions and
settings, the machine and the git revision of the cases' repository. Its layout is
kinem/report/schema.json (documented in docs/report.md); SCHEMA_VERSION
changes whenever a field changes meaning or goes away."""
import json
import math
import os
import platform
import subprocess
from datetime import datetime, timezone
from pathlib import Path

from ..errors import InputError
from ..fingerprint import fingerprint, instants, solver_settings
from .schema import SCHEMA, problems

SCHEMA_VERSION = 5
PACKAGES = ("kinem", "numpy", "scipy", "matplotlib", "pymunk", "mujoco", "exudyn")
WP_ERROR = "position_error_rel"      # the work-precision diagram's error
WP_COST = "wall_per_sim_second"      # and its cost
PLOT_ONLY = ("series", "path", "elapsed", "families", "knobs")   # knobs: the work-precision points carry them


def build(cases, runs, options, duration):
    """cases: (path, Case, Model) triples; runs: execute()'s {path: [run]}.
    Returns (results document, {case name: {engine: series}}, plus
    "(equivalence)": {group: {case: (t, deviation)}})."""
    out, series, engines = [], {}, {}
    for path, case, model in cases:
        rs = runs[path]
        main = [r for r in rs if r["knob"] is None]
        order = ["native"] + list(options["engines"])
        main.sort(key=lambda r: order.index(r["engine"]))
        series[case.name] = {r["engine"]: r["series"] for r in main if r.get("series")}
        ref_tol = next((r.get("reference_tolerance") for r in main if r["engine"] == "native"), None)
        speed = next((r.get("speed") for r in main if r["engine"] == "native"), None)
        for r in main:
            if r["engine"] != "native":
                e = engines.setdefault(r["engine"], {"version": r["version"], "status": "ok", "outcome": "ok",
                                                     "detail": ""})
                if r.get("import_failed"):
                    e.update(status=r["status"], outcome=r["outcome"], detail=r["detail"])
        out.append({
            "name": case.name, "path": str(path), "fingerprint": fingerprint(case), "description": case.description,
            "length": model.length, "unit": case.length_unit, "end": case.end, "steps": case.steps,
            "coordinates": model.n, "reference_tolerance": ref_tol,
            "equivalent": None if case.equivalent is None else {"group": case.equivalent.group,
                                                                "points": list(case.equivalent.points)},
            "speed": speed, "solver": solver_settings(case),
            "runs": [_strip(r) for r in main],
            "work_precision": _work_precision(rs, options["engines"]),
        })
        attribute(out[-1])
    from . import equivalence

    groups, curves = equivalence.build(out, series)
    series["(equivalence)"] = curves   # not a case name: those have no parentheses
    doc = {
        "schema_version": SCHEMA_VERSION, "tool": "kinem report",
        "created": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"), "duration": duration,
        "git": git_revision([path for path, _, _ in cases]), "machine": machine(), "options": options, "engines": engines,
        "cases": out, "equivalence": groups, "gate": None,
    }
    return clean(doc), series


def _strip(r):
    return {k: v for k, v in r.items()
            if k not in PLOT_ONLY and k not in ("import_failed", "reference_tolerance", "speed")}


def attribute(case):
    """The engines' consensus (adapters.compare.consensus) on a case's main
    runs: native's run DISAGREES, the agreeing engines' runs are CONSISTENT,
    each carrying it as ``attributed``."""
    from dataclasses import asdict

    from adapters.compare import Verdict, consensus

    runs = {r["engine"]: r for r in case["runs"] if r["outcome"] == "ok" and r.get("trajectory")}
    if "native" not in runs or case.get("speed") is None:
        return
    engines = {e: r for e, r in runs.items() if e != "native"}
    c = consensus({e: r["trajectory"] for e, r in runs.items()}, {e: r["tolerance"] for e, r in engines.items()},
                  engines, case["length"], case["speed"])
    if c is None:
        return
    runs["native"].update(attributed=asdict(c), verdict=Verdict.DISAGREES.value)
    for e in c.engines:
        runs[e].update(attributed=asdict(c), verdict=Verdict.CONSISTENT.value)


def _point(r):
    return {"value": r["value"], "knobs": r["knobs"], "status": r["status"], "outcome": r["outcome"],
            "detail": r["detail"],
            "error": r[WP_ERROR],
            "cost": r[WP_COST], "velocity_error_rel": r["velocity_error_rel"], "wall_time": r["wall_time"],
            "counts": r["counts"], "front": False}


def _work_precision(rs, engines):
    """One curve per engine and knob family (the knob settings other than
    the swept one) that has sweep points: (knob value, error, cost), the
    defaults' family first; each point carries its full knob setting, and
    ``front`` marks the engine's Pareto front over all its families
    (adapters.tune.pareto: no other point of the engine is both cheaper and
    more accurate, errors below the gate's ERROR_FLOOR counting as equal)."""
    from adapters.tune import pareto

    from .gate import ERROR_FLOOR   # errors below it are rounding noise: equal on the front
    from .runs import step

    curves = []
    for e in ("native",) + tuple(engines):
        pts = [r for r in rs if r["engine"] == e and r["knob"] is not None]
        if not pts:
            continue
        knob = pts[0]["knob"]
        if e != "native":  # the main run is the sweep's factor-1 point of the defaults' family
            pts += [dict(r, value=step(r)) for r in rs
                    if r["engine"] == e and r["knob"] is None and r["outcome"] == "ok"]
        families = []
        for r in pts:
            family = {k: v for k, v in r["knobs"].items() if k != knob}
            if family not in families:
                families.append(family)
        main = next((r["knobs"] for r in rs if r["engine"] == e and r["knob"] is None), {})
        families.sort(key=lambda f: f != {k: v for k, v in main.items() if k != knob})   # the defaults' first
        mine = []
        for family in families:
            group = sorted((r for r in pts if {k: v for k, v in r["knobs"].items() if k != knob} == family),
                           key=lambda r: r["value"])
            curve = {"engine": e, "knob": knob, "family": family, "points": [_point(r) for r in group]}
            curves.append(curve)
            mine += curve["points"]
        ok = [dict(p, error=p["error"] if p["outcome"] == "ok" else None) for p in mine]
        for k in pareto(ok, cost="cost", error="error", floor=ERROR_FLOOR):
            mine[k]["front"] = True
    if not curves:
        return None
    return {"error": WP_ERROR, "cost": WP_COST, "curves": curves}


def clean(x):
    """JSON values only: non-finite floats become null, tuples lists."""
    if isinstance(x, dict):
        return {str(k): clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def dumps(doc) -> str:
    return json.dumps(doc, indent=1, allow_nan=False) + "\n"


MAX_BYTES = 256 * 2**20   # a results.json read (the 14 cases' baseline: 0.6 MB)


def load(path, what="baseline"):
    """A stored results.json, checked against the schema; InputError otherwise."""
    if isinstance(path, str) and not path:   # (Path("") would be the current folder)
        raise InputError(f"{what} {str(path)!r}: no file named; expected a results.json of kinem report")
    import stat

    from ..output import read_fifo

    try:   # at most MAX_BYTES (/dev/zero ends); a FIFO's writer waited for a bounded time (never for ever)
        if stat.S_ISFIFO(os.stat(path).st_mode):
            raw = read_fifo(path, MAX_BYTES + 1)
        else:
            with open(path, "rb") as f:
                raw = f.read(MAX_BYTES + 1)
    except FileNotFoundError:
        raise InputError(f"{what} {path}: no such file (create one with --update-baseline)") from None
    except IsADirectoryError:
        raise InputError(f"{what} {path}: cannot read: is a directory; expected a results.json of kinem report") \
            from None
    except OSError as e:
        raise InputError(f"{what} {path}: cannot read: {e.strerror or e}") from None
    if len(raw) > MAX_BYTES:
        raise InputError(f"{what} {path}: more than {MAX_BYTES} bytes; expected a results.json of kinem report")
    try:   # a byte order mark (an editor's) is not JSON's: read past, as the case files' is
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"{what} {path}: cannot read: not UTF-8 text (byte {e.start}); expected a results.json "
                         "of kinem report") from None
    try:
        doc = json.loads(text, parse_constant=_no_constant)
    except (ValueError, RecursionError) as e:   # RecursionError: arrays or tables nested thousands deep
        raise InputError(f"{what} {path}: not JSON ({e}); expected a results.json of kinem report") from None
    if not isinstance(doc, dict):   # a JSON array, number or text: no schema_version to name
        raise InputError(f"{what} {path}: a JSON {_kind(doc)}; expected a results.json of kinem report (a JSON "
                         "object)")
    version = doc.get("schema_version")
    if version != SCHEMA_VERSION:
        raise InputError(f"{what} {path}: schema_version {version!r}; expected {SCHEMA_VERSION} "
                         "(rewrite it with --update-baseline)")
    bad = problems(doc, SCHEMA) or non_finite(doc) or untyped(doc) or missing_figures(doc) or trajectories(doc)
    if bad:
        raise InputError(f"{what} {path}: {bad[0]}" + (f" (+{len(bad) - 1} more)" if len(bad) > 1 else ""))
    return doc


def _kind(doc) -> str:
    """JSON's name for the kind of a parsed value that is not an object."""
    return "array" if isinstance(doc, list) else "string" if isinstance(doc, str) else "null" if doc is None else \
        "boolean" if isinstance(doc, bool) else "number"


# The deterministic cost counts of each kind of run; an edited baseline with
# other keys (or none) would switch their check off.
COUNTS = {"native": ("instants", "newton_iterations", "jacobian_evaluations", "factorizations"),
          "engine": ("steps", "substeps")}
def untyped(doc) -> list:
    """Statuses that are not the label of their outcome (adapters.base.Status)
    and detail, and count keys that are not the run's own (an ok run must
    have them all; another may have none): 'where: problem' lines."""
    from adapters.base import Status

    out = []

    def label(where, status, outcome, detail):
        if status != Status(outcome).label(detail):
            out.append(f"{where}: status {status[:40]!r} is not the label of outcome {outcome!r} and detail "
                       f"{detail[:40]!r}; expected {Status(outcome).label(detail)[:40]!r}")

    def check(where, engine, status, counts, outcome, detail):
        label(where, status, outcome, detail)
        keys = COUNTS["native" if engine == "native" else "engine"]
        if (status == "ok" or counts) and sorted(counts) != sorted(keys):
            out.append(f"{where}: counts {sorted(counts)}; expected {list(keys)}")

    for c in doc["cases"]:
        for r in c["runs"]:
            check(f"cases.{c['name']}.runs.{r['engine']}", r["engine"], r["status"], r["counts"], r["outcome"],
                  r["detail"])
        for curve in (c.get("work_precision") or {}).get("curves", ()):
            for p in curve["points"]:
                check(f"cases.{c['name']}.work_precision.{curve['engine']}.{p['value']:g}", curve["engine"],
                      p["status"], p["counts"], p["outcome"], p["detail"])
    for name, e in doc["engines"].items():
        label(f"engines.{name}", e["status"], e["outcome"], e["detail"])
    return out


def non_finite(x, where="$") -> list:
    """Numbers that are not finite (JSON's 1e999 reads as inf): 'where: problem' lines."""
    if isinstance(x, float) and not math.isfinite(x):
        return [f"{where}: {x} is not finite; expected a finite number"]
    out = []
    if isinstance(x, dict):
        for k, v in x.items():
            out += non_finite(v, f"{where}.{k}")
    elif isinstance(x, list):
        for k, v in enumerate(x):
            name = v.get("name") or v.get("engine") if isinstance(v, dict) else None
            out += non_finite(v, f"{where}.{name if isinstance(name, str) else k}")
    return out


def expected_instants(case) -> list:
    """The instants a case's compact trajectories are kept at (fingerprint.instants of its time grid)."""
    return [k * (case["end"] / case["steps"]) for k in instants(case["steps"] + 1)]


def trajectories(doc) -> list:
    """Every ok main run must carry its compact trajectory at the case's
    instants, every column one value per instant, and each body or named
    point all of its columns (native: positions, velocities and
    accelerations; an engine: what it has); the case its peak speed. A
    null, truncated or re-timed trajectory would switch the gate's check of
    the run off: 'where: problem' lines."""
    from ..fingerprint import KINDS

    out = []
    for c in doc["cases"]:
        ok = [r for r in c["runs"] if r["outcome"] == "ok"]
        if any(r["engine"] == "native" for r in ok) and not (c.get("speed") or 0) > 0:
            out.append(f"cases.{c['name']}.speed: {c.get('speed')!r}; expected the native run's peak speed (> 0)")
        want = expected_instants(c)
        for r in ok:
            where = f"cases.{c['name']}.runs.{r['engine']}.trajectory"
            tr = r.get("trajectory")
            if tr is None:
                out.append(f"{where}: null in an ok run; expected its compact trajectory")
                continue
            t = tr["t"]
            if len(t) != len(want) or any(abs(a - b) > 1e-9 * max(c["end"], 1e-300) for a, b in zip(t, want)):
                out.append(f"{where}.t: {len(t)} instants {_span(t)}; expected {len(want)} at {_span(want)} "
                           f"(the case's t = 0 … {c['end']:g} s in {c['steps']} steps)")
                continue
            items = {}
            for name, values in tr["columns"].items():
                item, _, suffix = name.rpartition(".")
                if suffix not in KINDS:
                    out.append(f"{where}.columns.{name}: not a known column; expected ITEM.x, .y, .phi, .vx, ...")
                elif len(values) != len(t):
                    out.append(f"{where}.columns.{name}: {len(values)} values; expected {len(t)}, one per instant")
                items.setdefault(item, set()).add(suffix)
            if not items:
                out.append(f"{where}.columns: empty; expected every body's and named point's columns")
            full = set.union(*items.values()) if items else set()
            for item, have in items.items():
                need = full if "phi" in have else full - {"phi", "omega", "alpha"}
                for k in sorted(need - have):
                    out.append(f"{where}.columns: no column '{item}.{k}'; expected it beside {item}'s other columns")
    return out


def _span(t):
    return f"{t[0]:g} … {t[-1]:g} s" if t else "(none)"


def _no_constant(name):
    raise ValueError(f"non-finite number {name}; expected finite figures")


def missing_figures(doc) -> list:
    """Gated figures that are null where the run is ok (a NaN written as null
    would switch its check off): 'where: problem' lines; empty when none."""
    from .gate import GATED

    out = []
    for c in doc["cases"]:
        for r in c["runs"]:
            if r["outcome"] == "ok":
                out += [f"cases.{c['name']}.runs.{r['engine']}: {k} is null in an ok run; expected a finite number"
                        for k in GATED if r.get(k) is None]
        for curve in (c.get("work_precision") or {}).get("curves", ()):
            for p in curve["points"]:
                if p["outcome"] == "ok":
                    out += [f"cases.{c['name']}.work_precision.{curve['engine']}.{p['value']:g}: {k} is null in an "
                            "ok point; expected a finite number" for k in ("error", "velocity_error_rel")
                            if p.get(k) is None]
    return out


def machine() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    packages = {}
    for name in PACKAGES:
        try:
            packages[name] = version(name)
        except PackageNotFoundError:
            packages[name] = None
    return {"cpu": cpu_model(), "cores": os.cpu_count() or 1, "platform": platform.platform(),
            "python": f"{platform.python_implementation()} {platform.python_version()}",
            "packages": packages}


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def git_revision(paths) -> dict:
    """The revision of the git repository holding the cases (the first
    path's folder): its top folder, HEAD (None before the first commit) and
    whether tracked files differ from it; nulls outside a repository. Git
    runs there only, never in kinem's own install, and takes no lock
    (--no-optional-locks: nothing is written under .git)."""
    none = {"repository": None, "revision": None, "dirty": None}
    if not paths:
        return none
    folder = Path(paths[0]).resolve().parent

    def git(*args):
        p = subprocess.run(["git", "--no-optional-locks", "-C", str(folder), *args], capture_output=True, text=True,
                           timeout=20, stdin=subprocess.DEVNULL)
        return p.stdout.strip() if p.returncode == 0 else None

    try:
        top = git("rev-parse", "--show-toplevel")
        if not top:
            return none
        rev = git("rev-parse", "--verify", "--quiet", "HEAD^{commit}")
        dirty = git("status", "--porcelain", "--untracked-files=no") if rev else None
    except (OSError, subprocess.SubprocessError):
        return none
    return {"repository": top, "revision": rev or None, "dirty": None if dirty is None else bool(dirty)}

