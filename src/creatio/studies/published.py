"""Figures published in the CREATIO notebook, restated here so reports and tests can
compare against them without the notebook (maximum Euclidean errors unless stated).

Where the notebook's own code used approximate derivatives, its figures are upper bounds.
"""

from __future__ import annotations

import math
from decimal import Decimal


class Published(float):
    """A published figure: its value (a float, as tests compare it) and the digits the
    notebook prints (``1.110``), so that a report shows what the publication gives and how
    far the computation is from it. ``kind`` says how to read it: ``value`` (agrees when
    within half a unit of the last printed digit), ``bound`` (an upper bound: the notebook's
    code used approximate derivatives) or ``magnitude`` (rounding noise: the order of
    magnitude is what compares)."""

    text: str
    kind: str

    def __new__(cls, text: str, kind: str = "value") -> Published:
        if kind not in ("value", "bound", "magnitude"):
            raise ValueError(f"published figure {text}: unknown kind {kind!r}")
        obj = super().__new__(cls, float(text))
        obj.text, obj.kind = text, kind
        return obj

    def __reduce__(self) -> tuple:
        return (Published, (self.text, self.kind))

    @property
    def half_unit(self) -> float:
        """Half a unit of the last printed digit (1.110 -> 0.0005; 6.04e-11 -> 5e-14)."""
        exponent = Decimal(self.text).as_tuple().exponent
        return 0.5 * 10.0 ** int(exponent)

    @property
    def decimals(self) -> int:
        """Decimal places of the printed value in fixed notation (1.110 -> 3; -360 -> 0)."""
        return max(0, -int(Decimal(self.text).as_tuple().exponent))

    def verdict(self, computed: float) -> str:
        """How the computed value stands against this figure, in a few words."""
        if not math.isfinite(computed):
            return "not computed"
        if self.kind == "bound":
            return "below the bound" if computed < self else "ABOVE the bound"
        if self.kind == "magnitude":
            same = (computed == 0.0 == self) or (
                computed > 0 and self > 0 and abs(math.log10(computed / self)) < 1.0)
            return "same order" if same else "other order of magnitude"
        off = abs(computed - self)
        if off <= self.half_unit * (1 + 1e-9):
            return "agrees to the printed digits"
        return f"differs by {off / (2 * self.half_unit):.3g} units of the last digit"


def published_digits(values: dict[str, str], kind: str = "value") -> dict[str, Published]:
    """{key: Published} from the printed figures."""
    return {k: Published(v, kind) for k, v in values.items()}


# EN-01 derivative check: h -> (c_R, c_alpha [m], c_t [m/s]). Rows with h < 1e-4 are
# rounding-dominated and may differ in their leading digit.
EN01_FD_ERROR: dict[str, dict[str, Published]] = {
    name: published_digits(row) for name, row in {
        "c_R": {"0.01": "1.462e-04", "0.003": "1.316e-05", "0.001": "1.462e-06",
                "0.0003": "1.316e-07", "0.0001": "1.462e-08", "1e-05": "1.590e-10",
                "1e-06": "4.279e-10", "1e-07": "5.376e-09"},
        "c_alpha": {"0.01": "6.896e-04", "0.003": "6.207e-05", "0.001": "6.897e-06",
                    "0.0003": "6.207e-07", "0.0001": "6.897e-08", "1e-05": "7.400e-10",
                    "1e-06": "5.829e-10", "1e-07": "9.002e-09"},
        "c_t": {"0.01": "4.392e-06", "0.003": "3.953e-07", "0.001": "4.392e-08",
                "0.0003": "3.953e-09", "0.0001": "4.402e-10", "1e-05": "5.055e-11",
                "1e-06": "6.153e-10", "1e-07": "5.874e-09"},
    }.items()
}
# Smallest h whose row is truncation-dominated (compared digit for digit).
EN01_TRUNCATION_ROWS = ("0.01", "0.003", "0.001", "0.0003", "0.0001")

# EN-01 regularity (rounding noise: expect the order of magnitude, not the digits).
EN01_REGULARITY = {
    **published_digits({"normal_length_error": "3.33e-16", "normal_tangent_dot": "2.18e-16",
                        "j_identity_error": "1.34e-15"}, "magnitude"),
    "j_min": Published("0.50"),
}

# EN-01 pattern velocity over the EN-02 cycle.
EN01_PATTERN = {
    **published_digits({"pattern_max_rate_rad_s": "0.09817477",
                        "pattern_max_rate_time_s": "60", "pattern_travel_deg": "-360"}),
    "pattern_fd_error": Published("7.95e-11", "bound"),  # "agree to better than"
}

# EN-02 summary figures (timestep difference and energy residual are upper bounds).
EN02 = {
    **published_digits({"angular_displacement_deg": "-360", "final_radius_m": "1.110",
                        "min_normal_reaction_N": "9.810"}),
    **published_digits({"timestep_difference_m": "6.04e-11", "energy_residual_J": "1.48e-7"},
                       "bound"),
}

# The config keys EN-02's figures depend on (dotted prefixes): the published case is EN-02's
# default (mu 0.15, T 120 s, open loop, RK4 at dt 2 ms against dt / 2). Not among them: the
# title, the step budget, dense output and the stability override, which change no figure.
EN02_CASE = ("study.duration", "study.initial", "study.outputs", "geometry", "phases", "sphere",
             "control", "structure", "flight", "solver.method", "solver.dt", "solver.refine",
             "solver.output_interval", "solver.rtol", "solver.atol", "solver.fixed_step")
