"""A scene's ``index.html``: one self-contained file that opens offline.

The page is the template ``web/page.html`` with everything inline: the style, the three.js
bundle (:mod:`creatio.scenes.assets`), the viewer script and the scene's dataset as JSON
(numeric arrays as base64 little-endian float64, so the page draws the dataset's own
numbers). No request leaves the page: no CDN, no server, no font download.
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

import creatio
from creatio.scenes.assets import web_file
from creatio.scenes.family import MAX_BYTES
from creatio.store.atomic import atomic_save

__all__ = ["MAX_BYTES", "family_data", "fill", "page_data", "write_page"]


#: The angles the page evaluates the surface with, c(alpha, R) in radians (viewer.js): the
#: dataset states them in degree (docs/datasets.md), the page's JSON carries them in rad.
PAGE_RADIANS = ("phase_r", "phase_a", "inclination")

#: Dataset attributes the page needs (provenance is shown in the footer instead).
PAGE_ATTRS = ("kind", "scene", "frame_interval", "playback_speed", "playback_fps", "draw",
              "readouts", "mesh", "time", "alpha_deg", "R", "normal_length", "velocity_scale",
              "magnification", "R0", "dR", "A", "Kr", "Ka", "strain_legend", "strain_ticks",
              "strain_colours", "strain_label", "strain_thickness")

#: Levels of an array sent as 16-bit codes over its ``legend_range`` (the strain field of a
#: strain scene, a value per vertex and frame): the page decodes low + code (high - low) /
#: CODES, within (high - low) / (2 CODES) of the dataset's value, a quarter of float64's size;
#: the code CODES + 1 is NaN (frames past the scene's own span, padded for a longer member).
CODES = 65534


def _attr(value: Any) -> Any:
    if isinstance(value, str) and value[:1] in "[{":
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def _array(values: Any) -> dict[str, Any]:
    """A numeric array as the viewer decodes it: shape and base64 little-endian float64."""
    values = np.ascontiguousarray(values, dtype="<f8")
    return {"shape": list(values.shape),
            "b64": base64.b64encode(values.tobytes()).decode("ascii")}


def _coded(values: Any, legend_range: Any) -> dict[str, Any]:
    """An array as 16-bit codes over [low, high] (little-endian uint16, base64), which the
    viewer decodes to low + code (high - low) / CODES, NaN as CODES + 1; every other value
    must lie in the range."""
    low, high = (float(x) for x in np.asarray(_attr(legend_range), float).ravel())
    values = np.asarray(values, float)
    finite = values[~np.isnan(values)]
    if finite.size and not (finite.min() >= low and finite.max() <= high):
        raise ValueError(f"values outside their legend_range [{low}, {high}]")
    scaled = np.rint((np.nan_to_num(values, nan=low) - low) / (high - low) * CODES)
    codes = np.where(np.isnan(values), CODES + 1, scaled).astype("<u2")
    return {"shape": list(values.shape), "low": low, "high": high,
            "u16": base64.b64encode(np.ascontiguousarray(codes).tobytes()).decode("ascii")}


def _finite(values: Any) -> Any:
    """Nested lists with NaN as None (JSON has no NaN)."""
    return [_finite(v) for v in values] if isinstance(values, list) else (
        values if isinstance(values, str) or math.isfinite(values) else None)


def page_data(ds: xr.Dataset) -> dict[str, Any]:
    """The JSON the viewer reads: kind, attributes, coordinates, arrays, labels and units,
    and the family of an explorable scene (:func:`family_data`)."""
    arrays, strings, labels, units = {}, {}, {}, {}
    for name, var in {**ds.coords, **ds.data_vars}.items():
        if str(name).startswith("family_"):
            continue
        radians = (name in PAGE_RADIANS and name in ds.data_vars
                   and var.attrs.get("units") in ("degree", "deg"))
        if var.dtype.kind in "fiub" and "legend_range" in var.attrs and var.ndim >= 3:
            arrays[name] = _coded(var.values, var.attrs["legend_range"])
        elif var.dtype.kind in "fiub":
            arrays[name] = _array(np.radians(var.values) if radians else var.values)
        else:
            strings[name] = [str(v) for v in np.atleast_1d(var.values)]
        if "long_name" in var.attrs:
            labels[name] = str(var.attrs["long_name"])
        if "units" in var.attrs:
            units[name] = "rad" if radians else str(var.attrs["units"]).replace("degree", "deg")
    attrs = {k: _attr(ds.attrs[k]) for k in PAGE_ATTRS if k in ds.attrs}
    coords = {name: strings[name] for name in ("run", "mode") if name in strings}
    out = {"kind": attrs["kind"], "attrs": attrs, "coords": coords, "arrays": arrays,
           "strings": strings, "labels": labels, "units": units}
    if "family_axes" in ds.attrs:
        out["family"] = family_data(ds)
    return out


def family_data(ds: xr.Dataset) -> dict[str, Any]:
    """The family of an explorable scene as the viewer reads it: the axes, per member its
    status, reason refused and headline figures, and the frames of the members that ran
    (packed: ``rows`` maps a member to its row, -1 for a refused one)."""
    status = ds["family_status"].values
    ran = ~np.all(status == "refused", axis=1)
    rows = np.cumsum(ran) - 1
    figures = json.loads(str(ds.attrs["family_figures"]))
    per_run = {"frames_run", "sphere_radius", "R0", "dR", "A", "Kr", "Ka", "skin_c", "skin_s"}
    arrays = {}
    for name, var in ds.data_vars.items():
        short = str(name).removeprefix("family_")
        if str(name).startswith("family_") and ("frame" in var.dims or short in per_run):
            values = var.values[ran]
            if short in PAGE_RADIANS and var.attrs.get("units") in ("degree", "deg"):
                values = np.radians(values)  # as the scene's own phases (PAGE_RADIANS)
            arrays[short] = _array(values)
    return {
        "axes": json.loads(str(ds.attrs["family_axes"])),
        "base": int(ds.attrs["family_base_member"]),
        "size": int(ds.sizes["member"]),
        "rows": [int(r) if ok else -1 for r, ok in zip(rows, ran, strict=True)],
        "status": status.tolist(),
        "message": [str(m) for m in ds["family_message"].values],
        "direction": [[str(d) for d in row] for row in ds["family_direction"].values],
        "figures": {name: {"label": label, "unit": unit, "meaning": meaning,
                           "values": _finite(ds[f"family_{name}"].values.tolist())}
                    for name, (label, unit, meaning) in figures.items()},
        "arrays": arrays,
    }


def _provenance(ds: xr.Dataset, library_sha: str) -> str:
    a = ds.attrs
    dirty = " (dirty)" if int(a.get("git_dirty", 0)) else ""
    return html.escape(
        f"scene {a.get('scene')} · config sha256 {str(a.get('config_sha256', ''))[:12]} · "
        f"creatio {a.get('creatio_version')} · commit {str(a.get('git_commit', ''))[:10]}"
        f"{dirty} · created {a.get('date_created')} · three.js bundle sha256 "
        f"{library_sha[:12]}")


def fill(template: str, slots: dict[str, str]) -> str:
    """The template with each ``{{NAME}}`` replaced by its slot, in one pass over the
    template only: text put into a slot (a title, the data, the bundle) is never read for
    slots again, so a title holding ``{{THREE}}`` stays that text. An unknown slot name is
    an error of the template."""
    def slot(m: re.Match) -> str:
        return slots[m.group(1)]

    return re.sub(r"\{\{([A-Z_]+)\}\}", slot, template)


def write_page(ds: xr.Dataset, out: str | Path, library: str | Path) -> Path:
    """Write the scene's page to ``out`` from its dataset and the three.js bundle."""
    from creatio.scenes.assets import digest

    out = Path(out)
    lib_text = Path(library).read_text(encoding="utf-8")
    revision = re.search(r'REVISION:\(\)=>(\w+)', lib_text)
    rev = ""
    if revision:
        value = re.search(rf'\b{revision.group(1)}="(\d+)"', lib_text)
        rev = value.group(1) if value else ""
    data = json.dumps(page_data(ds), separators=(",", ":"), allow_nan=False
                      ).replace("</", "<\\/")
    subtitle = ds.attrs.get("subtitle", "")
    slots = {"CSS": web_file("viewer.css"),
             "VIEWER": web_file("viewer.js"),
             "TITLE": html.escape(str(ds.attrs.get("title", ""))),
             "SUBTITLE": html.escape(str(subtitle)),
             "VERSION": html.escape(creatio.__version__),
             "PROVENANCE": _provenance(ds, digest(library)),
             "THREE_REVISION": rev,
             "DATA": data,
             "THREE": lib_text.replace("</script", "<\\/script")}
    text = fill(web_file("page.html"), slots)
    size = len(text.encode("utf-8"))
    if size > MAX_BYTES:
        raise ValueError(f"{out}: the page would be {size / 1e6:.1f} MB, above the "
                         f"{MAX_BYTES / 2**20:.0f} MB limit: lower scene.mesh or the frame rate")
    return atomic_save(out, lambda tmp: tmp.write_text(text, encoding="utf-8"))
