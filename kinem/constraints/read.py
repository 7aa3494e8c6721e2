"""The [[constraints]] tables: each checked against its type's declared keys
(kinem.case reads the file; the key kinds are kinem.casefile.keys)."""
from ..casefile.checks import IDENT_RE, IDENT_TEXT, show, suggest
from ..casefile.keys import BodyKey, LocalKey, Scope
from ..casefile.sections import MAX_ITEMS
from ..spec import Constraint, frozen_map
from . import REGISTRY, implemented_types


def constraints(ck, cs, bodies, points, end):
    """The Constraint of each valid table, in file order."""
    if cs is None:  # missing: reported with the top level's keys
        return []
    if not isinstance(cs, list) or not cs:
        ck.bad("[[constraints]]", None, f"got {show(cs)}", "at least one [[constraints]] table")
        return []
    if len(cs) > MAX_ITEMS:
        ck.bad("[[constraints]]", None, f"{len(cs)} constraints", f"at most {MAX_ITEMS}")
        return []
    out, seen = [], set()
    for index, c in enumerate(cs, 1):
        con = constraint(ck, index, c, bodies, points, end)
        if con is None:
            continue
        if con.name in seen:
            ck.bad(con.where, "name", "duplicate name", "a name used by no other constraint")
        seen.add(con.name)
        out.append(con)
    return out


def constraint_id(c) -> str:
    """How a design parameter path names constraint c (kinem.parameters):
    its name, ``#<index>`` when the file gave none (then named type-index)."""
    return f"#{c.index}" if c.name == f"{c.type}-{c.index}" else c.name


def constraint(ck, index, c, bodies, points, end):
    where = f"constraint {index}"
    if not isinstance(c, dict):
        ck.bad(where, None, f"got {show(c)}", "a table")
        return None
    ctype = c.get("type")
    if ctype is None:
        ck.bad(where, "type", "missing", "one of " + ", ".join(REGISTRY))
        return None
    if not isinstance(ctype, str) or ctype not in REGISTRY:
        guess = suggest(ctype, REGISTRY)
        if guess is not None:
            ck.bad(where, "type", f"unknown type {show(ctype)}; did you mean '{guess}'?")
        else:
            ck.bad(where, "type", f"unknown type {show(ctype)}", "one of " + ", ".join(REGISTRY))
        return None
    decl = REGISTRY[ctype]
    name = c.get("name", f"{ctype}-{index}")
    if not isinstance(name, str) or not IDENT_RE.fullmatch(name):
        ck.bad(where, "name", f"got {show(name)}", IDENT_TEXT)
        name = f"{ctype}-{index}"
    where = f"constraint {index} ('{name}', {ctype})"
    if decl.family is None:
        ck.bad(where, "type", f"type '{ctype}' (Eqs. {decl.equations}) is not implemented yet",
               "one of " + ", ".join(implemented_types()))
        return None
    allowed = ("type", "name") + tuple(k.name for k in decl.keys)
    n_before = ck.failures
    ck.keys(where, c, allowed, tuple(k.name for k in decl.keys if k.required))
    scope = Scope(bodies, points, end, c)
    fields = {}
    for key in decl.keys:
        if key.name in c:
            v = key.parse(ck, where, c[key.name], scope)
            if v is not None:
                fields[key.name] = key.radians(v, c) if ck.degrees else v
    if ck.failures > n_before:
        return None
    used = [fields[k.name] for k in decl.keys if isinstance(k, BodyKey) and k.name in fields]
    if len(set(used)) != len(used):
        ck.bad(where, None, "the same body is named twice (" + ", ".join(used) + ")", "distinct bodies")
        return None
    if decl.check is not None:
        for key, problem, expected in decl.check(fields, bodies):
            ck.bad(where, key, problem, expected)
        if ck.failures > n_before:
            return None
    refs = {k.name: c[k.name] for k in decl.keys if isinstance(k, LocalKey) and isinstance(c.get(k.name), str)}
    filled = tuple(k for k in fields if k not in c)
    return Constraint(ctype, name, index, frozen_map(fields), frozen_map(refs), filled)
