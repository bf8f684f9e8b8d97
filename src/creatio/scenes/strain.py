"""Strain scenes: a sphere scene whose membrane is coloured by the strain its shape demands.

The dataset is a sphere scene's (creatio.scenes.compute.sphere_scene: the runs' frames) plus
``strain`` per run, frame and mesh vertex: the largest principal Green-Lagrange strain of the
face of a sheet of ``scene.strain.thickness`` (the mid-surface's at h = 0), from
creatio.model.strain at the very vertices the page draws (alpha_i = 2 pi i / (n_alpha - 1),
R_j = dR j / (n_R - 1)) and the frame times, on each run's own surface and phase laws. The
membrane moves with the phases whatever the sphere does, so every frame has its strain, after
a run's end too. The legend's range is the data's, rounded outward to a round step (from 0
when no strain is negative); its colours are the dataset's own (``strain_colours``), which
the page and the animation both use.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from creatio.model.strain import strains
from creatio.model.surface import Motion

__all__ = ["STRAIN_COLOURS", "legend_range", "mesh_coordinates", "strain_frames",
           "strain_media", "strain_scene", "with_strain"]

Array = NDArray[np.float64]

#: The legend's colours from its low end to its high end (RGB in [0, 1]): light grey for no
#: strain through yellow and orange to dark red; distinct from the trace's viridis.
STRAIN_COLOURS = ((0.90, 0.91, 0.92), (0.99, 0.87, 0.45), (0.99, 0.55, 0.24),
                  (0.85, 0.16, 0.12), (0.45, 0.0, 0.10))

#: Frames evaluated at once (each holds a few tens of float64 fields of the mesh's size).
_FRAMES_PER_BLOCK = 16


def mesh_coordinates(n_alpha: int, n_R: int, dR: float) -> tuple[Array, Array]:
    """The alpha (rad) and R (m) of the page's mesh vertices: alpha_i = 2 pi i / (n_alpha - 1),
    R_j = dR j / (n_R - 1) (the closing column repeats alpha = 0 as 2 pi)."""
    return (2.0 * math.pi * np.arange(n_alpha) / (n_alpha - 1),
            dR * np.arange(n_R) / (n_R - 1))


def strain_frames(base: Any, alpha: Array, R: Array, times: Array, thickness: float) -> Array:
    """(frame, alpha, R) largest principal face strain of a study config's surface under its
    phase laws at a sheet thickness (the mid-surface's at 0), from creatio.model.strain."""
    surface = base.geometry.surface()
    motion = Motion(*base.phases.laws())
    out = np.empty((times.size, alpha.size, R.size))
    for start in range(0, times.size, _FRAMES_PER_BLOCK):
        tt = times[start:start + _FRAMES_PER_BLOCK]
        st = strains(surface, motion, alpha[None, :, None], R[None, None, :],
                     tt[:, None, None], thickness)
        out[start:start + tt.size] = np.broadcast_to(st.largest_face(),
                                                     (tt.size, alpha.size, R.size))
    return out


def _step(span: float) -> float:
    """A round step (1, 2, 2.5 or 5 x 10^k) giving about five legend intervals over span."""
    raw = span / 5.0
    p = 10.0 ** math.floor(math.log10(raw))
    return next(m * p for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * p >= raw * (1 - 1e-12))


def legend_range(values: Array) -> tuple[float, float, list[float]]:
    """(low, high, ticks) of a legend covering every finite value: the data's range rounded
    outward to a round step, from 0 when no value is negative."""
    finite = values[np.isfinite(values)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    lo = min(lo, 0.0)
    span = hi - lo
    if span <= 0.0:
        span = max(abs(hi), 1e-6)
    step = _step(span)
    low = math.floor(lo / step) * step
    high = math.ceil(hi / step) * step
    if high <= low:
        high = low + step
    n = round((high - low) / step)
    ticks = [float(f"{low + k * step:.12g}") for k in range(n + 1)]
    return float(f"{low:.12g}"), float(f"{high:.12g}"), ticks


def with_strain(ds: xr.Dataset, obj: Any) -> xr.Dataset:
    """A sphere scene's dataset with its runs' strain at the mesh vertices and frame times,
    and the legend (range, ticks, colours, label) as attributes."""
    s = obj.scene
    h = float(s.strain.thickness)
    times = ds.time.values.astype(float)
    fields, alphas, radii = [], None, None
    for name in [str(r) for r in ds.run.values]:
        base = obj.bases[name]
        alpha, R = mesh_coordinates(s.mesh.n_alpha, s.mesh.n_R, base.geometry.dR)
        if radii is not None and not np.array_equal(R, radii):
            raise ValueError("the runs of a strain scene must share the membrane's width dR "
                             "(one mesh for all)")
        alphas, radii = alpha, R
        fields.append(strain_frames(base, alpha, R, times, h))
    values = np.stack(fields)
    low, high, ticks = legend_range(values)
    where = "the mid-surface" if h == 0.0 else f"the sheet's faces (h = {h:g} m)"
    label = f"largest principal Green-Lagrange strain of {where}"
    out = ds.assign_coords(mesh_alpha=("mesh_alpha", alphas, {"long_name": "alpha of the "
                                                              "mesh vertices", "units": "rad"}),
                           mesh_R=("mesh_R", radii, {"long_name": "R of the mesh vertices",
                                                     "units": "m"}))
    out["strain"] = (("run", "frame", "mesh_alpha", "mesh_R"), values, {
        "long_name": label, "units": "1", "legend_range": [low, high],
        "comment": "creatio.model.strain at each mesh vertex and frame time; reference: the "
                   "same surface without corrugation (A = 0); material coordinates"})
    out.attrs.update({
        "strain_legend": json.dumps([low, high]),
        "strain_ticks": json.dumps(ticks),
        "strain_colours": json.dumps([list(c) for c in STRAIN_COLOURS]),
        "strain_label": label,
        "strain_thickness": h,
        "strain_max": float(np.nanmax(values)),
        "strain_min": float(np.nanmin(values)),
    })
    return out


def strain_scene(resolved: Any, reuse: Mapping[str, str | Path] | None = None) -> xr.Dataset:
    """The dataset of a strain scene: the sphere scene's runs plus their strain."""
    from creatio.scenes.compute import sphere_scene

    return with_strain(sphere_scene(resolved, reuse), resolved.obj)


def strain_media(ds: xr.Dataset, cfg: Any, animation: Path, poster: Path) -> None:
    """Animation and poster of a strain scene: the sphere scene's, with the membrane coloured
    by its strain (evaluated on the animation's own mesh) and a colour bar in percent."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LinearSegmentedColormap, Normalize

    from creatio.scenes.media import sphere_media

    low, high = json.loads(str(ds.attrs["strain_legend"]))
    ticks = json.loads(str(ds.attrs["strain_ticks"]))
    colours = [tuple(c) for c in json.loads(str(ds.attrs["strain_colours"]))]
    cmap = LinearSegmentedColormap.from_list("creatio_strain", colours)
    norm = Normalize(low, high)
    h = float(ds.attrs["strain_thickness"])
    runs = [str(r) for r in ds.run.values]
    times = ds.time.values.astype(float)

    def paint(r: int, i: int, alpha: Array, R: Array) -> Array:
        values = strain_frames(cfg.bases[runs[r]], alpha, R, times[i:i + 1], h)[0]
        return cmap(norm(values))

    def legend(fig: Any) -> None:
        cax = fig.add_axes((0.91, 0.18, 0.016, 0.55))
        bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=cax, ticks=ticks)
        bar.ax.set_yticklabels([f"{100 * t:g} %" for t in ticks], fontsize=7)
        bar.set_label("strain (%)", fontsize=7.5)

    sphere_media(ds, cfg, animation, poster, paint=paint, legend=legend)
