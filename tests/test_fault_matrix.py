"""A small, bounded run of benchmarks/fault_matrix.py (issue 25, "done
when"): mutated case files, and SIGKILL/SIGTERM at random moments of solve
and export plus closed standard streams, all within the command line's
contract. The 5,000-case run is the script itself (docs/benchmarks.md)."""
import random
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import fault_matrix  # noqa: E402


def test_mutated_cases_keep_the_contract():
    problems = []
    counts, _ = fault_matrix.fuzz(12, random.Random(25), problems)
    assert problems == [] and sum(counts.values()) == 12


def test_signals_and_closed_streams_keep_the_contract(tmp_path):
    problems = []
    table = fault_matrix.faults(2, random.Random(25), problems, tmp_path, names=("solve",), disk=False)
    assert problems == [] and len(table) >= 3   # two signals (or one twice) and the three closed streams
