"""Issue 24's mechanisms (tests/mechanisms24.py: Watt II, Klann-type,
Geneva, geared five-bar) at 0.25x, 1x and 4x speed: each engine's verdict at
its chosen setting, the steps per interval and the cost.

    python benchmarks/issue24_bench.py [ENGINES]
"""
import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]
import kinem  # noqa: E402
from adapters.compare import run_engine  # noqa: E402
from mechanisms24 import MECHANISMS  # noqa: E402


def main(engines):
    for name, make in MECHANISMS.items():
        for f in (0.25, 1.0, 4.0):
            case = kinem.load_dict(make(f))
            model = kinem.compile(case)
            ref = kinem.solve(model, options=dataclasses.replace(kinem.Options.of(case), tolerance=1e-13))
            for e in engines:
                c = run_engine(model, ref, e)
                figs = (f"pos {c.position_error_rel:.1e} ang {c.angle_error:.1e} vel {c.velocity_error_rel:.1e} "
                        f"omg {c.angular_velocity_error_rel:.1e}") if c.ok else ""
                print(f"{name:16s} f={f:<5g} {e:7s} {figs} steps/int {c.substeps:4d} "
                      f"us/int {1e6 * c.time_per_interval:8.1f}  {c.verdict_text if c.ok else c.label[:90]}",
                      flush=True)


if __name__ == "__main__":
    main(tuple(sys.argv[1].split(",")) if len(sys.argv) > 1 else ("pymunk", "mujoco", "exudyn"))
