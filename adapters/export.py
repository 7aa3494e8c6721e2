"""The engine model exactly as the harness runs it, as a file users can take
away (``kinem export CASE --engine NAME --out FILE``).

pymunk: a Python script (pymunk and numpy only) that builds the adapter's
Space body by body and joint by joint from the built Space itself, and steps
it as the adapter does; the prescribed poses and driven joint targets at every
step are embedded as a compressed table. Exudyn: not yet (its drivers are
symbolic user functions built in memory; writing them out is left to do).

MuJoCo: MJCF XML (adapters.mujoco_sim.mjcf, the same text the adapter
compiles) plus a keyframe "start" with the harness's initial joint positions
and velocities (native's state at t = 0). A driver whose function is linear in
t is inside the model: its joint has the armature of the settings (1e9 by
default), so from the keyframe's velocity it keeps turning at that rate
whatever the reactions (plain mj_step reproduces the harness). Any other
driver cannot be expressed in MJCF: a comment names its joint and function,
and the loop that drives it (set qpos, qvel from d(t), d'(t) and qfrc_applied
from armature d''(t) before every mj_step), as the harness does.
"""
import math

import numpy as np

from kinem.functions import Poly

# Armature of driven joints in an exported MJCF: the harness overwrites their
# qpos and qvel before every step (1e9 is ample there); a plain mj_step loop
# does not, so reactions move them by ~ force / armature: 1e12 keeps the
# exported run within 2e-8 L of the harness on the book cases (1e9: 6e-6 L).
ARMATURE = 1e12


def _comment(text):
    return "<!-- " + text.replace("--", "- -") + " -->"


def mujoco_model(model, q0, qd0, settings=None):
    """MJCF text of the model started at (q0, qd0)."""
    import mujoco

    from . import get
    from .mujoco_sim import drive_tables, initial_state

    adapter = get("mujoco")
    settings = {"armature": ARMATURE, **(settings or {})}
    why = adapter.unsupported(model, q0)
    if why:
        from kinem.errors import InputError

        raise InputError(f"{model.case.source}: mujoco cannot represent this case: {why}")
    s = adapter.settings(settings)
    times = np.asarray(model.times, float)
    adapter.steps_per_interval(s, float(times[1] - times[0]) if len(times) > 1 else float(model.case.end))
    plan, xml = adapter.build(model, np.asarray(q0, float), s)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    initial_state(m, d, plan, np.asarray(qd0, float))
    jid = [m.joint(f"{b}:{j}").id for _, b, j, _, _ in plan.driven]
    P, V, _ = drive_tables(plan, np.zeros(1), s["armature"])
    d.qpos[m.jnt_qposadr[jid]], d.qvel[m.jnt_dofadr[jid]] = P[0], V[0]
    notes = [f"kinem export of case '{model.case.name}' ({model.case.source}) for MuJoCo {mujoco.__version__}:",
             f"the harness's model and settings ({s['integrator']}, timestep {s['dt']:.6g} s, "
             f"{s['substeps']} steps per output interval of {s['dt'] * s['substeps']:.6g} s).",
             "Start from the keyframe 'start' (mj_resetDataKeyframe(m, d, 0)); body frames are the case's;",
             "custom numerics kinem:substeps and kinem:intervals: mj_step(m, d, substeps) once per output interval.",
             f"Driven joints have armature {s['armature']:g} (the harness: {adapter.defaults()['armature']:g} with "
             "qpos and qvel overwritten before every step)."]
    motors = []
    for dr, body, j, a, v0 in plan.driven:
        if isinstance(dr.f, Poly) and len(dr.f.coeffs) <= 3:
            # d'' constant: a motor with gear armature a d'' at ctrl 1 gives the joint that acceleration
            force = s["armature"] * a * (2.0 * dr.f.coeffs[2] if len(dr.f.coeffs) == 3 else 0.0)
            if force:
                motors.append(f'<motor name="drive:{len(motors)}" joint="{body}:{j}" gear="{force!r}"/>')
            how = ("polynomial of degree <= 2: inside the model (armature, keyframe velocity"
                   + (", a motor at ctrl 1 for d''" if force else "") + "); plain mj_step reproduces it")
        else:
            how = ("not expressible in MJCF: before every mj_step set qpos = a (d(t) - v0), qvel = a d'(t) and "
                   "qfrc_applied = armature a d''(t) on this joint, as the harness does")
        notes.append(f"driver '{dr.name}' on joint '{body}:{j}' (a = {a:.17g}, v0 = {v0:.17g}, d = {dr.f}): {how}")
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

    from . import get
    from .pymunk_sim import _Mechanism

    adapter = get("pymunk")
    why = adapter.unsupported(model)
    if why:
        from kinem.errors import InputError

        raise InputError(f"{model.case.source}: pymunk cannot represent this case: {why}")
    s = adapter.settings(settings)
    times = np.asarray(model.times, float)
    adapter.steps_per_interval(s, float(times[1] - times[0]) if len(times) > 1 else float(model.case.end))
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


SCRIPT = '''"""kinem export of case '{name}' ({source}) for pymunk {version}: the harness's
Space and stepping, runnable with pymunk and numpy only. Prints the case bodies'
final x, y, phi as JSON (--all: every output instant; --velocities: x', y', phi' too)."""
import base64, io, json, math, sys, zlib

import math

import numpy as np
import pymunk

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
