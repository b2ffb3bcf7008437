"""The accuracy matrix's fast subset (experiments/accuracy.py; the whole matrix is
``benchmarks/bench_accuracy_matrix.py``, its page docs/results/accuracy_matrix.md).

Three cells of the covering design, rendered with truth, calibrated through their doors,
reported and scored: the defaults on a head whose encoder scale is off, with a ChArUco
board seen in part, through the command line (both doors, one file); the defaults on a
head whose tilt axis misses the pan axis, with an AprilGrid at positions ``rasc plan``
chose; and the scales held on the scale-error head, which the calibration must not call
usable. Each is checked for accuracy against its own σ (every quantity's d² within the χ²
quantile of its dimension at 1e-4), honesty (the normalized errors' spread), a verdict
that agrees, the report built, and the two doors' files equal.
"""

from __future__ import annotations

import numpy as np
import pytest

from experiments import accuracy as acc

pytestmark = pytest.mark.slow


def _cell(**levels) -> dict[str, str]:
    cells = [c for c in acc.covering_cells() if all(c[k] == v for k, v in levels.items())]
    assert cells, levels
    return cells[0]


def test_the_design_covers_every_pair_of_levels():
    cells = acc.covering_cells()
    valid = [c for c in (dict(zip(acc.FACTORS, combo, strict=True)) for combo in
                         __import__("itertools").product(*acc.FACTORS.values()))
             if acc._valid(c)]
    needed = set().union(*(acc._pairs(c) for c in valid))
    covered = set().union(*(acc._pairs(c) for c in cells))
    assert needed <= covered
    # the impossible pair is never asked for, and the design is far smaller than the
    # product (5 x 4 pairs of the two largest factors bound it from below)
    assert not any(c["target"] == "chessboard" and c["motion"] == "wide" for c in cells)
    assert 20 <= len(cells) <= 30 < len(valid)
    assert acc.covering_cells() == cells            # deterministic


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    cells = [_cell(head="encoder_scales", options="defaults", target="charuco", door="cli"),
             _cell(head="offset_skew", options="defaults", target="aprilgrid",
                   motion="planned"),
             _cell(head="encoder_scales", options="scales_hold")]
    return acc.run_matrix(tmp_path_factory.mktemp("matrix"), cells, seed=7, quiet=True,
                          log=lambda s: None)


def test_every_cell_passes_the_matrix_rule(results):
    for r in results:
        ok, why = acc.cell_passes(r)
        assert ok, (acc.cell_name(r.cell), why)
        assert r.report_pages and r.report_pages >= 4        # summary, head, parameters, ...
    assert results[0].doors_agree is True                    # the CLI door's file = Python's


def test_the_defaults_deliver_their_sigma(results):
    for r in results[:2]:
        s = r.score
        assert s.within_bounds is True, (acc.cell_name(r.cell), s.quantities)
        assert r.verdict == "usable", r.verdict_line
        # the scale-error head: the default estimated the scales (F far above 10)
        if r.cell["head"] == "encoder_scales":
            assert r.scales["estimated"] is True and r.scales["F"] > 100
    # honesty over the cells' compared parameters: normalized errors of unit spread (on
    # renders the σ are somewhat optimistic: the matrix measured RMS z 1.1-1.2)
    z = np.array([v for r in results[:2] for v in r.score.z.values()])
    assert len(z) >= 60
    assert np.mean(np.abs(z) <= 3.0) >= 0.95
    assert 0.5 <= np.sqrt(np.mean(z ** 2)) <= 1.6


def test_scales_held_on_a_scale_error_is_not_called_usable(results):
    r = results[2]
    assert r.cell["options"] == "scales_hold" and r.cell["head"] == "encoder_scales"
    assert r.scales["mode"] == "hold" and r.scales["F"] > 10
    assert r.verdict != "usable", r.verdict_line
    assert any("--scales hold" in w for w in r.warnings)


def test_the_lens_cells():
    """The lens factor on projected corners (experiments.accuracy.LENS_CELLS): every lens
    with its right model within its bounds and usable, unwarned; the 170° fisheye
    calibrated as a pinhole warned on both eyes and not called usable."""
    results = [acc.run_lens_cell(cell, seed=3) for cell in acc.LENS_CELLS]
    for r in results:
        ok, why = acc.lens_cell_passes(r)
        assert ok, (acc.lens_cell_name(r.cell), why)
        if r.cell.get("wrong"):
            assert acc.lens_warned(r) and r.verdict != "usable", r.verdict_line
            assert r.score.within_bounds is False          # what the warning is for
        else:
            assert r.verdict == "usable" and r.score.within_bounds is True, r.verdict_line
            assert not acc.lens_warned(r)
    table = acc.lens_markdown_table(results)
    assert table.count("| ok |") == len(acc.LENS_CELLS), table


def test_the_continuous_cells():
    """Continuous motion on projected corners (experiments.accuracy.CONTINUOUS_CELLS),
    calibrated with the defaults: δ estimated within its bounds, with an imperfect unit,
    a ChArUco board and a fisheye lens; δ held at 0 on a moving head not called usable.
    (The fisheye cell failed before the synthetic capture projected through the head's
    lens: it was projected as a pinhole, 61 mm of hand-eye error.)"""
    results = [acc.run_continuous_cell(cell, seed=5) for cell in acc.CONTINUOUS_CELLS]
    for r in results:
        ok, why = acc.continuous_cell_passes(r)
        assert ok, (acc.continuous_cell_name(r.cell), why)
        if r.cell.get("time_offset") == "hold":
            assert r.verdict != "usable" and "time offset (ms)" not in r.score.errors
            continue
        assert r.verdict == "usable" and r.score.within_bounds is True, r.verdict_line
        # δ to a few µs of its truth (the target: 1 ms), within its own bound
        assert abs(r.score.errors["time offset (ms)"]) < 0.02
        d2, bound, _ = r.score.quantities["time offset"]
        assert d2 <= bound
        assert max(r.score.errors[f"{e} hand-eye translation (mm)"]
                   for e in ("left", "right")) < 1.0
    table = acc.continuous_markdown_table(results)
    assert table.count("| ok |") == len(acc.CONTINUOUS_CELLS), table


def test_a_continuous_calibration_gives_point_sigmas(tmp_path):
    """A continuous calibration's covariance holds δ (time_offset): rasc triangulate's
    point sigmas read it (before: 'refinement.covariance.names: unknown parameter
    'time_offset''), and δ moves no point: the sigmas are those of the head's block."""
    from rasc.head.model import HeadCalibration
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.head.uncertainty import HeadCovariance, covariance_of_document, point_uncertainty
    from rasc.head.use import point_covariances
    from rasc.sim.synthetic import continuous_corner_dataset, default_head

    cal = calibrate_dataset(continuous_corner_dataset(default_head(), seed=2,
                                                      clock_offset=0.02),
                            CalibrationOptions())
    doc = acc._document(cal, tmp_path)
    path = tmp_path / "cal.json"
    path.write_text(__import__("json").dumps(doc))
    cov = covariance_of_document(doc)
    assert "time_offset" in cov.names
    head = HeadCalibration.from_dict(doc["head"])
    uv = np.array([[600.0, 450.0], [700.0, 520.0]])
    args = (head, uv, uv - [40.0, 0.0], np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2))
    unc, note = point_covariances(path, *args)
    assert note["calibration_covariance"] is True
    keep = [i for i, n in enumerate(cov.names) if n != "time_offset"]
    block = HeadCovariance(tuple(cov.names[i] for i in keep),
                           cov.matrix[np.ix_(keep, keep)], cov.sigma_px)
    alone = point_uncertainty(*args, pixel_sigma=note["pixel_sigma_px"], covariance=block)
    np.testing.assert_allclose(unc.sigma, alone.sigma, rtol=1e-9)
    assert unc.with_calibration and np.all(unc.calibration.diagonal(axis1=1, axis2=2) > 0)


def test_the_report_door_through_a_fisheye_and_a_continuous_capture():
    """The report of a fisheye calibration and of a continuous one: the parameter table
    names the lens (fisheye, dist_model fisheye) and δ ± σ (s); the residual page says it
    projected through the fisheye and read the pose images at time + δ; and the residuals
    are those of the lens: a fisheye head's own images (rasc.sim.synthetic.image_dataset,
    painted, the detector's error on them ~0.1 px) reproject within 0.3 px through it, and
    many times worse through the same K taken as a pinhole."""
    import dataclasses

    from rasc.head.model import HeadCalibration
    from rasc.head.pipeline import CalibrationOptions, calibrate_dataset
    from rasc.report.data import report_data
    from rasc.report.pdf import _parameter_rows, _residuals_how
    from rasc.sim.synthetic import continuous_corner_dataset, fisheye_head, image_dataset

    head = fisheye_head()
    cal = calibrate_dataset(continuous_corner_dataset(head, seed=4, clock_offset=0.015),
                            CalibrationOptions(dist_model="fisheye"))
    doc = acc._document(cal, "<projected>")
    rows, _ = _parameter_rows(doc)
    assert rows["left"][0] == rows["right"][0] == "lens fisheye (dist_model fisheye)"
    delta = [r for r in rows["head"] if r.startswith("time_offset")]
    assert len(delta) == 1 and " ± " in delta[0] and delta[0].endswith(" s"), rows["head"]
    value = float(delta[0].split()[1])
    assert abs(value - 0.015) < 1e-5
    how = _residuals_how(doc)
    assert "left fisheye, right fisheye" in how
    assert f"time + δ = {1e3 * value:.3f} ms" in how
    assert _residuals_how({"head": {"left": {}, "right": {}}}) == ""

    images = image_dataset(head, seed=1, n_intrinsics=3, poses_deg=((0, 0), (8, 8), (-8, 0)))
    true = HeadCalibration.from_truth(acc.synthetic_truth(head))
    rms = report_data(true, images).rms_by_role()
    assert rms["intrinsics"] < 0.3 and rms["pose"] < 0.3, rms
    as_pinhole = HeadCalibration(**{eye: dataclasses.replace(getattr(true, eye), lens="pinhole",
                                                             dist=np.zeros(5))
                                    for eye in ("left", "right")})
    wrong = report_data(as_pinhole, images).rms_by_role()
    assert wrong["pose"] > 10 * rms["pose"], (wrong, rms)


def test_a_refused_combination_is_refused_in_one_line():
    """Continuous motion rendered through a lens is refused (RenderOptions), in one line
    naming the field; the matrix's page prints it."""
    refused = acc.refused_combinations()
    assert list(refused) == ["continuous motion rendered through a fisheye"]
    line = refused["continuous motion rendered through a fisheye"]
    assert "\n" not in line and line.startswith("motion_speed_deg_s: ")
