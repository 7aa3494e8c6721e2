"""The structural decomposition (issue 31; kinem/core/src/decompose.rs,
Model.structure, `kinem info --blocks`, docs/solver.md): block lower
triangular with square diagonal blocks on every case, the docs' tables as
the command prints them, and failures that name their block."""
import json
import tomllib
import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import kinem
import kinem.batch
from kinem import native
from kinem.info import describe_blocks

ROOT = Path(__file__).resolve().parents[1]
CASES = sorted((ROOT / "cases").glob("*.toml")) + sorted((ROOT / "cases" / "stress").glob("*.toml"))
sys.path.insert(0, str(ROOT / "benchmarks"))
import peers  # noqa: E402


def run(*args):
    p = subprocess.run([sys.executable, "-m", "kinem", *map(str, args)], capture_output=True, text=True, cwd=ROOT)
    return p.returncode, p.stdout, p.stderr


def check_triangular(m, n, rows, cols, exact, blocks):
    """Every row and coordinate in one block, square blocks, each matched
    pair an entry, and no entry above the block diagonal."""
    if not exact:
        assert len(blocks) == 1 and list(blocks[0][0]) == list(range(m)) and list(blocks[0][1]) == list(range(n))
        return
    brow, bcol = np.full(m, -1), np.full(n, -1)
    entries = set(zip(rows.tolist(), cols.tolist()))
    for k, (r, c) in enumerate(blocks):
        assert len(r) == len(c)
        assert (brow[list(r)] == -1).all() and (bcol[list(c)] == -1).all()
        brow[list(r)], bcol[list(c)] = k, k
        assert all((a, b) in entries for a, b in zip(r, c)), "the block's diagonal is its matching"
    assert (brow >= 0).all() and (bcol >= 0).all()
    assert (brow[rows] >= bcol[cols]).all(), "an entry above the block diagonal"


def test_every_case_is_block_triangular():
    for path in CASES:
        model = kinem.compile(kinem.load(path))
        s = model.structure
        check_triangular(model.m, model.n, model.jac_rows, model.jac_cols, s.exact, s.blocks)
        assert s.exact == (model.m == model.n), path.name
        assert s.rank == min(model.m, model.n), path.name
        if s.exact:  # the ground's three coordinates come first (each case's first constraint grounds a body)
            assert all(len(c) == 1 for _, c in s.blocks[:3]), path.name


def test_the_redundant_parallelogram_is_one_block():
    model = kinem.compile(kinem.load(ROOT / "cases/stress/parallelogram_redundant.toml"))
    s = model.structure
    assert not s.exact and len(s.blocks) == 1 and "redundant" in s.kind


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 12), st.integers(0, 2), st.data())
def test_random_patterns(n, extra, data):
    m = n + extra
    rows = np.array(data.draw(st.lists(st.integers(0, m - 1), min_size=1, max_size=4 * m)), np.int64)
    cols = np.array(data.draw(st.lists(st.integers(0, n - 1), min_size=len(rows), max_size=len(rows))), np.int64)
    exact, kind, rank, blocks, _ = native.Plan.blocks(m, n, rows, cols)
    assert rank <= min(m, n) and exact == (m == n and rank == n), kind
    check_triangular(m, n, rows, cols, exact, blocks)


def docs_block(first_line):
    """The ```text block of docs/solver.md that starts with first_line."""
    text = (ROOT / "docs" / "solver.md").read_text()
    start = text.index("```text\n" + first_line) + len("```text\n")
    return text[start:text.index("\n```", start)]


def test_the_docs_tables_are_the_commands_output():
    code, out, err = run("info", ROOT / "cases/slider_crank.toml", "--blocks")
    assert code == 0, err
    assert out.rstrip("\n") == docs_block("case slider_crank:")
    assert "8      5     rod.x, rod.y, rod.phi, slider.x, slider.y  B, A, T" in out
    jansen = kinem.compile(kinem.load_dict(peers.jansen_case()))
    assert describe_blocks(jansen) == docs_block("case jansen:")
    assert [len(c) for _, c in jansen.structure.blocks] == [1] * 6 + [6] * 3


def test_blocks_as_json():
    code, out, err = run("info", ROOT / "cases/four_bar.toml", "--blocks", "--json")
    assert code == 0, err
    d = json.loads(out)
    assert (d["exact"], d["rank"], len(d["blocks"])) == (True, 12, 7)
    assert d["blocks"][-1]["constraints"] == ["A", "B", "O4"]
    assert d["blocks"][-1]["coordinates"][0] == "coupler.x"


def test_a_limit_position_names_its_block():
    r = kinem.solve(kinem.compile(kinem.load(ROOT / "cases/stress/slider_dead_centre.toml")))
    assert r.status.name == "SINGULAR"
    assert "at t = 0.5: in block 7 of 7 (the loop of crank, rod, closed by O, B, A), conditioning" in r.message, r.message


def test_an_assembly_that_cannot_close_names_its_block():
    """The slider-crank with a rod of 50 where the crank pin is 100 off the
    slider's line: its loop cannot close."""
    case = tomllib.loads((ROOT / "cases/slider_crank.toml").read_text())
    for c in case["constraints"]:
        if c.get("name") == "B":
            c["si"] = [30.0, 0.0]
        if c.get("name") == "A":
            c["sj"] = [-20.0, 0.0]
    r = kinem.solve(kinem.compile(kinem.load_dict(case)))
    assert not r.success
    assert "cannot close in block 8 of 8 (the loop of rod, slider, closed by B, A, T)" in r.message, r.message


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 30), st.data())
def test_connected_components_are_scipys(n, data):
    """Model.blocks's components come from the core (Plan.blocks' last
    item): numbered as scipy.sparse.csgraph.connected_components numbers
    them, so the blocks' layout is the one scipy's gave."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = data.draw(st.integers(1, 30))
    rows = np.array(data.draw(st.lists(st.integers(0, m - 1), min_size=m, max_size=3 * m)), np.int64)
    rows[:m] = np.arange(m)   # every row has an entry
    cols = np.array(data.draw(st.lists(st.integers(0, n - 1), min_size=len(rows), max_size=len(rows))), np.int64)
    labels = np.asarray(native.Plan.blocks(m, n, rows, cols)[4])
    pattern = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(m, n)).tocsr()
    count, theirs = connected_components(pattern.T @ pattern, directed=False)
    assert labels.max() + 1 == count and (labels == theirs).all()


@settings(max_examples=60, deadline=None)
@given(st.permutations(list(range(9))))
def test_parity_counts_cycles(perm):
    from kinem.model import parity

    inversions = sum(perm[i] > perm[j] for i in range(len(perm)) for j in range(i + 1, len(perm)))
    assert parity(perm) == (-1) ** inversions


def test_merged_variants_are_one_block_each():
    case = kinem.load(ROOT / "cases/slider_crank.toml")
    model = kinem.compile(kinem.batch.merge([case] * 7))
    b = model.blocks
    assert (b.count, b.size, b.square, b.sign) == (7, 12, True, 1)
    assert (b.col_pos // 12 == np.arange(model.n) // 12).all()
    assert len(model.structure.blocks) == 7 * 8


def test_a_chain_above_64_coordinates_solves_by_blocks_as_superlu_does():
    """The N-four-bar chain of benchmarks/scaling_bench.py with 66 coordinates
    (one block, 16 diagonal blocks of at most 6): the core's block-triangular
    LU (was a dense 66 x 66 LU) gives the trajectory SuperLU's step-by-step
    analysis gives, to 1e-11 of the size and of the rates' peaks (both are
    rounding times the conditioning)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from scaling_bench import chain_case

    case, _ = chain_case(22, 40)
    model = kinem.compile(case)
    assert model.n == 66 and max(len(c) for _, c in model.structure.blocks) == 6
    ours = kinem.solve(model)
    theirs = kinem.solve(model, options=kinem.Options(linear_solver="sparse"))
    assert ours.success and theirs.success
    for a, b, size in ((ours.q, theirs.q, model.length), (ours.qd, theirs.qd, np.abs(theirs.qd).max()),
                       (ours.qdd, theirs.qdd, np.abs(theirs.qdd).max())):
        assert np.abs(a - b).max() <= 1e-11 * size
