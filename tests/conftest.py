import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

# CI: a fixed, derandomised example budget so that runs are repeatable and bounded.
settings.register_profile("ci", max_examples=40, derandomize=True, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=200, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(scope="session")
def wheel(tmp_path_factory):
    """kinem's wheel as users get it (``pip wheel .``, the compiled core
    inside), built once per test session: xdist's workers share it through
    their common temporary root, the first to ask building it under a lock
    (tests/test_install.py, tests/test_ci_recipe.py). Skipped without a Rust
    toolchain to build it with."""
    import fcntl
    import shutil
    import subprocess

    if shutil.which("cargo") is None:
        pytest.skip("no Rust toolchain to build the wheel with")
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base   # the session's, for every worker
    out = shared / "kinem-wheel"
    with open(shared / "kinem-wheel.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        found = sorted(out.glob("kinem-*.whl"))
        if not found:
            r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                                "--disable-pip-version-check", "-q", "-w", str(out), str(ROOT)],
                               capture_output=True, text=True)
            assert r.returncode == 0, r.stderr[-2000:]
            found = sorted(out.glob("kinem-*.whl"))
    (whl,) = found
    return whl
