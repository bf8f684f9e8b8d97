"""The "skipped" table: per scene, what it computes, its state size, and its time against the
full study run, all measured in this one process.

For every sphere scene and every study it shows, three ways to get the frames are timed:

* **full study run**: what `snakemake all` runs for the study (every dataset part: dt and the
  dt / refine partner, histories every 0.1 s, rotation and energy integrated, provenance,
  NetCDF written), then the frames read back;
* **scene, computed**: the scene's own plan (one run at dt, histories at the frame times
  only, no energy, rotation only if drawn), through ``creatio.scenes.run.scene_dataset``;
* **scene, reused**: the scene reading the study dataset written above.

The kinematic scenes evaluate model formulas only (no study computes their data). Each time is
the minimum over ``--repeats`` runs after one warm-up (so the compiler's first load is not
counted). Sizes: integrated state components, history rows, bytes of the NetCDF files.

Usage: .venv/bin/python scripts/scene_costs.py [--repeats 3] [--out data/scenes/costs.md]
"""

from __future__ import annotations

import argparse
import platform
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from creatio.pipeline.run import run_study
from creatio.scenes import registry
from creatio.scenes.config import resolve, route
from creatio.scenes.needs import needs
from creatio.scenes.run import scene_dataset
from creatio.store.netcdf import write_dataset
from creatio.studies import registry as studies
from creatio.studies.schema import vary


def best(fn: Callable[[], object], repeats: int) -> tuple[float, object]:
    """(minimum wall time over repeats after one warm-up, the last result)."""
    result = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return min(times), result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None, help="also write the table here")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="creatio-costs-"))
    full: dict[str, dict] = {}  # study config sha -> its full run's figures
    rows = []
    for scene in (s.id for s in registry.SCENES.values() if s.reads is None):
        # (a scene that reads a study's dataset, EN-04's, computes nothing of its own)
        # the scene's own frames, without its family (scripts/bench_scene_family.py times it)
        r = resolve(scene, route(scene, ["scene.axes.sphere=null"])[0]
                    if "axes" in resolve(scene).data.get("scene", {}) else [])
        runs = needs(r)
        if not runs:
            t, ds = best(lambda r=r: scene_dataset(r), args.repeats)
            path = write_dataset(ds, tmp / f"{scene}.nc")
            rows.append([scene, "model formulas at the drawn points (no dynamics)", "-", "-",
                         f"{path.stat().st_size / 1e3:.0f} kB", f"{t:.3f}", "-", "-", "-"])
            continue
        for need in runs:
            base = r.bases[need.study]
            if base.sha256 not in full:
                entry = studies.get(need.study)
                parts = entry.parts(base.obj)

                def study_run(base=base, parts=parts):
                    return [write_dataset(run_study(base, p.name), tmp / f"{p.name}.nc")
                            for p in parts]

                t, paths = best(study_run, args.repeats)
                problem = base.obj.sphere_problem()
                rot, en = problem.rotation_integrated, bool(problem.output.energy)
                full[base.sha256] = {
                    "seconds": t, "paths": paths, "parts": len(parts),
                    "state": len(problem.initial_state(rot, en)),
                    "rows": round(base.obj.study.duration / base.obj.solver.output_interval) + 1,
                    "bytes": sum(p.stat().st_size for p in paths),
                }
        f = [full[r.bases[n.study].sha256] for n in runs]
        t_scene, ds = best(lambda r=r: scene_dataset(r, {}), args.repeats)
        reuse = {n.study: str(x["paths"][0]) for n, x in zip(runs, f, strict=True)}
        t_reuse, _ = best(lambda r=r, reuse=reuse: scene_dataset(r, reuse), args.repeats)
        path = write_dataset(ds, tmp / f"{scene}.nc")
        states = []
        for n in runs:
            problem = vary(r.bases[n.study].obj, n.changes()).sphere_problem()
            rot, en = problem.rotation_integrated, bool(problem.output.energy)
            states.append(len(problem.initial_state(rot, en)))
        what = "; ".join(
            f"{n.study}: 1 run at dt = {n.dt:g} s, {'+'.join(n.outputs)}"
            f"{'' if 'rotation' in n.outputs else ' (rotation by physics)'}, "
            f"{n.frames} frames every {n.interval:g} s, no energy, no dt/2 partner"
            for n in runs)
        t_full = sum(x["seconds"] for x in f)
        rows.append([
            scene, what,
            " + ".join(str(s) for s in states) + " / " + " + ".join(str(x["state"]) for x in f),
            f"{sum(n.frames for n in runs)} / "
            f"{sum(x['rows'] * x['parts'] for x in f)}",
            f"{path.stat().st_size / 1e3:.0f} kB / {sum(x['bytes'] for x in f) / 1e3:.0f} kB",
            f"{t_scene:.3f}", f"{t_reuse:.3f}", f"{t_full:.3f}",
            f"{t_full / t_scene:.1f}x",
        ])
    header = ["scene", "what the scene computes", "state size (scene / full)",
              "history rows (scene / full)", "dataset (scene / full)", "scene computed (s)",
              "scene reused (s)", "full study run (s)", "full / computed"]
    lines = [f"Measured in one process ({platform.processor() or platform.machine()}, "
             f"Python {platform.python_version()}), minimum of {args.repeats} after a "
             "warm-up. Full study run: every dataset part (dt and dt / 2), 0.1 s histories, "
             "rotation and energy, written to NetCDF.", "",
             "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
