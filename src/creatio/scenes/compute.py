"""Scene datasets: exactly what a scene draws, computed minimally or read from a study.

* sphere scenes: per study (dimension ``run``) and frame, the centre, the orientation (when
  drawn), the phases that shape the membrane, and the readouts the scene lists; each run
  either read from the study's own dataset at the frame times (reuse) or computed once with
  the outputs :mod:`creatio.scenes.plan` derived (a validated variant of the study config);
* the surface family: the slider's inclinations and their surface class, at fixed phases;
* velocity / normal: per mode and frame, the point's position, unit normal and velocity c_t,
  and the phases that shape the surface.

The membrane is drawn from the phases: the page evaluates c(alpha, R) of docs/model.md s.1.1
on its mesh (tests/scenes check its vertices against creatio.model.surface). Provenance is
attached by :mod:`creatio.scenes.run`.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.errors import ConfigError
from creatio.model.cavity import classify_inclination
from creatio.model.surface import Frame, Motion, Surface
from creatio.scenes.needs import RunNeed, needs
from creatio.scenes.schema import En04Readout, Readout
from creatio.studies.schema import GeometryConfig, vary

__all__ = ["EN04_READOUTS", "READOUTS", "en04_scene", "run_need", "skin_rows", "sphere_scene",
           "surface_family_scene", "velocity_normal_scene"]

log = logging.getLogger("creatio")

COMPONENTS = ["x", "y", "z"]

#: The velocity/normal explorer's modes in the notebook's order.
NOTEBOOK_MODES = ("angular", "radial", "oscillation")

#: Each readout: (label, unit, how to take it from a study dataset).
READOUTS: dict[Readout, tuple[str, str, Any]] = {
    Readout.time: ("time", "s", None),
    Readout.speed: ("speed", "m/s", lambda ds: ds.speed.values),
    Readout.normal_reaction: ("normal reaction", "N", lambda ds: ds.normal_reaction.values),
    Readout.slip_speed: ("slip speed", "m/s", lambda ds: ds.slip_speed.values),
    Readout.friction_magnitude: ("friction force |f|", "N",
                                 lambda ds: np.linalg.norm(ds.friction.values, axis=-1)),
    Readout.spin_rate: ("spin rate", "rad/s", lambda ds: ds.spin_rate.values),
    Readout.cumulative_spin: ("cumulative spin", "deg", lambda ds: ds.cumulative_spin.values),
    Readout.displacement: ("sphere displacement", "deg",
                           lambda ds: ds.centre_azimuth.values - ds.centre_azimuth.values[0]),
    Readout.pattern_rotation: ("pattern rotation", "deg",
                               lambda ds: ds.pattern_angle.values - ds.pattern_angle.values[0]),
    Readout.centre_radius: ("centre radius", "m", lambda ds: ds.centre_radius.values),
    Readout.radial_phase: ("radial phase", "deg", None),
}


def _geometry_attrs(g: GeometryConfig) -> dict[str, float]:
    return {"R0": g.R0, "dR": g.dR, "A": g.A, "Kr": g.Kr, "Ka": g.Ka}


def skin_rows(surface: Surface, n_alpha: int) -> tuple[np.ndarray, np.ndarray]:
    """(S_c, S_s) at the page's mesh angles alpha_i = 2 pi i / (n_alpha - 1): the two fixed
    functions of alpha whose combination cos(phi_a) S_c - sin(phi_a) S_s is the angular
    factor of W (creatio.model.ribs): a rib surface's splines, cos and sin(Ka alpha) ideal."""
    alpha = 2.0 * math.pi * np.arange(n_alpha) / (n_alpha - 1)
    if surface.ribs is None:
        return np.cos(surface.Ka * alpha), np.sin(surface.Ka * alpha)
    from creatio.model.ribs import NCOEF, spline_eval

    table = surface.skin_table
    return spline_eval(table[:, :NCOEF], alpha), spline_eval(table[:, NCOEF:], alpha)


# --------------------------------------------------------------------------- sphere scenes
def run_need(base: Any, need: RunNeed) -> tuple[xr.Dataset, dict[str, Any]]:
    """Compute one study's frames as the scene needs them: one run at the configured step,
    histories at the frame times only, no energy, rotation only if needed. Returns the
    study dataset and what was computed (outputs, state size, steps, rows, seconds)."""
    from creatio.studies.sphere import run

    cfg = vary(base, need.changes())
    problem = cfg.sphere_problem()
    t0 = time.perf_counter()
    ds = run(cfg, cfg.solver.dt)
    seconds = time.perf_counter() - t0
    rot, en = problem.rotation_integrated, bool(problem.output.energy)
    info = {
        "outputs": list(need.outputs),
        "rotation_integrated": rot,
        "energy_integrated": en,
        "state_size": len(problem.initial_state(rot, en)),
        "steps": int(ds.attrs["steps"]),
        "rows": int(ds.sizes["time"]),
        "seconds": seconds,
    }
    return ds, info


def _frames_of(ds: xr.Dataset, times: np.ndarray) -> xr.Dataset:
    """The dataset at the given times (every one must be an output time, to 1e-9 s)."""
    t = ds.time.values
    idx = np.searchsorted(t, times - 1e-9)
    idx = np.minimum(idx, t.size - 1)
    bad = np.abs(t[idx] - times) > 1e-9
    if bad.any():
        raise ValueError(f"the dataset has no output at t = {times[bad][0]:g} s")
    return ds.isel(time=idx)


def sphere_scene(resolved: Any, reuse: Mapping[str, str | Path] | None = None,
                 computed: Mapping[str, tuple[xr.Dataset, dict[str, Any]]] | None = None
                 ) -> xr.Dataset:
    """The dataset of a sphere scene: per run (study) and frame, what the scene draws.

    ``reuse`` maps a study to its own dataset, read instead of computing when its config hash
    is the scene's base's (else the run is computed and the mismatch logged); ``computed``
    maps a study to the :func:`run_need` result already in hand (a family member's).
    """
    from creatio.store.netcdf import read_dataset

    reuse = dict(reuse or {})
    s = resolved.obj.scene
    runs = needs(resolved)
    interval = s.playback.interval
    span = max(n.duration for n in runs)
    times = np.arange(round(span / interval) + 1) * interval
    n = times.size
    per_run: dict[str, list] = {}
    sources, meta = [], []
    for need in runs:
        base = resolved.bases[need.study]
        study_ds, info = None, None
        if need.study in reuse:
            study_ds, _ = read_dataset(reuse[need.study])
            if study_ds.attrs.get("config_sha256") != base.sha256:
                log.warning("scene %s: %s holds another config of %s; computing instead",
                            resolved.id, reuse[need.study], need.study)
                study_ds = None
            else:
                sources.append(f"reused {reuse[need.study]}")
                info = {"outputs": "read from the study dataset", "seconds": 0.0}
        if study_ds is None:
            study_ds, info = (computed or {}).get(need.study) or run_need(base.obj, need)
            sources.append(
                f"computed: {base.obj.solver.method} at dt = {need.dt:g} s, outputs "
                f"{'+'.join(need.outputs)}, {info['rows']} frames every {interval:g} s, "
                f"state size {info['state_size']}, {info['steps']} steps, "
                f"{info['seconds']:.2f} s")
        meta.append(info)
        own = study_ds.time.values
        keep = times[times <= own[-1] + 1e-9]
        f = _frames_of(study_ds, keep)
        per_run.setdefault("centre", []).append(_pad(f.centre.values, n))
        if s.rotation:
            per_run.setdefault("quaternion", []).append(_pad(f.quaternion.values, n))
        laws = base.obj.phases.laws()
        for name, law in zip(("phase_r", "phase_a", "inclination"), laws, strict=True):
            per_run.setdefault(name, []).append(np.degrees(law(times).value))
        for r in s.readouts:
            if r is Readout.time:
                continue
            if r is Readout.radial_phase:
                values = np.degrees(laws[0](keep).value)
            else:
                values = READOUTS[r][2](f)
            per_run.setdefault(str(r), []).append(_pad(np.asarray(values, float), n))
        per_run.setdefault("status", []).append(str(study_ds.attrs["status"]))
        per_run.setdefault("stop_time", []).append(float(study_ds.attrs["stop_time"]))
        per_run.setdefault("frames_run", []).append(keep.size)
        per_run.setdefault("sphere_radius", []).append(base.obj.sphere.b)
        surface = base.obj.geometry.surface()
        per_run.setdefault("ribs", []).append(surface.ribs is not None)
        for name, row in zip(("skin_c", "skin_s"), skin_rows(surface, s.mesh.n_alpha),
                             strict=True):
            per_run.setdefault(name, []).append(row)
        for key, value in _geometry_attrs(base.obj.geometry).items():
            per_run.setdefault(key, []).append(value)
    data: dict[str, Any] = {
        **_run_frames(per_run),
        "sphere_radius": ("run", per_run["sphere_radius"], {"units": "m"}),
        "direction": ("run", [_direction(per_run, i) for i in range(len(runs))]),
        "source": ("run", sources),
    }
    for key in ("R0", "dR", "A", "Kr", "Ka"):
        data[key] = ("run", per_run[key])
    if any(per_run["ribs"]):  # the page draws a rib surface from its splines
        for name in ("skin_c", "skin_s"):
            data[name] = (("run", "mesh_alpha"), np.stack(per_run[name]), {
                "long_name": f"{'S_c' if name == 'skin_c' else 'S_s'}: angular factor of W "
                             "at the mesh angles, W = A sin(u) (cos(phi_a) S_c - "
                             "sin(phi_a) S_s)", "units": "1"})
    if s.rotation:
        data["quaternion"] = (("run", "frame", "quaternion_component"),
                              np.stack(per_run["quaternion"]),
                              {"long_name": "orientation, unit quaternion, scalar first"})
    for r in s.readouts:
        if r is not Readout.time:
            label, unit, _ = READOUTS[r]
            data[str(r)] = (("run", "frame"), np.stack(per_run[str(r)]),
                            {"long_name": label, "units": unit})
    coords = {
        "run": ("run", [n.study for n in runs]),
        "time": ("frame", times, {"units": "s"}),
        "component": ("component", COMPONENTS),
        "quaternion_component": ("quaternion_component", ["w", "x", "y", "z"]),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "scene": resolved.id,
        "kind": "sphere",
        "frame_interval": interval,
        "playback_speed": s.playback.speed,
        "playback_fps": s.playback.fps,
        "draw": [str(x) for x in s.draw],
        "readouts": [str(r) for r in s.readouts],
        "mesh": [s.mesh.n_alpha, s.mesh.n_R],
        "computed_seconds": float(sum(m["seconds"] for m in meta)),
        "comment": "NaN after a run's end (frames_run); sources say what was computed",
    })
    return ds


def _run_frames(per_run: dict[str, list]) -> dict[str, Any]:
    """The variables every sphere-format scene dataset has, per run and frame (centre, the
    three phases) and per run (status, stop time, frames run), from the lists collected."""
    return {
        "centre": (("run", "frame", "component"), np.stack(per_run["centre"]),
                   {"long_name": "sphere centre X = c + b n", "units": "m"}),
        "phase_r": (("run", "frame"), np.stack(per_run["phase_r"]),
                    {"long_name": "radial phase phi_r", "units": "degree"}),
        "phase_a": (("run", "frame"), np.stack(per_run["phase_a"]),
                    {"long_name": "angular phase phi_a", "units": "degree"}),
        "inclination": (("run", "frame"), np.stack(per_run["inclination"]),
                        {"long_name": "inclination gamma", "units": "degree"}),
        "status": ("run", per_run["status"]),
        "stop_time": ("run", per_run["stop_time"], {"units": "s"}),
        "frames_run": ("run", per_run["frames_run"],
                       {"long_name": "frames up to the run's end (NaN after)"}),
    }


def _pad(values: np.ndarray, n: int) -> np.ndarray:
    """values (frames first) extended to n frames with NaN."""
    out = np.full((n, *values.shape[1:]), np.nan)
    out[: values.shape[0]] = values
    return out


def _direction(per_run: dict[str, list], i: int) -> str:
    """A label of which way the pattern and the sphere went (from the run's own frames)."""
    k = per_run["frames_run"][i] - 1
    parts = []
    if "pattern_rotation" in per_run:
        turn = float(per_run["pattern_rotation"][i][k])
        parts.append(f"pattern {_sense(turn)} ({turn:+.0f} deg)")
    if "displacement" in per_run:
        disp = float(per_run["displacement"][i][k])
        parts.append(f"sphere {_sense(disp)} ({disp:+.1f} deg)")
    c = per_run["centre"][i]
    r0, r1 = float(np.hypot(*c[0, :2])), float(np.hypot(*c[k, :2]))
    if abs(r1 - r0) > 0.01:
        parts.append(f"{'outward' if r1 > r0 else 'inward'} {r0:.2f} -> {r1:.2f} m")
    return ", ".join(parts)


def _sense(angle_deg: float) -> str:
    if abs(angle_deg) < 0.5:
        return "still"
    return "counterclockwise" if angle_deg > 0 else "clockwise"


# ----------------------------------------------------------------------------- EN-04 scene
#: Each EN-04 readout: (label, unit, the en04_control path variable it is).
EN04_READOUTS: dict[En04Readout, tuple[str, str, str]] = {
    En04Readout.lead: ("lead delta = alpha_p - alpha (cavity minus contact)", "degree",
                       "path_lead"),
    En04Readout.pattern_speed: ("pattern speed dalpha_p/dt = -dphi_a/dt / Ka", "rad s-1",
                                "path_pattern_speed"),
    En04Readout.travel: ("travel theta = alpha - alpha(0)", "degree", "path_theta"),
    En04Readout.load_power: ("load power (membrane into sphere)", "W", "path_power"),
}

#: The EN-04 paths the scene shows, in panel order: (path name in en04_control, run name).
EN04_RUNS = (("closed_loop", "closed loop"), ("quintic", "open loop"))


def en04_scene(resolved: Any, reuse: Mapping[str, str | Path] | None = None) -> xr.Dataset:
    """The EN-04 scene's dataset, in the sphere scenes' format (two runs, one page): the
    fastest carried closed loop and the open-loop quintic at its carried boundary T, both the
    study's own runs as ``en04_control.nc`` recorded them (centre, phi_a, orientation, lead,
    pattern speed, travel, load power at the frame times); phi_r and gamma from the control
    base's laws, which both runs keep. ``reuse['en04']`` is that dataset, required: a file of
    another EN-04 config is refused."""
    from creatio.store.netcdf import read_dataset

    s = resolved.obj.scene
    study = resolved.bases["en04"]
    path = (reuse or {}).get("en04")
    if path is None:
        raise ConfigError("--reuse", None, "scene en04 draws the EN-04 control dataset: pass "
                          "--reuse en04=<root>/studies/en04/en04_control.nc (snakemake beyond "
                          "builds it)")
    src, _ = read_dataset(path)
    if src.attrs.get("config_sha256") != study.sha256 or src.attrs.get("part") != "control":
        raise ConfigError("--reuse", str(path), f"is not the control dataset of the scene's "
                          f"EN-04 config (sha256 {study.sha256[:12]}; the file's "
                          f"{str(src.attrs.get('config_sha256', '?'))[:12]}, part "
                          f"{src.attrs.get('part', '?')})")
    names = [str(p) for p in src.path.values]
    if "closed_loop" not in names:
        raise RuntimeError(f"{path}: no controller of the grid carried the sphere: there is no "
                           "closed-loop run to show")
    if not int(src.attrs["open_loop_boundary_found"]):
        raise RuntimeError(f"{path}: the quintic bracket held no carried boundary: there is "
                           "no open-loop boundary run to show")
    control = study.obj.study.control
    base = study.obj.bases[control.base]
    interval = s.playback.interval
    times = np.arange(round(control.duration / interval) + 1) * interval
    t = src.time.values
    idx = np.searchsorted(t, times - 1e-9)
    if idx[-1] >= t.size or np.max(np.abs(t[np.minimum(idx, t.size - 1)] - times)) > 1e-9:
        raise ValueError(f"{path}: its paths are not sampled at the scene's {interval:g} s frames")
    laws = base.phases.laws()
    fixed = {name: np.degrees(law(times).value)
             for name, law in zip(("phase_r", "inclination"), (laws[0], laws[2]), strict=True)}
    fastest = int(src.attrs["fastest_case"])
    T = float(src.attrs["open_loop_boundary_T"])
    case = {k: float(src[k].values[fastest])
            for k in ("omega_max", "delta_max_deg", "omega_c", "omega_n")}
    direction = {
        # the media break the line at each ", " (three short lines in a panel's title)
        "closed_loop": (f"fastest carried controller (of {int(src.carried.sum())}): arrival "
                        f"{float(src.attrs['fastest_arrival']):.2f} s, limits Omega_max "
                        f"{case['omega_max']:g} rad/s · delta_max {case['delta_max_deg']:g} deg, "
                        f"gains omega_c {case['omega_c']:g} · omega_n {case['omega_n']:g} rad/s"),
        "quintic": (f"quintic cycle at its carried boundary T = {T:.3f} s, arrival "
                    f"{float(src.attrs['quintic_boundary_arrival']):.2f} s"),
    }
    status = {"closed_loop": str(src.status.values[fastest]),
              # the boundary run is the bisection's shortest carried T: carried and ran to
              # the end (creatio.studies.en04_control.measure), so its status is ok
              "quintic": "ok"}
    per_run: dict[str, list] = {}
    for name, _ in EN04_RUNS:
        p = names.index(name)
        centre = src.path_centre.values[p, idx]
        per_run.setdefault("centre", []).append(centre)
        per_run.setdefault("phase_a", []).append(src.path_phase_a.values[p, idx])
        for key, values in fixed.items():
            per_run.setdefault(key, []).append(values)
        if s.rotation:
            per_run.setdefault("quaternion", []).append(src.path_quaternion.values[p, idx])
        for r in s.readouts:
            if r is not En04Readout.time:
                per_run.setdefault(str(r), []).append(src[EN04_READOUTS[r][2]].values[p, idx])
        ran = np.isfinite(centre).all(axis=1)
        per_run.setdefault("frames_run", []).append(int(np.argmin(ran)) if not ran.all()
                                                    else times.size)
        per_run.setdefault("stop_time", []).append(float(times[ran][-1]))
        per_run.setdefault("status", []).append(status[name])
        per_run.setdefault("direction", []).append(direction[name])
        label = str(src.path_label.values[p])
        per_run.setdefault("source", []).append(
            f"read from {path} (path {name}: {label}; EN-04 config "
            f"sha256 {study.sha256[:12]}), nothing integrated here")
    data: dict[str, Any] = {
        **_run_frames(per_run),
        "sphere_radius": ("run", [base.sphere.b] * len(EN04_RUNS), {"units": "m"}),
        "direction": ("run", per_run["direction"]),
        "source": ("run", per_run["source"]),
        **{key: ("run", [value] * len(EN04_RUNS))
           for key, value in _geometry_attrs(base.geometry).items()},
    }
    if s.rotation:
        q = np.stack(per_run["quaternion"])
        ran = np.isfinite(np.stack(per_run["centre"])[..., 0])
        if not np.isfinite(q[ran]).all():
            raise RuntimeError(f"{path}: the runs did not integrate the orientation the scene "
                               "draws (marker, band): draw neither")
        data["quaternion"] = (("run", "frame", "quaternion_component"), q,
                              {"long_name": "orientation, unit quaternion, scalar first"})
    for r in s.readouts:
        if r is not En04Readout.time:
            label, unit, _ = EN04_READOUTS[r]
            data[str(r)] = (("run", "frame"), np.stack(per_run[str(r)]),
                            {"long_name": label, "units": unit})
    coords = {
        "run": ("run", [run for _, run in EN04_RUNS]),
        "time": ("frame", times, {"units": "s"}),
        "component": ("component", COMPONENTS),
        "quaternion_component": ("quaternion_component", ["w", "x", "y", "z"]),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "scene": resolved.id,
        "kind": "sphere",  # the sphere scenes' page and media draw it
        "frame_interval": interval,
        "playback_speed": s.playback.speed,
        "playback_fps": s.playback.fps,
        "draw": [str(x) for x in s.draw],
        "readouts": [str(r) for r in s.readouts],
        "mesh": [s.mesh.n_alpha, s.mesh.n_R],
        "computed_seconds": 0.0,
        "en04_dataset": str(path),
        "en04_fastest_case": fastest,
        "en04_fastest_arrival": float(src.attrs["fastest_arrival"]),
        "en04_open_loop_boundary_T": T,
        "en04_quintic_boundary_arrival": float(src.attrs["quintic_boundary_arrival"]),
        "comment": "the two runs of en04_control.nc at the frame times; NaN after a run's end",
    })
    return ds


# ----------------------------------------------------------------------- kinematic scenes
def surface_family_scene(resolved: Any, reuse: Mapping[str, Any] | None = None) -> xr.Dataset:
    """The surface family: the slider's inclinations (deg) and their class, at the phases
    of the config at ``scene.time`` (the viewer's constant phases by default)."""
    cfg = resolved.obj
    s = cfg.scene
    incl = np.array(s.inclinations_deg())
    laws = cfg.phases.laws()
    pr, pa = (math.degrees(float(law(s.time).value)) for law in laws[:2])
    classes = [classify_inclination(math.radians(g)) for g in incl]
    ds = xr.Dataset(
        {"surface_class": (("inclination",), classes),
         "phase_r": ((), pr, {"long_name": "radial phase phi_r", "units": "degree"}),
         "phase_a": ((), pa, {"long_name": "angular phase phi_a", "units": "degree"})},
        coords={"inclination": ("inclination", incl,
                                {"long_name": "inclination gamma", "units": "degree"})},
    )
    ds.attrs.update({"scene": resolved.id, "kind": "surface_family", "time": s.time,
                     "mesh": [s.mesh.n_alpha, s.mesh.n_R], **_geometry_attrs(cfg.geometry)})
    return ds


def velocity_normal_scene(resolved: Any, reuse: Mapping[str, Any] | None = None) -> xr.Dataset:
    """Per mode and frame: the point c, its unit normal n and fixed-coordinate velocity c_t,
    the speed |c_t|, and the phases (creatio.model.surface, docs/model.md s.1.3-1.4)."""
    cfg = resolved.obj
    s = cfg.scene
    surface = cfg.geometry.surface()
    times = np.linspace(0.0, s.duration, s.frames)
    alpha = math.radians(s.alpha_deg)
    cols: dict[str, list] = {}
    # The notebook's order first (a resolved config lists its modes sorted by name).
    names = sorted(s.modes, key=lambda m: (NOTEBOOK_MODES.index(m) if m in NOTEBOOK_MODES
                                           else len(NOTEBOOK_MODES), m))
    for phases in (s.modes[m] for m in names):
        laws = phases.laws()
        fr = Frame(surface, Motion(*laws), alpha, s.R, times)
        cols.setdefault("position", []).append(fr.position)
        cols.setdefault("normal", []).append(fr.normal)
        cols.setdefault("velocity", []).append(fr.c_t)
        cols.setdefault("speed", []).append(np.linalg.norm(fr.c_t, axis=-1))
        for name, law in zip(("phase_r", "phase_a", "inclination"), laws, strict=True):
            cols.setdefault(name, []).append(np.degrees(law(times).value))
    vec = ("mode", "frame", "component")
    ds = xr.Dataset(
        {"position": (vec, np.stack(cols["position"]), {"long_name": "surface point c",
                                                         "units": "u"}),
         "normal": (vec, np.stack(cols["normal"]), {"long_name": "unit normal n = "
                                                     "(c_R x c_alpha) / J"}),
         "velocity": (vec, np.stack(cols["velocity"]),
                      {"long_name": "fixed-coordinate velocity c_t", "units": "u s-1"}),
         "speed": (("mode", "frame"), np.stack(cols["speed"]), {"units": "u s-1"}),
         **{name: (("mode", "frame"), np.stack(cols[name]), {"units": "degree"})
            for name in ("phase_r", "phase_a", "inclination")}},
        coords={"mode": ("mode", names),
                "time": ("frame", times, {"units": "s"}),
                "component": ("component", COMPONENTS)},
    )
    ds.attrs.update({"scene": resolved.id, "kind": "velocity_normal",
                     "alpha_deg": s.alpha_deg, "R": s.R, "normal_length": s.normal_length,
                     "velocity_scale": s.velocity_scale, "magnification": s.magnification,
                     "mesh": [s.mesh.n_alpha, s.mesh.n_R], **_geometry_attrs(cfg.geometry)})
    return ds
