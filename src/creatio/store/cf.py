"""CF-1.10 conformance of every dataset, applied once where datasets are written.

The studies, analyses, sweeps and scenes build their datasets in the project's own notation
(``deg``, ``m/s``, the model length unit ``u``, a few prose unit strings, string labels).
:func:`conform` turns that into what CF tools read (docs/datasets.md): UDUNITS unit strings,
a ``long_name`` on every variable (from the table below, else derived from the name),
``standard_name`` where the CF table has one, simulated time as an elapsed time in ``s``,
no ``_FillValue`` on coordinates and string labels as character arrays (:func:`encoding`).
Values are never touched. :func:`restore` is its inverse for the project's own reader: the
attributes as the computing code stated them (conform marks what it added in
``creatio_added`` and keeps the units it rewrote in ``creatio_units``) and string labels as
strings, so that reports, scenes and ``creatio diff`` (against releases written before) see
what the studies wrote.
"""

from __future__ import annotations

import re
from collections.abc import Hashable, Mapping
from typing import Any

import numpy as np
import xarray as xr

__all__ = [
    "ADDED",
    "CONVENTIONS",
    "MIXED_UNITS",
    "MODEL_LENGTH_NOTE",
    "ORIGINAL_UNITS",
    "STANDARD_NAMES",
    "STORED_UNITS",
    "TIME_UNITS",
    "decode_time",
    "VARIABLES",
    "conform",
    "encoding",
    "is_string",
    "restore",
    "udunits",
]

CONVENTIONS = "CF-1.10"
#: Attribute keeping the units as the computing code stated them (project notation) where
#: conform rewrote them; read_dataset puts them back.
ORIGINAL_UNITS = "creatio_units"
#: Attribute naming the attributes conform added (space-separated); read_dataset drops them.
ADDED = "creatio_added"
#: Simulated time is an elapsed time (the runs have no date): plain seconds, no ``since``.
#: CF-1.11 s.4.4 reserves ``since`` units, standard_name time and axis T for instants in a
#: calendar; an elapsed time is an ordinary coordinate in a unit of time (docs/datasets.md).
TIME_UNITS = "s"
#: How releases before 0.2 wrote it (read back as seconds: :func:`decode_time`).
PLACEHOLDER_TIME_UNITS = "seconds since 1970-01-01 00:00:00"
#: Global attribute of a dataset whose lengths are in the model length unit u.
MODEL_LENGTH_NOTE = (
    "u: the notebook's model length unit (the CT-02 geometry, R0 = 0.68 u). Every length in "
    "this dataset is a multiple of u and is written as that pure number: units 1 for a "
    "length, s-1 for a velocity (UDUNITS would read the symbol u as the atomic mass unit); "
    "creatio_units gives the unit in the project's notation.")

#: Unit strings in prose (written by the kinematic studies) and their UDUNITS form. The
#: finite-difference step h is a multiple of its coordinate's unit (pure number); the
#: derivative errors are lengths per unit of the differentiated coordinate.
PROSE_UNITS = {
    "model units (u, rad, s)": "1",
    "m, rad, s": "1",
    "u (per coordinate unit)": "u",
    "m (c_R: dimensionless)": "m",
}
#: Project symbols that UDUNITS spells otherwise (u, the model length, is handled apart).
SYMBOLS = {"deg": "degree", "degrees": "degree", "sec": "s"}
#: Summary-figure names carry their unit as a suffix (docs/studies.md, report contract).
SUFFIX_UNITS = (("_m_s", "m s-1"), ("_rad_s", "rad s-1"), ("_deg", "degree"), ("_rad", "rad"),
                ("_m", "m"), ("_s", "s"), ("_J", "J"), ("_N", "N"), ("_kg", "kg"))
#: Units of the config keys a sweep may run over (its coordinates are named key__sub).
CONFIG_UNITS = {
    "sphere.mu": "1", "sphere.eps": "m s-1", "sphere.b": "m", "sphere.m": "kg",
    "sphere.g": "m s-2", "sphere.beta_deg": "degree", "sphere.psi_deg": "degree",
    "phases.T": "s", "study.duration": "s", "solver.dt": "s", "solver.h0": "s",
    "solver.rtol": "1", "solver.output_interval": "s",
}
#: Numeric variables whose unit depends on another variable: written without units.
MIXED_UNITS = {
    "setting_value": "rtol (units 1) or the fixed step dt (s), as setting_kind says",
}

#: CF standard names of the variables that have one. The CF table is made for the earth
#: sciences: none of the project's quantities is in it (``time`` names an instant of a
#: calendar, not the elapsed time of a run), so none is written.
STANDARD_NAMES: dict[str, str] = {}

L = "L"  # placeholder of the dataset's length unit (u or m) in the table below
#: long_name and units (project notation) of every variable the pipeline writes, used where
#: the dataset does not state them itself. None: no units (labels, mixed units).
VARIABLES: dict[str, tuple[str, str | None]] = {
    # shared coordinates and labels
    "time": ("simulated time since the start of the run", "s"),
    "component": ("Cartesian component (x, y, z)", None),
    "quaternion_component": ("quaternion component (w, x, y, z; scalar first)", None),
    "derivative": ("differentiated coordinate of c (c_R, c_alpha, c_t)", None),
    "inclination": ("inclination gamma", None),
    "status": ("run status (ok or why the run stopped)", None),
    "message": ("why a point was refused (empty when it ran)", None),
    "study": ("study id", None),
    # CT-02 and EN-01
    "h": ("finite-difference step", "1"),
    "feature_time": ("time of the cavity derivative check", "s"),
    "pitch_component": ("component of the helical pitch (p_R, p_z, p_rho)", None),
    "surface_class": ("class of the surface (annulus, cone, cylinder)", None),
    "pitch_formula": ("helical pitch of the cavity, closed form", L),
    "pitch_measured": ("displacement of the cavity over one turn of alpha_c", L),
    "j_identity_error": ("max |J - |c_R x c_alpha|| over the samples", L),
    "normal_tangent_dot": ("max normalised normal-tangent product |n . c_q| / |c_q|", "1"),
    "normal_length_error": ("max ||n| - 1| over the samples", "1"),
    "seam_closure": ("max |c(alpha + 2 pi) - c(alpha)| over the samples", L),
    "j_min_sampled": ("smallest sampled J", L),
    "law": ("time-law case", None),
    # sphere studies and scenes
    "kinetic_energy": ("kinetic energy", "J"),
    "potential_energy": ("potential energy", "J"),
    "quaternion": ("orientation, unit quaternion, scalar first", "1"),
    "marker": ("body marker, starts at (0, 0, 1)", "1"),
    "normal": ("unit normal n", "1"),
    "speed": ("speed", None),
    "phase_r": ("radial phase phi_r", None),
    "phase_a": ("angular phase phi_a", None),
    "stop_time": ("time at which the run stopped", "s"),
    "frames_run": ("frames up to the run's end", "1"),
    "sphere_radius": ("sphere radius b", L),
    "direction": ("direction of travel of the run", None),
    "source": ("where the run came from (reused study dataset or computed)", None),
    "run": ("run (study id)", None),
    "mode": ("velocity/normal mode", None),
    "R0": ("inner radius R0 of the annulus", L),
    "dR": ("radial width dR of the annulus", L),
    "A": ("corrugation amplitude A", L),
    "Kr": ("radial wave number Kr", "1"),
    "Ka": ("angular wave number Ka", "1"),
    # sweeps
    "point": ("index of the point in the sweep's row-major product", "1"),
    "point_key": ("sha256 of the point's resolved config", None),
    "max_b_kappa": ("maximum of b times the larger principal curvature", "1"),
    "dt_s": ("time step", "s"),
    "stability_limit_dt_s": ("largest stable RK4 step of the config (friction)", "s"),
    # work precision
    "entry": ("index of the (method, setting) entry", "1"),
    "repeat": ("index of the timed repeat", "1"),
}

_U = re.compile(r"(?<![A-Za-z_])u(?![A-Za-z_])")
_FACTOR = re.compile(r"^([A-Za-z_]+|1)\^?(-?\d+)?$")
_SINCE = re.compile(r"^\s*(s|sec|second|seconds)\s+since\s+", re.IGNORECASE)


def is_string(var: xr.Variable) -> bool:
    """True for a variable of text (numpy str, bytes, or objects that are all str)."""
    if var.dtype.kind in "US":
        return True
    return var.dtype.kind == "O" and all(isinstance(v, str) for v in np.ravel(var.values))


def _numeric(var: xr.Variable) -> bool:
    return var.dtype.kind in "fiub"


def udunits(units: str) -> str | None:
    """The UDUNITS form of a unit string in project notation (``m/s`` -> ``m s-1``, ``deg``
    -> ``degree``; the model length u becomes 1), or None when it is not a product of unit
    symbols with integer powers (prose)."""
    text = PROSE_UNITS.get(units.strip(), units.strip())
    if not text:
        return None
    parts = text.split("/")
    if len(parts) > 2:
        return None
    factors: list[tuple[str, int]] = []
    for sign, part in zip((1, -1), parts, strict=False):
        for token in re.split(r"[\s.*]+", part.strip()):
            m = _FACTOR.match(token)
            if not m:
                return None
            symbol, power = m.group(1), sign * int(m.group(2) or 1)
            if symbol in ("1", "u"):  # a pure number; u is a multiple of the model length
                continue
            factors.append((SYMBOLS.get(symbol, symbol), power))
    return " ".join(s if p == 1 else f"{s}{p}" for s, p in factors) or "1"


def _length_unit(ds: xr.Dataset) -> str:
    """u when any variable of ds states a unit in the model length u, else m."""
    for var in ds.variables.values():
        if _U.search(str(var.attrs.get(ORIGINAL_UNITS, var.attrs.get("units", "")))):
            return "u"
    return "m"


def _describe(name: str) -> tuple[str, str | None]:
    """(long_name, units in project notation) of a variable the dataset leaves undescribed:
    the table's, else the name's (a sweep's key__sub, a figure's unit suffix)."""
    if name in VARIABLES:
        return VARIABLES[name]
    base = name.removesuffix("_varying")
    if base != name and base in VARIABLES:
        long_name, units = VARIABLES[base]
        return f"{long_name} (time-varying inclination)", units
    if "__" in name:
        key = name.replace("__", ".")
        return key, CONFIG_UNITS.get(key)
    for suffix, units in SUFFIX_UNITS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name.removesuffix(suffix).replace("_", " "), units
    return name.replace("_", " "), None


def _cf_attrs(name: str, var: xr.Variable, length: str) -> dict[str, Any]:
    """The CF attributes of one variable: the stated ones, completed and rewritten."""
    attrs = dict(var.attrs)
    long_name, table_units = _describe(name)
    if not str(attrs.get("long_name", "")).strip():
        attrs["long_name"] = long_name
    if is_string(var) or not _numeric(var):
        return attrs
    if name in STANDARD_NAMES:
        attrs.setdefault("standard_name", STANDARD_NAMES[name])
    stated = str(attrs.get("units", "")).strip()  # as the computing code wrote it
    units = stated
    if not units and table_units is not None and name not in MIXED_UNITS:
        units = re.sub(rf"(?<![A-Za-z_]){L}(?![A-Za-z_])", length, table_units)
    if not units or "since" in units:  # nothing to state, or already a CF time unit
        return attrs
    cf_units = udunits(units)
    if cf_units is None:  # prose no table knows: kept apart, not passed off as units
        attrs.pop("units", None)
    else:
        attrs["units"] = cf_units
    return attrs


def _marked(stated: Mapping[Hashable, Any], cf: dict[str, Any]) -> dict[str, Any]:
    """cf plus what restore needs to get back to stated: the attributes added (ADDED) and
    the units as stated where they were rewritten or dropped (ORIGINAL_UNITS)."""
    added = [k for k in cf if k not in stated]
    out = dict(cf)
    if "units" in stated and cf.get("units") != stated["units"]:
        out[ORIGINAL_UNITS] = stated["units"]
    if added:
        out[ADDED] = " ".join(added)
    return out


def conform(ds: xr.Dataset) -> xr.Dataset:
    """A copy of ds with CF-1.10 metadata (values, dimensions and encodings untouched):
    units UDUNITS reads, a long_name everywhere, the CF time coordinate, Conventions. A
    variable conformed before (it carries the marks) is left as it is."""
    out = ds.copy()
    length = _length_unit(ds)
    for name, var in out.variables.items():
        if ADDED not in var.attrs and ORIGINAL_UNITS not in var.attrs:
            var.attrs = _marked(var.attrs, _cf_attrs(str(name), var, length))
    if ADDED not in out.attrs:
        attrs = {"Conventions": CONVENTIONS, **out.attrs}
        if length == "u":
            attrs.setdefault("model_length_unit", MODEL_LENGTH_NOTE)
        out.attrs = _marked(out.attrs, attrs)
    return out


def encoding(ds: xr.Dataset) -> dict[Hashable, dict[str, Any]]:
    """Per-variable CF encodings: text as character arrays (classic tools read them; xarray
    decodes them back to strings), no _FillValue on coordinates (CF 2.5.1)."""
    out: dict[Hashable, dict[str, Any]] = {}
    for name, var in ds.variables.items():
        enc: dict[str, Any] = {}
        if var.dtype.kind in "mM":  # decoded times keep the units they were read with
            enc = {k: v for k, v in var.encoding.items() if k in ("units", "calendar", "dtype")}
        if is_string(var):
            enc["dtype"] = "S1"
        if name in ds.coords:
            enc["_FillValue"] = None
        out[name] = enc
    return out


def _unmarked(attrs: Mapping[Hashable, Any]) -> dict[Hashable, Any]:
    """The attributes as stated before conform: added ones dropped, units put back."""
    out = dict(attrs)
    for key in str(out.pop(ADDED, "")).split():
        out.pop(key, None)
    if ORIGINAL_UNITS in out:
        out["units"] = out.pop(ORIGINAL_UNITS)
    return out


#: Encoding key recording the units a variable had in the file, before restore (diffs
#: report a change of encoding, such as the time units, without counting it as data).
STORED_UNITS = "creatio_stored_units"


def decode_time(attrs: dict[Hashable, Any]) -> dict[Hashable, Any]:
    """Attributes of a time read back from a file written with the placeholder reference
    date (``seconds since 1970-01-01``, creatio before 0.2): its values are the seconds of
    the run, so its units are ``s`` and its calendar goes. Other attributes are unchanged."""
    units = str(attrs.get("units", ""))
    if not _SINCE.match(units) or "1970-01-01" not in units:
        return attrs
    out = {k: v for k, v in attrs.items() if k != "calendar"}
    out["units"] = "s"
    return out


def restore(ds: xr.Dataset) -> xr.Dataset:
    """The dataset as its computing code made it, from one just read back (times undecoded)
    from a file conform wrote: the attributes it stated (restored in place), text labels as
    numpy strings, time in seconds. Files written before conform existed come back
    unchanged. Each variable's units as stored are kept in its encoding (STORED_UNITS)."""
    ds.attrs = _unmarked(ds.attrs)
    for var in ds.variables.values():
        var.encoding[STORED_UNITS] = var.attrs.get("units")
        var.attrs = _unmarked(var.attrs)
        if "units" in var.attrs and "since" in str(var.attrs["units"]):
            var.attrs = decode_time(var.attrs)
    text = {name: xr.Variable(var.dims, var.values.astype(str), var.attrs)
            for name, var in ds.variables.items() if var.dtype.kind == "O" and is_string(var)}
    coords: Mapping[Hashable, Any] = {n: v for n, v in text.items() if n in ds.coords}
    return ds.assign_coords(coords).assign({n: v for n, v in text.items() if n not in coords})
