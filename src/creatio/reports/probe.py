"""`creatio probe`: the notebook's velocity/normal explorer at one point, as a text table."""

from __future__ import annotations

import numpy as np

from creatio.model.surface import Frame, Motion
from creatio.studies.schema import ProbeConfig

__all__ = ["probe_table"]


def probe_table(p: ProbeConfig) -> str:
    """Position, velocity c_t, unit normal and J at (alpha in degrees, R, t) of a surface."""
    surface = p.geometry.surface()
    motion = Motion(*p.phases.laws())
    fr = Frame(surface, motion, np.deg2rad(p.alpha), p.R, p.t)
    pr, pa, gm = motion.at(p.t)
    vel = fr.c_t
    rows = [
        ("point", f"alpha = {p.alpha:g} deg, R = {p.R:g} u, t = {p.t:g} s"),
        ("phases", f"phi_r = {float(pr.value):.6g} rad, phi_a = {float(pa.value):.6g} rad, "
                   f"gamma = {np.rad2deg(float(gm.value)):.6g} deg"),
        ("position c (u)", _vec(fr.position)),
        ("velocity c_t (u/s)", _vec(vel)),
        ("|velocity| (u/s)", f"{float(np.linalg.norm(vel)):.9g}"),
        ("unit normal n (1)", _vec(fr.normal)),
        ("J (u)", f"{float(fr.J):.9g}"),
        ("u", f"the notebook's model length unit (R0 = {surface.R0:g} u, dR = "
              f"{surface.dR:g} u): lengths here are multiples of it, not metres"),
    ]
    if not 0.0 <= p.R <= surface.dR:
        rows.append(("note", f"R = {p.R:g} lies outside [0, dR = {surface.dR:g}]: "
                             "the formula is extended beyond the annulus"))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def _vec(v) -> str:
    return "(" + ", ".join(f"{float(x): .9f}" for x in v) + ")"
