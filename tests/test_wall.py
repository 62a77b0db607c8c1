"""Wall thickness and strain: closed forms on analytic shells, the generator's truth, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from ladders.study.cohort import make_synthetic_cohort
from ladders.study.cohort.synthetic_lv import SubjectParameters, SyntheticLVModel, lv_grid
from ladders.study.wall import (
    WallMaps,
    cardiac_directions,
    directional_stretch,
    signed_peaks,
    surface_strains,
    thickening,
    true_endocardium,
    true_epicardium,
    true_wall_maps,
    wall_maps,
    wall_thickness,
)

APEX, BASE = np.array([0.0, 0.0, -30.0]), np.array([0.0, 0.0, 30.0])


def _sphere(level: int, radius: float):
    s = trimesh.creation.icosphere(level, radius=radius)
    return np.asarray(s.vertices, float), np.asarray(s.faces, np.int64)


def _sagitta(vertices, faces, radius: float) -> float:
    """Largest gap between a triangle and the surface of radius of curvature ``radius``
    through its corners: ``h^2 / (8 R)`` with ``h`` the longest edge."""
    edges = np.concatenate([vertices[faces[:, i]] - vertices[faces[:, j]]
                            for i, j in ((0, 1), (1, 2), (2, 0))])  # fmt: skip
    return float(np.linalg.norm(edges, axis=1).max() ** 2 / (8.0 * radius))


# thickness on shells of known thickness ---------------------------------------------------


def test_a_spherical_shell_has_its_thickness_at_every_vertex():
    inner, faces = _sphere(3, 20.0)
    outer, outer_faces = _sphere(5, 29.0)
    out = wall_thickness(inner, outer, outer_faces)
    bound = _sagitta(outer, outer_faces, 29.0)
    assert bound < 0.01
    assert np.all(out.thickness <= 9.0 + 1e-9)  # the polyhedron lies inside the sphere
    assert np.all(out.thickness >= 9.0 - bound)
    np.testing.assert_allclose(np.linalg.norm(out.points, axis=1), 29.0, atol=bound)
    assert not out.on_rim.any()
    scaled = wall_thickness(2.0 * inner, 2.0 * outer, outer_faces, scale=2.0)  # a frame in 2 mm
    np.testing.assert_allclose(scaled.thickness, out.thickness, rtol=1e-12)


def test_an_ellipsoidal_shell_of_parallel_surfaces_has_its_thickness():
    """The epicardium is the ellipsoid moved by ``d`` along its exact normals (its parallel
    surface): the closest-point distance is ``d`` within the triangles' sagitta."""
    axes, d = np.array([20.0, 25.0, 40.0]), 8.0
    unit, faces = _sphere(5, 1.0)
    inner = unit * axes
    normals = inner / axes**2
    outer = inner + d * normals / np.linalg.norm(normals, axis=1, keepdims=True)
    probe = _sphere(2, 1.0)[0] * axes  # endocardial points exactly on the ellipsoid
    out = wall_thickness(probe, outer, faces)
    bound = _sagitta(outer, faces, axes.min() ** 2 / axes.max() + d)
    assert bound < 0.03
    assert np.all(out.thickness <= d + 1e-9) and np.all(out.thickness >= d - bound)


def test_a_vertex_above_an_epicardium_cut_lower_is_flagged_on_its_rim():
    inner, _ = _sphere(3, 20.0)
    outer, outer_faces = _sphere(4, 29.0)
    keep = outer[outer_faces].mean(axis=1)[:, 2] < 10.0  # the epicardium cut at z = 10
    out = wall_thickness(inner, outer, outer_faces[keep])
    above = inner[:, 2] > 12.0
    assert out.on_rim[above].all() and not out.on_rim[inner[:, 2] < 0].any()
    assert (out.thickness[above] > 9.5).all()  # to the rim: longer than the wall


def test_thickening_is_absolute_and_relative_from_the_first_frame():
    t = np.array([[8.0, 10.0], [10.0, 9.0], [12.0, 10.0]])
    absolute, relative = thickening(t)
    np.testing.assert_allclose(absolute, [[0, 0], [2, -1], [4, 0]])
    np.testing.assert_allclose(relative, [[0, 0], [0.25, -0.1], [0.5, 0]])
    with pytest.raises(ValueError, match="vertex 1"):
        thickening(np.array([[8.0, 0.0], [9.0, 1.0]]))


def test_concentric_incompressible_shells_give_the_analytic_radial_strain():
    """Endocardium ``R1 -> k R1``, wall volume kept: ``R2'^3 = R2^3 - R1^3 + (k R1)^3``."""
    r1, r2, k = 20.0, 29.0, 0.75
    inner, faces = _sphere(3, r1)
    outer, outer_faces = _sphere(6, r2)
    r2_es = (r2**3 - r1**3 + (k * r1) ** 3) ** (1.0 / 3.0)
    maps = wall_maps(np.stack([inner, k * inner]), faces,
                     [(outer, outer_faces), (outer * r2_es / r2, outer_faces)], APEX, BASE)  # fmt: skip
    expected = (r2_es - k * r1) / (r2 - r1) - 1.0
    assert expected > 0.3
    np.testing.assert_allclose(maps.radial[1], expected, atol=2e-3)
    np.testing.assert_allclose(maps.circumferential[1], k - 1.0, atol=1e-12)
    np.testing.assert_allclose(maps.longitudinal[1], k - 1.0, atol=1e-12)
    np.testing.assert_allclose(maps.peak("radial"), expected, atol=2e-3)  # two frames: ES
    np.testing.assert_allclose(maps.peak("circumferential"), k - 1.0, atol=1e-12)


# strain ------------------------------------------------------------------------------------


def test_directions_are_the_short_axis_tangent_and_the_tangent_towards_the_base():
    v, f = _sphere(3, 20.0)
    circ, lon = cardiac_directions(v, f, APEX, BASE)
    axis = (BASE - APEX) / np.linalg.norm(BASE - APEX)
    normals = v / 20.0
    np.testing.assert_allclose(np.linalg.norm(circ, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(lon, axis=1), 1.0, atol=1e-12)
    for a, b in ((circ, lon), (circ, normals), (circ, axis[None])):
        assert np.abs(np.sum(a * b, axis=1)).max() < 0.02  # the mesh's normals: a few degrees
    assert (lon @ axis > -1e-12).all()
    with pytest.raises(ValueError, match="coincide"):
        cardiac_directions(v, f, APEX, APEX)


def _squeezed_sphere_error(level: int, k: float) -> np.ndarray:
    """Largest and mean errors of the circumferential and longitudinal strains of a sphere
    squeezed by ``k`` across the axis (``z`` kept)."""
    v, f = _sphere(level, 20.0)
    circ, lon = surface_strains(np.stack([v, v * [k, k, 1.0]]), f, APEX, BASE)
    cos = np.hypot(v[:, 0], v[:, 1]) / 20.0  # the meridian's horizontal part
    sin = np.abs(v[:, 2]) / 20.0
    expected_lon = np.sqrt(k**2 * sin**2 + cos**2) - 1.0  # tangent (cos theta, -sin theta)
    circ_error, lon_error = np.abs(circ[1] - (k - 1.0)), np.abs(lon[1] - expected_lon)
    return np.array([circ_error.max(), lon_error.max(), circ_error.mean(), lon_error.mean()])


def test_a_radial_contraction_gives_the_analytic_strains_at_second_order():
    """``(x, y, z) -> (k x, k y, z)``: circumferential strain ``k - 1`` everywhere, the
    meridian's ``sqrt(k^2 cos^2 + sin^2) - 1``. The errors fall as ``h^2``, but for the
    largest longitudinal one, at the twelve vertices of valence 5, which falls as ``h``
    (their normal's first-order error tilts the longitudinal direction)."""
    errors = np.array([_squeezed_sphere_error(level, 0.7) for level in (3, 4, 5)])
    assert errors[-1, :2].max() < 1e-3
    slopes = np.log2(errors[:-1] / errors[1:])  # per halving of the edge
    assert (slopes[:, [0, 2, 3]] > 1.6).all() and (slopes[:, 1] > 0.8).all(), slopes


def test_stretch_is_one_for_a_rigid_motion_and_the_same_in_batches():
    v, f = _sphere(3, 20.0)
    circ, lon = cardiac_directions(v, f, APEX, BASE)
    turn = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3])[:3, :3]
    moved = np.stack([v, v @ turn.T + 5.0, 1.3 * v])
    got = directional_stretch(v, moved, f, circ)
    np.testing.assert_allclose(got[:2], 1.0, atol=1e-12)
    np.testing.assert_allclose(got[2], 1.3, atol=1e-12)
    np.testing.assert_allclose(got[2], directional_stretch(v, moved[2], f, circ), atol=1e-15)
    flat = v.copy()
    flat[f[0]] = flat[f[0, 0]]  # a triangle collapsed to a point
    with pytest.raises(ValueError, match="degenerate"):
        directional_stretch(flat, moved, f, circ)
    with pytest.raises(ValueError, match="directions"):
        directional_stretch(v, moved, f, circ[:5])


def test_peaks_take_each_measure_in_its_sense():
    t = np.linspace(0, 1, 10, endpoint=False)
    curve = -0.2 * np.sin(np.pi * t) ** 2  # shortening, most negative at t = 0.5
    maps = WallMaps(np.stack([9 + 3 * np.sin(np.pi * t) ** 2] * 2, axis=1),
                    np.stack([curve] * 2, axis=1), np.stack([curve] * 2, axis=1),
                    np.zeros((10, 2), bool))  # fmt: skip
    np.testing.assert_allclose(maps.peak("circumferential"), -0.2, atol=1e-3)
    np.testing.assert_allclose(maps.peak("thickness"), 12.0, atol=1e-2)
    np.testing.assert_allclose(maps.peak("radial"), 1 / 3, atol=2e-3)
    np.testing.assert_allclose(signed_peaks(curve[:, None], -1), -0.2, atol=1e-3)
    with pytest.raises(ValueError, match="measure"):
        maps.peak("shear")


# the generator's truth ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def plain():
    """A subject without harmonics, bulge or heterogeneity: a surface of revolution."""
    p = SubjectParameters.mean(SyntheticLVModel())
    return SubjectParameters(**{**p.__dict__, "bulge": 0.0})


def test_the_true_thickness_at_ed_is_the_distance_to_the_meridian(plain):
    """Axisymmetric: the distance from an endocardial point to the epicardium is the 2-D
    distance, in a meridian plane, to the curve ``(rho_e(z) + w, z)`` with the cap
    ``rho^2 + z^2 = w^2`` below the apex, sampled densely (independent of the mesh)."""
    theta = np.linspace(0.05, 0.5 * np.pi, 12)
    phi = np.zeros_like(theta)
    truth = true_wall_maps(plain, theta, phi, [0.0], n_around=240, n_rings=240)
    fine = np.linspace(0.0, 0.5 * np.pi, 200_001)
    ring = true_endocardium(plain, fine, np.zeros_like(fine))
    curve = np.concatenate([
        np.c_[9.0 * np.sin(fine), -9.0 * np.cos(fine)],  # the cap
        np.c_[np.hypot(ring[:, 0], ring[:, 1]) + 9.0, ring[:, 2]],
    ])  # fmt: skip
    points = true_endocardium(plain, theta, phi)
    expected = [np.hypot(*(curve - [p[0], p[2]]).T).min() for p in points]
    np.testing.assert_allclose(truth.thickness[0], expected, atol=5e-3)


def test_the_true_thickness_converges_at_second_order_in_the_epicardium_resolution(plain):
    """The default resolution (480 x 240) is within 3e-3 mm of the surface it samples."""
    theta, phi, _ = lv_grid(12, 6)
    thick = [true_wall_maps(plain, theta, phi, [0.0, 1.0], n_around=n, n_rings=n // 2).thickness
             for n in (120, 240, 480)]  # fmt: skip
    gaps = np.array([np.abs(a - b).max() for a, b in zip(thick[:-1], thick[1:])])
    assert 3.0 < gaps[0] / gaps[1] < 5.0 and gaps[1] < 0.01, gaps  # h^2: the rest ~ gaps[1] / 3
    assert abs(thick[-1][0, 0] - 9.0) < 3e-3  # the apex: the cap is the sphere of radius w
    v0, _ = true_epicardium(plain, 0.0)
    np.testing.assert_allclose(v0[0], [0.0, 0.0, -9.0], atol=1e-12)  # the cap's lowest point


def test_the_true_circumferential_strain_is_the_radial_contraction(plain):
    """Without heterogeneity the ring at height ``u`` is scaled by ``1 - f r(u)`` and turned:
    its circumferential strain is ``-f r(u)``, with ``r = r0 (1 + gamma (1 - 2u))``."""
    theta, phi, _ = lv_grid(16, 8)
    truth = true_wall_maps(plain, theta, phi, [0.0, 0.6, 1.0], n_around=120, n_rings=60)
    u = 1.0 - np.cos(theta)
    r = plain.radial_contraction * (1.0 + plain.contraction_gradient * (1.0 - 2.0 * u))
    off_apex = theta > 0
    for i, f in enumerate((0.0, 0.6, 1.0)):
        np.testing.assert_allclose(truth.circumferential[i, off_apex], -f * r[off_apex],
                                   atol=1e-8)  # fmt: skip
    assert np.isnan(truth.circumferential[:, ~off_apex]).all()
    assert (truth.longitudinal[2, off_apex] < -0.05).all()


def test_maps_of_the_true_surfaces_reproduce_the_truth():
    """The mesh's strains on the generator's own frames (1009 vertices), with its own
    epicardium: only the discretisation of the strains remains."""
    cohort = make_synthetic_cohort(1, n_vertices=1009)
    p = cohort.subjects[0].parameters
    theta, phi, faces = lv_grid(42, 24)
    fractions = [0.0, 0.5, 1.0]
    truth = true_wall_maps(p, theta, phi, fractions, n_around=180, n_rings=90)
    frames = np.stack([true_endocardium(p, theta, phi, f) for f in fractions])
    epicardia = [true_epicardium(p, f, n_around=180, n_rings=90) for f in fractions]
    maps = wall_maps(frames, faces, epicardia, np.zeros(3), [0.0, 0.0, p.long_axis])
    np.testing.assert_allclose(maps.thickness, truth.thickness, atol=1e-12)
    for name in ("circumferential", "longitudinal"):
        error = np.abs(maps.measure(name) - truth.measure(name))[:, theta > 0]
        assert np.nanmax(error) < 0.01 and np.nanmean(error) < 1e-3, name
    with pytest.raises(ValueError, match="one epicardium per frame"):
        wall_maps(frames, faces, epicardia[:2], np.zeros(3), [0.0, 0.0, p.long_axis])
