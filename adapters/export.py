"""The engine model exactly as the harness runs it, as a file users can take
away (``kinem export CASE --engine NAME --out FILE``).

pymunk: a Python script (pymunk and numpy only) that builds the adapter's
Space body by body and joint by joint from the built Space itself, and steps
it as the adapter does; the prescribed poses and driven joint targets at every
step are embedded as a compressed table. Exudyn: a Python script (exudyn
and numpy only; with kinem too for cams and slots, whose outlines kinem's
core evaluates) that adds the items of the system the adapter built, read back
one by one with the fields the adapter set, in the same order, with the
adapter's simulation settings; its user functions (drivers from their specs,
user constraints) are made by the adapter's own portable functions
(adapters.exudyn_sim.PORTABLE), whose source the script carries.

MuJoCo: MJCF XML (adapters.mujoco_sim.mjcf, the same text the adapter
compiles) plus a keyframe "start" with the harness's initial joint positions
and velocities (the harness's start: the model's assembly at t = 0). A driver whose function is linear in
t is inside the model: its joint has the armature 1e12 (the harness's with
drive "interval", its default for such drivers), so from the keyframe's
velocity it keeps turning at that rate whatever the reactions (plain mj_step
reproduces the harness). Any other
driver cannot be expressed in MJCF: a comment names its joint and function,
and the loop that drives it (set qpos, qvel from d(t), d'(t) and qfrc_applied
from armature d''(t) before every mj_step), as the harness does.
"""
import math
import re
from xml.sax.saxutils import quoteattr

import numpy as np

from kinem.functions import Poly

# Armature of driven joints in an exported MJCF: a plain mj_step loop does not
# overwrite their qpos and qvel, so reactions move them by ~ force / armature:
# 1e12 (the harness's own with drive "interval") keeps the exported run within
# 2e-8 L of the harness on the book cases (1e9: 6e-6 L).
from .mujoco_sim import HELD_ARMATURE as ARMATURE  # noqa: E402


def _comment(text):
    """An XML comment holding ``text`` (which must not contain "--": every
    hyphen before another gets a space; strings from the case are repr'd by
    the caller, so the comment holds no control character)."""
    return "<!-- " + re.sub("-(?=-)", "- ", text) + " -->"


def _prepared(engine, model, settings, q0, qd0, *support):
    """(the adapter, its checked settings with substeps and dt resolved, the
    output instants); InputError when the engine cannot represent the case.
    Settings the adapter chooses itself ("auto") are those the harness's run
    from (q0, qd0) ends with, a retry included (adapters.base.Adapter.retry)."""
    from . import get

    adapter = get(engine)
    why = adapter.unsupported(model, *support)
    if why:
        from kinem.errors import InputError

        raise InputError(f"{model.case.source}: {engine} cannot represent this case: {why}")
    s = adapter.settings(settings)
    if "auto" in s.values():
        run = adapter.run(model, q0, qd0, s)
        if run.ok:
            s = adapter.settings({k: v for k, v in run.settings.items() if k in s})
    times = np.asarray(model.times, float)
    adapter.resolve(model, s, q0, qd0)
    return adapter, s, times


def mujoco_model(model, q0, qd0, settings=None):
    """MJCF text of the model started at (q0, qd0)."""
    import mujoco

    from .mujoco_sim import drive_tables, initial_state

    adapter, s, times = _prepared("mujoco", model, {"armature": ARMATURE, **(settings or {})}, q0, qd0, q0)
    plan, xml = adapter.build(model, np.asarray(q0, float), s)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    initial_state(m, d, plan, np.asarray(qd0, float))
    jid = [m.joint(f"{b}:{j}").id for _, b, j, _, _ in plan.driven]
    P, V, _ = drive_tables(plan, np.zeros(1), s["armature"])
    d.qpos[m.jnt_qposadr[jid]], d.qvel[m.jnt_dofadr[jid]] = P[0], V[0]
    notes = [f"kinem export of case {model.case.name!r} ({model.case.source!r}) for MuJoCo {mujoco.__version__!r}:",
             f"the harness's model and settings ({s['integrator']}, timestep {s['dt']:.6g} s, "
             f"{s['substeps']} steps per output interval of {s['dt'] * s['substeps']:.6g} s).",
             "Start from the keyframe 'start' (mj_resetDataKeyframe(m, d, 0)); body frames are the case's;",
             "custom numerics kinem:substeps and kinem:intervals: mj_step(m, d, substeps) once per output interval.",
             f"Driven joints have armature {s['armature']:g} (the harness's, drive {s['drive']!r}: "
             + ("qpos and qvel overwritten before every step)." if s["drive"] == "overwrite" else
                "set at output instants, each interval stepped by one mj_step call).")]
    motors = []
    for dr, body, j, a, v0 in plan.driven:
        if isinstance(dr.f, Poly) and len(dr.f.coeffs) <= 3:
            # d'' constant: a motor with gear armature a d'' at ctrl 1 gives the joint that acceleration
            force = s["armature"] * a * (2.0 * dr.f.coeffs[2] if len(dr.f.coeffs) == 3 else 0.0)
            if force:
                motors.append(f'<motor name="drive:{len(motors)}" joint={quoteattr(f"{body}:{j}")} gear="{force!r}"/>')
            how = ("polynomial of degree <= 2: inside the model (armature, keyframe velocity"
                   + (", a motor at ctrl 1 for d''" if force else "") + "); plain mj_step reproduces it")
        else:
            how = ("not expressible in MJCF: before every mj_step set qpos = a (d(t) - v0), qvel = a d'(t) and "
                   "qfrc_applied = armature a d''(t) on this joint, as the harness does")
        notes.append(f"driver {dr.name!r} on joint {f'{body}:{j}'!r} (a = {a:.17g}, v0 = {v0:.17g}, d = {dr.f}): {how}")
    ctrl = f' ctrl="{" ".join("1" for _ in motors)}"' if motors else ""
    key = (f'<keyframe><key name="start" qpos="{" ".join(repr(float(x)) for x in d.qpos)}" '
           f'qvel="{" ".join(repr(float(x)) for x in d.qvel)}"{ctrl}/></keyframe>')
    act = "<actuator>" + "".join(motors) + "</actuator>\n" if motors else ""
    act += (f'<custom><numeric name="kinem:substeps" data="{s["substeps"]}"/>'
            f'<numeric name="kinem:intervals" data="{len(times) - 1}"/></custom>\n')
    head, tail = xml.rsplit("</mujoco>", 1)
    return "\n".join(_comment(n) for n in notes) + "\n" + head + act + key + "\n</mujoco>" + tail + "\n"


WRITERS = {"mujoco": (mujoco_model, ".xml")}


def export(model, engine, q0, qd0, settings=None) -> str:
    """The text of the exported model (InputError for an engine without an exporter)."""
    if engine not in WRITERS:
        from kinem.errors import InputError

        raise InputError(f"--engine: got {engine!r}; export writes one of {', '.join(WRITERS)}")
    return WRITERS[engine][0](model, q0, qd0, settings)


def _pymunk_script(model, q0, qd0, settings=None):
    """A Python script (pymunk and numpy only) that builds the harness's
    Space body by body and joint by joint, steps it exactly as the adapter
    does (prescribed bodies and driven joint targets set before each step from
    tables computed here, embedded compressed) and prints the case bodies'
    final x, y, phi as JSON (``--all``: at every output instant)."""
    import base64
    import io
    import zlib

    import pymunk

    from .pymunk_sim import _Mechanism

    _, s, times = _prepared("pymunk", model, settings, q0, qd0)
    n_sub, dt = s["substeps"], s["dt"]
    tt = np.arange(n_sub * (len(times) - 1) + 2) * dt
    mech = _Mechanism(model, np.asarray(q0, float), np.asarray(qd0, float), s, tt)
    bodies = list(mech.space.bodies)
    index = {id(b): k for k, b in enumerate(bodies)}
    kinds = {pymunk.Body.STATIC: "pymunk.Body.STATIC", pymunk.Body.KINEMATIC: "pymunk.Body.KINEMATIC"}

    def num(x):
        return repr(float(x)) if math.isfinite(x) else "math.inf"

    lines = []
    for k, b in enumerate(bodies):
        if b.body_type in kinds:
            lines.append(f"B.append(pymunk.Body(body_type={kinds[b.body_type]}))")
        else:
            lines.append(f"B.append(pymunk.Body({num(b.mass)}, {num(b.moment)}))")
        lines.append(f"place(B[{k}], {num(b.position.x)}, {num(b.position.y)}, {num(b.angle)}, "
                     f"{num(b.velocity.x)}, {num(b.velocity.y)}, {num(b.angular_velocity)})")
    joints = list(mech.space.constraints)
    jindex = {id(j): k for k, j in enumerate(joints)}
    for j in joints:
        a, b = f"B[{index[id(j.a)]}]", f"B[{index[id(j.b)]}]"
        if isinstance(j, pymunk.PivotJoint):
            args = f"{a}, {b}, {tuple(j.anchor_a)}, {tuple(j.anchor_b)}"
        elif isinstance(j, pymunk.GrooveJoint):
            args = f"{a}, {b}, {tuple(j.groove_a)}, {tuple(j.groove_b)}, {tuple(j.anchor_b)}"
        elif isinstance(j, pymunk.PinJoint):
            args = f"{a}, {b}, {tuple(j.anchor_a)}, {tuple(j.anchor_b)}"
        elif isinstance(j, pymunk.GearJoint):
            args = f"{a}, {b}, {num(j.phase)}, {num(j.ratio)}"
        else:
            raise NotImplementedError(f"export of {type(j).__name__}")
        lines.append(f"J.append(add(pymunk.{type(j).__name__}({args}), {num(j.error_bias)}))")
        if isinstance(j, pymunk.PinJoint):
            lines.append(f"J[-1].distance = {num(j.distance)}")
    tables = {}
    for n, (b, x, y, phi) in enumerate(mech.kinematic):
        tables[f"kin{n}"] = np.stack([x, y, phi])
    for n, (j, attr, v) in enumerate(mech.targets):
        tables[f"target{n}"] = np.asarray(v, float)
    buf = io.BytesIO()
    np.savez(buf, **tables)
    blob = base64.b64encode(zlib.compress(buf.getvalue(), 9)).decode()
    kin = [f"(B[{index[id(b)]}], T['kin{n}'])" for n, (b, *_) in enumerate(mech.kinematic)]
    tgt = [f"(J[{jindex[id(j)]}], {attr!r}, T['target{n}'])" for n, (j, attr, _) in enumerate(mech.targets)]
    case_bodies = [index[id(mech.body[name])] for name in model.body_names]
    return SCRIPT.format(name=model.case.name, source=model.case.source, version=pymunk.version,
                         iterations=int(s["iterations"]), build="\n".join(lines), blob=blob, dt=repr(dt),
                         n_sub=n_sub, intervals=len(times) - 1, kin=", ".join(kin), tgt=", ".join(tgt),
                         centered=bool(s["centered_velocity"]), bodies=case_bodies, names=list(model.body_names))


SCRIPT = '''"""kinem export for pymunk of the case CASE (read from the file SOURCE): the
harness's Space and stepping, runnable with pymunk and numpy only. Prints the case bodies'
final x, y, phi as JSON (--all: every output instant; --velocities: x', y', phi' too)."""
import base64, io, json, math, sys, zlib

import numpy as np
import pymunk

CASE, SOURCE, PYMUNK = {name!r}, {source!r}, {version!r}   # Python literals: a path may hold any character

space = pymunk.Space()
space.iterations = {iterations}
space.gravity = (0.0, 0.0)
space.damping = 1.0
B, J = [], []


def place(b, x, y, phi, vx, vy, w):
    b.angle = phi
    b.position = (x, y)
    b.velocity = (vx, vy)
    b.angular_velocity = w
    space.add(b)


def add(joint, error_bias):
    joint.error_bias = error_bias
    joint.collide_bodies = False
    space.add(joint)
    return joint


{build}

# prescribed poses (x, y, phi) and driven joint targets at the step instants t_0 .. t_N+1
T = np.load(io.BytesIO(zlib.decompress(base64.b64decode("{blob}"))))
dt, n_sub, intervals = {dt}, {n_sub}, {intervals}
kin = [{kin}]
kin = [(b, p[:, 1:-1] - dt * np.diff(p, axis=1)[:, 1:] / dt, np.diff(p, axis=1)[:, 1:] / dt) for b, p in kin]
targets = [{tgt}]
bodies, centered = [B[k] for k in {bodies}], {centered}


def state(velocity=False):
    if velocity:
        return [v for b in bodies for v in (b.velocity.x, b.velocity.y, b.angular_velocity)]
    return [v for b in bodies for v in (b.position.x, b.position.y, b.angle)]


def step(i):
    for b, start, vel in kin:
        b.angle, b.position = start[2, i], (start[0, i], start[1, i])
        b.velocity, b.angular_velocity = (vel[0, i], vel[1, i]), vel[2, i]
    for j, attr, v in targets:
        setattr(j, attr, v[i])
    space.step(dt)


out, vout, i = [state()], [state(True)], 0
for k in range(intervals):
    for _ in range(n_sub - 1 if centered else n_sub):
        step(i)
        i += 1
    before = state(True)
    if centered:
        step(i)
        i += 1
    out.append(state())
    v = state(True)
    vout.append([(a + b) / 2 for a, b in zip(v, before)] if centered else v)
rows = out if "--all" in sys.argv else out[-1:]
print(json.dumps({{"bodies": {names}, "q": rows, "qd": (vout if "--all" in sys.argv else vout[-1:])
                  if "--velocities" in sys.argv else None}}))
'''

WRITERS["pymunk"] = (_pymunk_script, ".py")


def _exudyn_code(v, functions):
    """Python source of an item field or a setting value as the harness set it
    (``functions``: id of a user function -> the script's name for it)."""
    import exudyn as exu

    if id(v) in functions:
        return functions[id(v)]
    if v is None or isinstance(v, (bool, str)):
        return repr(v)
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return repr(v) if math.isfinite(v) else f"float('{v}')"
    if isinstance(v, (int, np.integer)):
        return repr(int(v))
    if isinstance(v, exu.MatrixContainer):
        return f"exu.MatrixContainer({_exudyn_code(np.asarray(v.GetPythonObject()), functions)})"
    if isinstance(v, np.ndarray) and v.ndim > 1:
        return f"np.zeros({v.shape!r})" if not v.size else f"np.array({_exudyn_code(v.tolist(), functions)})"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_exudyn_code(x, functions) for x in v) + "]"
    if hasattr(exu, type(v).__name__) and hasattr(v, "name"):  # an Exudyn enum
        return f"exu.{type(v).__name__}.{v.name}"
    if type(v).__name__.endswith("Index"):                      # NodeIndex, MarkerIndex, ...
        return repr(int(v))
    raise NotImplementedError(f"export of {type(v).__name__} {v!r}")


def _exudyn_item(item, functions):
    """``ei.Class(field=value, ...)``: the fields that differ from the class's defaults."""
    cls = type(item)
    default = dict(cls())
    args = []
    for k, v in list(dict(item).items())[1:]:           # the first is the item's type
        if k[:1] == "V" and k[1:2].isupper():           # visualization: left at Exudyn's defaults
            continue
        code = _exudyn_code(v, functions)
        if code != _exudyn_code(default.get(k), functions):
            args.append(f"{k}={code}")
    return f"ei.{cls.__name__}({', '.join(args)})"


# Simulation settings the adapter sets that equal Exudyn's defaults today:
# written out all the same, so that the script does not depend on them.
EXUDYN_SETTINGS = ("ss.timeIntegration.startTime", "ss.timeIntegration.verboseMode",
                   "ss.timeIntegration.generalizedAlpha.spectralRadius", "ss.timeIntegration.newton.absoluteTolerance",
                   "ss.timeIntegration.newton.maxIterations", "ss.solution.sensors.writePeriod",
                   "ss.linearSolver.solverType", "ss.linearSolver.ignoreSingularJacobian")


def _exudyn_settings(d, default, path="ss"):
    """``ss.a.b = value`` for every simulation setting that differs from
    Exudyn's default or is in EXUDYN_SETTINGS."""
    lines = []
    for k, v in d.items():
        if isinstance(v, dict):
            lines += _exudyn_settings(v, default[k], f"{path}.{k}")
        elif _exudyn_code(v, {}) != _exudyn_code(default[k], {}) or f"{path}.{k}" in EXUDYN_SETTINGS:
            lines.append(f"{path}.{k} = {_exudyn_code(v, {})}")
    return lines


def _exudyn_script(model, q0, qd0, settings=None):
    """A Python script (exudyn and numpy only) that builds the harness's
    Exudyn system item by item (read back from the system the adapter built,
    its user functions made by the adapter's own portable functions, whose
    source the script carries), solves it with the harness's settings and
    prints the case bodies' final x, y, phi as JSON."""
    import inspect

    import exudyn as exu

    from kinem.result import BODY_COLUMNS

    from .exudyn_sim import INTEGRATORS, PORTABLE

    adapter, s, times = _prepared("exudyn", model, settings, q0, qd0)
    saved = exu.config.printToConsole
    exu.config.printToConsole = False
    try:
        b, sensors, ss = adapter.build(model, np.asarray(q0, float), np.asarray(qd0, float), s, times, record=True)
    finally:
        exu.config.printToConsole = saved
    names, functions = {}, []
    for n, (call, made) in enumerate(b.made):
        functions.append(f"F{n} = {call}")
        names.update({id(f): f"F{n}[{k}]" for k, f in enumerate(made)})
    body_of = {("AddNode", int(v)): k for k, v in b.node.items()}
    body_of.update({("AddObject", int(v)): k for k, v in b.body.items()})
    items, count = [], {}
    for method, item in b.mbs.items:
        index = count[method] = count.get(method, -1) + 1
        note = f"  # {method[3:].lower()} {index}" + (f": body {body_of[method, index]!r}"
                                                      if (method, index) in body_of else "")
        items.append(f"mbs.{method}({_exudyn_item(item, names)}){note}")
    cols = [f"{body}.{c}" for body in model.body_names for c in BODY_COLUMNS["positions"] + BODY_COLUMNS["velocities"]]
    curves = any(c.type in CURVE_TYPES for c in model.case.constraints)
    return EXUDYN_SCRIPT.format(
        imports=CURVE_IMPORT if curves else "", only="exudyn, numpy and kinem" if curves else "exudyn and numpy",
        name=model.case.name, source=model.case.source, version=exu.config.Version(),
        integrator=s["integrator"], dt=f"{s['dt']:.6g}", substeps=s["substeps"],
        interval=f"{s['dt'] * s['substeps']:.6g}", intervals=len(times) - 1,
        portable="\n\n\n".join(inspect.getsource(f).rstrip() for f in PORTABLE),
        functions="\n".join(functions) or "# (none)", items="\n".join(items),
        settings="\n".join(_exudyn_settings(ss.GetDictionary(), exu.SimulationSettings().GetDictionary())),
        solver=INTEGRATORS[s["integrator"]], names=list(model.body_names), start=_exudyn_code(b.q0, {}),
        sensors={model.body_names.index(k): (int(p), int(v)) for k, (p, v) in sensors.items()},
        angles={col: (int(p), int(v)) for col, (p, v) in b.angles.items()},
        columns=["t"] + cols)


CURVE_TYPES = ("cam-point", "cam-roller", "cam-flat", "point-follower")
# the outlines of cams and slots are evaluated by kinem's core, as in the harness (never a second copy)
CURVE_IMPORT = "from kinem.outline import Outline, OutlineSet  # outlines of cams and slots: kinem's own evaluation\n"

EXUDYN_SCRIPT = '''"""kinem export for Exudyn of the case CASE (read from the file SOURCE):
the harness's Exudyn system and solver settings, runnable with {only}
only: the integrator INTEGRATOR, step {dt} s ({substeps} steps per output interval of {interval} s),
{intervals} output intervals, started from the model's assembly at t = 0 (the harness's start).

Every moving body is a NodeRigidBody2D (reference coordinates 0: node
coordinates are the body frame's absolute x, y, phi) with an ObjectRigidBody2D;
a fixed body is an ObjectGround. Driving functions are CoordinateConstraint
offset user functions made from their specs by `evaluate` below (symbolic user
functions, run in C++, unless the harness was set to Python ones); a table is
kinem's not-a-knot cubic spline, its piecewise coefficients embedded: the same
values as the harness. User constraints (distance drivers, rack and pinion,
cams and slots: their outline angle theta a NodeGenericODE2 of its own) are
Python user functions. The functions below are the adapter's own source
(adapters/exudyn_sim.py).

python THIS.py [--all] [--velocities] [TRAJECTORY.csv]: prints the case bodies'
final x, y, phi as JSON (--all: every output instant; --velocities: their
velocities too); TRAJECTORY.csv: every output instant, positions and velocities.
"""
import bisect
import json
import math
import sys

import numpy as np

import exudyn as exu
from exudyn import itemInterface as ei
from exudyn.advancedUtilities import CreateSymbolicUserFunction
{imports}
CASE, SOURCE, EXUDYN = {name!r}, {source!r}, {version!r}   # Python literals: a path may hold any character
INTEGRATOR = {integrator!r}

{portable}


sc = exu.SystemContainer()
mbs = sc.AddSystem()

# user functions (kept in these variables while the system lives)
{functions}

# the items in the harness's order: the numbers in markerNumbers, nodeNumber, ... are their indices
{items}
mbs.Assemble()

ss = exu.SimulationSettings()
{settings}

BODIES = {names}
START = np.array({start})      # x, y, phi of each body, then any outline angle, at t = 0 (fixed bodies stay there)
SENSORS = {sensors}   # body index: (coordinates sensor, velocities sensor)
ANGLES = {angles}   # column of an outline angle theta after the bodies': (its coordinate, velocity sensor)

exu.config.printToConsole = False   # keep stdout for the JSON
try:
    ok = mbs.SolveDynamic(ss, solverType=exu.DynamicSolverType.{solver})
except Exception:   # the solver raises when it stops
    ok = False
if not ok:
    solver = mbs.sys.get("dynamicSolver")
    sys.exit(f"Exudyn solver failed: stopped at t = {{solver.it.currentTime:.6g}}: {{solver.GetErrorString().strip()}}")

n = {intervals} + 1
q, qd, t = np.tile(START, (n, 1)), np.zeros((n, len(START))), None
for k, (sq, sv) in SENSORS.items():
    pos, vel = mbs.GetSensorStoredData(sq), mbs.GetSensorStoredData(sv)
    q[:, 3 * k: 3 * k + 3], qd[:, 3 * k: 3 * k + 3], t = pos[:, 1:4], vel[:, 1:4], pos[:, 0]
for col, (sq, sv) in ANGLES.items():
    q[:, col], qd[:, col] = mbs.GetSensorStoredData(sq)[:, 1], mbs.GetSensorStoredData(sv)[:, 1]
args = [a for a in sys.argv[1:] if not a.startswith("--")]
if args:
    t = t if t is not None else np.linspace(0.0, ss.timeIntegration.endTime, n)
    columns = [m[:, 3 * k: 3 * k + 3] for k in range(len(BODIES)) for m in (q, qd)]   # kinem's column order
    np.savetxt(args[0], np.column_stack([t] + columns), delimiter=",", header=",".join({columns}), comments="")
rows = slice(None) if "--all" in sys.argv else slice(-1, None)
print(json.dumps({{"bodies": BODIES, "q": q[rows].tolist(),
                  "qd": qd[rows].tolist() if "--velocities" in sys.argv else None}}))
'''

WRITERS["exudyn"] = (_exudyn_script, ".py")
