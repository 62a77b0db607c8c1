"""The rotation about the long axis: closed forms, invariances and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ladders.study.wall_rotation import rotation_about_axis, twist_angle

APEX, BASE = np.array([1.0, -2.0, 3.0]), np.array([4.0, 2.0, 90.0])


def _about_axis(points, degrees, axis_from=BASE, axis_to=APEX):
    """Points turned right-handedly by ``degrees`` about the line from axis_from to axis_to."""
    u = (axis_to - axis_from) / np.linalg.norm(axis_to - axis_from)
    turn = Rotation.from_rotvec(np.radians(degrees) * u)
    return turn.apply(points - APEX) + APEX


@settings(max_examples=40, deadline=None)
@given(angle=st.floats(-170, 170), shift=st.floats(-20, 20), seed=st.integers(0, 2**16))
def test_a_rigid_turn_about_the_axis_is_its_angle_at_every_point(angle, shift, seed):
    """Counter-clockwise seen from the apex is a right-handed turn about base -> apex; a
    slide along the axis adds nothing."""
    points = np.random.default_rng(seed).normal(scale=30.0, size=(50, 3)) + APEX
    u = (APEX - BASE) / np.linalg.norm(APEX - BASE)
    moved = _about_axis(points, angle) + shift * u
    got = rotation_about_axis(points, moved, APEX, BASE, min_radius=1.0)
    off = np.linalg.norm(np.cross(points - APEX, u), axis=1) >= 1.0
    assert np.isnan(got[~off]).all()
    np.testing.assert_allclose(got[off], angle, atol=1e-9)


def test_counter_clockwise_seen_from_the_apex_is_positive():
    """Axis +z from apex (origin) to base: seen from the apex (below, looking up), +x to
    +y is clockwise, hence negative."""
    apex, base = np.zeros(3), np.array([0.0, 0.0, 80.0])
    start, moved = np.array([[10.0, 0.0, 40.0]]), np.array([[0.0, 10.0, 40.0]])
    assert rotation_about_axis(start, moved, apex, base)[0] == pytest.approx(-90.0)
    assert rotation_about_axis(start, moved, base, apex)[0] == pytest.approx(90.0)


def test_batches_broadcast_and_radial_motion_does_not_turn():
    rng = np.random.default_rng(0)
    start = rng.normal(scale=30.0, size=(40, 3)) + APEX
    angles = np.array([-20.0, 0.0, 35.0])
    moved = np.stack([_about_axis(start, a) for a in angles])  # (3, 40, 3)
    got = rotation_about_axis(start, moved, APEX, BASE, min_radius=0.5)
    assert got.shape == (3, 40)
    loop = np.stack([rotation_about_axis(start, m, APEX, BASE, min_radius=0.5) for m in moved])
    np.testing.assert_array_equal(got, loop)
    u = (APEX - BASE) / np.linalg.norm(APEX - BASE)
    radial = start - APEX - ((start - APEX) @ u)[:, None] * u
    shrunk = start - 0.3 * radial  # the wall contracting towards the axis
    np.testing.assert_allclose(np.nan_to_num(rotation_about_axis(start, shrunk, APEX, BASE)), 0,
                               atol=1e-9)  # fmt: skip


def test_bad_input_is_named():
    p = np.ones((4, 3))
    with pytest.raises(ValueError, match="apex and base: the same point"):
        rotation_about_axis(p, p, APEX, APEX)
    with pytest.raises(ValueError, match=r"start: expected points \(\.\.\., 3\)"):
        rotation_about_axis(np.ones((4, 2)), p, APEX, BASE)
    with pytest.raises(ValueError, match="moved: not finite"):
        rotation_about_axis(p, np.full((4, 3), np.nan), APEX, BASE)
    with pytest.raises(ValueError, match="base: expected 3 finite coordinates"):
        rotation_about_axis(p, p, APEX, [0.0, 1.0])
    with pytest.raises(ValueError, match="min_radius: expected >= 0"):
        rotation_about_axis(p, p, APEX, BASE, min_radius=-1.0)


def test_the_twist_of_opposite_apical_and_basal_turns():
    """Apex turned by +a, base by -b, the middle by anything: the twist is a + b; batches
    of moved points give one twist each; a part without a point off the axis is named."""
    rng = np.random.default_rng(1)
    h = rng.uniform(0, 1, 300)
    theta = rng.uniform(0, 2 * np.pi, 300)
    radius = 5.0 + 25.0 * np.sqrt(h)  # a cone-like wall, the apex near the axis
    start = np.c_[radius * np.cos(theta), radius * np.sin(theta), 80.0 * h]
    apex, base = np.zeros(3), np.array([0.0, 0.0, 80.0])
    turn = np.where(h < 0.3, 6.0, np.where(h > 0.7, -3.0, rng.uniform(-50, 50, 300)))
    c, s = np.cos(np.radians(-turn)), np.sin(np.radians(-turn))  # counter-clockwise from below
    moved = np.c_[c * start[:, 0] - s * start[:, 1], s * start[:, 0] + c * start[:, 1],
                  start[:, 2] - 4.0 * h]  # fmt: skip
    assert twist_angle(start, moved, apex, base) == pytest.approx(9.0, abs=1e-9)
    both = twist_angle(start, np.stack([moved, start]), apex, base)
    np.testing.assert_allclose(both, [9.0, 0.0], atol=1e-9)
    with pytest.raises(ValueError, match="no apical point 5.0 or more from the axis"):
        twist_angle(start[h > 0.5], moved[h > 0.5], apex, base)
