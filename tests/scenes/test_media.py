"""The animation's frames: drawn into one figure per process, each frame replacing only the
artists that move, they must show exactly what a fresh figure shows (no state of an earlier
frame may leak into a later one), and the membrane built as arrays must be what matplotlib's
own ``plot_surface(facecolors=...)`` draws."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from creatio.model.surface import Surface
from creatio.scenes import media
from creatio.scenes.config import resolve, route
from creatio.scenes.run import _read, write_scene_dataset

SMALL = ["scene.media.width=320", "scene.media.height=200"]


def _fresh(draw_into, size=(3.2, 2.0), dpi=100) -> np.ndarray:
    fig = media.plt.figure(figsize=size, dpi=dpi)
    try:
        draw_into(fig)
        return media._rgb(fig)
    finally:
        media.plt.close(fig)


@pytest.mark.parametrize("alpha", [1.0, 0.6])
def test_the_membrane_is_drawn_as_plot_surface_draws_it(alpha):
    """Same pixels as ``plot_surface(..., facecolors=, rstride=1, cstride=1, shade=True)``,
    the call the frames made before (and matplotlib's reference for a coloured surface)."""
    surf = Surface(0.5, 1.0, 0.08, 3, 4)
    pos, w = media.surface_mesh(surf, 0.7, -1.1, math.radians(20.0), 40, 9)
    assert np.ptp(w) > 1.0  # a corrugated surface: the colours vary over it

    def reference(fig) -> None:
        ax = media._frame_axes(fig, (0, 1), surf.R1 * 0.9)
        ax.plot_surface(pos[..., 0], pos[..., 1], pos[..., 2],
                        facecolors=media._HEIGHT((w + 1) / 2), rstride=1, cstride=1,
                        linewidth=0, edgecolor="none", antialiased=False, shade=True,
                        alpha=alpha, zorder=1)

    def ours(fig) -> None:
        media._draw_surface(media._frame_axes(fig, (0, 1), surf.R1 * 0.9), pos, w, alpha)

    want, got = _fresh(reference), _fresh(ours)
    assert (want != 255).any()  # something was drawn
    np.testing.assert_array_equal(got, want)


def _setup(scene: str, overrides: list[str], tmp_path: Path, monkeypatch):
    """The scene's frame drawing (what its media function hands to _render), its frame
    indices and the figure size, from a small dataset of the scene computed here."""
    r = resolve(scene, route(scene, [*SMALL, *overrides])[0])
    nc = write_scene_dataset(r, tmp_path / "scene.nc")
    ds, resolved = _read(nc)
    got = {}

    def capture(setup, indices, poster_index, m, *_):
        got.update(setup=setup, indices=list(indices), poster=poster_index,
                   size=(m.width / 100, m.height / 100))

    monkeypatch.setattr(media, "_render", capture)
    resolved.entry.media_function()(ds, resolved.obj, tmp_path / "a.webp", tmp_path / "p.png")
    return got


@pytest.mark.parametrize(("scene", "overrides"), [
    ("compare", ["scene.axes={}", "scene.media.every=20"]),
    ("surface_family", ["scene.media.every=30"]),
    ("velocity_normal", ["scene.media.every=30"]),
])
def test_a_frame_drawn_after_others_equals_it_drawn_alone(scene, overrides, tmp_path,
                                                           monkeypatch):
    """Every frame, drawn in order into one figure, equals that frame drawn into a fresh
    figure; and so does a frame drawn after a later one (the trace shrinks again)."""
    got = _setup(scene, overrides, tmp_path, monkeypatch)
    setup, indices, size = got["setup"], got["indices"], got["size"]
    assert len(indices) >= 3

    def alone(i: int) -> np.ndarray:
        return _fresh(lambda fig: setup(fig)(i), size)

    fig = media.plt.figure(figsize=size, dpi=100)
    try:
        draw = setup(fig)
        titles = media._Titles(fig)  # as _render draws them: the titles pasted
        order = [*indices, indices[0], got["poster"]]
        seen = []
        for i in order:
            draw(i)
            seen.append(titles.rgb())
    finally:
        media.plt.close(fig)
    fresh = {i: alone(i) for i in set(order)}
    assert not np.array_equal(fresh[indices[0]], fresh[indices[-1]])  # the frames differ
    for i, rgb in zip(order, seen, strict=True):
        np.testing.assert_array_equal(rgb, fresh[i], err_msg=f"{scene} frame {i}")


def test_titles_are_drawn_whole_over_another_background_or_when_they_change():
    """A frame with something drawn where a title sits, and a frame whose title changed,
    are drawn whole: every frame equals it drawn with its title, pasted or not."""

    def frame(fig, k: int, title: str) -> None:
        fig.clear()
        ax = fig.add_axes((0.1, 0.1, 0.8, 0.7))
        ax.plot([0, 1], [0, k])
        ax.set_title(title, y=1.02)  # placed as the scenes place theirs
        if k == 2:  # across the title
            fig.text(0.5, 0.84, "in the way", ha="center", color="red")

    fig = media.plt.figure(figsize=(3.2, 2.0), dpi=100)
    try:
        frame(fig, 0, "panel")
        titles = media._Titles(fig)
        seen = [titles.rgb()]
        for k in (1, 2, 3):
            frame(fig, k, "panel")
            titles.texts = [ax.title for ax in fig.axes if ax.title.get_text()]
            seen.append(titles.rgb())
        pasted = titles.pasted
        frame(fig, 4, "another panel")
        titles.texts = [ax.title for ax in fig.axes if ax.title.get_text()]
        seen.append(titles.rgb())
    finally:
        media.plt.close(fig)
    titled = ["panel"] * 4 + ["another panel"]
    for k, rgb in enumerate(seen):
        np.testing.assert_array_equal(rgb, _fresh(lambda f, k=k: frame(f, k, titled[k])),
                                      err_msg=f"frame {k}")
    assert pasted == 2 and not titles.static  # frames 1 and 3; frame 2 whole; then changed


def _decoded(data: bytes) -> np.ndarray:
    import io

    from PIL import Image

    im = Image.open(io.BytesIO(data))
    out = []
    for k in range(im.n_frames):
        im.seek(k)
        out.append(np.asarray(im.convert("RGB")).copy())
    return np.stack(out)


def test_animations_encoded_in_parts_play_as_one():
    """The parts the children encode, spliced, decode to every part's frames in order (each
    part's first frame replaces the whole canvas), loop and keep their frame time."""
    y, x = np.mgrid[0:64, 0:96]
    base = np.stack([2 * x, 3 * y, 120 + x - y], axis=-1).astype(np.uint8)  # smooth
    frames = []
    for k in range(9):  # a moving block over a fixed background: sub-frame updates
        f = base.copy()
        f[10:30, 5 + 8 * k:25 + 8 * k] = (200, 30, 30)
        frames.append(f)
    parts = [media._webp(frames[:4], 150, 70), media._webp(frames[4:], 150, 70)]
    whole = media._splice(parts)
    got = _decoded(whole)
    np.testing.assert_array_equal(got, np.concatenate([_decoded(p) for p in parts]))
    assert np.abs(got.astype(int) - np.stack(frames)).mean() < 10  # lossy, but these frames
    chunks = media._chunks(whole)
    assert [t for t, _ in chunks] == [b"VP8X", b"ANIM", *[b"ANMF"] * 9]
    assert {int.from_bytes(p[12:15], "little") for t, p in chunks if t == b"ANMF"} == {150}
    assert chunks[1][1][4:6] == b"\0\0"  # loops forever
    # A part whose first frame blends into what was shown cannot be spliced exactly.
    head, anim, first, *rest = media._chunks(parts[1])
    blended = first[1][:15] + bytes([first[1][15] & ~0b10]) + first[1][16:]
    bad = b"WEBP" + b"".join(media._chunk(t, p) for t, p in [head, anim, (b"ANMF", blended),
                                                              *rest])
    with pytest.raises(ValueError, match="unblended frame of the whole canvas"):
        media._splice([parts[0], b"RIFF" + len(bad).to_bytes(4, "little") + bad])
