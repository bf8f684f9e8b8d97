"""Compile the quick tier's default loops into numba's cache: ``full`` (EN-02's dataset with
rotation and energy, and with the controlled phase) or ``trajectory`` (rotation, no energy).

tests/conftest.py runs both parts in two processes before pytest-xdist starts its workers,
so that each loop is compiled once on a cold cache instead of once per worker; on a warm
cache each part only loads it (a few seconds). Not a test module: pytest never collects it.
"""

from __future__ import annotations

import sys


def main(part: str) -> None:
    """Run the short runs of ``part`` (their results are not used: the cache is the point)."""
    from creatio.pipeline.config import resolve

    if part == "full":
        from creatio.studies import sphere

        for overrides in (["phases.T=0.2"], ["control=pd", "phases.T=0.2"]):
            cfg = resolve("en02", overrides).obj
            sphere.run(cfg, cfg.solver.dt)
    elif part == "trajectory":
        from creatio.dynamics import simulate

        simulate(resolve("en02", ["phases.T=0.2"]).obj.sphere_problem().replace(energy=False))
    else:
        raise SystemExit(f"warm_loops: unknown part {part!r} (full or trajectory)")


if __name__ == "__main__":
    main(sys.argv[1])
