"""Figures published in the CREATIO notebook, restated here so reports and tests can
compare against them without the notebook (maximum Euclidean errors unless stated).

Where the notebook's own code used approximate derivatives, its figures are upper bounds.
"""

from __future__ import annotations

# EN-01 derivative check: h -> (c_R, c_alpha [m], c_t [m/s]). Rows with h < 1e-4 are
# rounding-dominated and may differ in their leading digit.
EN01_FD_ERROR: dict[str, dict[str, float]] = {
    "c_R": {"0.01": 1.462e-04, "0.003": 1.316e-05, "0.001": 1.462e-06, "0.0003": 1.316e-07,
            "0.0001": 1.462e-08, "1e-05": 1.590e-10, "1e-06": 4.279e-10, "1e-07": 5.376e-09},
    "c_alpha": {"0.01": 6.896e-04, "0.003": 6.207e-05, "0.001": 6.897e-06, "0.0003": 6.207e-07,
                "0.0001": 6.897e-08, "1e-05": 7.400e-10, "1e-06": 5.829e-10,
                "1e-07": 9.002e-09},
    "c_t": {"0.01": 4.392e-06, "0.003": 3.953e-07, "0.001": 4.392e-08, "0.0003": 3.953e-09,
            "0.0001": 4.402e-10, "1e-05": 5.055e-11, "1e-06": 6.153e-10, "1e-07": 5.874e-09},
}
# Smallest h whose row is truncation-dominated (compared digit for digit).
EN01_TRUNCATION_ROWS = ("0.01", "0.003", "0.001", "0.0003", "0.0001")

# EN-01 regularity (rounding noise: expect the order of magnitude, not the digits).
EN01_REGULARITY = {
    "normal_length_error": 3.33e-16,
    "normal_tangent_dot": 2.18e-16,
    "j_identity_error": 1.34e-15,
    "j_min": 0.50,
}

# EN-01 pattern velocity over the EN-02 cycle.
EN01_PATTERN = {
    "pattern_max_rate_rad_s": 0.09817477,
    "pattern_max_rate_time_s": 60.0,
    "pattern_travel_deg": -360.0,
    "pattern_fd_error": 7.95e-11,  # an upper bound: "agree to better than"
}

# EN-02 summary figures (timestep difference and energy residual are upper bounds).
EN02 = {
    "angular_displacement_deg": -360.0,
    "final_radius_m": 1.110,
    "min_normal_reaction_N": 9.810,
    "timestep_difference_m": 6.04e-11,
    "energy_residual_J": 1.48e-7,
}
