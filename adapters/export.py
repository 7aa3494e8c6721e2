"""The engine model exactly as the harness runs it, as a file users can take
away (``kinem export CASE --engine NAME --out FILE``).

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
