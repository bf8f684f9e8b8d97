"""Shared fixtures: the repository, and the EN-02 sphere problem built two ways.

``en02_problem`` restates EN-02 from docs/studies.md by hand, independently of conf/, so a
test comparing it with the composed config checks the config too; ``en02_config_problem``
is what the pipeline builds from conf/ (trajectory only: energy bookkeeping off).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest

from creatio.dynamics import Model, Sphere, SphereProblem, Start
from creatio.model.laws import Law
from creatio.model.surface import Motion, Surface

REPO = Path(__file__).resolve().parents[1]

# The shared worker that the tests' `snakemake` runs start (creatio.pipeline.worker) stops a
# minute after their last job instead of fifteen.
os.environ.setdefault("CREATIO_WORKER_IDLE", "60")
# No daemon started behind a test's back by its `creatio run` (creatio.pipeline.worker
# .autostart), and a report's figures drawn before the command returns, so that a test reads
# them at once; the worker's and the deferred figures' own tests set both themselves.
os.environ.setdefault("CREATIO_WORKER", "off")
os.environ.setdefault("CREATIO_FIGURES", "now")


@pytest.fixture(scope="session")
def repo() -> Path:
    """The repository root (where the Snakefile and conf/ live)."""
    return REPO


@pytest.fixture(scope="session")
def en02_problem() -> SphereProblem:
    """EN-02 by hand (docs/studies.md): notebook geometry R0 = 0.68, dR = 1.72, A = 0.18,
    Kr = 1, Ka = 6, gamma = 0, phi_r = 0, phi_a = 12 pi s(t / 120); m = 1, b = 0.12,
    g = 9.81, mu = 0.15, eps = 0.01; at rest at R = 0.43, alpha = pi/6 (a cavity bottom);
    RK4 at dt = 0.002 s for 120 s."""
    return SphereProblem(
        model=Model(
            surface=Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=6),
            motion=Motion(phi_r=Law.constant(0.0), phi_a=Law.quintic(0.0, 12.0 * math.pi, 120.0),
                          gamma=Law.constant(0.0)),
            sphere=Sphere(m=1.0, b=0.12, g=9.81, mu=0.15, eps=0.01),
        ),
        start=Start(R=0.43, alpha=math.pi / 6),
    )


@pytest.fixture(scope="session")
def en02r_problem(en02_problem: SphereProblem) -> SphereProblem:
    """EN-02R: phi_a = -12 pi s, phi_r = -pi s; the cavity follows R_c = 0.43 + 0.86 s."""
    return en02_problem.replace(phi_a=Law.quintic(0.0, -12.0 * math.pi, 120.0),
                                phi_r=Law.quintic(0.0, -math.pi, 120.0))


@pytest.fixture(scope="session")
def en02_config_problem() -> SphereProblem:
    """EN-02 as the pipeline composes it from conf/, trajectory only (energy off)."""
    from creatio.pipeline.config import resolve

    return resolve("en02").obj.sphere_problem().replace(energy=False)


# ------------------------------------------------------------------------------ test tiers
#: The second tier (marker ``long``: `make test-long`; CI runs it after `make test`): the
#: end-to-end tests (Snakemake, the CLI in subprocesses, SLURM, Chromium) and the numerical
#: tests that take seconds each (measured with `pytest --durations`). A whole module,
#: module::test (every parametrization of it) or module::test[id] (that one). Kept here, in
#: one list, rather than as decorators spread over the modules.
LONG = (
    "tests/workflow/test_slurm.py",
    "tests/workflow/test_workflow.py",
    "tests/scenes/test_browser.py",
    "tests/scenes/test_browser_family.py",
    "tests/workflow/test_scene_workflow.py",
    "tests/studies/test_en02g.py::test_en02g_at_zero_inclination_is_en02_bit_for_bit",
    "tests/studies/test_en02g.py::"
    "test_equilibrium_solves_jt_g_to_rounding_and_is_a_minimum",
    "tests/studies/test_en03m.py::"
    "test_base_pull_closes_the_energy_balance_like_gravity",
    "tests/studies/test_en03.py::test_en03_study_dataset_and_report",
    "tests/studies/test_en03.py::test_every_integrator_runs_the_structure",
    "tests/studies/test_en03.py::"
    "test_point_mass_estimate_approached_as_the_cavity_shrinks_and_stiffens",
    "tests/studies/test_boundaries.py::test_cli_help_lists_the_analysis_config",
    "tests/studies/test_boundaries.py::test_default_run_b_kappa_is_the_cavity_bottom_curvature",
    "tests/dynamics/test_simulation.py::test_frictionless_no_spin_and_auto_rotation_off",
    "tests/studies/test_en04.py::test_report_contract_on_short_cycles",
    "tests/studies/test_en05.py::test_a_synthetic_track_is_fitted_back_within_its_interval",
    "tests/model/test_flight.py::test_first_impact_time_and_apex_ratio",
    "tests/dynamics/solvers/test_radau_coefficients.py::"
    "test_linear_stiff_system_follows_its_tolerance_with_one_jacobian",
    "tests/dynamics/solvers/test_radau_coefficients.py::test_observed_orders_5_9_13_at_fixed_steps",
    "tests/dynamics/solvers/test_radau_coefficients.py::"
    "test_variable_order_agrees_with_radau5_and_scipy_at_a_common_tolerance",
    "tests/dynamics/solvers/test_solvers.py::test_observed_order_on_smooth_case",
    "tests/studies/test_sphere.py::test_trajectory_only_skips_what_it_does_not_need",
    "tests/studies/test_work_precision.py::test_tiny_run_end_to_end",
    "tests/pipeline/test_calibrate.py::"
    "test_point_list_runs_through_the_sweep_batches_and_reuses_points",
    "tests/pipeline/test_calibrate.py::test_the_en05_target_builds_everything_into_its_hash_dir",
    "tests/store/test_cf.py::test_no_high_priority_failure_on_any_kind_of_dataset",
    "tests/trust/test_hardening.py::"
    "test_run_help_presents_creatio_and_only_the_groups_a_user_picks",
    "tests/pipeline/test_sweep.py::test_sweep_workflow_batches_and_reruns_only_new_points",
    "tests/trust/test_trust.py::test_ctrl_c_inside_the_compiled_loop_exits_130_in_one_line",
    "tests/trust/test_trust.py::test_override_text_never_reaches_a_shell",
    "tests/trust/test_trust.py::test_quoted_values_work_end_to_end",
    "tests/trust/test_trust.py::test_sweep_values_with_shell_text_stay_text",
    "tests/scripts/test_scripts.py::test_radau_orders_quick",
    "tests/dynamics/solvers/test_solvers.py::test_dense_output_order_at_off_step_times",
    "tests/dynamics/solvers/test_solvers.py::test_harness_measures_the_native_error_on_the_same_solution",
    "tests/studies/test_en03m.py::"
    "test_normal_preload_work_closes_the_energy_balance",
    "tests/dynamics/test_simulation.py::test_stop_edge_crossed_and_left_annulus",
    "tests/trust/test_trust.py::"
    "test_an_env_interpolation_in_an_override_is_refused_in_one_line",
    "tests/trust/test_trust.py::test_beyond_builds_only_the_selected_studies",
    "tests/trust/test_trust.py::test_a_refused_scene_config_is_one_line",
    "tests/trust/test_trust.py::test_the_sweep_limit_has_a_ceiling",
    "tests/trust/test_trust.py::test_re_invoked_jobs_get_only_shell_inert_config_text",
    "tests/pipeline/test_worker.py::test_a_job_in_the_worker_writes_the_same_data_as_its_own_process",
    "tests/pipeline/test_worker.py::"
    "test_a_calibration_in_the_worker_writes_the_same_data_as_its_own_process",
    "tests/pipeline/test_worker.py::"
    "test_a_worker_killed_mid_job_stops_the_job_and_the_command_runs_alone",
    "tests/pipeline/test_worker.py::test_ctrl_c_of_a_served_job_exits_130_in_one_line",
    "tests/pipeline/test_worker.py::test_snakemake_jobs_run_in_the_shared_worker_across_invocations",
    "tests/pipeline/test_worker.py::test_a_refused_value_in_the_worker_is_one_line_and_exit_2",
    "tests/pipeline/test_worker.py::test_creatio_run_without_hydra_options_runs_as_the_hydra_app",
    "tests/store/test_forked.py::test_a_sphere_report_is_the_same_bytes_with_children_or_without",
    "tests/pipeline/test_worker.py::"
    "test_the_shared_worker_is_found_or_started_and_older_code_is_replaced",
    # the Radau IIA orders 9/13 and the controlled phase (each compiles a specialisation of
    # its own: 15-65 s apiece in the quick tier's --durations, load 2-3)
    "tests/dynamics/solvers/test_radau_high_order.py",
    "tests/dynamics/test_progress.py::test_budget_stops_a_run_without_changing_its_steps",
    "tests/model/test_control.py::test_energy_residual_rk4_order",
    # the control group's implicit and flight paths (each compiles specialisations of its
    # own) and its CLI refusals (subprocesses)
    "tests/dynamics/solvers/test_radau5.py::test_implicit_methods_agree_with_rk4",
    "tests/dynamics/solvers/test_flight.py",
    "tests/pipeline/test_config_control.py::test_refusal_is_one_line_exit_2",
    "tests/dynamics/solvers/test_radau_coefficients.py::test_dense_output_order_is_s_plus_1_off_the_steps",
    "tests/dynamics/solvers/test_radau_coefficients.py::test_order_switch_picks_higher_orders_at_tighter_tolerance",
    "tests/studies/test_en02g.py::test_a_short_cycle_leaves_its_cavity_yet_ends_ok",
    "tests/dynamics/test_simulation.py::"
    "test_trajectory_only_matches_full_run_when_frictionless",
    # the EN-04 scene's tests that compute a cut-down EN-04 control dataset (the controlled
    # path's compile, then 8-s runs) or start a browser
    "tests/scenes/test_scene_en04.py::test_the_scene_draws_the_studys_own_runs",
    "tests/scenes/test_scene_en04.py::test_the_recorded_path_is_the_runs_own",
    "tests/scenes/test_scene_en04.py::test_a_dataset_of_another_config_is_refused",
    "tests/scenes/test_scene_en04.py::test_the_page_draws_the_dataset_at_the_chosen_time",
    "tests/scenes/test_scene_en04.py::test_beyond_builds_the_scene_after_its_studys_dataset",
    # The quick tier compiles the default specialisations only (rk4 with rotation and
    # energy, the trajectory-only and sweep loops): a test that needs a rare one (an
    # implicit kind, flight, control, the structure, the high Radau orders) is here unless
    # it is its module's only test. Measured with an empty numba cache, --durations, load 6-8
    # on 2 cores (issue 39): the EN-02F flight run 342 s; the CF fixture of every dataset kind
    # (work-precision's implicit methods) 58 s; flight budget 25 s; radau5 / rodas4 dense
    # output 19 / 12 s; stiff collapse (radau5 with energy) 15 s; the structure's equations
    # 13 s; control 7 s; and the end-to-end ones: the Chromium bench of every scene 47 s,
    # Hydra's multirun in a subprocess 33 s, the EN-02 bench and the Radau theta scripts.
    "tests/trust/test_trust.py::test_a_run_whose_own_checks_are_absurd_never_ends_ok",
    "tests/store/test_cf.py::test_every_variable_has_a_long_name_and_units_udunits_reads",
    "tests/store/test_cf.py::test_plain_open_dataset_gives_time_in_seconds",
    "tests/dynamics/test_progress.py::test_budget_bounds_the_flight_loop",
    "tests/dynamics/test_progress.py::"
    "test_a_stiff_regularisation_collapses_in_seconds_not_a_budget_later",
    "tests/dynamics/solvers/test_solvers.py::"
    "test_adaptive_dense_output_meets_the_tolerance_in_fewer_steps[radau5]",
    "tests/dynamics/solvers/test_solvers.py::"
    "test_adaptive_dense_output_meets_the_tolerance_in_fewer_steps[rodas4]",
    "tests/studies/test_en03.py::test_equations_of_motion_against_high_order_differences",
    "tests/model/test_control.py::test_zero_lead_limit_keeps_the_sphere_at_its_bottom",
    "tests/scenes/test_bench_scene_family.py",
    "tests/pipeline/test_sweep.py::test_hydra_multirun_gives_the_same_aggregate",
    "tests/scripts/test_scripts.py::test_bench_en02_quick",
    "tests/scripts/test_scripts.py::test_radau_thet_one_setting",
    # every other quick test that ran a rare specialisation (their entry points recorded
    # per test: flight, control, the free structure, radau5, rodas4, the high Radau orders)
    *(f"tests/model/test_flight.py::test_{name}" for name in (
        "adaptive_method_locates_the_same_events", "contact_lost_without_flight_and_ok_with",
        "drop_has_no_spin_and_balance_closes", "elastic_frictionless_drop_loses_nothing",
        "en02f_builds_its_datasets_and_report",
        "events_that_do_not_advance_the_clock_end_the_run",
        "flight_energy_balance_closes_with_losses", "impact_cap_turns_bounces_into_contact",
        "separation_time_converges_at_fourth_order")),
    "tests/model/test_control.py::test_adaptive_methods_agree_with_rk4",
    *(f"tests/studies/test_en04_control.py::test_{name}" for name in (
        "actuation_figures_along_a_controlled_run_against_its_closed_forms",
        "arrival_rule_on_the_histories", "controller_beats_the_quintic_boundary",
        "mass_does_not_change_the_closed_loop",
        "the_compiled_servo_and_the_skipped_search_change_no_figure")),
    "tests/studies/test_sphere_control.py::test_energy_residual_converges_at_rk4_order",
    *(f"tests/studies/test_en03.py::test_{name}" for name in (
        "en03_defaults_conserve_hz_and_energy_to_rounding", "frictionless_leaves_the_spin_at_zero",
        "large_inertia_is_en02_to_its_timestep_difference")),
    *(f"tests/studies/test_en03m.py::test_{name}" for name in (
        "base_at_m_g_on_a_fixed_structure_is_en02", "en03m_study_dataset_and_report",
        "the_normal_preload_does_not_carry")),
    *(f"tests/dynamics/solvers/test_solvers.py::test_{name}" for name in (
        "a_step_the_integrator_cannot_take_stops_cleanly", "adaptive_methods_meet_their_tolerance",
        "radau5_accurate_far_beyond_the_explicit_limit",
        "radau5_step_is_set_by_the_slow_dynamics_at_large_mu",
        "scipy_peer_agrees_with_the_native_port",
        # compiles a probe of each implicit kind's workspace (33 s on a cold cache)
        "implicit_workspaces_are_laid_out_by_their_slot_names")),
    "tests/dynamics/test_progress.py::test_a_run_failing_at_its_first_step_has_one_row",
    # the CF module's fixture of every dataset kind runs work-precision's implicit methods
    *(f"tests/store/test_cf.py::test_{name}" for name in (
        "cf_xarray_and_pint_xarray_read_every_dataset",
        "read_dataset_gives_back_what_the_study_made",
        "one_unit_per_kind_of_angle_and_one_meaning_per_name")),
    *(f"tests/studies/test_stability_map.py::test_{name}" for name in (
        "break_scales_like_eps", "rk4_break_brackets_linear_limit", "run_resolved_end_to_end")),
    *(f"tests/studies/test_work_precision.py::test_{name}" for name in (
        "a_newly_registered_method_is_benchmarked_without_editing",
        "a_peer_that_is_not_installed_is_left_out_and_said_so",
        "harness_measures_the_native_error_on_the_same_solution")),
    # Issue 39 item 8, measured with an empty numba cache (CPU seconds, load 4-14): the
    # radau5 loops that the quick tier still compiled (h0's first step under radau5 21 s;
    # the stability map's radau5 reference, the module fixture of every mu_map test, 27 s),
    # the free structure's equations (2 s), and the end-to-end duplicates of a quick test
    # (another snakemake refusal, another damaged numba cache in a fresh process, the
    # kinematics bench script)
    "tests/dynamics/test_simulation.py::test_an_adaptive_run_takes_h0_as_its_first_step",
    *(f"tests/studies/test_stability_map.py::test_{name}" for name in (
        "break_scales_like_one_over_mu", "dop853_over_rk4_break_is_bound_ratio",
        "small_mu_rk4_is_accuracy_limited", "references_agree", "map_agrees_with_validation",
        "dataset_is_cf_annotated", "figure_takes_any_number_of_methods")),
    "tests/studies/test_en03.py::test_stability_limit_gains_the_structure_turn",
    "tests/trust/test_trust.py::test_garbage_in_a_numba_cache_entry_is_rebuilt",
    "tests/scripts/test_scripts.py::test_bench_kinematics_quick",
    *(f"tests/trust/test_boundary.py::test_snakemake_refuses_in_one_line_writing_nothing[{i}]"
      for i in ("args1-tol[0]='x=abc': must be", "args2-(did you mean en02?)",
                "args3-sphere.mu=-1.0: must be >= 0")),
    # and the rare loops that new quick tests compiled (same measurement): work-precision's
    # tiny fixture under CVODE's harness (the high Radau orders, 52 s), calibration's radau5
    # fits (24-31 s each), radau5's control Jacobian and dense-output kernels (8, 2 s), and
    # the EN-05 sample's ladder runs (10, 6 s) and its radau5 indices (33 s)
    "tests/studies/test_work_precision.py::"
    "test_cvode_harness_measures_the_native_error_on_the_same_solution",
    "tests/pipeline/test_calibrate.py::test_calibrate_the_example_track",
    "tests/pipeline/test_calibrate.py::"
    "test_mass_total_index_is_zero_within_the_estimators_noise_on_kinematic_outputs",
    "tests/dynamics/solvers/test_radau5.py::test_jacobian_control_columns_against_central_differences",
    "tests/dynamics/solvers/test_radau5.py::"
    "test_dense_output_order_against_the_collocation_polynomial",
    "tests/pipeline/test_points.py::test_a_deliberately_loose_rung_is_caught_on_the_check_and_tightened",
    "tests/pipeline/test_points.py::"
    "test_the_pilot_chooses_a_looser_rung_and_the_budget_holds_on_the_check",
    "tests/pipeline/test_points.py::"
    "test_indices_agree_with_the_configured_tolerance_within_their_intervals",
    "tests/pipeline/test_calibrate.py::"
    "test_a_fit_that_leaves_the_range_is_held_at_the_bound_and_never_printed",
    # Issue 39 item 8 again (which compiled loop each quick test called, recorded per test
    # at creatio.dynamics.jit.ensure_compiled): EN-05's fits and design run radau5 (its
    # trajectory loop compiled 45 s, load 4, in the round trip's module fixture), and h0's
    # check runs radau5 with energy (39 s)
    *(f"tests/studies/test_en05.py::test_{name}" for name in (
        "a_design_run_too_loosely_is_caught_and_tightened",
        "a_fit_counts_its_runs_and_most_are_cheap",
        "a_loose_rung_is_caught_by_the_check_and_tightened",
        "a_track_of_a_sticking_sphere_flags_both_keys_not_identifiable",
        "design_step_check_and_lost_runs_follow_the_runs",
        "intervals_cover_the_truth_about_95_percent_of_seeds",
        "cramer_rao_sigma_matches_the_spread_of_fitted_mu",
        "seeds_sharing_one_jacobian_agree_with_their_own_fits",
        "the_chosen_rung_is_within_the_noise_budget_on_the_check",
        "the_fast_fit_agrees_with_the_full_accuracy_fit_to_1e3_of_its_interval")),
    "tests/studies/test_schema_solver.py::test_a_configured_h0_is_the_first_step_each_run_takes",
    # and radau5 with energy in a sweep's absurd point, and in EN-05's raw-run rows
    "tests/trust/test_trust.py::test_a_sweep_point_with_absurd_checks_is_recorded_checks_failed",
    "tests/pipeline/test_points.py::"
    "test_a_point_row_from_the_raw_run_equals_the_outputs_of_its_dataset",
)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist starts its workers (its hook is trylast)
def pytest_sessionstart(session: pytest.Session) -> None:
    """Under pytest-xdist (`make test`), compile the default loops into numba's cache first,
    in two processes (tests/warm_loops.py): on a cold cache every worker would otherwise
    compile each of them itself. Best effort: a part that fails leaves its compile to the
    tests, which then say so on stderr as any run does."""
    import subprocess
    import sys

    config = session.config
    workers = getattr(config.option, "numprocesses", None)
    if not isinstance(workers, int) or workers < 2 or hasattr(config, "workerinput"):
        return
    script = str(REPO / "tests" / "warm_loops.py")
    parts = [subprocess.Popen([sys.executable, script, part], stdout=subprocess.DEVNULL)
             for part in ("full", "trajectory")]
    for p in parts:
        p.wait()


@pytest.hookimpl(tryfirst=True)  # before -m and -k deselect: every collected item is here
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the tests LONG names ``long``; an entry that names no test of a module collected
    whole is an error (a renamed test would otherwise move to the quick tier unseen)."""
    long_mark = pytest.mark.long
    used: set[str] = set()
    modules = set()
    for item in items:
        path = item.nodeid.split("::", 1)[0]
        name = item.nodeid.split("[", 1)[0]
        modules.add(path)
        for entry in (path, name, item.nodeid):
            if entry in LONG:
                item.add_marker(long_mark)
                used.add(entry)
    stale = [e for e in LONG if e not in used and e.split("::", 1)[0] in modules]
    if stale and not any("::" in str(a) for a in config.args):
        raise pytest.UsageError(f"tests/conftest.py LONG names what no test is: {stale}")
