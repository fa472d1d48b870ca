"""Test-suite configuration: the ``slow`` marker and the fast subset.

``python -m pytest -m "not slow"`` runs the fast subset (every test but those listed here:
the ones that took a second or more on the 2-core CI machine, mostly whole sweeps, tuning,
kill/resume and subprocess runs); ``python -m pytest`` runs everything.  The list is kept
here, in one place, rather than on each test: re-measure with ``python -m pytest
--durations=0`` and move a test in or out when its time changes.
"""

from __future__ import annotations

import os

import pytest

# The test workers keep every core busy: the force loop compiles in the process that needs
# it, not in a child beside it (which would compile the helpers it shares with the elements'
# ``init`` functions a second time).  tests/test_compile_aside.py runs the child on purpose.
os.environ.setdefault("ACC_COMPILE_IN_PROCESS", "1")

#: Test functions (every parametrisation) that are not in the fast subset, by module.
SLOW: dict[str, tuple[str, ...]] = {
    "test_compile_command.py": (
        "test_compiled_configurations_are_loaded_from_the_cache_by_a_later_process",
        "test_processes_that_need_a_new_configuration_at_once_compile_it_once",
    ),
    "test_compile_aside.py": (
        "test_a_new_configuration_is_compiled_by_a_child_and_loaded_by_the_parent",
    ),
    "test_sweep_checked.py": (
        "test_checked_build_equals_the_validated_one",
        "test_parallel_validation_gives_the_serial_outcome",
        "test_a_child_building_runs_that_raises_is_raised_here",
    ),
    "test_figure_process.py": (
        "test_forked_figure_equals_in_process_and_failure_is_one_line",
        "test_sweep_figures_are_drawn_by_the_second_process_as_in_process",
        "test_a_sweep_figure_failing_in_the_second_process_leaves_no_output",
    ),
    "test_figures.py": (
        "test_plot_gain_ratio_bars_labels_apart",
        "test_response_figure_force_per_revolution_under_tooth_passing",
        "test_metrics_figure_groups_by_kind_and_profile",
        "test_force_bands_figure_one_panel_per_profile",
        "test_plot_bode_margin_markers_distinct_per_curve",
        "test_servo_axis_figure_difference_panels",
        "test_disturbance_study_figure_keeps_the_largest_effects",
        "test_comparison_figure_estimates_only_for_kinds_with_an_estimator",
        "test_robust_design_pareto_names_inside_the_frame",
        "test_axis_response_figure_small_step_in_um_and_zoomed",
        "test_plot_force_bands_one_axes_many_groups",
        "test_response_figure_measured_drawn_over_the_force",
    ),
    "test_adaptive_pi.py": (
        "test_the_shipped_design_is_the_one_written_here",
    ),
    "test_adding_a_controller.py": (
        "test_kinds_are_listed_in_one_order_whichever_module_was_imported_first",
        "test_campaign_analysis_tuning_and_listing_see_it",
        "test_without_derivative_it_is_the_pi_run_for_run",
    ),
    "test_analysis.py": (
        "test_frd_margins_are_python_controls_stability_margins",
        "test_acc_analyze_writes_the_table_and_figures",
        "test_simulation_agrees_with_the_gain_ratio_boundary_on_both_sides",
        "test_written_margins_are_python_controls_on_the_returned_objects",
    ),
    "test_axis_analysis.py": (
        "test_briquez_reproduction_table1_equals_the_roots_of_eq2",
        "test_contour_error_of_a_line_equals_two_simulated_mismatched_axes",
        "test_kv_limit_separates_converging_from_diverging_runs",
        "test_fitted_integrator_gain_reproduces_the_printed_step",
        "test_type2_gain_limit_brackets_the_unit_circle",
    ),
    "test_axis_scenario.py": (
        "test_huron_axis_runs_and_its_kv_limit_is_analysed",
    ),
    "test_axis_servo.py": (
        "test_force_loop_on_the_servo_axis_equals_a_loop_written_here",
        "test_stiffness_against_cutting_torque_equals_the_static_balance",
    ),
    "test_breakage_in_loop.py": (
        "test_closed_loop_alarm_is_the_batch_detectors_on_the_recorded_signal",
        "test_faulted_force_in_the_loop_equals_the_batch_fault_model",
    ),
    "test_campaign.py": (
        "test_a_paired_sweep_simulates_with_the_paired_noise",
        "test_runs_paired_over_the_controller_share_draws_and_noise",
    ),
    "test_cli.py": (
        "test_acc_run_writes_summary_manifest_traces_and_figure",
    ),
    "test_cli_conventions.py": (
        "test_verbose_shows_debug_notes",
    ),
    "test_compare_contouring_strategies.py": (
        "test_quick_study",
    ),
    "test_comparison.py": (
        "test_hard_material_fixed_pi_oscillates_and_adaptive_pi_holds_as_analysis_says",
        "test_kinds_compared_see_the_same_noise_bit_for_bit",
        "test_table_rows_are_the_metrics_of_each_run_simulated_alone",
    ),
    "test_conformance.py": (
        "test_every_registered_element_has_a_case",
        "test_step_contract",
    ),
    "test_contour_scenario.py": (
        "test_acc_run_on_the_lacerda_circle_equals_simulate_xy",
        "test_zero_gain_cec_equals_the_independent_axes",
    ),
    "test_contour_tuning.py": (
        "test_pid_loop_spectral_radius_equals_simulated_growth",
        "test_ultimate_gain_bounds_the_simulated_p_loop",
    ),
    "test_depth_of_cut_identification.py": (
        "test_identification_error_with_noise_matches_linearised_prediction",
    ),
    "test_disturbance_observer.py": (
        "test_simulation_agrees_on_both_sides_of_the_boundary",
    ),
    "test_docs.py": (
        "test_api_pages_come_from_the_docstrings",
        "test_benchmark_tables_are_included_as_written",
        "test_key_reference_defaults_are_what_a_scenario_without_keys_gets",
        "test_key_reference_lists_every_key_of_every_lab",
        "test_notebooks_are_linked_not_executed",
        "test_site_builds_with_warnings_as_errors",
        "test_units_come_from_the_docstrings_or_the_key_names",
    ),
    "test_end_mill_geometry.py": (
        "test_instantaneous_closed_form_equals_axial_slices",
    ),
    "test_filtered_smith_predictor.py": (
        "test_perfect_model_reference_response_is_the_delay_free_loop_delayed",
    ),
    "test_fuzz_inputs.py": (
        "test_fuzz_campaign_files",
        "test_fuzz_gate_files",
        "test_fuzz_scenario_values_in_the_file_or_in_set",
    ),
    "test_gate.py": (
        "test_project_ci_gate_passes",
        "test_check_without_out_writes_nothing_in_the_working_directory",
    ),
    "test_gate_hardening.py": (
        "test_not_reached_is_nan_in_the_summary_the_report_and_the_gate",
    ),
    "test_geometric_loop.py": (
        "test_current_estimated_force_without_noise_regulates_the_true_force",
        "test_tooth_passing_force_averages_to_the_tooth_period_average",
        "test_without_edge_forces_the_geometric_loop_equals_the_table_loop_with_its_gain",
    ),
    "test_interrupts.py": (
        "test_a_real_sigint_during_a_gate_exits_130_in_one_line",
    ),
    "test_lab_campaigns.py": (
        "test_lab_sweep_killed_and_resumed_is_byte_identical",
        "test_the_sweep_parent_holds_a_bounded_window_of_chunks",
    ),
    "test_lacerda_high_speed_table.py": (
        "test_e1_1_at_25_m_min_is_feasible_on_the_high_speed_table",
    ),
    "test_linuxcnc.py": (
        "test_adaptive_feed_step_is_exact_in_time_and_ramps_at_half_the_acceleration",
        "test_closed_loop_settles_and_matches_the_prediction",
        "test_nothing_is_left_after_a_failure_or_a_timeout_kill",
        "test_exported_component_runs_the_controller_in_hal",
    ),
    "test_linuxcnc_config.py": ("test_component_on_a_standin_machine_is_the_prediction",),
    "test_linuxcnc_drive.py": (
        "test_force_loop_runs_the_planner",
        "test_force_loop_chip_load_behind_the_axis_lag_is_exact",
        "test_runs_of_different_drives_in_one_batch_are_the_runs_alone",
        "test_analyze_uses_and_states_the_small_signal_model",
    ),
    "test_linear.py": (
        "test_bode_nyquist_step_margin_run_on_the_objects",
    ),
    "test_notebooks.py": (
        "test_notebook_executes_and_draws",
    ),
    "test_observer_structures.py": (
        "test_observer_with_the_sensor_in_its_model_keeps_the_nominal_loop",
    ),
    "test_oracle_design.py": (
        "test_oracle_pi_is_the_tuner_on_the_cells_plant_alone",
    ),
    "test_packaging.py": (
        "test_wheel_installed_in_a_fresh_venv_runs_the_readme_main_job",
    ),
    "test_peng_contouring.py": (
        "test_velocity_feedforward_removes_the_ramp_error_of_its_own_axis",
    ),
    "test_python_control_recipe.py": (  # the module fixture runs the page's code (~4 s)
        "test_the_blocks_connect_and_the_loop_integrates",
        "test_the_margins_are_those_of_the_hand_loop",
        "test_the_bode_plot_spans_the_sampled_loop_and_draws_the_hand_phase",
    ),
    "test_reproduce_peng_contouring.py": (
        "test_validation_csv",
    ),
    "test_robust_design.py": (
        "test_no_simulated_kind_beats_the_bound",
        "test_study_quick_run_writes_its_outputs",
    ),
    "test_run_verdicts.py": (
        "test_dead_time_overload_gets_no_productivity",
    ),
    "test_servo_current_sensor_loop.py": (
        "test_inverse_model_regulates_the_previous_steps_feed_force_exactly",
        "test_steady_state_estimate_is_the_current_minus_the_viscous_tare_and_settles_on_the_force",
    ),
    "test_simulator.py": (
        "test_batch_of_n_runs_equals_n_single_runs",
    ),
    "test_study_tables.py": (
        "test_quick_run_writes_the_committed_tables_structure",
        "test_the_pages_command_reproduces_the_committed_table",
    ),
    "test_sweep.py": (
        "test_dask_backend_gives_the_same_summary",
        "test_resume_after_kill_gives_the_uninterrupted_summary",
        "test_sweep_with_traces_draws_force_bands_per_kind_and_profile",
    ),
    "test_sweep_hardening.py": (
        "test_a_raising_run_is_marked_failed_with_its_reason_and_the_sweep_finishes",
        "test_workers_exit_when_the_sweep_process_is_killed",
    ),
    "test_tune_options.py": (
        "test_analyze_writes_the_design_corners_with_python_controls_margins",
        "test_casadi_phase_margin_bound_is_met_or_refused_in_one_line",
        "test_tune_designs_over_the_design_section_and_the_flag_overrides_it",
    ),
    "test_tuning.py": (
        "test_worst_case_equals_python_controls_responses_and_margins",
        "test_acc_tune_exits_1_in_one_line_when_the_constraints_cannot_be_met",
        "test_casadi_tuner_improves_a_poor_start_and_meets_every_constraint",
        "test_unrolled_step_costs_equal_python_controls_sampled_responses",
    ),
    "test_typing.py": (
        "test_a_users_script_sees_the_documented_types",
        "test_public_modules_pass_mypy",
    ),
    "test_validation_limits.py": (
        "test_extreme_but_accepted_values_run_to_finite_metrics",
    ),
    "test_xy_table.py": (
        "test_uncoupled_axes_equal_single_axis_runs_bit_for_bit",
    ),
    "test_lab_verdicts.py": (
        "test_trace_csv_is_streamed_in_blocks_not_held_whole",
        "test_dry_friction_leaves_the_verdict_to_the_bounds",
    ),
    "test_report_columns.py": (
        "test_a_summary_read_a_column_at_a_time_reports_as_one_read_whole",
        "test_the_report_of_the_chosen_columns_is_that_of_the_whole_summary",
    ),
    "test_fuzz_lab_inputs.py": (
        "test_fuzz_lab_values_in_the_file_or_in_set",
    ),
    "test_cache_processes.py": (
        "test_four_processes_compiling_at_once_keep_all_four_specialisations",
    ),
    "test_python_entry.py": (
        "test_helper_has_no_python_entry_and_python_calls_go_to_a_cached_twin",
    ),
    "test_identification.py": (
        "test_round_trip_identify_then_acc_run",
        "test_intervals_cover_the_truth",
        "test_acc_excite_writes_a_schedule_that_identify_reads",
    ),
}


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "slow: not in the fast subset (pytest -m 'not slow')")
    config.addinivalue_line(
        "markers",
        "linuxcnc: runs LinuxCNC headless (skipped, with the reason, when it is not installed)",
    )


#: Modules whose tests take the most wall time together on the 2-core CI machine [s] (after
#: the install's ``acc compile``; re-measure with ``python -m pytest -n 3 --durations=0``).
#: Under xdist they start the workers' queues (see :func:`order_for_workers`).
HEAVY: dict[str, float] = {
    "test_linuxcnc.py": 42.0,  # real time: LinuxCNC runs its programs
    "test_docs.py": 35.0,
    "test_compile_command.py": 25.0,
    "test_tune_options.py": 20.0,
    "test_typing.py": 17.0,
    "test_analysis.py": 17.0,
    "test_notebooks.py": 16.0,
    "test_packaging.py": 14.0,
    "test_tuning.py": 10.0,
    "test_fuzz_lab_inputs.py": 9.0,
    "test_study_tables.py": 9.0,
    "test_filtered_smith_predictor.py": 9.0,
    "test_lab_verdicts.py": 8.0,
    "test_compile_aside.py": 7.0,
    "test_cache_processes.py": 7.0,
    "test_linear.py": 7.0,
}


def order_for_workers(items: list[pytest.Item], workers: int) -> list[pytest.Item]:
    """The collection reordered for ``workers`` xdist workers under ``--dist worksteal`` (the
    project's default, ``addopts`` in pyproject.toml).

    The scheduler hands each worker an equal count of consecutive tests, then moves tests
    from the end of the longest queue to a worker that ran out.  So each worker's share
    starts with its part of the :data:`HEAVY` modules (whole modules, dealt longest first to
    the least loaded share) and is filled up with the other tests in their order: the long
    tests start early, and the tail that is moved about at the end is short tests.  The order
    within a module is kept (its fixtures are set up once per worker).
    """
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(_module(item), []).append(item)
    heavy = sorted((m for m in modules if m in HEAVY), key=lambda m: -HEAVY[m])
    shares: list[list[pytest.Item]] = [[] for _ in range(workers)]
    load = [0.0] * workers
    for m in heavy:
        i = load.index(min(load))
        shares[i].extend(modules[m])
        load[i] += HEAVY[m]
    light = [item for m, its in modules.items() if m not in HEAVY for item in its]
    out: list[pytest.Item] = []
    for i, share in enumerate(shares):
        size = (len(items) - len(out)) // (workers - i)  # what the scheduler sends worker i
        fill = max(0, size - len(share))
        out += share + light[:fill]
        light = light[fill:]
    return out + light


def _module(item: pytest.Item) -> str:
    """The file name of a test's module (``""`` for a test without a path)."""
    return item.path.name if item.path is not None else ""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        module = _module(item)
        name = getattr(item, "originalname", None) or item.name
        if name in SLOW.get(module, ()):
            item.add_marker(pytest.mark.slow)
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))  # set in xdist's workers
    if workers > 1:
        items[:] = order_for_workers(items, workers)
