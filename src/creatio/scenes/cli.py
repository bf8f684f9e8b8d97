"""`creatio task scene ...`: the steps of the scene rules (workflows/rules/scenes.smk).

    creatio task scene library OUT.js                       bundle three.js (npm ci + esbuild)
    creatio task scene frames SCENE OUT.nc [--config-file F | --config-yaml Y | --override K=V]
                                            [--reuse STUDY=DATASET.nc ...]
    creatio task scene dataset SCENE OUT.nc [--config-file F | --config-yaml Y | --override K=V]
                                            [--reuse STUDY=DATASET.nc ... | --frames F.nc]
                                            [--family BATCH.nc ...] [--store DIR]
    creatio task scene family-batch SCENE OUT.nc --batch K [--batch-size N] [--store DIR]
                                            [--config-file F | --config-yaml Y | --override K=V]
    creatio task scene page SCENE.nc LIBRARY.js OUT.html
    creatio task scene media FRAMES.nc ANIMATION.webp POSTER.png   (or SCENE.nc)
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from creatio.errors import ConfigError, Parser

__all__ = ["main"]


def main(argv: Sequence[str]) -> int:
    """Run one scene step; 2 on a refused config, 1 on a failed build."""
    from creatio.scenes import registry

    ap = Parser(prog="creatio task scene", description="One scene step.")
    sub = ap.add_subparsers(dest="step", required=True)
    lib = sub.add_parser("library", help="bundle the pages' three.js (needs Node.js and npm)")
    lib.add_argument("out", type=Path)
    fr = sub.add_parser("frames", help="compute a scene's own frames (what its animation "
                        "draws, without the family): frames.nc")
    d = sub.add_parser("dataset", help="compute (or read) a scene's data: scene.nc")
    for q in (fr, d):
        q.add_argument("scene", choices=list(registry.SCENES))
        q.add_argument("out", type=Path)
        q.add_argument("--config-yaml", default=None, help="the resolved scene config (YAML)")
        q.add_argument("--config-file", type=Path, default=None,
                       help="a file holding the resolved scene config (the workflow's)")
        q.add_argument("--override", action="append", default=[], metavar="KEY=VALUE",
                       help="a Hydra override, routed to the scene (sphere.mu reaches its "
                       "bases)")
        q.add_argument("--reuse", action="append", default=[], metavar="STUDY=DATASET",
                       help="read a study's frames from its own dataset instead of computing")
    d.add_argument("--frames", type=Path, default=None,
                   help="the scene's own frames, written by `frames` (else computed here)")
    d.add_argument("--family", nargs="*", default=[], type=Path, metavar="BATCH",
                   help="the family's batch files (else the family is computed here)")
    d.add_argument("--store", type=Path, default=None,
                   help="where computed family members are kept and looked up")
    f = sub.add_parser("family-batch", help="compute one batch of an explorable scene's family")
    f.add_argument("scene", choices=list(registry.SCENES))
    f.add_argument("out", type=Path)
    f.add_argument("--batch", type=int, required=True, help="the batch's number, from 0")
    f.add_argument("--batch-size", type=int, default=None,
                   help="members per batch (the family's own batching by default)")
    f.add_argument("--store", type=Path, default=None,
                   help="where computed family members are kept and looked up")
    for q in (f,):
        q.add_argument("--config-yaml", default=None, help="the resolved scene config (YAML)")
        q.add_argument("--config-file", type=Path, default=None,
                       help="a file holding the resolved scene config (the workflow's)")
        q.add_argument("--override", action="append", default=[], metavar="KEY=VALUE",
                       help="a Hydra override, routed to the scene")
    p = sub.add_parser("page", help="write index.html from scene.nc")
    p.add_argument("dataset", type=Path)
    p.add_argument("library", type=Path)
    p.add_argument("out", type=Path)
    m = sub.add_parser("media", help="write the animated WebP and the poster PNG")
    m.add_argument("dataset", type=Path, help="frames.nc (or scene.nc)")
    m.add_argument("animation", type=Path)
    m.add_argument("poster", type=Path)
    args = ap.parse_args(argv)
    try:
        if args.step == "library":
            from creatio.scenes.assets import build_library

            build_library(args.out)
        elif args.step == "frames":
            from creatio.scenes.run import write_scene_frames

            write_scene_frames(_config(args), args.out, dict(_pair(r) for r in args.reuse))
        elif args.step == "dataset":
            from creatio.scenes.run import write_scene_dataset

            if args.frames is not None and args.reuse:
                raise ConfigError("--reuse", args.reuse, "the frames given (--frames) were "
                                  "computed with their own reused datasets")
            write_scene_dataset(_config(args), args.out, dict(_pair(r) for r in args.reuse),
                                args.family, args.store, args.frames)
        elif args.step == "family-batch":
            _family_batch(args)
        elif args.step == "page":
            from creatio.scenes.run import write_page

            write_page(args.dataset, args.out, args.library)
        else:
            from creatio.scenes.run import write_media

            write_media(args.dataset, args.animation, args.poster)
    except ConfigError as e:
        print(f"creatio task scene: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:
        print(f"creatio task scene: {e}", file=sys.stderr)
        return 1
    return 0


def _family_batch(args: argparse.Namespace) -> None:
    """One batch of a family, named as the workflow names it (its size is the plan's)."""
    from creatio.scenes.family import family_of, run_batch

    resolved = _config(args)
    family = family_of(resolved) if resolved.entry.kind.runs else None
    if family is None:
        raise ConfigError("scene.axes", {}, f"scene {resolved.id} declares no axis: it "
                          "has no family to compute")
    if args.batch_size is not None and args.batch_size != family.batch_size:
        raise ConfigError("--batch-size", args.batch_size, f"the family of {family.size} "
                          f"members is cut into batches of {family.batch_size}")
    if not 0 <= args.batch < family.n_batches:
        raise ConfigError("--batch", args.batch, f"must lie in [0, {family.n_batches - 1}]")
    run_batch(resolved, family, args.batch, args.out, args.store,
              progress=lambda text: print(text, file=sys.stderr))


def _pair(text: str) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    if not sep or not key or not value:
        raise ConfigError("--reuse", text, "must be STUDY=DATASET")
    return key, value


def _config(args: argparse.Namespace):
    """The resolved scene config: YAML text, or conf/ with routed overrides."""
    from creatio.scenes.config import resolve, route, validate

    if args.config_file is not None:
        from creatio.store.regular import read_text

        args.config_yaml = read_text(args.config_file)
    if args.config_yaml is None:
        routed, used = route(args.scene, args.override)
        unused = [o for o in args.override if o not in used]
        if unused:
            raise ConfigError("--override", unused, f"scene {args.scene} has no such key")
        return resolve(args.scene, routed)
    if args.override:
        raise ConfigError("--override", args.override, "cannot be combined with a config")
    from creatio.store.yamlio import load_yaml

    resolved = validate(load_yaml(args.config_yaml))
    if resolved.id != args.scene:
        raise ConfigError("--config-yaml", resolved.id, f"is not scene {args.scene}")
    return resolved
