"""A scene's animation (animated WebP) and poster (PNG), drawn with matplotlib from scene.nc.

matplotlib draws each frame (3D axes: the membrane from the frame's phases through
creatio.model.surface, the sphere with its marker and band turned by the frame's quaternion,
the trace so far coloured by time); Pillow, already installed with matplotlib, writes the
frames as one animated WebP. The poster is the frame at ``media.poster_time``, larger.
Nothing here computes physics: every number comes from the dataset.

A figure and its 3D axes are built once per process (they cost more than a frame's
drawing); each frame replaces only the artists that move (:class:`_Moving`), so a frame
shows what a fresh figure would show, pixel for pixel (tests/scenes/test_media.py).
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from creatio.model.laws import Law
from creatio.model.surface import Frame, Motion, Surface
from creatio.reports.common import plt
from creatio.store import forked
from creatio.store.atomic import atomic_path, atomic_save

__all__ = ["plain", "sphere_media", "surface_family_media", "velocity_normal_media"]


def plain(text: object) -> str:
    """Text matplotlib draws as written: a pair of ``$`` would start mathtext (a title like
    ``$\\frac$`` fails the whole animation), so each is escaped."""
    return str(text).replace("$", r"\$")


def _surface(ds: xr.Dataset, run: int | None = None) -> Surface:
    def get(name: str) -> float:
        return float(ds[name].values[run] if run is not None else ds.attrs[name])
    return Surface(get("R0"), get("dR"), get("A"), int(get("Kr")), int(get("Ka")))


def surface_mesh(surface: Surface, phase_r: float, phase_a: float, gamma: float,
                 n_alpha: int, n_R: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n_alpha, n_R, 3) and W / A of the surface at fixed phases (the model's)."""
    motion = Motion(Law.constant(phase_r), Law.constant(phase_a), Law.constant(gamma))
    alpha = np.linspace(0.0, 2.0 * math.pi, n_alpha)[:, None]
    R = np.linspace(0.0, surface.dR, n_R)[None, :]
    fr = Frame(surface, motion, alpha, R, 0.0)
    w = fr.w.W / surface.A if surface.A > 0 else 0.0 * fr.w.W
    return fr.position, w


_HEIGHT = plt.matplotlib.colors.LinearSegmentedColormap.from_list(
    "creatio_height", [(0.16, 0.35, 0.62), (0.86, 0.87, 0.85), (0.72, 0.45, 0.20)])


def _draw_surface(ax, pos: np.ndarray, w: np.ndarray, alpha: float = 1.0,
                  rgba: np.ndarray | None = None) -> Poly3DCollection:
    """The membrane coloured by height (or by ``rgba`` per vertex): what
    ``plot_surface(..., facecolors=, rstride=1, cstride=1, shade=True)`` draws (the same
    quads, corners in its order, each the colour of its first corner, shaded by the same
    light), built as arrays: plot_surface takes a per-quad Python loop and converts each
    colour alone when given facecolors."""
    quads = np.stack([pos[:-1, :-1], pos[:-1, 1:], pos[1:, 1:], pos[1:, :-1]], axis=2)
    colours = _HEIGHT((w[:-1, :-1] + 1) / 2) if rgba is None else rgba[:-1, :-1]
    poly = Poly3DCollection(quads.reshape(-1, 4, 3), facecolors=colours.reshape(-1, 4),
                            shade=True, linewidth=0, edgecolor="none", antialiased=False,
                            alpha=alpha, zorder=1)
    ax.add_collection3d(poly)
    return poly


class _Moving:
    """The artists of the frame on show, removed before the next frame draws its own."""

    def __init__(self) -> None:
        self.artists: list[Any] = []

    def add(self, *artists: Any) -> None:
        """Keep these (an artist, or the list ``ax.plot`` returns) to remove next frame."""
        for a in artists:
            self.artists.extend(a if isinstance(a, list) else [a])

    def clear(self) -> None:
        """Remove the last frame's moving artists from their axes."""
        for a in self.artists:
            a.remove()
        self.artists.clear()


def _frame_axes(fig, where: tuple[int, int], extent: float, title: str = ""):
    """3D axes filling panel where = (index, count) of a row of panels, below the title."""
    i, n = where
    ax = fig.add_axes((i / n, 0.0, 1.0 / n, 0.9), projection="3d")
    ax.set_xlim(-extent, extent)
    ax.set_ylim(-extent, extent)
    ax.set_zlim(-0.5 * extent, 0.5 * extent)
    ax.set_box_aspect((1, 1, 0.5), zoom=1.3 if n == 1 else 1.12)
    ax.view_init(elev=38, azim=-80)
    ax.set_axis_off()
    # Draw in the order of zorder (membrane, trace, sphere, marker), not by mean depth, which
    # puts a sphere resting in a cavity behind the membrane around it.
    ax.computed_zorder = False
    if title:
        ax.set_title(plain(title), fontsize=8.5, y=0.93)
    return ax


def _rgb(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


class _Titles:
    """The axes titles of an animation's figure, which its frames draw alike (a panel's
    name and directions): drawn once, then pasted into every frame drawn without them,
    instead of laid out and rendered glyph by glyph again (a fifth of EN-02's frame time).
    A pasted frame is the frame drawn with its titles, pixel for pixel: the paste covers
    each title's box and a margin, and is made only where the frame drawn without titles
    has there what the first frame had (else the frame is drawn whole); a figure whose
    titles change between frames is drawn whole every frame."""

    MARGIN = 4  # pixels around a title's box (its glyphs' antialiased edges)

    def __init__(self, fig) -> None:
        self.fig = fig
        self.texts = [ax.title for ax in fig.axes if ax.title.get_text()]
        self.kept: tuple[list, list, list, list, list] | None = None
        self.static = bool(self.texts)
        self.pasted = 0  # frames whose titles were pasted

    def _keys(self) -> list:
        return [(t.get_text(), t.get_fontsize(), str(t.get_color()), t.get_rotation())
                for t in self.texts]

    def _extents(self) -> list:
        """Where each title is drawn now (a draw may move one: 2D axes lift their titles
        over tick labels)."""
        renderer = self.fig.canvas.get_renderer()
        return [tuple(t.get_window_extent(renderer).bounds) for t in self.texts]

    def _bare(self) -> np.ndarray:
        for t in self.texts:
            t.set_visible(False)
        try:
            return _rgb(self.fig)
        finally:
            for t in self.texts:
                t.set_visible(True)

    def rgb(self) -> np.ndarray:
        """The frame on show as RGB, titles included."""
        if not self.static:
            return _rgb(self.fig)
        if self.kept is None:
            full = _rgb(self.fig)
            extents = self._extents()
            boxes = [_box(e, full.shape, self.MARGIN) for e in extents]
            bare = self._bare()
            self.kept = (self._keys(), extents, boxes, [full[b].copy() for b in boxes],
                         [bare[b].copy() for b in boxes])
            return full
        keys, extents, boxes, drawn, under = self.kept
        if self._keys() != keys:
            self.static = False
            return _rgb(self.fig)
        bare = self._bare()
        if self._extents() != extents or not all(
                np.array_equal(bare[b], u) for b, u in zip(boxes, under, strict=True)):
            return _rgb(self.fig)
        for b, d in zip(boxes, drawn, strict=True):
            bare[b] = d
        self.pasted += 1
        return bare


def _box(bounds: tuple[float, float, float, float], shape: tuple[int, ...],
         margin: int) -> tuple[slice, slice]:
    """Rows and columns of an image (top row first) covering a display box (x0, y0, width,
    height, origin at the bottom left), widened by margin pixels and cut to the image."""
    x0, y0, w, h = bounds
    height, width = shape[0], shape[1]
    top = max(0, height - math.ceil(y0 + h) - margin)
    bottom = min(height, height - math.floor(y0) + margin)
    left = max(0, math.floor(x0) - margin)
    right = min(width, math.ceil(x0 + w) + margin)
    return slice(top, bottom), slice(left, right)


#: libwebp's effort, 0 (fastest) to 6 (smallest), and no key frame but the first (kmax=0:
#: each frame is encoded as the change from the last, not also tried as a whole frame). An
#: animation plays from its start, so none is needed; with them and method 4, as before,
#: EN-02's frames took 2.5 times the CPU time for the same bytes (1.04 against 0.41 s for 50
#: frames, 0.617 MB either way; method 2 with key frames: 0.56 s, 0.644 MB).
WEBP_METHOD, WEBP_KMIN, WEBP_KMAX = 2, 0, 0
#: The animation is drawn and encoded in this many consecutive parts (in forked children
#: where cores are free), a fixed number: the file is the same bytes on every machine.
PARTS = 2


def _webp(frames: Sequence[np.ndarray], frame_ms: float, quality: int) -> bytes:
    """The frames as one looping animated WebP, every frame shown frame_ms."""
    from PIL import Image

    images = [Image.fromarray(f) for f in frames]
    out = io.BytesIO()
    images[0].save(out, format="WEBP", save_all=True, append_images=images[1:],
                   duration=max(20, round(frame_ms)), loop=0, quality=quality,
                   method=WEBP_METHOD, kmin=WEBP_KMIN, kmax=WEBP_KMAX)
    return out.getvalue()


def _png(rgb: np.ndarray) -> bytes:
    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(rgb).save(out, format="PNG", optimize=True)
    return out.getvalue()


def _chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    """(fourcc, payload) of every chunk of a RIFF WEBP file."""
    if data[:4] != b"RIFF" or data[8:12] != b"WEBP":
        raise ValueError("not a WebP file")
    out, at = [], 12
    while at + 8 <= len(data):
        size = int.from_bytes(data[at + 4:at + 8], "little")
        out.append((data[at:at + 4], data[at + 8:at + 8 + size]))
        at += 8 + size + (size & 1)
    return out


def _chunk(tag: bytes, payload: bytes) -> bytes:
    return tag + len(payload).to_bytes(4, "little") + payload + b"\0" * (len(payload) & 1)


def _splice(parts: Sequence[bytes]) -> bytes:
    """Consecutive animations of one canvas as one: the first's header (VP8X, ANIM), then
    every animation's frames (ANMF) in order. Exact, because libwebp starts an animation
    with a frame that covers the whole canvas and is not blended with what was shown (so
    each part's first frame shows what it showed alone); refused if a part does not."""
    head = _chunks(parts[0])
    if [t for t, _ in head[:2]] != [b"VP8X", b"ANIM"]:
        raise ValueError("an animated WebP starts with VP8X and ANIM chunks")
    vp8x, canvas = bytearray(head[0][1]), head[0][1][4:10]
    frames: list[bytes] = []
    for data in parts:
        chunks = _chunks(data)
        tags = [t for t, _ in chunks]
        anmf = [p for t, p in chunks if t == b"ANMF"]
        first = anmf[0] if anmf else b""
        if (tags != [b"VP8X", b"ANIM", *[b"ANMF"] * len(anmf)] or chunks[0][1][4:10] != canvas
                or first[:6] != bytes(6) or first[6:12] != canvas or not first[15] & 0b10):
            raise ValueError("a part does not start on an unblended frame of the whole canvas")
        vp8x[0] |= chunks[0][1][0]  # alpha if any part has it (the animation flag is set)
        frames += anmf
    body = b"WEBP" + _chunk(b"VP8X", bytes(vp8x)) + _chunk(b"ANIM", head[1][1]) + b"".join(
        _chunk(b"ANMF", f) for f in frames)
    return b"RIFF" + len(body).to_bytes(4, "little") + body


#: A scene's drawing: given a figure, build what every frame shares (axes, fixed titles)
#: and return the function that draws frame i into it (replacing the last frame's artists).
Setup = Callable[[Any], Callable[[int], None]]


def _render(setup: Setup, indices: Sequence[int], poster_index: int,
            media: Any, frame_ms: float, animation: Path, poster: Path) -> None:
    """Draw each index into one figure of the media size per process, built once, and
    encode; the poster into its own figure at twice the dpi."""
    size = (media.width / 100, media.height / 100)

    def draw_all(at: Sequence[int], dpi: int = 100) -> list[np.ndarray]:
        fig = plt.figure(figsize=size, dpi=dpi)
        try:
            draw = setup(fig)
            titles = _Titles(fig)
            drawn = []
            for i in at:
                draw(i)
                drawn.append(titles.rgb() if len(at) > 1 else _rgb(fig))
            return drawn
        finally:
            plt.close(fig)

    # The parts and the poster are independent: each drawn (and encoded) by a forked child
    # where a core is free (creatio.store.forked), handed back as a file beside the
    # animation; spliced here in order. The poster is a task of its own: drawn by the last
    # part, as before, it made that part the job's longest by a poster's time.
    n = max(1, min(PARTS, len(indices) // 8))
    shares = [list(indices[k * len(indices) // n:(k + 1) * len(indices) // n]) for k in range(n)]
    # temporaries of creatio.store.atomic: a killed job's are cleaned by the next write
    tmps = [atomic_path(animation, f"-part{k}") for k in range(n + 1)]  # the last: poster's
    done: dict[int, bytes] = {}

    def part(k: int) -> None:
        if k == n:
            data = _png(draw_all([poster_index], dpi=200)[0])
        else:
            data = _webp(draw_all(shares[k]), frame_ms, media.quality)
        if k == 0:
            done[k] = data
        else:
            tmps[k].write_bytes(data)

    try:
        forked.run_all([lambda k=k: part(k) for k in range(n + 1)])
        data = [done[j] if j in done else tmps[j].read_bytes() for j in range(n + 1)]
    finally:
        for tmp in tmps:
            tmp.unlink(missing_ok=True)
    atomic_save(animation, lambda tmp: tmp.write_bytes(_splice(data[:n])))
    atomic_save(poster, lambda tmp: tmp.write_bytes(data[n]))


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


# --------------------------------------------------------------------------- sphere scenes
#: Colours of the membrane of run r at frame i on a mesh (alpha, R): RGBA (alpha, R, 4).
Paint = Callable[[int, int, np.ndarray, np.ndarray], np.ndarray]


def sphere_media(ds: xr.Dataset, cfg: Any, animation: Path, poster: Path,
                 paint: Paint | None = None, legend: Callable[[Any], None] | None = None
                 ) -> None:
    """Animation and poster of a sphere scene: one panel per run, one shared clock; the
    membrane coloured by height, or by ``paint`` with ``legend`` drawing its key once."""
    s = cfg.scene
    runs = [str(r) for r in ds.run.values]
    times = ds.time.values
    draw_set = {str(x) for x in s.draw}
    n_alpha, n_R = max(24, s.mesh.n_alpha * 2 // 5), max(6, s.mesh.n_R // 2)
    surfaces = [_surface(ds, r) for r in range(len(runs))]
    cmap = plt.get_cmap("viridis")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
    unit = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    ring = np.stack([np.cos(np.linspace(0, 2 * np.pi, 40)), np.sin(np.linspace(0, 2 * np.pi, 40)),
                     np.zeros(40)], axis=-1)

    # What every frame reads, taken out of the dataset once; the trace's colours by time.
    title = plain(ds.attrs.get("title", ""))
    centre = ds.centre.values
    phases = np.stack([ds[n].values for n in ("phase_r", "phase_a", "inclination")], axis=-1)
    last = ds.frames_run.values.astype(int) - 1
    radius = ds.sphere_radius.values.astype(float)
    quaternion = ds.quaternion.values if "quaternion" in ds else None
    colours = cmap(times / times[-1])
    panels = [f"{name.upper()}\n" + str(ds.direction.values[r]).replace(", ", "\n")
              for r, name in enumerate(runs)]

    def setup(fig) -> Callable[[int], None]:
        axes = [_frame_axes(fig, (r, len(runs)), surfaces[r].R1 * 0.92, panel)
                for r, panel in enumerate(panels)]
        moving = _Moving()
        if legend is not None:
            legend(fig)
        mesh_alpha = np.linspace(0.0, 2.0 * math.pi, n_alpha)
        mesh_R = [np.linspace(0.0, surf.dR, n_R) for surf in surfaces]

        def draw(i: int) -> None:
            moving.clear()
            fig.suptitle(f"{title}   t = {float(times[i]):5.1f} s", fontsize=10)
            for r, ax in enumerate(axes):
                k = min(i, int(last[r]))
                if "membrane" in draw_set:
                    pos, w = surface_mesh(surfaces[r], *map(math.radians, phases[r, i]),
                                          n_alpha, n_R)
                    rgba = None if paint is None else paint(r, i, mesh_alpha, mesh_R[r])
                    moving.add(_draw_surface(ax, pos, w, alpha=0.85, rgba=rgba))
                c = centre[r]
                if "trace" in draw_set and k > 0:
                    moving.add(ax.scatter(c[: k + 1, 0], c[: k + 1, 1], c[: k + 1, 2] + 0.01,
                                          s=3, c=colours[: k + 1], depthshade=False, zorder=2))
                b = float(radius[r])
                rot = _quat_matrix(quaternion[r, k]) if quaternion is not None else np.eye(3)
                if "sphere" in draw_set:
                    ball = c[k] + b * unit
                    moving.add(ax.plot_surface(ball[..., 0], ball[..., 1], ball[..., 2],
                                               color="0.88", linewidth=0, shade=True, zorder=3))
                if "marker" in draw_set:
                    tip = c[k] + rot @ np.array([0.0, 0.0, 2.0 * b])
                    moving.add(ax.plot(*zip(c[k], tip, strict=True), color="#d1342f", lw=2.2,
                                       zorder=4))
                if "band" in draw_set:
                    band = c[k] + 1.01 * b * ring @ rot.T
                    moving.add(ax.plot(band[:, 0], band[:, 1], band[:, 2], color="#1f6fd1",
                                       lw=1.8, zorder=4))
        return draw

    every = s.media.every
    indices = list(range(0, times.size, every))
    if indices[-1] != times.size - 1:
        indices.append(times.size - 1)
    poster_index = int(np.argmin(np.abs(times - s.media.poster_time)))
    frame_ms = 1000.0 * every / s.playback.fps
    _render(setup, indices, poster_index, s.media, frame_ms, animation, poster)


# ----------------------------------------------------------------------- kinematic scenes
def surface_family_media(ds: xr.Dataset, cfg: Any, animation: Path, poster: Path) -> None:
    """The family swept from the first to the last inclination; poster at poster_time deg."""
    s = cfg.scene
    surf = _surface(ds)
    incl = ds.inclination.values
    pr, pa = math.radians(ds.phase_r), math.radians(ds.phase_a)  # stored in degree
    n_alpha, n_R = max(24, s.mesh.n_alpha // 2), max(6, s.mesh.n_R // 2)

    title = plain(ds.attrs.get("title", ""))

    def setup(fig) -> Callable[[int], None]:
        ax = _frame_axes(fig, (0, 1), surf.R1 * 0.8)
        ax.set_zlim(-0.2 * surf.R1, 0.8 * surf.R1)
        moving = _Moving()

        def draw(k: int) -> None:
            moving.clear()
            pos, w = surface_mesh(surf, pr, pa, math.radians(float(incl[k])), n_alpha, n_R)
            moving.add(_draw_surface(ax, pos, w))
            fig.suptitle(f"{title}\ngamma = {incl[k]:.0f} deg: {ds.surface_class.values[k]}",
                         fontsize=10)
        return draw

    indices = list(range(0, incl.size, s.media.every))
    poster_index = int(np.argmin(np.abs(incl - s.media.poster_time)))
    _render(setup, indices, poster_index, s.media, 1000.0 / 12, animation, poster)


def velocity_normal_media(ds: xr.Dataset, cfg: Any, animation: Path, poster: Path) -> None:
    """One panel per mode: the surface, the point, its normal (blue) and velocity (red)."""
    s = cfg.scene
    surf = _surface(ds)
    modes = [str(m) for m in ds.mode.values]
    times = ds.time.values
    n_alpha, n_R = max(24, s.mesh.n_alpha // 2), max(6, s.mesh.n_R // 2)
    scale = s.velocity_scale * s.magnification

    title = plain(ds.attrs.get("title", ""))
    phases = np.stack([ds[n].values for n in ("phase_r", "phase_a", "inclination")], axis=-1)
    speed, position = ds.speed.values, ds.position.values
    normal, velocity = ds.normal.values, ds.velocity.values

    def setup(fig) -> Callable[[int], None]:
        axes = [_frame_axes(fig, (m, len(modes)), surf.R1 * 0.8) for m in range(len(modes))]
        moving = _Moving()

        def draw(i: int) -> None:
            moving.clear()
            fig.suptitle(f"{title}   t = {times[i]:4.2f} s   (normal {s.normal_length} u; "
                         f"velocity x{s.magnification:g})", fontsize=10)
            for m, (mode, ax) in enumerate(zip(modes, axes, strict=True)):
                ax.set_title(plain(f"{mode}: |c_t| = {float(speed[m, i]):.3f} u/s"),
                             fontsize=8.5, y=0.93)
                pos, w = surface_mesh(surf, *map(math.radians, phases[m, i]), n_alpha, n_R)
                moving.add(_draw_surface(ax, pos, w, alpha=0.6))
                p = position[m, i]
                nv = p + s.normal_length * normal[m, i]
                vv = p + scale * velocity[m, i]
                moving.add(ax.plot(*zip(p, nv, strict=True), color="#1f6fd1", lw=2.4, zorder=3),
                           ax.plot(*zip(p, vv, strict=True), color="#d1342f", lw=2.4, zorder=3),
                           ax.scatter(*p, color="k", s=12, depthshade=False, zorder=4))
        return draw

    indices = list(range(0, times.size, s.media.every))
    poster_index = int(np.argmin(np.abs(times - s.media.poster_time)))
    frame_ms = 1000.0 * (times[1] - times[0]) * s.media.every
    _render(setup, indices, poster_index, s.media, frame_ms, animation, poster)
