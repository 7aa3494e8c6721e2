"""Inlining at the source level, for the march kinem.march writes: a call
statement replaced by the called function's statements.

numba can inline a call too (``inline="always"``, kinem.jit.inlined), but
its arguments then reach the inlined code through tuples, and each array
taken from a tuple costs a reference count: kinem.newton.settle inlined
that way, with its operations' arrays in a tuple, made the slider-crank's
instant 45 % slower (1.9 -> 2.8 us; 404 increfs in the loop's code instead
of 158). Written out, the statements use the caller's own variables.
"""
import ast
import copy
import inspect
import textwrap


def function(fn) -> ast.FunctionDef:
    """The syntax tree of a function (or of a kernel's Python function)."""
    fn = getattr(fn, "py_func", fn)
    return ast.parse(textwrap.dedent(inspect.getsource(fn))).body[0]


def _assigned(fn: ast.FunctionDef) -> set:
    return {n.id for n in ast.walk(fn) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}


class _Body(ast.NodeTransformer):
    """fn's statements for one call: parameters replaced by the call's
    arguments, its own variables renamed (prefix), ``return x`` made
    ``target = x`` (and ``break`` out of the loop it is in)."""

    def __init__(self, fn, call, target, prefix, last):
        params = [a.arg for a in fn.args.args]
        if len(call.args) != len(params) or call.keywords:
            raise ValueError(f"{fn.name}: the call must give every parameter, by position")
        if _assigned(fn) & set(params):
            raise ValueError(f"{fn.name}: assigns to a parameter")
        self.names = dict(zip(params, call.args))
        for name in _assigned(fn):
            self.names[name] = ast.Name(prefix + name)
        self.target, self.last, self.loops, self.exit_loop = target, last, 0, False

    def visit_Name(self, node):
        new = self.names.get(node.id)
        if new is None:
            return node
        new = copy.deepcopy(new)
        if isinstance(new, ast.Name):
            new.ctx = node.ctx
        return new

    def visit_While(self, node):
        self.loops += 1
        exit_loop = self.exit_loop
        self.exit_loop = (node is self.last and isinstance(node, ast.While) and isinstance(node.test, ast.Constant)
                          and node.test.value is True)
        node = self.generic_visit(node)
        self.loops -= 1
        self.exit_loop = exit_loop
        return node

    visit_For = visit_While

    def visit_Return(self, node):
        if not (self.loops == 0 and node is self.last or self.loops == 1 and self.exit_loop):
            raise ValueError("returns before its end, or from a loop that is not its last statement, "
                             "a `while True`")
        value = self.visit(node.value) if node.value is not None else ast.Constant(None)
        out = [ast.Assign([copy.deepcopy(self.target)], value)] if self.target is not None else [ast.Expr(value)]
        return out + [ast.Break()] * self.loops


def _calls(statements, name):
    """(index, target, call) of the statements ``target = name(...)`` or ``name(...)``."""
    for i, s in enumerate(statements):
        value = s.value if isinstance(s, (ast.Assign, ast.Expr)) else None
        if isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == name:
            yield i, (s.targets[0] if isinstance(s, ast.Assign) else None), value


def expand(caller: ast.FunctionDef, fn: ast.FunctionDef, prefix: str) -> None:
    """Replaces, in caller (in place), each statement ``target = fn(...)``
    or ``fn(...)`` by fn's statements, its variables prefixed. fn returns
    at its end, or from a ``while True`` loop that is its last statement
    (the return becomes an assignment and a ``break``): ``target`` holds
    the value returned in both cases."""
    body = [s for s in fn.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
    for node in list(ast.walk(caller)):
        for field in ("body", "orelse"):
            statements = getattr(node, field, None)
            if not isinstance(statements, list):
                continue
            for i, target, call in reversed(list(_calls(statements, fn.name))):
                copied = copy.deepcopy(body)
                writer, new = _Body(fn, call, target, prefix, copied[-1]), []
                for s in copied:
                    out = writer.visit(s)
                    new.extend(out if isinstance(out, list) else [out])
                statements[i:i + 1] = new
    ast.fix_missing_locations(caller)
