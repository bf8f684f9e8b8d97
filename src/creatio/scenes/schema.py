"""The config schema of every scene: typed dataclasses and the rules their values obey.

A scene config is ``conf/scene/<id>.yaml`` on one of these schemas (Hydra composes it from
``conf/scene.yaml``; :mod:`creatio.scenes.config` merges and checks it). Its ``scene`` node says
what the scene draws (elements, readouts), how it plays (speed, frames per second) and how its
media look; the rest is the data it draws from: ``bases.<study>`` (the full config of a sphere
study, validated on that study's own schema) or ``geometry`` / ``phases`` for the kinematic
scenes. Every rule raises :class:`~creatio.errors.ConfigError` naming key, value and rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from creatio.errors import ConfigError
from creatio.model.numerics import steps_in
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    GeometryConfig,
    PhasesConfig,
    check_angle_deg,
    check_bases,
    require,
)

__all__ = [
    "Element",
    "En04Readout",
    "En04SceneConfig",
    "En04SceneSettings",
    "MediaConfig",
    "MeshConfig",
    "PlaybackConfig",
    "Readout",
    "SphereSceneConfig",
    "SphereSceneSettings",
    "SurfaceFamilyConfig",
    "SurfaceFamilySettings",
    "VelocityNormalConfig",
    "VelocityNormalSettings",
]


class Element(StrEnum):
    """What a sphere scene draws in its 3D view."""

    membrane = "membrane"
    sphere = "sphere"
    marker = "marker"      # the body-fixed arrow: needs the orientation
    band = "band"          # the band on the equator: needs the orientation
    trace = "trace"        # the centre's path so far, coloured by time


class Readout(StrEnum):
    """A number a sphere scene shows beside the view at the current time."""

    time = "time"
    speed = "speed"
    normal_reaction = "normal_reaction"
    slip_speed = "slip_speed"
    friction_magnitude = "friction_magnitude"  # |f|: the study datasets' friction is the vector
    spin_rate = "spin_rate"            # needs the rotation
    cumulative_spin = "cumulative_spin"  # needs the rotation
    displacement = "displacement"
    pattern_rotation = "pattern_rotation"
    centre_radius = "centre_radius"
    radial_phase = "radial_phase"


#: The elements and readouts that need the sphere's orientation or spin integrated.
NEEDS_ROTATION = {Element.marker, Element.band, Readout.spin_rate, Readout.cumulative_spin}


@dataclass
class PlaybackConfig:
    """How simulated time plays: ``speed`` simulated seconds per second, ``fps`` frames per
    second of playback. The frame interval speed / fps is the only sampling a scene computes."""

    speed: float = 1.0
    fps: float = 20.0

    @property
    def interval(self) -> float:
        """Simulated time between two frames (s)."""
        return self.speed / self.fps

    def check(self, path: str) -> None:
        """speed and fps finite and > 0."""
        for name in ("speed", "fps"):
            v = getattr(self, name)
            require(math.isfinite(v) and v > 0.0, f"{path}.{name}", v, "must be finite and > 0")


@dataclass
class MeshConfig:
    """Sampling of the drawn surface: points along alpha (whole turn) and along R."""

    n_alpha: int = 181
    n_R: int = 25

    def check(self, path: str) -> None:
        """At least 8 x 2 points, at most 400 x 200 (the page stays light)."""
        require(8 <= self.n_alpha <= 400, f"{path}.n_alpha", self.n_alpha, "must lie in [8, 400]")
        require(2 <= self.n_R <= 200, f"{path}.n_R", self.n_R, "must lie in [2, 200]")


@dataclass
class MediaConfig:
    """The animation (animated WebP) and the poster PNG.

    ``every``: the animation keeps every n-th frame of the scene (its frame rate is then
    playback fps / every); ``poster_time``: simulated time of the poster (s; clipped to the
    run), or the slider position for a scene without time.
    """

    every: int = 2
    width: int = 720
    height: int = 450
    quality: int = 70
    poster_time: float = 0.0

    def check(self, path: str) -> None:
        """every >= 1, sizes within 160..1920 pixels, quality 1..100."""
        require(self.every >= 1, f"{path}.every", self.every, "must be >= 1")
        for name in ("width", "height"):
            v = getattr(self, name)
            require(160 <= v <= 1920, f"{path}.{name}", v, "must lie in [160, 1920] pixels")
        require(1 <= self.quality <= 100, f"{path}.quality", self.quality, "must lie in [1, 100]")
        require(math.isfinite(self.poster_time), f"{path}.poster_time", self.poster_time,
                "must be finite")


#: The most frames a scene may have: the page holds every one and the animation draws every
#: `media.every`-th with matplotlib (~0.1 s each); the defaults use 300.
MAX_FRAMES = 20_000


# ------------------------------------------------------------------------- sphere scenes
@dataclass
class SphereSceneSettings:
    """A sphere scene: one view per study of ``studies`` (side by side, one shared clock)."""

    id: str = MISSING
    title: str = ""
    studies: list[str] = MISSING
    draw: list[Element] = field(default_factory=lambda: list(Element))
    readouts: list[Readout] = field(default_factory=lambda: [Readout.time])
    playback: PlaybackConfig = field(default_factory=lambda: PlaybackConfig(speed=8.0))
    mesh: MeshConfig = field(default_factory=MeshConfig)
    media: MediaConfig = field(default_factory=MediaConfig)
    axes: dict[str, Any] = field(default_factory=dict)

    @property
    def rotation(self) -> bool:
        """Whether anything drawn or read out needs the orientation or spin."""
        return any(x in NEEDS_ROTATION for x in (*self.draw, *self.readouts))


@dataclass
class SphereSceneConfig:
    """Root schema of a sphere scene: its settings and the full config of each study."""

    scene: SphereSceneSettings = field(default_factory=SphereSceneSettings)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """Each base valid (errors named under bases.<study>); every study of the scene has
        a base; the frame interval divides each run and is a multiple of its fixed step."""
        s = self.scene
        require(len(s.studies) >= 1, "scene.studies", list(s.studies), "needs a study")
        check_bases(self.bases)
        for name in s.studies:
            require(name in self.bases, "scene.studies", list(s.studies),
                    f"{name!r} has no config under bases (bases: {sorted(self.bases)})")
        require(len(set(s.draw)) == len(s.draw), "scene.draw", [str(x) for x in s.draw],
                "lists an element twice")
        s.playback.check("scene.playback")
        s.mesh.check("scene.mesh")
        s.media.check("scene.media")
        interval = s.playback.interval
        for name in s.studies:
            base = self.bases[name]
            require(steps_in(base.study.duration, interval) is not None, "scene.playback",
                    f"speed / fps = {interval:g} s",
                    f"must divide bases.{name}.study.duration = {base.study.duration:g} s")
            if not base.solver.adaptive:
                require(steps_in(interval, base.solver.dt) is not None, "scene.playback",
                        f"speed / fps = {interval:g} s",
                        f"must be a multiple of bases.{name}.solver.dt = {base.solver.dt:g} s")
            frames = base.study.duration / interval
            require(frames <= MAX_FRAMES, "scene.playback.fps", s.playback.fps,
                    f"asks for {frames:,.0f} frames (bases.{name}.study.duration x fps / "
                    f"speed), more than {MAX_FRAMES:,}: lower fps or raise speed")


# ---------------------------------------------------------------------------- EN-04 scene
class En04Readout(StrEnum):
    """A number the EN-04 scene shows per run at the current time (the study's paths)."""

    time = "time"
    lead = "lead"                    # delta: the cavity's lead on the contact (deg)
    pattern_speed = "pattern_speed"  # -phidot_a / Ka, the pattern's angular speed (rad/s)
    travel = "travel"                # theta = alpha - alpha(0) (deg)
    load_power = "load_power"        # the power the membrane puts into the sphere (W)


@dataclass
class En04SceneSettings:
    """The fastest carried closed loop of EN-04's controller grid beside the open-loop
    quintic at its carried boundary T: the study's own two runs, read from its control
    dataset (``en04_control.nc`` of the config under ``bases.en04``), on one clock."""

    id: str = MISSING
    title: str = ""
    draw: list[Element] = field(default_factory=lambda: list(Element))
    readouts: list[En04Readout] = field(default_factory=lambda: list(En04Readout))
    playback: PlaybackConfig = field(default_factory=lambda: PlaybackConfig(speed=1.0,
                                                                            fps=25.0))
    mesh: MeshConfig = field(default_factory=MeshConfig)
    media: MediaConfig = field(default_factory=MediaConfig)

    @property
    def rotation(self) -> bool:
        """Whether anything drawn needs the orientation."""
        return any(x in NEEDS_ROTATION for x in self.draw)


@dataclass
class En04SceneConfig:
    """Root schema of the EN-04 scene: its settings and the full EN-04 config (``bases.en04``,
    validated on the study's own schema, so its hash names the dataset the scene reads)."""

    scene: En04SceneSettings = field(default_factory=En04SceneSettings)
    bases: dict[str, Any] = field(default_factory=dict)

    def check(self) -> None:
        """bases.en04 a valid EN-04 config; the frame interval a multiple of its control
        paths' interval that divides their duration."""
        from creatio.pipeline.config import validate

        s = self.scene
        require(set(self.bases) == {"en04"}, "bases", sorted(self.bases),
                "must hold exactly the EN-04 config, under bases.en04")
        try:
            control = validate(self.bases["en04"]).obj.study.control
        except ConfigError as e:
            raise ConfigError(f"bases.en04.{e.key}", e.value, e.rule) from None
        require(len(set(s.draw)) == len(s.draw), "scene.draw", [str(x) for x in s.draw],
                "lists an element twice")
        require(len(set(s.readouts)) == len(s.readouts), "scene.readouts",
                [str(x) for x in s.readouts], "lists a readout twice")
        s.playback.check("scene.playback")
        s.mesh.check("scene.mesh")
        s.media.check("scene.media")
        interval = s.playback.interval
        require(steps_in(interval, control.path_interval) is not None, "scene.playback",
                f"speed / fps = {interval:g} s", "must be a multiple of "
                f"bases.en04.study.control.path_interval = {control.path_interval:g} s "
                "(the study's paths are sampled there)")
        require(steps_in(control.duration, interval) is not None, "scene.playback",
                f"speed / fps = {interval:g} s",
                f"must divide bases.en04.study.control.duration = {control.duration:g} s")
        frames = control.duration / interval
        require(frames <= MAX_FRAMES, "scene.playback.fps", s.playback.fps,
                f"asks for {frames:,.0f} frames (bases.en04.study.control.duration x fps / "
                f"speed), more than {MAX_FRAMES:,}: lower fps or raise speed")


# ---------------------------------------------------------------------- kinematic scenes
@dataclass
class SurfaceFamilySettings:
    """The CT-02 family at one set of phases: a slider over the inclination gamma."""

    id: str = MISSING
    title: str = ""
    gamma_min_deg: float = 0.0
    gamma_max_deg: float = 90.0
    gamma_step_deg: float = 1.0
    time: float = 0.0
    mesh: MeshConfig = field(default_factory=MeshConfig)
    media: MediaConfig = field(default_factory=MediaConfig)

    def inclinations_deg(self) -> list[float]:
        """The slider's stops, min to max (both included)."""
        n = round((self.gamma_max_deg - self.gamma_min_deg) / self.gamma_step_deg)
        return [self.gamma_min_deg + i * self.gamma_step_deg for i in range(n + 1)]


@dataclass
class SurfaceFamilyConfig:
    """Root schema of the surface-family scene."""

    scene: SurfaceFamilySettings = field(default_factory=SurfaceFamilySettings)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)
    phases: PhasesConfig = field(default_factory=PhasesConfig)

    def check(self) -> None:
        """Geometry and phases valid; the inclinations within [-90, 90] on a whole grid."""
        self.geometry.check("geometry")
        self.phases.check("phases")
        s = self.scene
        require(-90.0 <= s.gamma_min_deg <= 90.0, "scene.gamma_min_deg", s.gamma_min_deg,
                "must lie in [-90, 90]")
        require(s.gamma_min_deg <= s.gamma_max_deg <= 90.0, "scene.gamma_max_deg",
                s.gamma_max_deg, f"must lie in [gamma_min_deg = {s.gamma_min_deg}, 90]")
        require(s.gamma_step_deg > 0.0, "scene.gamma_step_deg", s.gamma_step_deg, "must be > 0")
        span = s.gamma_max_deg - s.gamma_min_deg
        stops = span / s.gamma_step_deg + 1
        require(stops <= MAX_FRAMES, "scene.gamma_step_deg", s.gamma_step_deg,
                f"asks for {stops:,.0f} slider stops (animation frames), more than "
                f"{MAX_FRAMES:,}")
        require(steps_in(span, s.gamma_step_deg) is not None or span == 0.0,
                "scene.gamma_step_deg", s.gamma_step_deg,
                f"must divide gamma_max_deg - gamma_min_deg = {span:g}")
        require(math.isfinite(s.time), "scene.time", s.time, "must be finite")
        s.mesh.check("scene.mesh")
        s.media.check("scene.media")


@dataclass
class VelocityNormalSettings:
    """One surface point (alpha, R) with its unit normal and its fixed-coordinate velocity
    c_t, under each of ``modes`` (a set of phase laws), played over ``duration``.

    Drawn lengths: the normal is ``normal_length`` long; the velocity is
    ``velocity_scale`` x |c_t| x magnification (12 x 0.10 u/s = 1.20 u at x1, the notebook's).
    """

    id: str = MISSING
    title: str = ""
    alpha_deg: float = MISSING
    R: float = MISSING
    duration: float = MISSING
    frames: int = 90
    normal_length: float = 0.65
    velocity_scale: float = 12.0
    magnification: float = 1.0
    modes: dict[str, PhasesConfig] = field(default_factory=dict)
    mesh: MeshConfig = field(default_factory=MeshConfig)
    media: MediaConfig = field(default_factory=MediaConfig)


@dataclass
class VelocityNormalConfig:
    """Root schema of the velocity/normal scene."""

    scene: VelocityNormalSettings = field(default_factory=VelocityNormalSettings)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)

    def check(self) -> None:
        """Geometry and every mode's laws valid; the point on the annulus; lengths > 0."""
        self.geometry.check("geometry")
        s = self.scene
        require(len(s.modes) >= 1, "scene.modes", dict(s.modes), "needs at least 1 mode")
        for name, phases in s.modes.items():
            phases.check(f"scene.modes.{name}")
        require(0.0 <= s.R <= self.geometry.dR, "scene.R", s.R,
                f"must lie in [0, geometry.dR = {self.geometry.dR}]")
        require(math.isfinite(s.alpha_deg), "scene.alpha_deg", s.alpha_deg, "must be finite")
        check_angle_deg("scene.alpha_deg", s.alpha_deg)
        require(s.duration > 0.0 and math.isfinite(s.duration), "scene.duration", s.duration,
                "must be finite and > 0")
        require(2 <= s.frames <= 2000, "scene.frames", s.frames, "must lie in [2, 2000]")
        for name in ("normal_length", "velocity_scale", "magnification"):
            v = getattr(s, name)
            require(math.isfinite(v) and v > 0.0, f"scene.{name}", v, "must be finite and > 0")
        s.mesh.check("scene.mesh")
        s.media.check("scene.media")
