"""The whole cardiac cycle: time course, volume motion, its inverse, cine label and intensity images."""

from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage

from ladders.study.cohort import (
    CohortError,
    MotionAbnormality,
    SubjectParameters,
    SyntheticLVModel,
    check_invertible,
    cycle_fraction,
    cycle_frames,
    frame_abnormality,
    frame_times,
    motion_forward,
    motion_inverse,
    planted_modulation,
    planted_region,
)
from ladders.study.cohort.cardiac_cycle import _endocardium
from ladders.study.cohort.synthetic_lv import grid_shape, lv_grid, lv_shapes
from ladders.study.imaging import (
    ImageError,
    TagGrid,
    ed_labels,
    read_label_image,
    render_cine,
    render_labels,
    short_axis_affine,
    tag_pattern,
    write_series,
)
from ladders.study.population import (
    CYCLE_ABNORMALITY,
    make_two_group_cohort,
    make_two_group_cycles,
    two_group_cycles,
)
from ladders.study.volume import enclosed_volume

GRID = lv_grid(*grid_shape(241))
FINE = lv_grid(*grid_shape(1009))
DELAY = MotionAbnormality("delay", transition_height=0.1)
#: A delay at two times of the cycle: less motion than the rest early, more late.
DELAYED = [frame_abnormality(DELAY, 0.2), frame_abnormality(DELAY, 0.8)]


@pytest.fixture(scope="module")
def params():
    return SubjectParameters.draw(SyntheticLVModel(), np.random.default_rng(3))


def _volume_points(rng, n=4000):
    return rng.uniform([-45.0, -45.0, -15.0], [45.0, 45.0, 110.0], size=(n, 3))


def _box(surface, h, margin=12.0):
    lo, hi = surface.min(axis=0) - margin, surface.max(axis=0) + 3.0
    affine = np.diag([h, h, h, 1.0])
    affine[:3, 3] = lo
    return affine, tuple(int(np.ceil(n)) for n in (hi - lo) / h)


def test_cycle_fraction_values_and_smoothness():
    assert cycle_fraction(0.0) == 0.0
    assert cycle_fraction(0.35) == pytest.approx(1.0, abs=1e-15)
    assert cycle_fraction(0.3, es_phase=0.3) == pytest.approx(1.0, abs=1e-15)
    assert cycle_fraction(1.0) == pytest.approx(0.0, abs=1e-15)
    t = np.linspace(0.0, 1.0, 20001)
    f = cycle_fraction(t)
    assert f.shape == t.shape and f.min() >= 0.0 and f.max() <= 1.0
    rising, falling = np.diff(f[t <= 0.35]), np.diff(f[t >= 0.35])
    assert (rising >= 0).all() and (falling <= 0).all()
    slope = np.diff(f) / np.diff(t)
    assert np.abs(np.diff(slope)).max() < 1e-2  # no kink: the slope is continuous
    assert abs(slope[0]) < 1e-2 and abs(slope[-1]) < 1e-2  # f' = 0 at ED, periodic
    np.testing.assert_allclose(frame_times(4), [0, 0.25, 0.5, 0.75])


@pytest.mark.parametrize("abnormality", [None, MotionAbnormality(), MotionAbnormality("twist")])
def test_forward_at_one_is_the_end_systole_of_lv_shapes(params, abnormality):
    theta, phi, _ = GRID
    modulation = None if abnormality is None else planted_modulation(abnormality, theta, phi)
    ed, es = lv_shapes(params, theta, phi, modulation)
    np.testing.assert_allclose(motion_forward(params, ed, 1.0, abnormality), es, atol=1e-10)
    assert np.array_equal(motion_forward(params, ed, 0.0, abnormality), ed)


@pytest.mark.parametrize(
    "abnormality",
    [None, MotionAbnormality("radial"), MotionAbnormality("twist"), CYCLE_ABNORMALITY, *DELAYED],
)
def test_inverse_undoes_forward_in_the_volume(params, abnormality):
    rng = np.random.default_rng(7)
    x = _volume_points(rng)
    x[0] = [0.0, 0.0, 30.0]  # on the long axis
    for f in (0.37, 1.0):
        y = motion_forward(params, x, f, abnormality)
        np.testing.assert_allclose(motion_inverse(params, y, f, abnormality), x, atol=1e-10)
        np.testing.assert_allclose(motion_forward(params, motion_inverse(params, x, f, abnormality), f, abnormality), x, atol=1e-10)  # fmt: skip
    assert np.array_equal(motion_inverse(params, x, 0.0, abnormality), x)


def _wall_points(params, rng, n=600, thickness=9.0):
    """Points of the ED myocardium (between the endocardium and ``thickness`` outside it)."""
    u, phi = rng.uniform(0.03, 0.97, n), rng.uniform(-np.pi, np.pi, n)
    rho = _endocardium(params, u, phi) + rng.uniform(0.05, thickness, n)
    return np.column_stack([rho * np.cos(phi), rho * np.sin(phi), u * params.long_axis])


def _jacobian_determinant(params, x, f, abnormality, h=1e-4):
    columns = []
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        plus = motion_forward(params, x + step, f, abnormality)
        columns.append((plus - motion_forward(params, x - step, f, abnormality)) / (2 * h))
    return np.linalg.det(np.stack(columns, axis=-1))


@pytest.mark.parametrize(
    "abnormality",
    [None, MotionAbnormality("radial"), MotionAbnormality("twist"), CYCLE_ABNORMALITY, *DELAYED],
)
def test_the_wall_is_incompressible(params, abnormality):
    rng = np.random.default_rng(11)
    wall = _wall_points(params, rng)
    cap = rng.uniform([-6.0, -6.0, -6.0], [6.0, 6.0, -0.1], size=(100, 3))  # below the apex
    for f in (0.4, 1.0):
        det = _jacobian_determinant(params, np.vstack([wall, cap]), f, abnormality)
        np.testing.assert_allclose(det, 1.0, atol=1e-4)  # exact up to the modulation's slopes
    u, phi = rng.uniform(0.03, 0.97, 200), rng.uniform(-np.pi, np.pi, 200)
    rho = rng.uniform(0.0, 0.98, 200) * _endocardium(params, u, phi)  # in the blood pool
    blood = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), u * params.long_axis])
    p = params
    r = p.radial_contraction * (
        1 + p.contraction_heterogeneity * np.cos(phi - p.heterogeneity_phase)
    )
    r = r * (1.0 + p.contraction_gradient * (1.0 - 2.0 * u))
    expected = (1.0 - r) ** 2 * (1.0 - p.longitudinal_shortening)  # the blood is ejected
    np.testing.assert_allclose(_jacobian_determinant(p, blood, 1.0, None), expected, atol=1e-6)


def test_the_wall_thickens_at_end_systole(params):
    phi = np.linspace(-np.pi, np.pi, 72, endpoint=False)
    for u in (0.35, 0.5, 0.65):
        rho_e = _endocardium(params, np.full_like(phi, u), phi)
        ring = np.column_stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)])
        ring[:, 2] = u * params.long_axis
        endo = ring * np.column_stack([rho_e, rho_e, np.ones_like(phi)])
        epi = ring * np.column_stack([rho_e + 9.0, rho_e + 9.0, np.ones_like(phi)])
        endo_es, epi_es = motion_forward(params, endo, 1.0), motion_forward(params, epi, 1.0)
        np.testing.assert_allclose(endo_es[:, 2], epi_es[:, 2], atol=1e-12)  # same height
        thickness = np.hypot(*epi_es[:, :2].T) - np.hypot(*endo_es[:, :2].T)
        ratio = thickness / 9.0
        assert ratio.min() > 1.25 and ratio.max() < 1.6, (u, ratio.min(), ratio.max())
        mid = motion_forward(params, epi, 0.5)  # thickening grows through systole
        assert (np.hypot(*mid[:, :2].T) - np.hypot(*motion_forward(params, endo, 0.5)[:, :2].T) < thickness).all()  # fmt: skip


def test_the_myocardial_volume_is_kept_in_the_images(params):
    theta, phi, faces = GRID
    ed, es = lv_shapes(params, theta, phi)
    h, lo = 1.5, ed.min(axis=0) - [12.0, 12.0, 12.0]
    affine = np.diag([h, h, h, 1.0])
    affine[:3, 3] = lo
    shape = tuple(int(n) for n in np.ceil((ed.max(axis=0) + [12.0, 12.0, 3.0] - lo) / h))
    labels = [render_labels(params, affine, shape, f) for f in (0.0, 1.0)]
    myocardium = [(image == 2).sum() for image in labels]
    assert myocardium[1] == pytest.approx(myocardium[0], rel=0.03)
    assert (labels[1] == 1).sum() < 0.7 * (labels[0] == 1).sum()  # the blood is ejected


def test_cycle_frames_and_the_two_group_cohort(params):
    theta, phi, _ = GRID
    frames = cycle_frames(params, theta, phi, n_frames=20, es_phase=0.35)
    ed, es = lv_shapes(params, theta, phi)
    assert frames.shape == (20, len(theta), 3)
    assert np.array_equal(frames[0], ed)
    np.testing.assert_allclose(frames[7], es, atol=1e-10)  # t = 7 / 20 = 0.35
    data = make_two_group_cohort(4, abnormality=CYCLE_ABNORMALITY, n_vertices=241, seed=1)
    cycles = two_group_cycles(data, n_frames=20)
    assert cycles.frames.shape == (4, 20, 241, 3)
    assert list(cycles.patients) == list(data.labels) and 0 < cycles.patients.sum() < 4
    for i, s in enumerate(data.cohort.subjects):
        np.testing.assert_allclose(cycles.frames[i, 0], s.ed, atol=1e-12)
        np.testing.assert_allclose(cycles.frames[i, 7], s.es, atol=1e-10)


def test_every_subject_of_the_cycle_cohort_renders():
    cycles = make_two_group_cycles(n_vertices=241, n_frames=20, check=False)
    assert cycles.frames.shape == (40, 20, 241, 3) and cycles.abnormality == CYCLE_ABNORMALITY
    assert cycles.patients.sum() == 20 and list(cycles.patients) == list(cycles.data.labels)
    assert (cycles.check_invertible() > 0).all()  # patients and controls, at every frame
    for i, s in enumerate(cycles.data.cohort.subjects):
        np.testing.assert_allclose(cycles.frames[i, 7], s.es, atol=1e-10)  # t = 7 / 20
    affine = short_axis_affine([-45.0, -45.0, 0.0], 3.0, 10.0)
    for i in (int(np.argmax(cycles.patients)), int(np.argmin(cycles.patients))):
        labels = cycles.render_labels(i, affine, (30, 30, 8), 7)
        assert (labels == 1).any() and (labels == 2).any()
        params, planted = cycles.motion_of(cycles.names[i])
        assert planted == (CYCLE_ABNORMALITY if cycles.patients[i] else None)
        assert np.array_equal(labels, render_labels(params, affine, (30, 30, 8), 1.0, planted))
    surface = two_group_cycles(make_two_group_cohort(40, n_vertices=241), n_frames=20)
    with pytest.raises(CohortError, match="^subject '.*folds the volume.*CYCLE_ABNORMALITY"):
        surface.check_invertible()  # the surface cohort's default: not for every subject
    with pytest.raises(CohortError, match="^frame: "):
        cycles.render_labels(0, affine, (4, 4, 4), 20)
    with pytest.raises(CohortError, match="^subject: "):
        cycles.render_cine("nobody", affine, (4, 4, 4), 0)


def test_a_delayed_contraction_peaks_later_with_the_same_amplitude():
    """The delay's segments follow the time course of an end-systole a tenth of the cycle
    later: their normal motion peaks 0.1 later and as deep; elsewhere, and in the controls,
    the motion is that of the cohort without it; ED is unchanged. At end-systole the
    delayed segments have reached cycle_fraction(0.35, 0.45) of their motion (the ED-ES
    cohort's planted shape). A delay is refused where only a fraction of the motion is
    given, and when it ends the contraction after the cycle."""
    from ladders.study.sequences import CycleMotion, curve_peaks

    delayed = make_two_group_cycles(6, DELAY, n_frames=40, n_vertices=241, seed=1)
    plain = make_two_group_cycles(6, None, n_frames=40, n_vertices=241, seed=1, check=False)
    assert (delayed.check_invertible() > 0).all()
    patients, weight = delayed.patients, delayed.data.region.weight
    peaks, times = {}, {}
    for name, c in (("delayed", delayed), ("plain", plain)):
        m = CycleMotion(c.names, c.frames - c.frames[:, :1], c.data.cohort.atlas, c.faces)
        peaks[name], times[name] = curve_peaks(m.normal())
    inside, outside = weight > 0.999, weight < 1e-6
    shift = times["delayed"][patients][:, inside] - times["plain"][patients][:, inside]
    np.testing.assert_allclose(shift, 0.1, atol=0.005)  # a fifth of a frame
    ratio = peaks["delayed"][patients][:, inside] / peaks["plain"][patients][:, inside]
    np.testing.assert_allclose(ratio, 1.0, atol=2e-3)
    np.testing.assert_allclose(delayed.frames[:, :, outside], plain.frames[:, :, outside],
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(delayed.frames[~patients], plain.frames[~patients], atol=1e-12)
    np.testing.assert_allclose(delayed.frames[:, 0], plain.frames[:, 0], atol=1e-12)
    theta, phi, _ = GRID
    at_es, region = planted_modulation(DELAY, theta, phi), planted_region(DELAY, theta, phi)
    expected = 1.0 - region.weight * (1.0 - cycle_fraction(0.35, 0.45))
    for factor in (at_es.radial, at_es.longitudinal, at_es.rotation):
        np.testing.assert_allclose(factor, expected, atol=1e-12)
    with pytest.raises(CohortError, match="a delay depends on the time of the cycle"):
        motion_forward(SubjectParameters.mean(SyntheticLVModel()), theta[:, None] * [0, 0, 1],
                       0.5, DELAY)  # fmt: skip
    with pytest.raises(CohortError, match=r"es_phase \+ delay must be < 1"):
        frame_abnormality(replace(DELAY, magnitude=0.7), 0.5)


def test_myocardium_around_the_end_diastolic_cavity(params):
    theta, phi, _ = GRID
    ed, _ = lv_shapes(params, theta, phi)
    ring = ed[(theta > 0.5) & (theta < 1.4)]
    radial = ring * [1.0, 1.0, 0.0] / np.hypot(ring[:, 0], ring[:, 1])[:, None]
    for offset, label in ((-1.0, 1), (4.0, 2), (8.5, 2), (10.0, 0)):
        assert (ed_labels(params, ring + offset * radial) == label).all(), offset
    apex = [[0, 0, -4.0], [0, 0, -8.9], [0, 0, -9.5], [0, 0, 1.0]]
    assert list(ed_labels(params, apex)) == [2, 2, 0, 1]
    assert ed_labels(params, [[0.0, 0.0, params.long_axis + 0.5]])[0] == 0  # above the base


@pytest.mark.parametrize("f", [0.0, 1.0])
def test_blood_pool_volume_is_the_enclosed_volume(params, f):
    theta, phi, faces = FINE
    ed, es = lv_shapes(params, theta, phi)
    surface = es if f == 1.0 else ed
    affine, shape = _box(surface, 1.5)
    labels = render_labels(params, affine, shape, f)
    volume = (labels == 1).sum() * 1.5**3
    assert volume == pytest.approx(enclosed_volume(surface, faces), rel=0.03)
    assert (labels == 2).sum() > 0 and labels[..., -1].max() == 0  # nothing above the base


def test_a_patient_label_image_follows_the_planted_motion(params):
    theta, phi, faces = FINE
    modulation = planted_modulation(CYCLE_ABNORMALITY, theta, phi)
    _, es = lv_shapes(params, theta, phi, modulation)
    affine, shape = _box(es, 2.0, margin=1.0)
    labels = render_labels(params, affine, shape, 1.0, CYCLE_ABNORMALITY)
    volume = (labels == 1).sum() * 2.0**3
    assert volume == pytest.approx(enclosed_volume(es, faces), rel=0.05)


def test_series_written_and_read_back_frame_by_frame(params, tmp_path):
    oblique = short_axis_affine([35.0, -35.0, -6.0], 1.4, 8.0, tilt_deg=10.0, flip=True)
    for name, affine in (("sax", short_axis_affine([-35, -35, -4], 1.4, 8.0)), ("obl", oblique)):
        fractions = cycle_fraction(frame_times(4))
        frames = [render_labels(params, affine, (50, 50, 12), f) for f in fractions]
        path = write_series(tmp_path / f"{name}.nii.gz", frames, affine)
        for k, frame in enumerate(frames):
            image = read_label_image(path, k)
            assert image.frame == k and np.array_equal(image.labels, frame)
            np.testing.assert_allclose(image.affine, affine, atol=1e-5)
        assert (frames[2] == 1).sum() < (frames[0] == 1).sum()  # contracted mid-cycle
    cine = [render_cine(params, oblique, (20, 20, 4), f, np.random.default_rng(0)) for f in (0, 1)]
    path = write_series(tmp_path / "cine.nii", cine, oblique)
    with pytest.raises(ImageError, match="not a label image"):
        read_label_image(path, 0)


def test_tag_lines_move_with_the_material(params):
    tags = TagGrid(spacing=7.0)
    flat = (1.0, 1.0, 1.0)  # the image is the tag pattern alone
    h, n = 0.5, 241
    ed_affine = np.diag([h, h, 1.0, 1.0])
    ed_affine[:3, 3] = [-60.0, -60.0, 40.0]
    ed_image = render_cine(params, ed_affine, (n, n, 1), 0.0, None, 0.0, tags, supersample=1,
                           intensities=flat)[..., 0]  # fmt: skip
    es_affine = np.diag([h, h, 1.0, 1.0])
    es_affine[:3, 3] = [-30.0, -30.0, 35.0]
    es_image = render_cine(params, es_affine, (121, 121, 1), 1.0, None, 0.0, tags,
                           supersample=1, intensities=flat)[..., 0]  # fmt: skip
    index = np.indices((121, 121)).reshape(2, -1).T * h - 30.0
    points = np.column_stack([index, np.full(len(index), 35.0)])
    material = motion_inverse(params, points, 1.0)
    pulled = ndimage.map_coordinates(ed_image, ((material[:, :2] + 60.0) / h).T, order=3)
    es = es_image.ravel()
    assert np.corrcoef(pulled, es)[0, 1] > 0.99
    assert np.abs(pulled - es).mean() < 0.01
    same_place = ed_image[60:181, 60:181].ravel()  # the ED pattern where the ES image is
    assert np.corrcoef(same_place, es)[0, 1] < 0.5  # the lines have moved


def test_3d_tag_planes_move_with_the_shortening(params):
    flat = (1.0, 1.0, 1.0)  # the image is the tag pattern alone
    h = 0.5
    affine = np.diag([h, 1.0, h, 1.0])
    affine[:3, 3] = [-30.0, 0.0, 10.0]  # a long-axis plane y = 0
    shape = (121, 1, 121)
    grid = TagGrid(spacing=7.0, axes=(0, 1, 2))
    ed, es = (render_cine(params, affine, shape, f, None, 0.0, grid, supersample=1,
                          intensities=flat)[:, 0, :] for f in (0.0, 1.0))  # fmt: skip
    i, k = np.indices((121, 121)).reshape(2, -1)
    points = np.column_stack([i * h - 30.0, np.zeros(i.size), k * h + 10.0])
    # at ED, dark lines of constant z: every column dips at z = 7 k
    on_plane = np.isclose(np.mod(points[:, 2], 7.0), 0.0)
    assert ed.ravel()[on_plane].max() < 0.2 + 1e-9
    expected = tag_pattern(motion_inverse(params, points, 1.0), grid)
    assert np.corrcoef(es.ravel(), expected)[0, 1] > 0.99
    assert np.corrcoef(es.ravel(), ed.ravel())[0, 1] < 0.5  # the planes have moved
    in_plane = render_cine(params, affine, shape, 1.0, None, 0.0, TagGrid(spacing=7.0),
                           supersample=1, intensities=flat)[:, 0, :].ravel()  # fmt: skip
    across = in_plane > 0.05  # what the planes across the long axis add: m(z)
    m_z = es.ravel()[across] / in_plane[across]
    only_z = TagGrid(spacing=7.0, axes=(2,))
    moved = tag_pattern(motion_inverse(params, points[across], 1.0), only_z)
    assert np.corrcoef(m_z, moved)[0, 1] > 0.99  # at the material's ED height
    assert np.corrcoef(m_z, tag_pattern(points[across], only_z))[0, 1] < 0.5  # not where they were


@pytest.mark.parametrize("axes", [(), (0, 0), (3,), ("z",), (True, 1), 2])
def test_tag_axes_are_checked(axes):
    with pytest.raises(ImageError, match="^tagging.axes: "):
        TagGrid(axes=axes)


def test_cine_intensities_partial_volume_and_noise(params):
    affine = np.diag([3.0, 3.0, 3.0, 1.0])
    affine[:3, 3] = [-40.0, -40.0, 30.0]
    clean = render_cine(params, affine, (28, 28, 3), 0.5, None, 0.0, supersample=2)
    labels = render_labels(params, affine, (28, 28, 3), 0.5)
    assert clean[labels == 1].max() == pytest.approx(1.0)  # blood bright
    assert np.median(clean[labels == 2]) < 0.3 < np.median(clean[labels == 0]) < 0.6
    assert ((clean > 0.16) & (clean < 0.44)).any()  # partial volume at the boundaries
    a = render_cine(params, affine, (28, 28, 3), 0.5, np.random.default_rng(5), 0.1, supersample=2)
    b = render_cine(params, affine, (28, 28, 3), 0.5, np.random.default_rng(5), 0.1, supersample=2)
    assert np.array_equal(a, b) and np.std(a - clean) == pytest.approx(0.1, rel=0.1)
    rician = render_cine(params, affine, (28, 28, 3), 0.5, np.random.default_rng(5), 0.1,
                         supersample=1, rician=True)  # fmt: skip
    assert (rician >= 0).all()


def test_bad_input_is_refused_naming_the_argument(params, tmp_path):
    theta, phi, _ = GRID
    x = np.zeros((2, 3))
    for f in (-0.1, 1.5, np.nan, "half"):
        with pytest.raises(CohortError, match="^f: "):
            motion_forward(params, x, f)
        with pytest.raises(CohortError, match="^f: "):
            motion_inverse(params, x, f)
    with pytest.raises(CohortError, match="^f: "):
        render_labels(params, np.eye(4), (2, 2, 2), 2.0)
    for n in (1, 0, 2.5):
        with pytest.raises(CohortError, match="^n_frames: "):
            cycle_frames(params, theta, phi, n_frames=n)
    for es in (0.0, 1.0, 1.5, -0.2):
        with pytest.raises(CohortError, match="^es_phase: "):
            cycle_fraction(0.2, es_phase=es)
        with pytest.raises(CohortError, match="^es_phase: "):
            cycle_frames(params, theta, phi, es_phase=es)
    with pytest.raises(CohortError, match="^t: "):
        cycle_fraction([0.2, 1.2])
    with pytest.raises(CohortError, match="^points: "):
        motion_forward(params, np.zeros((4, 2)), 0.5)
    strong = replace(params, radial_contraction=0.95, contraction_heterogeneity=0.1)
    with pytest.raises(CohortError, match="^params: .*not invertible"):
        motion_inverse(strong, x, 1.0)
    assert check_invertible(strong, 0.5) > 0  # half the motion is still invertible
    steep = replace(params, longitudinal_shortening=0.18)
    motion_forward(steep, x, 1.0, MotionAbnormality())  # the surfaces are fine ...
    with pytest.raises(
        CohortError, match="^abnormality: .*folds the volume at .* points of the wall"
    ):
        motion_forward(steep, _wall_points(steep, np.random.default_rng(0), 2000), 1.0, MotionAbnormality())  # fmt: skip
    with pytest.raises(CohortError, match="^abnormality: .*folds the volume"):
        motion_inverse(steep, x, 1.0, MotionAbnormality())  # ... the volume folds
    with pytest.raises(CohortError, match="^abnormality: .*sharp transition"):
        motion_inverse(params, x, 0.5, MotionAbnormality("twist", transition_angle=0.0))
    with pytest.raises(ImageError, match="^affine: "):
        render_labels(params, np.eye(3), (4, 4, 4), 0.5)
    with pytest.raises(ImageError, match="^affine: "):
        render_labels(params, np.diag([1.0, 1.0, 0.0, 1.0]), (4, 4, 4), 0.5)
    with pytest.raises(ImageError, match="^shape: "):
        render_labels(params, np.eye(4), (4, 4), 0.5)
    with pytest.raises(ImageError, match="^shape: "):
        render_cine(params, np.eye(4), (4, 4, 4, 2), 0.5, np.random.default_rng(0))
    with pytest.raises(ImageError, match="^rng: "):
        render_cine(params, np.eye(4), (4, 4, 4), 0.5, None, noise=0.1)
    with pytest.raises(ImageError, match="^supersample: "):
        render_cine(params, np.eye(4), (4, 4, 4), 0.5, None, 0.0, supersample=0)
    with pytest.raises(ImageError, match="^tagging.spacing: "):
        TagGrid(spacing=0.0)
    with pytest.raises(ImageError, match="^wall_thickness: "):
        render_labels(params, np.eye(4), (4, 4, 4), 0.5, wall_thickness=-1.0)
    frames = [np.zeros((4, 4, 4), np.int16), np.zeros((4, 4, 3), np.int16)]
    with pytest.raises(ImageError, match="^frames_images: frame 1 has shape"):
        write_series(tmp_path / "a.nii.gz", frames, np.eye(4))
    with pytest.raises(ImageError, match="^affine: "):
        write_series(tmp_path / "a.nii.gz", frames[:1], np.eye(3))
    with pytest.raises(ImageError, match="^path: "):
        write_series(tmp_path / "a.png", frames[:1], np.eye(4))
