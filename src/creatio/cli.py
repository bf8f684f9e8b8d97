"""`creatio` command line: Hydra apps for users, plain tasks for the Snakemake rules.

    creatio run [study=ID] [KEY=VALUE ...]       run one study (a Hydra app: --help, --cfg job)
    creatio probe [alpha=DEG R=R t=T KEY=VALUE]  surface quantities at one point (Hydra app)
    creatio release VERSION | verify | list     freeze the default outputs into data/releases/
    creatio diff A B                             compare datasets, directories or releases
    creatio task dataset|report|sweep|compare    one workflow step (used by the Snakefile)
    creatio benchmark|stability|boundaries OUT   work-precision, stability map, physics limits
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from creatio.config import (
    CONF_DIR,
    DYNAMIC,
    STUDIES,
    ConfigError,
    Resolved,
    dataset_path,
    output_root,
    resolve,
    validate,
)

log = logging.getLogger("creatio")

#: Commands backed by an analysis module's main(argv).
ANALYSES = {
    "benchmark": "creatio.benchmarks",
    "stability": "creatio.stability",
    "boundaries": "creatio.boundaries",
}

USAGE = """usage: creatio COMMAND [ARGS]

commands:
  run     run one study and write its datasets and report (Hydra app)
            creatio run study=en02 sphere.mu=0.3      creatio run --help
            creatio run -m study=en02 sphere.mu=0,0.15,0.3   (a sweep, then its aggregate)
  probe   position, velocity, normal and J at one surface point (Hydra app)
            creatio probe alpha=30 R=0.5 t=1.0 phases.gamma.phi0=45 phases.gamma.unit=deg
  release make, verify or list versioned releases of the default outputs
            creatio release 0.2.0    creatio release verify latest    creatio release list
  diff    compare datasets, data directories or releases (exit 0 same, 1 differs, 2 error)
            creatio diff latest data    creatio diff 0.1.0 0.2.0 --json    creatio diff --help
  benchmark   work-precision benchmark of the integrators (EN-02, EN-02R)
            creatio benchmark data/benchmarks [--studies en02] [--repeats 5] [--quick]
  stability   where each explicit scheme breaks over (mu, dt) and (eps, dt)
            creatio stability data/benchmarks
  boundaries  push EN-02 along T, A, b, gamma, mu until the model's assumptions fail
            creatio boundaries data/benchmarks [--axes T,A]
  task    one workflow step, as the Snakefile calls it
            creatio task dataset ct02 OUT.nc [--dt DT] [--override K=V ...]
            creatio task report ct02 OUTDIR DATASET.nc [DATASET.nc ...]
            creatio task compare OUTDIR EN02.nc EN02R.nc

Studies: {studies}. Configs live in {conf}.
"""


# ------------------------------------------------------------------------------ study work
def compute_dataset(resolved: Resolved, out: Path, dt: float | None = None) -> Path:
    """Run one study (at dt for a dynamic one) and write its dataset atomically."""
    from creatio.io import write_dataset
    from creatio.studies import run_study

    t0 = time.perf_counter()
    ds = run_study(resolved, dt=dt)
    write_dataset(ds, out)
    status = ds.attrs.get("status")
    log.info("%s%s: wrote %s in %.2f s%s", resolved.study, f" dt={dt:g}" if dt else "", out,
             time.perf_counter() - t0, f" (status {status})" if status else "")
    return out


def write_report(study: str, outdir: Path, datasets: Sequence[Path]) -> None:
    """Derive a study's report files from its dataset(s)."""
    from creatio import reports

    if study in DYNAMIC:
        paths = reports.write_dynamic_report([Path(p) for p in datasets], outdir)
    else:
        paths = reports.write_kinematic_report(datasets[0], outdir)
    log.info("%s: report %s", study, ", ".join(str(p) for p in paths.values()))


def run_resolved(resolved: Resolved, data_dir: Path = Path("data")) -> Path:
    """Everything `snakemake all` does for one study, in this process."""
    root = output_root(resolved, data_dir)
    if root != data_dir:
        log.info("%s: overridden config %s -> %s", resolved.study, resolved.key, root)
    if resolved.study in DYNAMIC:
        dts = resolved.obj.solver.timesteps()
        outs = [compute_dataset(resolved, dataset_path(root, resolved.study, dt), dt)
                for dt in dts]
    else:
        outs = [compute_dataset(resolved, dataset_path(root, resolved.study))]
    write_report(resolved.study, root / "reports", outs)
    return root


# ------------------------------------------------------------------------------ hydra apps
def _hydra_app(config_name: str, task) -> None:
    import hydra

    from creatio.config import _register_schemas

    _register_schemas()
    hydra.main(config_path=str(CONF_DIR), config_name=config_name, version_base="1.3")(task)()


def _run_task(cfg) -> None:
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    try:
        resolved = validate(cfg)
    except ConfigError as e:
        if HydraConfig.get().mode == RunMode.MULTIRUN:  # one refused point: record, go on
            log.warning("creatio run: point refused: %s", e)
            return
        print(f"creatio run: {e}", file=sys.stderr)
        sys.exit(2)
    run_resolved(resolved)


def _aggregate_multirun(args: Sequence[str]) -> None:
    """After `creatio run -m`, aggregate the points exactly as `snakemake sweep` does."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    from creatio.sweep import plan_sweep, write_sweep

    items = [a for a in args if not a.startswith("-") and not a.startswith("hydra")]
    parsed = OverridesParser.create().parse_overrides(items)
    study = next((o.get_value_element_as_str() for o in parsed if o.get_key_element() == "study"),
                 "ct02")
    sweep = [a for a, o in zip(items, parsed, strict=True) if o.is_sweep_override()]
    base = [a for a, o in zip(items, parsed, strict=True)
            if not o.is_sweep_override() and o.get_key_element() != "study"]
    if sweep:
        paths = write_sweep(plan_sweep(study, sweep, base))
        log.info("sweep aggregate: %s", ", ".join(str(p) for p in paths.values()))


def _probe_task(cfg) -> None:
    import numpy as np

    from creatio.config import ProbeConfig
    from creatio.geometry import Frame, Motion

    try:
        p = validate(cfg, schema=ProbeConfig).obj
    except ConfigError as e:
        print(f"creatio probe: {e}", file=sys.stderr)
        sys.exit(2)
    surface = p.geometry.surface()
    motion = Motion(*p.phases.laws())
    fr = Frame(surface, motion, np.deg2rad(p.alpha), p.R, p.t)
    pr, pa, gm = motion.at(p.t)
    vel = fr.c_t
    rows = [
        ("point", f"alpha = {p.alpha:g} deg, R = {p.R:g}, t = {p.t:g} s"),
        ("phases", f"phi_r = {float(pr.value):.6g} rad, phi_a = {float(pa.value):.6g} rad, "
                   f"gamma = {np.rad2deg(float(gm.value)):.6g} deg"),
        ("position c", _vec(fr.position)),
        ("velocity c_t", _vec(vel)),
        ("|velocity|", f"{float(np.linalg.norm(vel)):.9g}"),
        ("unit normal n", _vec(fr.normal)),
        ("J", f"{float(fr.J):.9g}"),
    ]
    if not 0.0 <= p.R <= surface.dR:
        rows.append(("note", f"R = {p.R:g} lies outside [0, dR = {surface.dR:g}]: "
                             "the formula is extended beyond the annulus"))
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"{k:<{width}}  {v}" for k, v in rows))


def _vec(v) -> str:
    return "(" + ", ".join(f"{float(x): .9f}" for x in v) + ")"


def _prevalidate(study_args: Sequence[str], config_name: str) -> None:
    """Refuse bad overrides with creatio's own message before Hydra starts."""
    if any(a.startswith("-") for a in study_args):  # --help, --cfg, -m: Hydra's business
        return
    overrides = [a for a in study_args if not a.startswith("hydra")]
    try:
        if config_name == "probe":
            from creatio.config import ProbeConfig, compose, override_error

            try:
                cfg = compose("", overrides, config_name="probe")
            except Exception as e:  # noqa: BLE001 - Hydra override refusal: name the key
                raise override_error("", overrides, e, config_name="probe") from None
            validate(cfg, schema=ProbeConfig)
        else:
            study = next((a.split("=", 1)[1] for a in overrides if a.startswith("study=")),
                         "ct02")
            resolve(study, [a for a in overrides if not a.startswith("study=")])
    except ConfigError as e:
        print(f"creatio {'probe' if config_name == 'probe' else 'run'}: {e}", file=sys.stderr)
        sys.exit(2)


# ------------------------------------------------------------------------------ tasks
def _task(argv: Sequence[str]) -> int:
    ap = argparse.ArgumentParser(prog="creatio task", description="One workflow step.")
    sub = ap.add_subparsers(dest="step", required=True)
    d = sub.add_parser("dataset", help="compute one study dataset")
    d.add_argument("study", choices=STUDIES)
    d.add_argument("out", type=Path)
    d.add_argument("--dt", type=float, default=None, help="timestep of a dynamic study (s)")
    d.add_argument("--override", action="append", default=[], metavar="KEY=VALUE")
    d.add_argument("--config-file", type=Path, default=None,
                   help="a resolved config (YAML file) to run instead of composing conf/")
    d.add_argument("--config-yaml", default=None,
                   help="the same, as YAML text (what the Snakefile passes)")
    r = sub.add_parser("report", help="derive a study's report from its datasets")
    r.add_argument("study", choices=STUDIES)
    r.add_argument("outdir", type=Path)
    r.add_argument("datasets", type=Path, nargs="+")
    w = sub.add_parser("sweep", help="aggregate a sweep's point datasets")
    w.add_argument("--study", required=True, choices=STUDIES)
    w.add_argument("--sweep", action="append", required=True, metavar="KEY=V1,V2,...")
    w.add_argument("--override", action="append", default=[], metavar="KEY=VALUE")
    c = sub.add_parser("compare", help="EN-02 vs EN-02R comparison from both datasets")
    c.add_argument("outdir", type=Path)
    c.add_argument("datasets", type=Path, nargs=2)
    args = ap.parse_args(argv)
    try:
        if args.step == "dataset":
            resolved = _task_config(args)
            if args.dt is not None and resolved.study in DYNAMIC:
                dts = resolved.obj.solver.timesteps()
                if not any(abs(args.dt - d) <= 1e-12 * d for d in dts):
                    raise ConfigError("--dt", args.dt, f"must be one of the config's timesteps "
                                      f"{dts} (solver.dt and solver.dt / solver.refine)")
            compute_dataset(resolved, args.out, args.dt)
        elif args.step == "sweep":
            from creatio.sweep import plan_sweep, write_sweep

            paths = write_sweep(plan_sweep(args.study, args.sweep, args.override))
            log.info("sweep: %s", ", ".join(str(p) for p in paths.values()))
        elif args.step == "report":
            write_report(args.study, args.outdir, args.datasets)
        else:
            from creatio.reports import write_comparison

            paths = write_comparison(args.datasets, args.outdir)
            log.info("comparison: %s", ", ".join(str(p) for p in paths.values()))
    except ConfigError as e:
        print(f"creatio task: {e}", file=sys.stderr)
        return 2
    return 0


def _task_config(args: argparse.Namespace) -> Resolved:
    """The resolved config of a task: a config file, or conf/ with overrides."""
    text = args.config_file.read_text() if args.config_file else args.config_yaml
    if text is None:
        return resolve(args.study, args.override)
    import yaml

    if args.override:
        raise ConfigError("--override", args.override, "cannot be combined with a config")
    resolved = validate(yaml.safe_load(text))
    if resolved.study != args.study:
        raise ConfigError("--config-file", str(args.config_file or "--config-yaml"),
                          f"holds study {resolved.study}, not {args.study}")
    return resolved


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `creatio` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(USAGE.format(studies=", ".join(STUDIES), conf=CONF_DIR))
        return 0
    command, rest = argv[0], argv[1:]
    if command in ("run", "probe"):
        config_name = "config" if command == "run" else "probe"
        _prevalidate(rest, config_name)
        sys.argv = [f"creatio {command}", *rest]
        _hydra_app(config_name, _run_task if command == "run" else _probe_task)
        if command == "run" and ("-m" in rest or "--multirun" in rest):
            _aggregate_multirun(rest)
        return 0
    if command == "task":
        return _task(rest)
    if command in ANALYSES:
        import importlib

        return importlib.import_module(ANALYSES[command]).main(rest)
    if command == "release":
        from creatio.release import main as release_main

        return release_main(rest)
    if command == "diff":
        from creatio.diff import main as diff_main

        return diff_main(rest)
    print(f"creatio: unknown command {command!r}\n", file=sys.stderr)
    print(USAGE.format(studies=", ".join(STUDIES), conf=CONF_DIR), file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
