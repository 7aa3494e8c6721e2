"""The command line's argument values: parsed, checked, turned into what
the API takes (one-line InputErrors naming the option)."""
import argparse
import json
import sys
from pathlib import Path

from ..errors import InputError, one_line
from ..result import OUTPUTS


class Parser(argparse.ArgumentParser):
    def error(self, message):
        command = self.prog.removeprefix("kinem").strip()   # "solve", or "" for kinem itself
        raise InputError(f"{command}: {message}" if command else message)


def load_model(path, end=None, steps=None, values=None):
    from ..case import check_time, load, time_options
    from ..model import compile

    end, steps = time_options(end, steps)  # the rules of the case file's [time]
    if end is None and steps is None:
        return compile(warned(load, path, parameters=set_values(values)))
    from ..loader import fast_drivers
    from ..moved import quiet

    # a fast driver's warning counts what is solved: the case's span and output intervals with --end and --steps
    case = check_time(quiet(load, path, parameters=set_values(values)).with_time(end, steps))
    for text in fast_drivers(case):
        print(one_line(f"kinem: warning: {text}"), file=sys.stderr)
    return compile(case)


def output_list(text, extra=()):
    items = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in items if s not in OUTPUTS + extra]
    if bad or not items:
        raise InputError(f"--outputs: got {text!r}; expected a comma-separated list of {', '.join(OUTPUTS + extra)}")
    return tuple(items)


def warned(fn, *args, **kwargs):
    """fn(...) with the KinemWarnings it gives printed as one line each on standard error."""
    import warnings

    from ..errors import KinemWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", KinemWarning)
        out = fn(*args, **kwargs)
    for w in caught:
        if issubclass(w.category, KinemWarning):
            print(one_line(f"kinem: warning: {w.message}"), file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return out


def frame_bar():
    """A frame progress bar (kinem.notebook.frame_bar) when standard error is a terminal, else None."""
    if not sys.stderr.isatty():
        return None
    from ..notebook import frame_bar

    return frame_bar(1)


def set_values(items) -> dict:
    """--set NAME=VALUE (repeatable) of solve and info: name -> value text
    (kinem.parameters.apply resolves the name and checks the value)."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise InputError(f"--set: got {item!r}; expected NAME=VALUE with NAME a named dimension of the "
                             "case's [parameters] or a design parameter path (kinem info CASE --parameters)")
        if name.strip() in out:   # as kinem sweep refuses it: the later value would win unseen
            raise InputError(f"--set: {name.strip()!r} given twice; expected each parameter once")
        out[name.strip()] = value.strip()
    return out


def set_option(p):
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="a named dimension of the case's [parameters] or a design parameter path (repeatable): "
                        "--set crank=55, --set constraints.B.si.0=0.31")


def file_format(out, fmt):
    """--format, or the one --out's suffix names (csv by default); they must agree."""
    suffix = Path(out).suffix.lower().lstrip(".") if out and out != "-" else ""
    if fmt and suffix in ("csv", "npz") and suffix != fmt:
        raise InputError(f"--format {fmt} does not match --out {out}: expected a .{fmt} file name, "
                         f"or --format {suffix}")
    fmt = fmt or (suffix if suffix in ("csv", "npz") else "csv")
    if fmt == "npz" and (not out or out == "-"):
        raise InputError("--format npz needs --out FILE")
    return fmt


def engine_settings(items, dt, engines=None):
    """--set engine.key=value (repeatable) and --dt into engine -> overrides,
    checked by each engine named (or in ``engines``) with a one-line error."""
    from adapters import names, settings

    ENGINES = names()
    out = {e: {} for e in ENGINES}
    for item in items or ():
        key, sep, raw = item.partition("=")
        engine, dot, name = key.partition(".")
        if not sep or not dot or engine not in ENGINES or not name:
            raise InputError(f"--set: got {item!r}; expected ENGINE.KEY=VALUE with ENGINE one of {', '.join(ENGINES)}")
        try:
            value = json.loads(raw)
        except ValueError:
            value = raw
        if name in out[engine]:   # as solve's --set: the later value would win unseen
            raise InputError(f"--set: {key!r} given twice; expected each setting once")
        if engines is not None and engine not in engines:   # it would be ignored
            raise InputError(f"--set: got {item!r}, but {engine} does not run (--engines {','.join(engines)}); "
                             "expected settings of the engines that run")
        out[engine][name] = value
    if dt is not None:
        if not dt > 0:
            raise InputError(f"--dt: got {dt}; expected a positive time step")
        if engines is not None and not any(e in ENGINES for e in engines):
            raise InputError(f"--dt: no engine runs (--engines {','.join(engines)}); expected --engines with one "
                             f"of {', '.join(ENGINES)}, or no --dt (native has no time step)")
        both = [e for e in ENGINES if "dt" in out[e]]
        if both:   # --dt would be ignored there
            raise InputError(f"--dt and --set {both[0]}.dt: give one (--dt sets every engine's dt)")
        for e in ENGINES:
            out[e]["dt"] = dt
    for e in ENGINES:
        if e in (engines or ()) or any(x.partition(".")[0] == e for x in items or ()):
            settings(e, out[e], "--set" if items else "--dt")
    return out


def engine_list(text) -> list:
    """--engines: a comma-separated list of native and the engines (None: all)."""
    from adapters import names

    ENGINES = names()
    if text is None:
        return ["native", *ENGINES]
    from ..casefile.checks import suggest

    engines = list(dict.fromkeys(e.strip() for e in text.split(",") if e.strip()))   # one run each
    unknown = [e for e in engines if e not in ("native",) + ENGINES]
    guess = suggest(unknown[0], ("native",) + ENGINES) if unknown else None
    if guess is not None:
        raise InputError(f"--engines: unknown engine {unknown[0]!r}; did you mean '{guess}'?")
    if unknown or not engines:
        raise InputError(f"--engines: got {text!r}; expected a comma-separated list of native, {', '.join(ENGINES)}")
    return engines
