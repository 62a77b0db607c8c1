"""The affine pre-alignment anchored by landmarks: the stretch along the axis a cut rim hides.

A ventricle's wall is close to a tube, so the affine fit of a template onto a mesh
cut below its true base takes its stretch along the long axis from the rim. The apex
and the base-plane centre, known on both, fix it. Ground truth: a known affine map of
the synthetic atlas, cut and re-triangulated.
"""

import numpy as np
import pytest

from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.imaging.surface_extraction import cut_at_plane
from ladders.study.preparation import CorrespondenceSettings, correspond_mesh, remesh
from ladders.study.preparation.affine import affine_icp, apply_affine
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks
from manifolds.lddmm import RegistrationSettings

#: A stretch along the long axis with a little shear, scale and translation (mm).
AFFINE = np.array(
    [[1.05, 0.02, 0.0, 1.0], [0.0, 0.97, 0.03, -2.0], [0.01, 0.0, 1.1, 3.0], [0.0, 0.0, 0.0, 1.0]]
)


@pytest.fixture(scope="module")
def atlas():
    cohort = make_synthetic_cohort(2, seed=1)
    marks = synthetic_landmarks(cohort.atlas)
    points = np.array([marks.apex, marks.base])
    return cohort, points


def _cut_target(cohort, gap: float):
    """The atlas moved by AFFINE, cut ``gap`` mm below its base and re-triangulated."""
    target = apply_affine(AFFINE, cohort.atlas)
    v, f = cut_at_plane(target, cohort.faces, (0.0, 0.0, target[:, 2].max() - gap, 0, 0, 1))
    return remesh(v, f, len(f)), target


def _fit_error(matrix, cohort, target) -> float:
    return float(np.linalg.norm(apply_affine(matrix, cohort.atlas) - target, axis=1).mean())


@pytest.mark.parametrize("gap, loose, anchored", [(2.0, 0.7, 0.35), (4.0, 1.5, 0.5)])
def test_anchors_recover_the_stretch_a_low_rim_hides(atlas, gap, loose, anchored):
    cohort, points = atlas
    (v, f), target = _cut_target(cohort, gap)
    anchors = (points, apply_affine(AFFINE, points))
    surface_only = affine_icp(cohort.atlas, cohort.faces, v, f)
    with_anchors = affine_icp(cohort.atlas, cohort.faces, v, f, anchors=anchors)
    assert _fit_error(surface_only, cohort, target) > loose
    assert _fit_error(with_anchors, cohort, target) < anchored


def test_zero_weight_is_the_surface_fit_and_heavy_anchors_pass_through_them(atlas):
    cohort, points = atlas
    (v, f), _ = _cut_target(cohort, 2.0)
    # anchors displaced along the axis from the truth: heavy ones are matched anyway
    moved = apply_affine(AFFINE, points) + np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.5]])
    plain = affine_icp(cohort.atlas, cohort.faces, v, f)
    zero = affine_icp(cohort.atlas, cohort.faces, v, f, anchors=(points, moved), anchor_weight=0)
    np.testing.assert_array_equal(plain, zero)
    heavy = affine_icp(cohort.atlas, cohort.faces, v, f, anchors=(points, moved),
                       anchor_weight=1e4)  # fmt: skip
    assert np.abs(apply_affine(heavy, points) - moved).max() < 0.05


def test_axial_anchors_set_the_heights_and_leave_the_sideways_position_to_the_surface(atlas):
    cohort, points = atlas
    (v, f), target = _cut_target(cohort, 2.0)
    true = apply_affine(AFFINE, points)
    axis = (true[1] - true[0]) / np.linalg.norm(true[1] - true[0])
    side = np.cross(axis, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    # anchors 2 mm aside of the truth: heavy axial anchors do not follow them sideways,
    # whole-point anchors do; both still find the stretch the low rim hides
    aside = true + 2.0 * side
    kwargs = dict(anchors=(points, aside), anchor_weight=1e3)
    axial = affine_icp(cohort.atlas, cohort.faces, v, f, anchor_direction=axis, **kwargs)
    whole = affine_icp(cohort.atlas, cohort.faces, v, f, **kwargs)
    assert _fit_error(axial, cohort, target) < 0.35
    assert _fit_error(whole, cohort, target) > 1.5
    heights = (apply_affine(axial, points) - true) @ axis
    assert np.abs(heights).max() < 0.05
    # moved along the axis, heavy axial anchors are followed there
    up = true + np.array([[0.0], [1.0]]) * axis
    lifted = affine_icp(cohort.atlas, cohort.faces, v, f, anchors=(points, up), anchor_weight=1e3,
                        anchor_direction=axis)  # fmt: skip
    assert np.abs((apply_affine(lifted, points) - up) @ axis).max() < 0.05


def test_correspondence_anchors_its_affine_fit_with_the_landmarks(atlas):
    cohort, points = atlas
    s = cohort.subjects[0]
    v, f = remesh(s.ed, cohort.faces, len(cohort.faces))
    quick = CorrespondenceSettings(
        registration=RegistrationSettings(sigma=20.0, control_points="grid", max_iter=2),
        alignment="none",
    )
    marks, subject_marks = synthetic_landmarks(cohort.atlas), synthetic_landmarks(s.ed)
    out = correspond_mesh(cohort.atlas, cohort.faces, v, f, quick, landmarks=subject_marks,
                          template_landmarks=marks)  # fmt: skip
    anchors = (points, np.array([subject_marks.apex, subject_marks.base]))
    expected = affine_icp(cohort.atlas, cohort.faces, v, f, anchors=anchors, anchor_weight=0.1,
                          anchor_direction=subject_marks.long_axis)  # fmt: skip
    np.testing.assert_allclose(out.affine, expected, atol=1e-12)
    points_out = correspond_mesh(cohort.atlas, cohort.faces, v, f, quick.replace(anchor="points"),
                                 landmarks=subject_marks, template_landmarks=marks)  # fmt: skip
    np.testing.assert_allclose(
        points_out.affine,
        affine_icp(cohort.atlas, cohort.faces, v, f, anchors=anchors, anchor_weight=0.1),
        atol=1e-12,
    )
    unanchored = correspond_mesh(cohort.atlas, cohort.faces, v, f,
                                 quick.replace(anchor_weight=0.0), landmarks=subject_marks,
                                 template_landmarks=marks)  # fmt: skip
    np.testing.assert_allclose(unanchored.affine, affine_icp(cohort.atlas, cohort.faces, v, f),
                               atol=1e-12)  # fmt: skip


def test_bad_anchors_are_named(atlas):
    cohort, points = atlas
    with pytest.raises(ValueError, match="anchor_weight"):
        affine_icp(cohort.atlas, cohort.faces, cohort.atlas, cohort.faces,
                   anchors=(points, points), anchor_weight=-1.0)  # fmt: skip
    with pytest.raises(ValueError, match="anchors"):
        affine_icp(cohort.atlas, cohort.faces, cohort.atlas, cohort.faces,
                   anchors=(points, points[:1]))  # fmt: skip
    with pytest.raises(ValueError, match="anchors"):
        affine_icp(cohort.atlas, cohort.faces, cohort.atlas, cohort.faces,
                   anchors=(points, points * np.nan))  # fmt: skip
    with pytest.raises(ValueError, match="anchor_direction"):
        affine_icp(cohort.atlas, cohort.faces, cohort.atlas, cohort.faces,
                   anchors=(points, points), anchor_direction=[0.0, 0.0, 0.0])  # fmt: skip
    with pytest.raises(ValueError, match="anchor_weight"):
        CorrespondenceSettings(anchor_weight=-0.1)
    with pytest.raises(ValueError, match="anchor"):
        CorrespondenceSettings(anchor="sideways")


def test_pairs_beyond_the_rim_left_out_with_the_base_height_anchored(atlas):
    """A rim ``gap`` mm below the base, the base's height along the axis anchored
    (``anchor_direction``): with the pairs at the rim the fit's error grows with the gap
    (the template is squeezed onto the rim); without them (``skip_rim``) it does not."""
    cohort, points = atlas
    base = (points[1:], apply_affine(AFFINE, points[1:]))  # the base-plane centre only
    axis = np.array([0.0, 0.0, 1.0])
    errors = {True: [], False: []}
    for gap in (2.0, 8.0, 12.0):
        (v, f), target = _cut_target(cohort, gap)
        for skip in errors:
            m = affine_icp(cohort.atlas, cohort.faces, v, f, anchors=base, anchor_direction=axis,
                           skip_rim=skip)  # fmt: skip
            errors[skip].append(_fit_error(m, cohort, target))
    skipped, kept = np.array(errors[True]), np.array(errors[False])
    print(f"fit error (mm) at gaps 2, 8, 12: with the rim's pairs {kept.round(2)}, without "
          f"{skipped.round(2)}")  # fmt: skip
    assert skipped.max() < 0.8 and np.ptp(skipped) < 0.35
    assert kept[-1] > 2.0 * skipped[-1] and kept[-1] > kept[0] + 1.0
