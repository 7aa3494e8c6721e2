"""The benchmark harness (benchmarks/run.py, docs/benchmarks.md) runs end to
end in its tiny configuration and writes every section. Smoke test only:
nothing here asserts on speed (timings on a shared machine are not a test)."""
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_harness_runs_tiny(tmp_path):
    out = tmp_path / "bench.json"
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "run.py"), "--tiny", "--json", str(out)],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    res = json.loads(out.read_text())
    for section in ("machine", "engines", "precision", "scaling", "batch", "skips", "anatomy", "coldstart", "targets"):
        assert section in res, section
    assert res["machine"]["python"] and res["machine"]["cores"] >= 1
    # the figures exist and are positive (their size is not tested)
    native = [r for r in res["engines"] if r.get("status") == "ok"]
    assert native and all(r["native_us_per_output_step"] > 0 and r["engine_us_per_step"] > 0 for r in native)
    assert all(r["us_per_step_sparse"] > 0 for r in res["scaling"]["rows"])
    assert [r["B"] for r in res["batch"]] == [1, 10]
    assert res["skips"]["families"]["constructed"] < res["skips"]["families"]["registered"]
    assert res["skips"]["factorization_reuse"]["factorizations_per_instant_twice"] > \
        res["skips"]["factorization_reuse"]["factorizations_per_instant_once"]
    # the compiled march beside the step-by-step march (block = 1)
    assert all(r["native_step_by_step_us_per_output_step"] > 0 for r in native)
    assert all(r["single_us_per_step"] > 0 and r["single_step_by_step_us_per_step"] > 0 for r in res["batch"])
    assert {r["case"] for r in res["skips"]["block_march"]} == {"slider_crank", "four_bar", "quick_return_1"}
    assert all(v["native_tolerance"] > 0 for v in res["precision"].values())
    groups = res["anatomy"]["block_march"].get("groups")  # absent without kinem.dense (issue 23)
    assert groups is None or abs(sum(g["share"] for g in groups.values()) - 1) < 1e-6
    for t in res["targets"]:
        assert isinstance(t["met"], bool) and t["figure"]
        assert t["met"] or t["gap"]
    for word in ("targets", "cold start", "work-precision", "scaling", "batch"):
        assert word in p.stdout


def test_issue23_peers_section_runs(tmp_path):
    """benchmarks/issue23_bench.py's peers section (kinem, pylinkage if
    installed, the C floor if a compiler is) and its targets table."""
    out = tmp_path / "i23.json"
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "issue23_bench.py"), "--quick", "--only", "peers",
                        "--json", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    res = json.loads(out.read_text())
    assert res["load_start"] and res["load_end"]
    assert all(row["us_per_instant"]["kinem"] > 0 for k, row in res["peers"].items() if k != "floor")
    if "floor" in res["peers"]:  # the C floor agrees with kinem (positions of the size, rates of their peaks)
        f = res["peers"]["floor"]
        assert f["positions_of_size"] <= 1e-12 and f["velocities_of_peak"] <= 1e-10
        assert f["accelerations_of_peak"] <= 1e-10 and f["us_per_instant_timed_in_c"] > 0
    for t in res["targets"]:
        assert isinstance(t["met"], bool) and t["figure"] and t["goal"] > 0
    assert "issue 23 targets" in p.stdout


def test_paired_runs_both_ways_on_one_tree():
    """benchmarks/paired.py pairs two builds in one process: run A/A (this
    tree twice, each copy on its own core) in both modes, for one case each.
    The copies go to a temporary folder: the benchmarks and the package gain no file (but bytecode,
    which other tests' imports may write meanwhile)."""
    def files():
        return sorted(p for d in ("benchmarks", "kinem") for p in (ROOT / d).rglob("*")
                      if "target" not in p.parts and "__pycache__" not in p.parts)

    before = files()
    for what, case in (("march", "four_bar"), ("sensitivity", "slider_crank")):
        p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "paired.py"), str(ROOT), "--what", what,
                            "--pairs", "2", "--cases", case], cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr[-3000:]
        lines = [x for x in p.stdout.splitlines() if x.startswith(case)]
        assert len(lines) == 1 and "B / A - 1" in lines[0], p.stdout
    assert files() == before
