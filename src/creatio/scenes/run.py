"""Build a scene: its dataset with provenance, its page, its animation and poster.

The steps the scene rules run (``creatio task scene dataset|page|media``), and all of them in
one process (:func:`build_scene`). Provenance is the pipeline's
(creatio.pipeline.provenance), for the
scene's resolved config, plus the config hash of every study it shows and where each run came
from (reused study dataset or computed here).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from creatio.pipeline.config import Resolved
from creatio.scenes.config import validate

__all__ = ["build_scene", "frames_dataset", "scene_dataset", "write_media", "write_page",
           "write_scene_dataset", "write_scene_frames"]

log = logging.getLogger("creatio")


def frames_dataset(resolved: Resolved, reuse: Mapping[str, str | Path] | None = None) -> Any:
    """The scene's own frames (what its animation draws: no family) with provenance
    attached: the config's hash, each study's, where each run came from."""
    from creatio.pipeline.provenance import provenance

    ds = resolved.entry.compute_function()(resolved, reuse or {})
    title = getattr(resolved.obj.scene, "title", "") or resolved.id
    attrs = provenance(resolved.id, resolved.yaml, resolved.sha256, title)
    attrs["references"] = f"CREATIO technical notebook, scene {resolved.id}"
    for name, base in resolved.bases.items():
        attrs[f"study_{name}_config_sha256"] = base.sha256
    attrs["subtitle"] = resolved.entry.description
    ds.attrs = {**attrs, **ds.attrs}
    return ds


def scene_dataset(resolved: Resolved, reuse: Mapping[str, str | Path] | None = None,
                  family: Sequence[str | Path] = (), store: str | Path | None = None,
                  frames: str | Path | None = None) -> Any:
    """The scene's dataset: its own frames (read from ``frames``, the workflow's frames.nc,
    else computed here) and its family when it declares axes: read from the ``family``
    batch files (the workflow's), else computed here, each member taken from or kept in
    ``store`` (creatio.scenes.family)."""
    from creatio.scenes.family import attach, compute_family, family_of

    ds = frames_dataset(resolved, reuse) if frames is None else _frames(resolved, frames)
    fam = family_of(resolved) if resolved.entry.kind.runs else None
    if fam is not None:
        members = compute_family(resolved, fam, family, store)
        ds = attach(ds, fam, members)
        log.info("scene %s: family of %d members (%d computed, %d reused, %d refused)",
                 resolved.id, fam.size, members.attrs["computed"], members.attrs["reused"],
                 members.attrs["refused"])
    return ds


def _frames(resolved: Resolved, path: str | Path) -> Any:
    """A frames dataset written for this very config (refused otherwise)."""
    from creatio.errors import ConfigError
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(path)
    if ds.attrs.get("config_sha256") != resolved.sha256:
        raise ConfigError("--frames", str(path), f"was computed for another config of scene "
                          f"{resolved.id}: rerun its frames job")
    return ds


def write_scene_frames(resolved: Resolved, out: str | Path,
                       reuse: Mapping[str, str | Path] | None = None) -> Path:
    """Compute the scene's own frames and write them atomically (``frames.nc``: what the
    animation draws, and what ``scene.nc`` adds the family to), while the family's batches
    compute."""
    from creatio.store.netcdf import write_dataset

    t0 = time.perf_counter()
    write_dataset(frames_dataset(resolved, reuse), out)
    log.info("scene %s: wrote %s in %.2f s", resolved.id, out, time.perf_counter() - t0)
    return Path(out)


def write_scene_dataset(resolved: Resolved, out: str | Path,
                        reuse: Mapping[str, str | Path] | None = None,
                        family: Sequence[str | Path] = (),
                        store: str | Path | None = None,
                        frames: str | Path | None = None) -> Path:
    """Compute (or read) the scene's data and write ``scene.nc`` atomically."""
    from creatio.store.netcdf import write_dataset

    t0 = time.perf_counter()
    ds = scene_dataset(resolved, reuse, family, store, frames)
    write_dataset(ds, out)
    log.info("scene %s: wrote %s in %.2f s", resolved.id, out, time.perf_counter() - t0)
    return Path(out)


def _read(path: str | Path) -> tuple[Any, Resolved]:
    """A scene dataset and the resolved config recorded in it (validated again, but its
    family, already in the dataset, not planned again)."""
    from creatio.store.netcdf import read_dataset
    from creatio.store.yamlio import load_yaml

    ds, _ = read_dataset(path)
    return ds, validate(load_yaml(ds.attrs["config_yaml"]), family=False)


def write_page(dataset: str | Path, out: str | Path, library: str | Path) -> Path:
    """``index.html`` from ``scene.nc`` and the three.js bundle."""
    from creatio.scenes import page

    ds, _ = _read(dataset)
    path = page.write_page(ds, out, library)
    log.info("scene %s: page %s (%.2f MB)", ds.attrs["scene"], path, path.stat().st_size / 1e6)
    return path


def write_media(dataset: str | Path, animation: str | Path, poster: str | Path) -> None:
    """The animated WebP and the poster PNG of a scene, from its frames (``frames.nc``, or
    ``scene.nc``, which holds them too)."""
    ds, resolved = _read(dataset)
    t0 = time.perf_counter()
    resolved.entry.media_function()(ds, resolved.obj, Path(animation), Path(poster))
    log.info("scene %s: %s, %s in %.1f s", resolved.id, animation, poster,
             time.perf_counter() - t0)


def build_scene(resolved: Resolved, outdir: str | Path, library: str | Path,
                reuse: Mapping[str, str | Path] | None = None,
                store: str | Path | None = None) -> dict[str, Path]:
    """Every file of one scene into ``outdir`` (what the scene rules do, in one process;
    a family's members taken from or kept in ``store``)."""
    outdir = Path(outdir)
    paths = {name: outdir / name for name in ("scene.nc", "index.html", "animation.webp",
                                              "poster.png")}
    frames = write_scene_frames(resolved, outdir / "frames.nc", reuse)
    try:
        write_scene_dataset(resolved, paths["scene.nc"], store=store, frames=frames)
        write_page(paths["scene.nc"], paths["index.html"], library)
        write_media(frames, paths["animation.webp"], paths["poster.png"])
    finally:
        frames.unlink(missing_ok=True)
    return paths
