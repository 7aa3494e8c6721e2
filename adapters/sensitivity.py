"""Design sensitivities cross-checked like the trajectories (issue 30, item 3;
docs/design.md, "Sensitivities cross-checked by the engines"): native's
exact d/dp of the position columns (bodies' x, y, angle and the named
points' x, y) against central differences of native and of every engine
that supports the case, each run at p + h and p - h.

The limit of a source e (an engine, or native) at every instant and column:

    |D_e(h) - S| <= eps_e * L / h  +  (2/3) max_t |D_n(2h) - D_n(h)|

S the exact sensitivity, D_e(h) = (C_e(p + h) - C_e(p - h)) / (2h) the
source's central difference, eps_e its own tolerance on positions relative
to the characteristic length L (an engine's ``position_error_rel``, its
``angle_error`` in rad for angles; native's Options.tolerance): each run is
within eps_e L of the truth, so the two runs' difference over 2h is off by
at most eps_e L / h. The second term is the truncation error of the central
difference, h^2 S''' / 6, estimated by Richardson's rule from native's own
differences at h and 2h (their difference is three times D_n(h)'s error)
and taken twice (the column's largest over t). An engine runs p + h and p - h at the step settings it
chose on the nominal case (its dt = "auto" resolved once), so that the
difference is not a change of step.
"""
from dataclasses import dataclass, field

import numpy as np

from .base import Status

STEP = 1e-3    # h, of the parameter's scale (max(|p|, L) for a length, max(|p|, 1) else)


@dataclass(frozen=True)
class Check:
    """One source's differences for one parameter: the worst column by its
    ratio to the limit (``figure``: ``d(COLUMN)/d(PARAMETER)``)."""
    engine: str
    parameter: str
    status: Status
    detail: str = ""
    h: float = float("nan")
    figure: str = ""
    error: float = float("nan")    # max over instants of |D_e - S| in the worst column ...
    limit: float = float("nan")    # ... and its limit at that instant
    at: float = float("nan")       # the instant
    ratio: float = float("nan")    # max |D_e - S| / limit over instants and columns
    settings: dict = field(default_factory=dict)
    curves: dict = field(default_factory=dict, repr=False, compare=False)   # column -> D_e

    @property
    def within(self) -> bool | None:
        return None if self.status is Status.UNSUPPORTED else (self.status is Status.OK and self.ratio <= 1.0)

    @property
    def text(self) -> str:
        if self.status is not Status.OK:
            return self.status.label(self.detail)
        word = "within" if self.within else "OUTSIDE"
        return f"{word}: {self.figure} off by {self.error:.2e}, limit {self.limit:.2e} at t = {self.at:.4g}"


def columns(model) -> list:
    """The position columns checked: moving bodies' x, y, angle; named points' x, y."""
    fixed = {c["body"] for c in model.case.constraints if c.type == "ground"}
    out = [f"{b.name}.{k}" for b in model.case.bodies if b.name not in fixed for k in ("x", "y", "angle")]
    return out + [f"{p.name}.{k}" for p in model.case.points if p.body not in fixed for k in ("x", "y")]


def check(model, paths, engines, overrides=None, options=None):
    """(exact Sensitivity, [Check]) for every parameter path and source
    (``engines``: names, 'native' included when asked). Raises InputError
    for an unknown path or engine setting. ``options`` (kinem.Options;
    default the case's): native's solves, e.g. their max_seconds, and the engines' runs."""
    from kinem.options import Options
    from kinem.parameters import resolve
    from kinem.sensitivity import differenced, name, sensitivity
    from kinem.solver import solve

    from . import case_settings, get
    from .compare import engines_deadline

    case = model.case
    bound = engines_deadline(options)   # the engines' runs end at options.max_seconds too
    listed = resolve(case, paths)
    exact = sensitivity(model, [p.path for p in listed], outputs=("positions",), options=options)
    cols = [c for c in columns(model) if c in exact.trajectory]
    eps_n = Options.of(case).tolerance
    t = exact.trajectory.t
    adapters = {e: get(e) for e in engines if e != "native"}
    chosen = {}   # engine -> its settings resolved on the nominal case
    for e, a in adapters.items():
        if a.unsupported(model) is None:
            s = a.settings(case_settings(model, e, (overrides or {}).get(e)))
            run = a.run(model, settings=s, limit=bound)
            fixed = {k: run.settings[k] for k in a.defaults() if k in run.settings}
            if "substeps" in fixed:
                fixed["substeps"] = run.settings.get("substeps") or None
            chosen[e] = (run, fixed)
    out = []
    for p in listed:
        h, moved, invalid = differenced(model, p, STEP)
        if invalid:
            out.append(Check("native", p.path, Status.FAILED, f"native at p +- h: {invalid}", h))
            continue
        native = {s: solve(m, outputs=("positions",), options=options) for s, m in moved.items()}
        bad = [r.message for r in native.values() if not r.success]
        if bad:
            out.append(Check("native", p.path, Status.FAILED, f"native at p +- h: {bad[0]}", h))
            continue
        nat = {s: r.trajectory for s, r in native.items()}
        truncation = {c: 2 / 3 * np.max(np.abs((nat[2][c] - nat[-2][c]) / (4 * h) - (nat[1][c] - nat[-1][c]) / (2 * h)))
                      for c in cols}   # the column's largest: pointwise it vanishes where S''' does
        S = {c: exact.of(c, p.path) for c in cols}

        def judge(engine, plus, minus, tol, settings=None):
            worst, curves = None, {}
            for c in cols:
                d = (plus[c] - minus[c]) / (2 * h)
                curves[c] = d
                eps = tol.get("angle_error", tol["position_error_rel"]) if c.endswith(".angle") else \
                    tol["position_error_rel"] * model.length
                limit = np.full(len(t), eps / h + truncation[c])
                err = np.abs(d - S[c])
                r = err / np.maximum(limit, 1e-300)
                k = int(np.argmax(r))
                if worst is None or r[k] > worst[0]:
                    worst = (float(r[k]), c, float(err[k]), float(limit[k]), float(t[k]))
            r, c, err, limit, at = worst
            return Check(engine, p.path, Status.OK, h=h, figure=name(c, p.path), error=err, limit=limit, at=at,
                         ratio=r, settings=dict(settings or {}), curves=curves)

        for e in engines:
            if e == "native":
                out.append(judge("native", nat[1], nat[-1], {"position_error_rel": eps_n, "angle_error": eps_n},
                                 {"tolerance": eps_n}))
                continue
            a = adapters[e]
            why = a.unsupported(model)
            if why:
                out.append(Check(e, p.path, Status.UNSUPPORTED, why, h))
                continue
            nominal, fixed = chosen[e]
            if nominal.status is not Status.OK:
                out.append(Check(e, p.path, nominal.status, f"nominal run: {nominal.detail}", h))
                continue
            runs = {s: a.run(moved[s], settings=fixed, limit=bound) for s in (1, -1)}
            failed = [r for r in runs.values() if r.status is not Status.OK]
            if failed:
                out.append(Check(e, p.path, failed[0].status, f"at p +- h: {failed[0].detail}", h))
                continue
            out.append(judge(e, runs[1].trajectory, runs[-1].trajectory, a.tolerance, fixed))
    return exact, out


def table(case_name, checks) -> str:
    lines = [f"case {case_name}: exact sensitivities against central differences (p +- h)",
             f"{'source':8s} {'parameter':34s} {'h':>9s} {'ratio':>8s}  verdict"]
    for c in checks:
        lines.append(f"{c.engine:8s} {c.parameter:34s} {c.h:9.3g} {c.ratio:8.2g}  {c.text}")
    lines.append("ratio: the largest |difference - exact| over its limit eps*L/h + (2/3) max_t|D_native(2h) - "
                 "D_native(h)| (eps: the source's position tolerance; docs/design.md)")
    return "\n".join(lines)
