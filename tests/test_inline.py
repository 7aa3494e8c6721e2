"""kinem.inline: a call statement replaced by the called function's
statements gives what the call gave."""
import ast
import textwrap

import pytest

from kinem import inline


def source(text):
    return ast.parse(textwrap.dedent(text)).body[0]


def run(caller, *fns):
    tree = source(caller)
    for i, fn in enumerate(fns):
        inline.expand(tree, source(fn), f"_{i}_")
    scope = {}
    exec(compile(ast.Module([tree], []), "<inlined>", "exec"), scope)
    return scope[tree.name], ast.unparse(tree)


SEARCH = """
def search(x, limit, step):
    it, y = 0, x
    while True:
        if y * y >= limit:
            return it, y
        if it == 50:
            return -1, y
        y = bump(y, step)
        it += 1
"""
BUMP = """
def bump(v, d):
    w = v + d
    return w
"""
CALLER = """
def caller(x, limit):
    it = 7  # the caller's own variable of the same name, kept
    n, y = search(x, limit, 0.5)
    return n, y, it
"""


@pytest.mark.parametrize("x, limit", [(0.0, 4.0), (1.0, 1.0), (0.0, 1e9)])
def test_written_out_as_called(x, limit):
    scope = {}
    exec(textwrap.dedent(SEARCH + BUMP + CALLER), scope)
    inlined, text = run(CALLER, SEARCH, BUMP)
    assert "search(" not in text and "bump(" not in text
    assert inlined(x, limit) == scope["caller"](x, limit)


@pytest.mark.parametrize("fn", [
    "def f(a):\n    if a:\n        return 1\n    return 2\n",           # a return before the end
    "def f(a):\n    for i in a:\n        return i\n    return 0\n",    # from a loop that is not the last statement
    "def f(a):\n    a = a + 1\n    return a\n",                        # assigns to a parameter
])
def test_what_it_cannot_write_out_is_refused(fn):
    with pytest.raises(ValueError):
        inline.expand(source("def g(x):\n    y = f(x)\n    return y\n"), source(fn), "_")
