"""Sweeps: a case solved over a grid of its design parameters' values.

``sweep(case, {"coupler": np.linspace(0.28, 0.32, 201)}, outputs=["B.x"])``
loads one variant per point of the grid (the product of the values given
for each parameter: a named dimension of [parameters] or any design
parameter path, validated by kinem.parameters.apply_many), solves them
all as one batch and returns a Sweep: one table of variant, parameters, t
and the outputs. The batch is kinem.variants' (each variant from the
nominal's first state, failing on its own) where the model's tables are
affine in the swept parameters; else merged cases (kinem.batch, its
variants marched side by side, kinem.batch.solve_merged), each variant from
its own estimates, a batch that fails halved until each failing variant is
solved alone. Either way one variant's failure (or bad
input: a value that makes a radius negative) is that variant's row and not
the others'.
"""
import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .casefile.checks import TOML_NUMBERS, floats, texts, toml_float, toml_number
from .errors import InputError, KinemError

MAX_VARIANTS = 100_000
LOAD_CHUNK = 64   # variants loaded by one kinem.parameters.apply_many


@dataclass(frozen=True, eq=False)
class Sweep:
    """``names`` swept and ``values`` (variants, names); ``t`` the output
    instants; ``data`` (variants, instants, columns), NaN for a variant that
    failed; ``errors`` per variant ("" when solved)."""
    names: tuple
    values: np.ndarray
    columns: tuple
    t: np.ndarray
    data: np.ndarray
    errors: tuple

    @property
    def success(self) -> bool:
        return not any(self.errors)

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, column) -> np.ndarray:
        """A column over (variants, instants)."""
        if column not in self.columns:   # a KeyError, worded as a Trajectory's
            from .errors import UnknownColumn
            from .result import missing_column

            raise UnknownColumn(missing_column(column, self.columns))
        return self.data[:, :, self.columns.index(column)]

    def csv(self) -> bytes:
        """The table: variant, the parameters, t, the outputs, error (one row
        per variant and instant; a failed variant: one row with its error)."""
        from .output import csv_rows

        out = [(",".join(("variant",) + self.names + ("t",) + self.columns + ("error",)) + "\n").encode()]
        nt = len(self.t)
        for k, (vals, error) in enumerate(zip(self.values, self.errors)):
            if error:
                text = error.replace('"', "'").replace("\n", " ")
                out.append(f"{k},{','.join(map(repr, vals.tolist()))},{',' * len(self.columns)},\"{text}\"\n".encode())
                continue
            block = np.column_stack([np.repeat(vals[None, 1:], nt, 0), self.t, self.data[k]])
            rows = csv_rows(np.full(nt, vals[0]), block).split(b"\n")[:-1]
            head = f"{k},".encode()
            out.append(b"".join(head + r + b",\n" for r in rows))
        return b"".join(out)

    def to_pandas(self):
        """A long DataFrame: variant, parameters, t, outputs, error (pandas is optional)."""
        try:
            import pandas as pd
        except ImportError:
            raise KinemError("Sweep.to_pandas needs pandas, which is not installed: pip install pandas") from None
        nv, nt = len(self.values), len(self.t)
        frame = {"variant": np.repeat(np.arange(nv), nt)}
        for j, n in enumerate(self.names):
            frame[n] = np.repeat(self.values[:, j], nt)
        frame["t"] = np.tile(self.t, nv)
        for j, c in enumerate(self.columns):
            frame[c] = self.data[:, :, j].ravel()
        frame["error"] = np.repeat(np.array(self.errors, dtype=object), nt)
        return pd.DataFrame(frame)

    def __repr__(self) -> str:
        failed = sum(1 for e in self.errors if e)
        return (f"Sweep({len(self.values)} variants of {', '.join(self.names)}, {len(self.t)} instants, "
                f"{len(self.columns)} columns, {failed} failed)")


def grid(values: dict):
    """(names, values (variants, names)): every combination of the values given per name."""
    if not isinstance(values, dict):
        raise InputError(f"sweep: values {values!r:.80}: expected a dict {{named dimension or design parameter "
                         "path: numbers}}")
    names = tuple(values)
    lists = []
    for n in names:
        v = floats(values[n])
        v = np.array([np.nan]) if v is None else np.atleast_1d(v)
        if v.ndim != 1 or not len(v) or not np.isfinite(v).all():
            raise InputError(f"sweep: parameter {n!r}: expected one or more finite numbers")
        lists.append(v)
    count = int(np.prod([len(v) for v in lists])) if lists else 0
    if not names or count > MAX_VARIANTS:
        raise InputError(f"sweep: {count} variants; expected 1 to {MAX_VARIANTS} (give values for one or more "
                         "parameters)")
    return names, np.array(list(itertools.product(*lists)), dtype=float).reshape(count, len(names))


def sweep(case, values: dict, outputs=None, progress=None) -> Sweep:
    """Solves ``case`` (a case file's path, or its dict) for every combination
    of ``values`` (named dimension or design parameter path -> numbers); ``outputs``: trajectory column
    names (default all); ``progress``: None, False or a kinem.report.progress.Progress
    (anything else an InputError, before the case is read)."""
    from .case import load_dict, read
    from .model import compile
    from .parameters import apply_many, resolve, to_paths

    bar = ("total", "done", "step", "show")   # what of a Progress is used
    if progress is not None and progress is not False and not all(hasattr(progress, k) for k in bar):
        raise InputError(f"sweep: progress {progress!r:.80}: expected None or a progress bar "
                         "(kinem.report.progress.Progress: total, done, step, show)")
    source = str(case) if isinstance(case, (str, Path)) else "<dict>"
    data = case if isinstance(case, dict) else read(case)
    names, grid_values = grid(values)
    nominal = load_dict(data, source)
    paths = to_paths(nominal, names, source)
    resolve(nominal, paths)   # the names resolve (else one InputError for all)
    base = compile(nominal)
    columns = _columns(base, outputs)
    from .budget import check_held

    check_held(len(grid_values) * len(base.times) * len(columns), source, f"sweep: {len(grid_values):,} variants x "
               f"{len(base.times):,} instants x {len(columns)} columns", "fewer variants, --outputs or --steps")
    cases, errors = [], [""] * len(grid_values)
    if progress:
        progress.total = 2 * len(grid_values)
    import warnings

    from .errors import KinemWarning
    from .loader import fast_drivers
    from .parameters import fast_line

    own, fast = set(fast_drivers(nominal)), []   # the case's own warnings are the base's, given once
    for start in range(0, len(grid_values), LOAD_CHUNK):
        rows = grid_values[start:start + LOAD_CHUNK]
        warned = []   # each variant's warnings: fast counts variants, not warnings
        loaded = apply_many(nominal, [dict(zip(names, row.tolist())) for row in rows], warned=warned)
        fast += [(k, new[0]) for k, texts in enumerate(warned, start) if (new := [w for w in texts if w not in own])]
        for k, variant in enumerate(loaded, start):
            if isinstance(variant, InputError):
                cases.append(None)
                errors[k] = f"bad input: {variant.summary()}"
            else:
                cases.append(variant)
            if progress:
                progress.step(f"variant {k + 1} loaded")
    if fast:   # a driver swept fast (a rate in degrees?): one line for all, not one a variant
        warnings.warn(fast_line("sweep", len(fast), len(grid_values), fast[0]), KinemWarning, stacklevel=2)
    out = np.full((len(grid_values), len(base.times), len(columns)), np.nan)
    valid = [k for k, c in enumerate(cases) if c is not None]
    if not (valid and _variants(base, paths, grid_values, valid, columns, out, errors, progress)):
        _solve(valid, cases, columns, out, errors, progress)
    return Sweep(names, grid_values, columns, np.array(base.times), out, tuple(errors))


def _variants(model, paths, grid_values, ks, columns, out, errors, progress) -> bool:
    """Solves variants ``ks`` as variants of the nominal model (kinem.variants)
    when its tables are affine in every path; False when they are not, or
    the nominal does not assemble (the merged path then solves them)."""
    from .errors import AnalysisError
    from .variants import affine, solve_variants

    if len(set(paths)) < len(paths) or not all(affine(model.case, p) for p in paths):
        return False
    try:
        r = solve_variants(model, {p: grid_values[ks, j] for j, p in enumerate(paths)}, outputs=columns)
    except AnalysisError:
        return False
    out[ks] = r.data
    for j, k in enumerate(ks):
        errors[k] = r.messages[j]
    if progress:
        progress.done += len(ks)
        progress.show(f"{len(ks)} variants solved")
    return True


def _columns(model, outputs) -> tuple:
    from .casefile.checks import suggest
    from .result import _layout

    names = _layout(model, 3)[0]
    if outputs is None:
        return tuple(names)
    given = texts(outputs)
    if given is None:
        raise InputError(f"--outputs: got {outputs!r:.80}; expected trajectory column names such as B.x")
    outputs = tuple(dict.fromkeys(given))
    for c in outputs:
        if c not in names:
            guess = suggest(c, names)
            raise InputError(f"--outputs: no column {c!r}" + (f"; did you mean '{guess}'?" if guess else
                                                             f"; columns: {', '.join(names[:24])}..."))
    if not outputs:
        raise InputError("--outputs: no columns given; expected trajectory column names such as B.x")
    return outputs


def _solve(ks, cases, columns, out, errors, progress):
    """Solves variants ``ks`` as merged cases (kinem.batch.solve_merged), each
    from its own case's estimates."""
    from .batch import OWN, solve_merged

    if not ks:
        return
    for k, done in zip(ks, solve_merged([cases[k] for k in ks], columns, start=OWN)):
        if done.data is not None:
            out[k] = done.data
        errors[k] = done.why
    if progress:
        failed = sum(1 for k in ks if errors[k])
        progress.done += len(ks)
        progress.show(f"{len(ks) - failed} variants solved" + (f", {failed} failed" if failed else ""))


def parse_values(item: str):
    """--set NAME=START:STOP:COUNT (COUNT values, ends included), NAME=A,B,C or NAME=A: (name, values)."""
    name, sep, text = item.partition("=")
    form = "NAME=START:STOP:COUNT, NAME=A,B,C or NAME=VALUE"
    if not sep or not name.strip() or not text.strip():
        raise InputError(f"--set: got {item!r}; expected {form}")
    try:
        if ":" in text:
            start, stop, count = text.split(":")
            n = toml_number(count)   # a whole number as a case file writes it (not 2.0, not 1__0)
            if not isinstance(n, int) or not 1 <= n <= MAX_VARIANTS:
                raise ValueError
            with np.errstate(all="ignore"):   # ends beyond a float: refused below, without numpy's warning
                start, stop = toml_float(start), toml_float(stop)
                values = np.linspace(start, stop, n)
            if n == 1 and start != stop and np.isfinite([start, stop]).all():
                # one value: START alone, STOP dropped unseen
                raise InputError(f"--set: got {item!r}: COUNT 1 takes START alone; expected COUNT 2 or more "
                                 "to reach STOP, or NAME=VALUE")
        else:
            values = np.array([toml_float(x) for x in text.split(",")])
    except ValueError:
        raise InputError(f"--set: got {item!r}; expected {form} (COUNT a whole number from 1 to "
                         f"{MAX_VARIANTS}; numbers as a case file writes them, {TOML_NUMBERS})") from None
    if not np.isfinite(values).all():
        raise InputError(f"--set: got {item!r}; expected finite numbers")
    return name.strip(), values
