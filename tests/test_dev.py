"""dev.py's build shows that it is alive (issue 29, item 7): each stage of
pip's and cargo's verbose output is printed as it comes, with the seconds
elapsed; the rest is kept back, and shown (its last lines) only when the
build fails."""
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def dev():
    spec = importlib.util.spec_from_file_location("dev", ROOT / "dev.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BUILD = """
import sys
for line in ["Collecting numpy>=1.26", "  noise of the resolver", "   Compiling pyo3 v0.27.0",
             "   Compiling faer v0.22.0", "warning: something cargo says", "    Finished `release` profile",
             "Successfully installed kinem-0.1.0"]:
    print(line, flush=True)
sys.exit(int(sys.argv[1]))
"""


def test_each_stage_is_printed_with_its_elapsed_time(capsys):
    dev().with_progress([sys.executable, "-c", BUILD, "0"], "building")
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("dev.py: building (minutes the first time")
    shown = [line.split("] ", 1)[1] for line in err if line.startswith("dev.py: [")]
    assert shown == ["Collecting numpy>=1.26", "Compiling pyo3 v0.27.0", "Compiling faer v0.22.0",
                     "Finished `release` profile", "Successfully installed kinem-0.1.0"]
    assert err[-1].startswith("dev.py: done in ")


def test_a_failed_build_shows_its_last_lines(capsys):
    with pytest.raises(subprocess.CalledProcessError):
        dev().with_progress([sys.executable, "-c", BUILD, "3"], "building")
    err = capsys.readouterr().err
    assert "warning: something cargo says" in err and "noise of the resolver" in err   # the tail, verbatim
    assert "dev.py: done" not in err
