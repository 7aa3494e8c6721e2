"""Tolerance bands (docs/design.md, "Tolerance bands"): how far the outputs
wander when every part is made within its tolerance.

For each chosen output column C at every instant:

- the worst-case linear band  C +- sum_p |dC/dp| pm_p                      (S6)
- the root-sum-square band    C +- sqrt(sum_p (dC/dp pm_p)^2)
- the Monte Carlo band: the minimum and maximum of C over N sampled designs
  (uniform in +-pm, or normal with sigma clipped to +-pm), each solved on
  the nominal's branch: the nominal's relative angle sign at every revolute
  joint between moving bodies and side of every cam roller pinned
  (kinem.branches), assembled from the nominal's configuration. A sample
  that cannot assemble, leaves that branch or fails on the way is counted
  and listed with its values, never taken into the band.

The derivatives are kinem.sensitivity's (exact). Seeded: the same seed gives
the same samples.
"""
import numbers
from dataclasses import dataclass

import numpy as np

from .casefile.checks import suggest, texts
from .errors import InputError
from .parameters import resolve, tolerances_of
from .moved import cases_of
from .options import Options
from .result import Trajectory
from .sensitivity import sensitivity
from .variants import affine


@dataclass(frozen=True, eq=False)
class Bands:
    """The bands of ``outputs`` (columns) over ``t``: ``table`` has t, then
    per output C: C, C.worst-, C.worst+, C.rss-, C.rss+, C.mc-, C.mc+.
    ``excess``: per output, the largest amount by which the Monte Carlo band
    leaves the worst-case linear band and where (t), 0 where linearisation
    holds. ``rejected``: (values {path: value}, why) of the samples not in
    the Monte Carlo band."""
    outputs: tuple
    table: Trajectory
    samples: int
    rejected: tuple
    excess: tuple     # (output, amount, t)
    seed: int
    singular: str = ""   # where Phi_q is singular (kinem.sensitivity's message): the linear bands inf there; else ""

    @property
    def accepted(self) -> int:
        """The samples in the Monte Carlo band (0: its columns are NaN, ``excess`` 0)."""
        return self.samples - len(self.rejected)

    def __getitem__(self, name):
        return self.table[name]

    def to_pandas(self):
        return self.table.to_pandas()


def tolerance(model, tolerances=None, samples=1000, outputs=None, seed=0, progress=None, chunk=None) -> Bands:
    """The linear, root-sum-square and Monte Carlo bands of ``outputs``
    (columns; default every named point's x and y) for the tolerances
    (default the case's [tolerances] section). The Monte Carlo samples are
    solved as variants of the model (kinem.variants, BATCH at a time) when
    its tables are affine in every toleranced parameter, else as merged
    cases, ``chunk`` at a time (default CHUNK). ``chunk`` 1: one by one, no
    threads: for a forked worker process, where a thread pool cannot run.
    ``progress``: None or a function progress(done, total), called as samples are solved."""
    from .solver import _checked_model

    _checked_model(model, "tolerance")
    case = model.case
    for key, v, most in (("samples", samples, MAX_SAMPLES), ("seed", seed, None)):
        if isinstance(v, bool) or not isinstance(v, numbers.Integral) or v < 0 or (most is not None and v > most):
            raise InputError(f"{case.source}: tolerance: {key} {v!r:.80}: expected a whole number from 0"
                             + (f" to {most:,}" if most is not None else ""))
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, numbers.Integral) or chunk < 1):
        raise InputError(f"{case.source}: tolerance: chunk {chunk!r:.80}: expected None or a whole number from 1 "
                         "(samples solved at a time)")   # -1 solved no sample, unseen; a text raised TypeError
    if progress is not None and not callable(progress):   # called after the first samples: refused before them
        raise InputError(f"{case.source}: tolerance: progress {progress!r:.80}: expected None or a function "
                         "progress(done, total)")
    given = () if outputs is None else texts(outputs)
    if given is None or (outputs is not None and not given):   # [] or --outputs '': none, as sweep says
        raise InputError(f"{case.source}: tolerance: outputs {outputs!r:.80}: expected a list of the trajectory's "
                         "column names (such as B.x)" + ("; none given" if given is not None else ""))
    given = tuple(dict.fromkeys(given))   # a column asked twice: its bands once
    tols = tolerances_of(case, tolerances)
    sens = sensitivity(model, [t.path for t in tols], outputs=("positions", "velocities", "accelerations"))
    nominal = sens.trajectory
    outputs = given or tuple(c for p in case.points for c in (f"{p.name}.x", f"{p.name}.y"))
    if not outputs:   # no named point to default to: a numpy error (exit 3) otherwise
        raise InputError(f"{case.source}: tolerance: the case has no named points, the default outputs; expected "
                         f"outputs (--outputs) such as {', '.join(nominal.columns[1:4])}")
    unknown = [c for c in outputs if c not in nominal]
    if unknown:
        guess = suggest(unknown[0], nominal.columns)
        raise InputError(f"{case.source}: --outputs: unknown column {unknown[0]!r}; " + (
            f"did you mean '{guess}'?" if guess else
            f"expected columns of the trajectory such as {', '.join(nominal.columns[:6])}"))
    pm = np.array([t.pm for t in tols])
    d = np.stack([np.stack([sens.of(c, t.path) for t in tols], axis=1) for c in outputs])   # (C, K, P)
    worst = np.abs(d) @ pm
    rss = np.sqrt((d * pm) ** 2 @ np.ones(len(tols)))
    lo, hi, rejected = _monte_carlo(model, tols, outputs, nominal, samples, seed, progress, chunk or CHUNK)
    cols, data = [], []
    excess = []
    for k, c in enumerate(outputs):
        v = nominal[c]
        cols += [c, f"{c}.worst-", f"{c}.worst+", f"{c}.rss-", f"{c}.rss+", f"{c}.mc-", f"{c}.mc+"]
        data += [v, v - worst[k], v + worst[k], v - rss[k], v + rss[k], lo[k], hi[k]]
        out = np.maximum(hi[k] - (v + worst[k]), (v - worst[k]) - lo[k])
        at = int(np.nanargmax(out)) if np.isfinite(out).any() else 0
        amount = float(max(np.nan_to_num(out[at], nan=0.0), 0.0))
        excess.append((c, amount if amount > _noise(case, nominal, c) else 0.0, float(nominal.t[at])))
    table = Trajectory(np.array(nominal.t), tuple(cols), np.column_stack(data))
    return Bands(outputs, table, samples, tuple(rejected), tuple(excess), seed,
                 sens.message if sens.singular.any() else "")


def _monte_carlo(model, tols, outputs, nominal, samples, seed, progress, chunk):
    """(min, max) of every output over the samples on the nominal's branch
    (each (C, K), nan without samples), and the rejected samples."""
    case = model.case
    K = len(nominal.t)
    lo = np.full((len(outputs), K), np.inf)
    hi = np.full((len(outputs), K), -np.inf)
    rng = np.random.default_rng(seed)
    pm = np.array([t.pm for t in tols])
    draws = rng.uniform(-1.0, 1.0, (samples, len(tols))) * pm
    for j, t in enumerate(tols):
        if t.sigma is not None:
            draws[:, j] = np.clip(rng.normal(0.0, t.sigma, samples), -t.pm, t.pm)
    base = {p.path: p.value for p in resolve(case, [t.path for t in tols])}
    q0 = _first(nominal, model)
    pinned = _pin(case, model, q0)
    nominal_branch = _branch(model, q0)
    rejected, accepted = [], 0

    def take(traj):
        nonlocal accepted
        accepted += 1
        for k, c in enumerate(outputs):
            lo[k] = np.minimum(lo[k], traj[c])
            hi[k] = np.maximum(hi[k], traj[c])

    from .budget import MAX_HELD

    most = max(1, int(MAX_HELD // (K * len(outputs))))   # samples whose outputs one batch may hold (long runs)
    if chunk > 1 and all(affine(case, t.path) for t in tols):   # the variants' batch solve (kinem.variants)
        batch = min(BATCH, most)
        for start in range(0, samples, batch):
            stop = min(samples, start + batch)
            for values, traj, why in _solve_variants(model, tols, base, draws[start:stop], nominal.t, nominal_branch,
                                                     outputs):
                if why is None:
                    take(traj)
                else:
                    rejected.append((values, why))
            if progress is not None:
                progress(stop, samples)
        return _bands(lo, hi, accepted, rejected)
    chunk = min(chunk, most)
    for start in range(0, samples, chunk):
        batch = []
        designs = [{t.path: base[t.path] + draws[s, j] for j, t in enumerate(tols)}
                   for s in range(start, min(samples, start + chunk))]
        for values, variant in zip(designs, cases_of(pinned, designs)):   # set in place where the paths allow
            if isinstance(variant, InputError):
                rejected.append((values, f"not a valid case: {variant}"))
            else:
                batch.append((values, variant))
        for values, traj, why in _solve_chunk(model, batch, nominal.t, q0, nominal_branch, outputs):
            if why is None:
                take(traj)
            else:
                rejected.append((values, why))
        if progress is not None:
            progress(min(samples, start + chunk), samples)
    return _bands(lo, hi, accepted, rejected)


PAIRS = {"x": "y", "y": "x", "vx": "vy", "vy": "vx", "ax": "ay", "ay": "ax"}   # a vector's two columns


def _noise(case, nominal, c) -> float:
    """How far the Monte Carlo band can leave the linear one by the figures'
    own noise: every sample and the nominal are converged to the Newton
    tolerance (at least 64 machine epsilons), relative to the output's peak
    over the run, or its vector's (a point's y of 0 beside an x of 700 is
    rounded as the x is)."""
    head, _, k = c.rpartition(".")
    columns = [c] + [n for n in (f"{head}.{PAIRS.get(k)}",) if k in PAIRS and n in nominal.columns]
    peak = max(float(np.max(np.abs(np.nan_to_num(nominal[n], nan=0.0, posinf=0.0, neginf=0.0)), initial=0.0))
               for n in columns)
    return max(Options.of(case).tolerance, 64 * np.finfo(float).eps) * peak   # the samples' solves' options


def _bands(lo, hi, accepted, rejected):
    if not accepted:
        lo[:] = np.nan
        hi[:] = np.nan
    return lo, hi, rejected


MAX_SAMPLES = 1_000_000   # Monte Carlo samples of one call (10,000 of the four-bar take about 1 s)
CHUNK = 128   # samples solved as one merged batch (kinem.batch)
BATCH = 4096  # samples solved as one batch of variants (kinem.variants)


def _solve_variants(model, tols, base, draws, times, branch, outputs):
    """(values, {output: values over times}, None) or (values, None, why)
    for every sample (a row of ``draws``), solved as variants of the model
    (kinem.variants: each from the nominal's first state)."""
    from .variants import solve_variants

    r = solve_variants(model, {t.path: base[t.path] + draws[:, j] for j, t in enumerate(tols)},
                       outputs=list(outputs), times=times)
    out = []
    for s in range(len(draws)):
        values = {t.path: base[t.path] + draws[s, j] for j, t in enumerate(tols)}
        if not r.success[s]:
            out.append((values, None, r.messages[s]))
        elif _branch(model, r.start[s]) != branch:
            out.append((values, None, "assembled on another branch"))
        else:
            out.append((values, {c: r.data[s, :, k] for k, c in enumerate(r.columns)}, None))
    return out


def _solve_chunk(model, chunk, times, q0, branch, outputs):
    """(values, {output: values over times}, None) or (values, None, why)
    for every sample of the chunk: solved as merged variants
    (kinem.batch.solve_merged), each from the nominal's first state q0,
    and kept only on the nominal's branch."""
    from .batch import solve_merged

    start = dict(zip(model.coordinate_names, q0))
    out = []
    for (values, _), done in zip(chunk, solve_merged([v for _, v in chunk], outputs, start=start, times=times)):
        if done.data is None:
            out.append((values, None, done.why))
        elif _branch(model, done.q) != branch:
            out.append((values, None, "assembled on another branch"))
        else:
            out.append((values, dict(zip(outputs, done.data.T)), None))
    return out


def _first(nominal, model):
    """The nominal's coordinates at its first instant."""
    return np.array([nominal[name][0] for name in model.coordinate_names])


def _branch(model, q) -> tuple:
    """The branch of configuration q: the sign of every revolute joint's
    relative angle between moving bodies, every cam roller's side."""
    from .branches import sides
    from .info import configuration

    return tuple(np.sign(a) for _, a in configuration(model, q)) + tuple(s.side for s in sides(model, q))


def _pin(case, model, q):
    """The case with the nominal's branch pinned (kinem.branches' sign and side keys)."""
    from .branches import sides
    from .info import configuration
    from .parameters import case_dict, validated

    data = case_dict(case)
    data.pop("tolerances", None)   # the samples' own: checked once, on the case
    signs = dict(configuration(model, q))
    sided = {s.constraint: s.side for s in sides(model, q)}
    for c, table in zip(case.constraints, data["constraints"]):
        if c.name in signs and signs[c.name] != 0:
            table["sign"] = "positive" if signs[c.name] > 0 else "negative"
        if c.name in sided:
            table["side"] = sided[c.name]
    from .moved import quiet

    return quiet(validated, data, case.source, as_written=False)   # its warnings are the case's, given at its load
