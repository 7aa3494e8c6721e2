"""kinem.parallel: the report, stress and compare on a Dask cluster
(``--scheduler``) give the same results as in this process; bad or
unreachable scheduler addresses are one-line input errors (exit 2)."""
import json
import re
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from kinem import parallel, stress
from kinem.cli import main

distributed = pytest.importorskip("distributed")
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def scheduler():
    """A local cluster: two worker processes, one thread each (the workers
    import kinem from the installed package), closed after the module."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster:
        yield cluster.scheduler_address


def short_four_bar(folder, end=1.0, steps=50):
    """cases/four_bar.toml (a work-precision case: it has a sweep) over a shorter time."""
    text = (ROOT / "cases" / "four_bar.toml").read_text()
    text = re.sub(r"\[time\][^\[]*", f"[time]\nend = {end}\nsteps = {steps}\n\n", text, count=1)
    (folder / "four_bar.toml").write_text(text)
    return "four_bar.toml"


def test_map_keeps_order_everywhere(scheduler):
    tasks = list(range(7))
    want = [abs(-t) for t in tasks]
    assert parallel.map(abs, tasks, jobs=0) == want
    assert parallel.map(abs, tasks, jobs=2) == want
    assert parallel.map(abs, tasks, scheduler=scheduler) == want


def test_stress_on_cluster_equals_local(scheduler, monkeypatch):
    subset = [s for s in stress.scenarios(quick=True) if s.group in ("length-scale", "singular-branch-redundant")]
    monkeypatch.setattr(stress, "scenarios", lambda quick=False: subset[:5])
    local = stress.run(("native", "pymunk"), quick=True, jobs=0)
    remote = stress.run(("native", "pymunk"), quick=True, scheduler=scheduler)
    key = lambda o: (o.value.scenario, o.value.engine, o.status, o.detail, f"{o.value.error:.12g}")
    assert [key(r) for r in remote] == [key(r) for r in local]
    assert len(local) == 10


def test_compare_on_cluster_equals_local(scheduler, capsys):
    args = ["compare", str(ROOT / "cases" / "four_bar.toml"), "--engines", "native,pymunk", "--json"]
    assert main(args) == 0
    local = json.loads(capsys.readouterr().out)["engines"]
    assert main(args + ["--scheduler", scheduler]) == 0
    remote = json.loads(capsys.readouterr().out)["engines"]
    timing = {"wall_time", "time_per_step", "time_per_interval", "overhead_per_interval", "time_per_sim_second",
              "cost_per_interval"}
    assert list(remote) == ["native", "pymunk"] and remote["pymunk"]["status"] == "ok"
    for e in local:
        assert {k: v for k, v in remote[e].items() if k not in timing} == \
               {k: v for k, v in local[e].items() if k not in timing}


def test_report_on_cluster_equals_local(scheduler, tmp_path, monkeypatch, capsys):
    """A relative case path (the workers run in another directory), the main
    runs and the sweeps submitted as the main runs come back."""
    monkeypatch.chdir(tmp_path)
    case = short_four_bar(tmp_path)
    common = [case, "--engines", "pymunk", "--quick", "--no-stress"]
    assert main(["report", *common, "--jobs", "0", "--out", "local"]) == 0
    assert main(["report", *common, "--scheduler", scheduler, "--out", "remote"]) == 0
    capsys.readouterr()

    def figures(out):
        doc = json.loads((tmp_path / out / "results.json").read_text())
        (c,) = doc["cases"]
        runs = [(c["path"], r["engine"], r["status"], r["counts"], r["position_error_rel"]) for r in c["runs"]]
        points = [(k["engine"], p["value"], p["status"], p["counts"], p["error"])
                  for k in c["work_precision"]["curves"] for p in k["points"]]
        return runs, points

    runs, points = figures("remote")
    local = figures("local")
    differ = [(a, b) for a, b in zip(runs + points, local[0] + local[1]) if a != b]
    assert (runs, points) == local, differ[:3]   # (remote, local): the first that differ
    assert [r[:3] for r in runs] == [(case, "native", "ok"), (case, "pymunk", "ok")]
    assert len(points) == 5 + 4   # native tolerances; pymunk dt factors 10, 5, 2, 1


def one_line_exit_2(args, capfd):
    code = main(args)
    err = capfd.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("kinem: error: --scheduler"), err
    return err


def test_unreachable_scheduler_is_input_error(monkeypatch, capfd):
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 1.0)
    with socket.socket() as s:   # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    case = str(ROOT / "cases" / "four_bar.toml")
    err = one_line_exit_2(["compare", case, "--engines", "native,pymunk", "--scheduler", f"tcp://127.0.0.1:{port}"],
                          capfd)
    assert "cannot connect" in err
    err = one_line_exit_2(["stress", "--quick", "--scheduler", "localhost"], capfd)
    assert "not a scheduler address" in err
    one_line_exit_2(["report", case, "--scheduler", "", "--out", "never"], capfd)


def test_scheduler_without_workers_is_input_error(monkeypatch, capfd, tmp_path):
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 1.0)
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=":0") as cluster:
        err = one_line_exit_2(["report", str(ROOT / "cases" / "four_bar.toml"), "--scheduler",
                               cluster.scheduler_address, "--out", str(tmp_path / "out")], capfd)
    assert "no workers" in err and not (tmp_path / "out").exists()


def test_unreachable_scheduler_cli_one_line():
    """The real command and timeout: bounded, one line, no traceback at exit."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    p = subprocess.run([sys.executable, "-m", "kinem", "stress", "--quick", "--scheduler", f"tcp://127.0.0.1:{port}"],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "cannot connect" in p.stderr, p.stderr


def test_dask_not_imported_without_scheduler():
    code = ("import sys, kinem.cli, kinem.parallel, kinem.stress, kinem.report.execute, adapters.compare; "
            "from kinem import parallel; parallel.map(abs, [1, 2], jobs=0); "
            "print(sorted(m for m in ('dask', 'distributed') if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert p.stdout.strip() == "[]"
