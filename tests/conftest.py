"""What every room shares: the test order and the ``slow`` marker (this file), and where
each room's rig comes from.

The tests stand in room folders (tests/<room>/), each with a conftest.py naming the
fixtures its tests use; a room without one uses none. Beside them, four helper modules
(tests/ is on sys.path through this conftest, so any test module imports them):

- :mod:`nominal_rig`: the nominal rig (``R_CAM_FROM_GAZE_NOMINAL``, ``PAPER``, ``rig``,
  ``random_rigid``, ``pan_tilt``, ``plausible_head``, ``HEAD_IMAGE_SIZE``), plain
  functions the solver and head tests import (``from nominal_rig import PAPER, rig``).
- :mod:`running`: ``python_rasc`` (``python -m rasc`` in a subprocess), ``run_rasc``
  (``rasc`` in this process), ``pip_build_flags``, ``marked_processes``.
- :mod:`shared_fixtures`: the fixtures several rooms use, and the run's shared folder
  and file lock (``shared_root``, ``locked``) for work done once per run.
- :mod:`json_strategies`: ``json_documents``, hypothesis strategies for the JSON readers.

Which room's conftest has which fixture (* defined there, the others from
shared_fixtures):

| room | fixtures |
| --- | --- |
| cli | rasc_cli, default_dataset, default_cli_run |
| docs | rasc_testing_cache |
| e2e | default_dataset, default_calibration, quick_experiments* |
| handeye | rasc_cli, rasc_testing_cache, my_solver_site* |
| head | rasc_cli, detections_counted, default_dataset, default_calibration |
| export, recordings, report | rasc_cli |
| stereo | rasc_cli, default_dataset, default_calibration, gaze_pairs* |
| study | default_dataset, default_calibration, short_tmp* |
| vision | rasc_cli, detections_counted, default_dataset, default_cli_run |
| geometry, io, project, sim | (none) |

Marker ``slow`` (registered in pyproject.toml): tests that take a second or more each
(renders, experiments, subprocesses, large property tests); every test that uses one of
the rendered default dataset's fixtures (``DATASET_FIXTURES``) gets it automatically.
``make test-fast`` (``-m "not slow"``) leaves them out. Slow tests are collected first
(see ``pytest_collection_modifyitems``), so that under pytest-xdist the long ones start
early and the short ones fill in around them.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import pytest  # noqa: E402

#: A test using any of these needs the rendered default dataset: it is ``slow``.
DATASET_FIXTURES = frozenset({"default_dataset", "default_cli_run", "default_calibration",
                              "quick_experiments"})


#: The longest tests, longest first (wall seconds each, measured in one whole run on
#: 2026-11-23; ``pytest --durations=30`` lists them): they run before the other slow
#: tests. Only the order depends on this list; a test missing from it, or
#: listed and gone, changes nothing else.
LONGEST_FIRST = (
    "test_doc_examples.py::test_page_examples_run",   # the pages: 2-25 s each (renders)
    "test_reproduce.py::test_same_seed_same_bytes_for_any_worker_count",                # 12.6
    "test_cli_render_calibrate.py::test_distortion_is_rendered_and_recovered",           # 9.1
    "test_study.py::test_process_pool_and_dask_localcluster_give_the_same_bytes",        # 9.0
    "test_cli_render_calibrate.py::test_noise_and_blur_still_calibrate",                 # 8.1
    "test_study_pose_sets.py::test_a_study_run_twice_renders_once",                      # 7.2
    "test_hostile.py::test_refusal_session_is_true",                            # 7.1
    "test_refine.py::test_predicted_std_matches_the_spread_of_20_renoised_refinements",  # 6.9
    "test_packaging.py::test_wheel_installs_renders_and_calibrates_away_from_the_checkout",
    "test_experiments_e1_e3.py::test_e1_files_rows_and_report",                          # 5.9
    "test_sim_render.py::test_corners_match_projection_at_the_nine_paper_poses",         # 5.3
    "test_e7.py::test_offset_breaks_the_paper_model_and_the_refinement_recovers",        # 4.9
    "test_sim_render.py::test_head_geometry_stays_out_of_the_cameras_views",             # 4.8
    "test_study_keys.py::test_error_against_tilt_axis_offset_grows_for_the_paper_model",  # 4.5
    "test_study.py::test_study_writes_tidy_samples_summary_and_figures",                 # 3.4
    "test_study.py::test_interrupted_study_keeps_finished_cells_and_resumes_to_the_same_bytes",
)
_LONGEST_RANK = {name: rank for rank, name in enumerate(LONGEST_FIRST)}


def _schedule_key(item) -> tuple[bool, int]:
    # "room/test_x.py::test_y" -> "test_x.py::test_y" (module names are unique in tests/)
    path, _, test = item.nodeid.split("[")[0].partition("::")
    name = f"{path.rsplit('/', 1)[-1]}::{test}"
    return item.get_closest_marker("slow") is None, _LONGEST_RANK.get(name, len(LONGEST_FIRST))


def pytest_collection_modifyitems(config, items):
    for item in items:
        if DATASET_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
    # Slow tests first, the longest of them (LONGEST_FIRST) before the others (a stable
    # sort: otherwise pytest's order, the same on every xdist worker, as xdist requires):
    # the run's wall time is bounded by the test that starts last plus its length, so the
    # long ones should start while the short ones can still fill the other worker
    # (longest-first scheduling; with `--dist worksteal`, see the Makefile, an idle worker
    # takes the second half of a busy one's pending tests, so what runs last is a short
    # test from the middle of this order, not a study test of 9 s at its end).
    items.sort(key=_schedule_key)
