"""The benchmark's arithmetic (convergence.py): when a curve of error
against time reaches an error, and the time-to-clean table built on it.
The benchmark itself prints figures and is no test; these are its sums."""

import math

import pytest

import numpy as np

from convergence import CLEAN_LEVELS, black_relmse, clean_image_table, glint_setup_seconds, peer_rows, relative_time_scatter, time_to_level, time_to_reach

# Error halving as time doubles: an unbiased estimator's 1/time law.
CURVE = [(1.0, 0.1), (2.0, 0.05), (4.0, 0.025)]


def test_a_level_on_the_curve_is_interpolated_log_log():
    t, extrapolated = time_to_level(CURVE, 0.07)
    # On a 1/time curve log–log interpolation is exact: t = 0.1/0.07.
    assert t == pytest.approx(0.1 / 0.07, rel=1e-9)
    assert not extrapolated


def test_a_level_above_the_first_point_takes_the_first_points_time():
    assert time_to_level(CURVE, 0.5) == (1.0, False)


def test_a_level_below_the_last_point_follows_the_one_over_time_law_and_is_flagged():
    t, extrapolated = time_to_level(CURVE, 0.001)
    assert t == pytest.approx(4.0 * 0.025 / 0.001)
    assert extrapolated
    # time_to_reach alone stops at the curve's end.
    assert time_to_reach(CURVE, 0.001) is None


def test_an_empty_curve_never_reaches_a_level():
    assert time_to_level([], 0.01) == (None, False)


def test_the_table_gives_each_renderers_time_and_glints_lead():
    rows = [{"renderer": "glint", "seconds": t, "relmse": e} for t, e in CURVE]
    # A peer twice as slow for every error, whose curve ends sooner.
    rows += [{"renderer": "cycles", "seconds": 2 * t, "relmse": e} for t, e in CURVE[:2]]
    lines = clean_image_table("scene", rows, ["cycles", "glint"]).splitlines()
    assert len(lines) == 1 + len(CLEAN_LEVELS)
    by_level = {float(line.split(": ")[1].split(" | ")[0]): line.split(" | ")[1:] for line in lines[1:]}
    cycles, glint, lead = by_level[0.1]
    assert (float(cycles), float(glint), lead) == (2.0, 1.0, "2.0×")
    # 0.03 is past the peer's curve (it ends at 0.05): extrapolated, marked.
    cycles, glint, lead = by_level[0.03]
    assert cycles.startswith("~") and not glint.startswith("~")
    assert math.isclose(float(cycles[1:]), 4.0 * 0.05 / 0.03, rel_tol=1e-3)
    assert lead.startswith("~")


def test_a_black_images_error_is_the_mean_of_ref_squared_over_ref_squared_plus_epsilon():
    ref = np.array([[[0.0, 0.1, 1.0]]])
    # 0, 0.01/0.02 and 1/1.01 averaged.
    assert black_relmse(ref) == pytest.approx((0.0 + 0.5 + 1 / 1.01) / 3)


def test_a_peers_point_above_a_black_images_error_is_marked():
    rows = [{"renderer": "glint", "spp": 1, "seconds": t, "relmse": e} for t, e in CURVE]
    rows += [{"renderer": "mitsuba", "spp": spp, "seconds": 0.5 * spp, "relmse": e} for spp, e in ((1, 0.4), (2, 0.2))]
    lines = peer_rows("scene", "mitsuba", rows, CURVE, black=0.3).splitlines()
    assert len(lines) == 3
    assert lines[1].endswith("(above a black image's error)") and "n/a" not in lines[1]
    # 0.2 is below the black image's 0.3, and Glint's curve (from 0.1 at 1 s) is there first: 1/1 = 1.0×.
    assert lines[2].endswith("1.0×")


def test_a_speed_up_carries_the_scatter_of_both_times():
    # Glint's points each timed to 10%, the peer's to 5%.
    rows = [{"renderer": "glint", "spp": 1, "seconds": t, "seconds_se": 0.1 * t, "relmse": e} for t, e in CURVE]
    rows += [{"renderer": "cycles", "spp": 1, "seconds": 2.0, "seconds_se": 0.1, "relmse": 0.5}]
    lines = peer_rows("scene", "cycles", rows, CURVE, black=1.0).splitlines()
    # Above Glint's first error: Glint's time is its first point's, 1 s.
    # 2/1 = 2.0×, relative error hypot(0.05, 0.1): ± 0.22.
    assert lines[1].endswith(f"2.0× ± {2.0 * math.hypot(0.05, 0.1):.2f}")
    # Between two points, the larger of their scatters.
    rows[1]["seconds_se"] = 0.3 * rows[1]["seconds"]
    assert relative_time_scatter(rows[:3], 0.07) == pytest.approx(0.3)
    assert relative_time_scatter(rows[:3], 0.2) == pytest.approx(0.1)


def test_a_speed_up_without_timings_scatter_has_none():
    rows = [{"renderer": "glint", "spp": 1, "seconds": t, "relmse": e} for t, e in CURVE]
    rows += [{"renderer": "cycles", "spp": 1, "seconds": 2.0, "seconds_se": float("nan"), "relmse": 0.5}]
    assert peer_rows("scene", "cycles", rows, CURVE, black=1.0).splitlines()[1].endswith("2.0×")


def test_glints_set_up_is_its_bvh_build_and_the_rest_before_rendering():
    # The --stats line as tests/cli.rs pins it; load is left out, as for
    # the peers (Cycles' sync reads Blender's data, not a file).
    lines = ["features: diffuse", "scene: 76 triangles, 64 emissive, 33 materials; load 0.002 s, BVH build 0.010 s, lights and the rest of the set-up 0.014 s", "time: 0.1 s per sample"]
    assert glint_setup_seconds(lines) == pytest.approx(0.024)
    assert glint_setup_seconds(["scene: 3 triangles; load 0.001 s, BVH build 0.002 s"]) is None
    assert glint_setup_seconds([]) is None
