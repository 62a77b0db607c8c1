"""Surface distances that leave out what lies beyond an open template's rim (a label's lid)."""

import numpy as np
import pytest

from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.preparation import CorrespondenceSettings, correspond_mesh, surface_distances
from ladders.study.preparation.alignment import SimilarityTransform
from ladders.study.volume import boundary_edges, boundary_vertices
from manifolds.lddmm import RegistrationSettings

COHORT = make_synthetic_cohort(1, n_vertices=241, seed=3)


def with_lid(vertices, faces, rings: int = 3):
    """The open ventricle closed at its rim by a flat lid of ``rings`` concentric rings."""
    rim = boundary_vertices(faces)
    edges = boundary_edges(faces)
    # the rim in order around the axis (the model's base is a circle about +z)
    centre = vertices[rim].mean(axis=0)
    angle = np.arctan2(*(vertices[rim] - centre)[:, 1::-1].T)
    ring = rim[np.argsort(angle)]
    assert len(edges) == len(ring)
    v, f = [np.asarray(vertices, float)], [np.asarray(faces)]
    outer, n = ring, len(vertices)
    for r in range(rings - 1, 0, -1):
        inner = centre + (vertices[ring] - centre) * r / rings
        idx = np.arange(n, n + len(ring))
        v.append(inner)
        n += len(ring)
        nxt = np.roll(np.arange(len(ring)), -1)
        f.append(np.c_[outer, outer[nxt], idx])
        f.append(np.c_[outer[nxt], idx[nxt], idx])
        outer = idx
    v.append(centre[None])
    nxt = np.roll(np.arange(len(ring)), -1)
    f.append(np.c_[outer, outer[nxt], np.full(len(ring), n)])
    return np.concatenate(v), np.concatenate(f)


def test_a_lid_beyond_the_rim_is_left_out_and_counted():
    atlas, faces = COHORT.atlas, COHORT.faces
    v, f = with_lid(atlas, faces)
    assert len(boundary_vertices(f)) == 0  # closed
    radius = np.linalg.norm(atlas[boundary_vertices(faces)][:, :2], axis=1).mean()
    plain = surface_distances(atlas, faces, v, f)
    assert plain["hausdorff"] == pytest.approx(radius, rel=0.05)  # the lid's centre
    rim_aware = surface_distances(atlas, faces, v, f, skip_beyond_rim=True)
    assert rim_aware["hausdorff"] < 1e-6 and rim_aware["mean_surface_distance"] < 1e-6
    # on or beyond the rim: the rim itself and the lid's rings and centre
    lid = len(boundary_vertices(faces)) * 3 + 1
    assert rim_aware["beyond_rim_fraction"] == pytest.approx(lid / len(v))
    assert "beyond_rim_fraction" not in plain


def test_a_misfit_within_the_rim_still_counts():
    atlas, faces = COHORT.atlas, COHORT.faces
    v, f = with_lid(atlas, faces)
    moved = v.copy()
    wall = int(np.argmin(np.abs(atlas[:, 2] - 0.5 * atlas[:, 2].max())))  # mid-height
    normal = np.r_[atlas[wall, :2], 0.0] / np.linalg.norm(atlas[wall, :2])
    moved[wall] += 5.0 * normal
    d = surface_distances(atlas, faces, moved, f, skip_beyond_rim=True)
    assert d["hausdorff"] == pytest.approx(5.0, rel=0.1)
    # a mesh no vertex of which the template covers: only the template's side counts
    far = surface_distances(atlas[:3], np.array([[0, 1, 2]]), v, f, skip_beyond_rim=True)
    assert 0.0 < far["beyond_rim_fraction"] <= 1.0 and np.isfinite(far["hausdorff"])


def test_the_correspondence_of_a_lidded_mesh_is_not_flagged_for_its_lid():
    s = COHORT.subjects[0]
    v, f = with_lid(s.ed, COHORT.faces)
    settings = CorrespondenceSettings(
        registration=RegistrationSettings(sigma=20.0, control_points="grid", max_iter=60),
        sigma_w=8.0,
    )
    out = correspond_mesh(COHORT.atlas, COHORT.faces, v, f, settings,
                          transform=SimilarityTransform.identity())  # fmt: skip
    q = out.quality
    assert q["hausdorff"] < settings.flag_hausdorff
    rim = len(boundary_vertices(COHORT.faces))
    inner = 2 * rim + 1  # the lid's rings and centre; the rim itself may fall either side
    assert inner / len(v) - 0.02 <= q["beyond_rim_fraction"] <= (inner + rim) / len(v) + 0.02
    plain = surface_distances(out.vertices, COHORT.faces, v, f)
    assert plain["hausdorff"] > 3 * q["hausdorff"]  # what the lid alone added before
