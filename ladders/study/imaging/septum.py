"""Apex, base-plane centre and septal point of a left-ventricle mesh, from a right-ventricle label.

A left ventricle (LV) is close to a surface of revolution: a surface fit cannot
tell how it is turned about its long axis, but the right ventricle (RV) can, since
the septum is the wall the two share (as in the UK Biobank pipeline).
:func:`landmarks_from_labels` gives the :class:`~ladders.study.preparation.landmarks.Landmarks`
of an LV mesh extracted from a label image that also holds an RV label. Vertices are
weighted by a third of the area of their faces, so that nothing depends on how the
vertices are spread.

1. **The base-plane centre and a first long axis** (:func:`lv_apex_and_base`). An
   open mesh (cut at the valve plane): the centroid of the region its rim (the
   boundary edges) encloses, projected onto the cut plane along its normal when one
   is given; the axis goes from the mesh's area-weighted centroid to it. (The mean of
   the rim's vertices depends on how decimation spread them: 1.1 mm from the true
   centre on average, up to 3.1 mm, at 1 mm voxels, against 0.04 and 0.09 mm.) A closed mesh (the label's
   lid at the base): the first principal axis of the mesh, oriented towards the cut
   plane's normal or else towards the wider end, finds the lid (the faces whose
   normals lie within :data:`LID_ANGLE` of the lid's mean normal); the base-plane
   centre is the lid's centroid, and the axis goes from the mesh's centroid to it.
   The principal axis alone is not used for open meshes: on the synthetic cohort's
   end-diastolic shapes, whose two largest principal variances can differ by only
   20 %, the wall's harmonics turn it by up to 12 degrees from the apex-to-base line
   (1.8 on average over 80 shapes), the centroid-to-rim line by at most 3.2 (1.3).
2. **The apex**: the vertex farthest from the base plane along that axis: of the
   vertices within :data:`APEX_BAND` (2.5 %) of the length of the far end, the one
   nearest to their centroid (weighted by area and by how near the end they are).
   That is the tip of a pointed apex and the centre of the flat cap thick slices
   give (where the farthest vertex would fall anywhere on the cap). The long axis of
   the landmarks is then the line from the apex to the base-plane centre.
3. **The septal direction**, orthogonal to the long axis. With ``septum="insertion"``
   (the default): the bisector of the RV's two insertion points, its angular edges
   about the long axis. The AHA segmentation bounds the septum by these points
   (Cerqueira et al., Circulation 2002), and the UK Biobank pipeline takes the middle
   of the wall the RV touches. Each RV voxel centre (world mm, the image's affine)
   gets its angle about the line from the apex to the base-plane centre, measured
   from the centroid direction below; the edges are the :data:`INSERTION_PERCENTILE`
   and ``100 -`` that percentiles of these angles, so a few stray voxels do not move
   them. With ``septum="centroid"``: from the LV's axis point (the mesh's
   area-weighted centroid) to the centroid of the RV voxels (:func:`label_centroid`).
   Their errors on the orientation benchmark's posed label images are in
   ``docs/generated/orientation_images.md``.
4. **The septal point**: where the ray from the long axis at mid-height (half way
   from the apex to the base-plane centre) in the septal direction first meets the
   mesh: a point of the surface in exactly the septal direction. Should the ray meet
   no face (a hole in the mesh), the vertex of the band of heights 40-60 % farthest
   along the septal direction is taken.

Everything is in the image's world coordinates (mm), like the meshes
:func:`~ladders.study.imaging.mesh_label_images` writes. The accuracy on synthetic
subjects of known pose is measured in ``tests/test_septum_landmarks.py``.
"""

from __future__ import annotations

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh

from ..preparation.landmarks import LandmarkError, Landmarks
from ..surface_queries import intersect_lines_triangles
from ..volume import boundary_vertices, enclosed_volume
from .label_images import ImageError, LabelImage

__all__ = [
    "landmarks_from_labels",
    "lv_apex_and_base",
    "label_centroid",
    "label_points",
    "SEPTUM_METHODS",
]

#: The smallest ratio of the two largest principal variances of an LV with a long axis.
MIN_ELONGATION = 1.05
#: The apex is sought among the vertices this fraction of the length from the far end.
APEX_BAND = 0.025
#: The faces of the lid of a closed mesh have normals within this angle (degrees) of its own.
LID_ANGLE = 15.0
#: The RV's insertion points: these percentiles of its voxels' angles about the long axis.
INSERTION_PERCENTILE = 1.0
#: An RV whose angles about the long axis span more than this (degrees) has no insertion points.
MAX_RV_SPAN = 330.0
#: The ways to take the septal direction from an RV label.
SEPTUM_METHODS = ("insertion", "centroid")
_FALLBACK_BAND = (0.4, 0.6)


def _where(image: LabelImage) -> str:
    return f"{image.path}{'' if image.frame is None else f' frame {image.frame}'}"


def _vertex_areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """A third of the area of the faces around each vertex (0 for an unused vertex)."""
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    weights = np.zeros(len(v))
    np.add.at(weights, f.ravel(), np.repeat(area / 3.0, 3))
    return weights


def _plane(cut_plane) -> tuple[np.ndarray, np.ndarray]:
    plane = np.asarray(cut_plane, dtype=float).ravel()
    if plane.shape != (6,) or not np.isfinite(plane).all() or not np.any(plane[3:]):
        raise ValueError(
            f"cut_plane: expected (x, y, z, nx, ny, nz) with a non-zero normal, got {cut_plane!r}"
        )
    return plane[:3], plane[3:] / np.linalg.norm(plane[3:])


def _apex(v: np.ndarray, weights: np.ndarray, used: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The apex: of the vertices within :data:`APEX_BAND` of the length of the low end along
    ``axis``, the one nearest to their centroid, weighted by area and by how near the end
    they are (the tip of a pointed apex, the centre of a flat cap)."""
    h = np.where(used, v @ axis, np.nan)
    low, high = np.nanmin(h), np.nanmax(h)
    nearness = np.nan_to_num(1.0 - (h - low) / (APEX_BAND * (high - low)), nan=0.0)
    near = np.flatnonzero(nearness > 0)
    w = weights[near] * nearness[near]
    centre = w @ v[near] / w.sum()
    return v[near[np.argmin(np.linalg.norm(v[near] - centre, axis=1))]]


def _lid_centre(v: np.ndarray, f: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The centre of the flat lid a label gives a closed mesh at its base (towards ``axis``).

    The lid is the faces whose normals lie within :data:`LID_ANGLE` of the lid's mean
    normal, found from ``axis`` by a few refinements; its centre is their area-weighted
    centroid.
    """
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    if enclosed_volume(v, f) < 0:  # inward normals: turn them out
        normals = -normals
    area = np.linalg.norm(normals, axis=1)
    unit = normals / np.where(area > 0, area, 1.0)[:, None]
    direction = axis
    for angle in (2 * LID_ANGLE, LID_ANGLE, LID_ANGLE, LID_ANGLE):
        lid = (unit @ direction > np.cos(np.radians(angle))) & (area > 0)
        if not lid.any():
            raise ValueError("lv mesh: closed, without a flat base (a lid) to find the base by")
        direction = area[lid] @ unit[lid]
        direction = direction / np.linalg.norm(direction)
    return area[lid] @ v[f[lid]].mean(axis=1) / area[lid].sum()


def _rim_centre(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The centroid of the region the rim encloses (the base section), not of its vertices.

    The rim's boundary edges, oriented as in their faces, make a fan of triangles with
    the mean of the rim's vertices; their areas, signed along the fan's total normal,
    weight their centroids. Unlike the mean of the rim's vertices, this does not depend
    on how the vertices are spread along the rim.
    """
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, index, counts = np.unique(np.sort(edges, axis=1), axis=0, return_index=True, return_counts=True)  # fmt: skip
    rim = edges[index[counts == 1]]
    hub = v[np.unique(rim)].mean(axis=0)
    a, b = v[rim[:, 0]], v[rim[:, 1]]
    normals = 0.5 * np.cross(a - hub, b - hub)
    total = normals.sum(axis=0)
    if not np.linalg.norm(total) > 0:
        return hub
    signed = normals @ (total / np.linalg.norm(total))
    return signed @ ((hub + a + b) / 3.0) / signed.sum()


def _long_axis(v: np.ndarray, f: np.ndarray, cut_plane) -> tuple[np.ndarray, ...]:
    """Apex, base-plane centre and area-weighted centroid (see :func:`lv_apex_and_base`)."""
    weights = _vertex_areas(v, f)
    total = float(weights.sum())
    if total <= 0.0:
        raise ValueError("lv mesh: its faces have no area")
    used = weights > 0
    centroid = weights @ v / total
    x = v - centroid
    values, vectors = np.linalg.eigh((x * weights[:, None]).T @ x / total)
    axis = vectors[:, 2]
    rim = boundary_vertices(f)
    plane = None if cut_plane is None else _plane(cut_plane)
    if rim.size:  # an open mesh: the axis goes from the centroid to the rim's centre
        base = _rim_centre(v, f)
        if plane is not None:  # onto the plane, along its normal
            base = base - ((base - plane[0]) @ plane[1]) * plane[1]
        if np.linalg.norm(base - centroid) <= 1e-9 * np.sqrt(values[2]):
            raise ValueError("lv mesh: the centre of its rim is its centroid: no long axis")
        axis = (base - centroid) / np.linalg.norm(base - centroid)
    elif values[2] < MIN_ELONGATION * values[1]:
        raise ValueError(
            "lv mesh: closed and without a clear long axis (its two largest principal "
            f"variances, {values[2]:.4g} and {values[1]:.4g} mm^2, are within "
            f"{MIN_ELONGATION - 1:.0%})"
        )
    elif plane is not None:
        axis = axis if axis @ plane[1] > 0 else -axis
    else:  # a closed mesh: the base is the wider end
        h = x @ axis
        radial = np.linalg.norm(x - np.outer(h, axis), axis=1)
        band = 0.15 * (h[used].max() - h[used].min())
        top = used & (h >= h[used].max() - band)
        bottom = used & (h <= h[used].min() + band)
        axis = axis if radial[top].mean() >= radial[bottom].mean() else -axis
    if plane is not None and abs(axis @ plane[1]) < 0.25:
        raise ValueError(
            f"lv mesh: the cut plane's normal is {np.degrees(np.arccos(abs(axis @ plane[1]))):.0f} "
            "degrees from the mesh's long axis: not a base plane"
        )
    if not rim.size:  # a closed mesh: the centre of its lid, and the axis through it
        base = _lid_centre(v, f, axis)
        axis = (base - centroid) / np.linalg.norm(base - centroid)
    apex = _apex(v, weights, used, axis)
    return apex, base, centroid


def lv_apex_and_base(vertices, faces, cut_plane=None) -> tuple[np.ndarray, np.ndarray]:
    """The apex and the base-plane centre of an LV mesh (steps 1-2 of the module).

    Parameters
    ----------
    vertices : array (k, 3)
    faces : int array (f, 3)
    cut_plane : sequence of 6 floats, optional
        ``(x, y, z, nx, ny, nz)``: the plane the mesh was cut at, its normal pointing
        to the base side (the side removed).

    Returns
    -------
    apex, base : ndarray, shape (3,)

    Raises
    ------
    ValueError
        A malformed mesh or plane; an open mesh whose rim's centre is its centroid; a
        closed mesh without a clear long axis (its two largest principal variances
        within 5 % of each other) or without a flat lid; a cut plane whose normal is
        more than 75 degrees from the long axis.
    """
    v, f = check_mesh(vertices, faces, "lv mesh")
    apex, base, _ = _long_axis(np.asarray(v, dtype=np.float64), f, cut_plane)
    return apex, base


def label_points(image: LabelImage, label: int, role: str = "label") -> np.ndarray:
    """The voxel centres of ``label`` in world coordinates (mm), shape ``(n, 3)``.

    Raises
    ------
    ImageError
        The label has no voxel; the message names the file, ``role`` and the label.
    """
    index = np.argwhere(np.asarray(image.labels) == int(label))
    if len(index) == 0:
        present = [int(x) for x in np.unique(image.labels) if x != 0][:10]
        raise ImageError(
            f"{_where(image)}: {role} {label} is absent (no voxels); labels present: "
            f"{present or 'none'}"
        )
    a = np.asarray(image.affine, dtype=float)
    return index @ a[:3, :3].T + a[:3, 3]


def label_centroid(image: LabelImage, label: int, role: str = "label") -> np.ndarray:
    """The centroid of the voxel centres of ``label`` in world coordinates (mm), shape (3,).

    Raises
    ------
    ImageError
        The label has no voxel; the message names the file, ``role`` and the label.
    """
    return label_points(image, label, role).mean(axis=0)


def _insertion_bisector(points, apex, axis, reference) -> tuple[np.ndarray, float]:
    """The bisector of the RV's insertion points about the long axis, and their angle apart.

    ``points`` (the RV's voxel centres) get their angles about the line through
    ``apex`` along ``axis``, from the unit ``reference`` orthogonal to it; the edges are
    the :data:`INSERTION_PERCENTILE` and ``100 -`` that percentiles (degrees apart
    returned with the unit bisector).
    """
    side = np.cross(axis, reference)
    rel = points - apex
    angle = np.arctan2(rel @ side, rel @ reference)
    low, high = np.percentile(angle, [INSERTION_PERCENTILE, 100.0 - INSERTION_PERCENTILE])
    middle = 0.5 * (low + high)
    return np.cos(middle) * reference + np.sin(middle) * side, float(np.degrees(high - low))


def _first_crossing(origin, direction, v, f) -> np.ndarray | None:
    """The first point where the ray ``origin + t direction`` (t > 0) crosses a face."""
    n = len(f)
    t, inside = intersect_lines_triangles(
        np.broadcast_to(origin, (n, 3)), np.broadcast_to(direction, (n, 3)),
        v[f[:, 0]], v[f[:, 1]], v[f[:, 2]], eps=0.0,
    )  # fmt: skip
    hit = inside & (t > 0)
    if not hit.any():
        return None
    return origin + float(t[hit].min()) * direction


def landmarks_from_labels(
    lv_vertices,
    lv_faces,
    labels_image: LabelImage,
    rv_label: int,
    cut_plane=None,
    septum: str = "insertion",
) -> Landmarks:
    """Apex, base-plane centre and septal point of an LV mesh from an RV label (see the module).

    Parameters
    ----------
    lv_vertices : array (k, 3)
        The LV mesh in the image's world coordinates (mm), e.g. from
        :func:`~ladders.study.imaging.extract_surface`.
    lv_faces : int array (f, 3)
    labels_image : LabelImage
        The label image the mesh comes from, holding the RV label.
    rv_label : int
        The RV's label.
    cut_plane : sequence of 6 floats, optional
        ``(x, y, z, nx, ny, nz)`` in world mm: the plane the mesh was cut at (the
        valve plane), its normal pointing away from the apex.
    septum : {"insertion", "centroid"}
        The septal direction: the bisector of the RV's insertion points (the default)
        or the direction of the RV's centroid (see the module, step 3).

    Returns
    -------
    Landmarks

    Raises
    ------
    ImageError
        Naming the file and the label: the RV label is absent, the RV's centroid lies
        on the LV's long axis (within half a voxel), the RV goes so far round the LV
        that it has no insertion points (its angles span more than
        :data:`MAX_RV_SPAN` degrees; ``septum="insertion"``), or the mesh gives no long
        axis (see :func:`lv_apex_and_base`).
    ValueError
        A malformed mesh, label or cut plane.
    """
    if isinstance(rv_label, bool) or not isinstance(rv_label, (int, np.integer)):
        raise ValueError(f"rv_label: expected an int, got {rv_label!r}")
    if septum not in SEPTUM_METHODS:
        raise ValueError(f"septum: expected one of {SEPTUM_METHODS}, got {septum!r}")
    v, f = check_mesh(lv_vertices, lv_faces, "lv mesh")
    v = np.asarray(v, dtype=np.float64)
    if cut_plane is not None:
        _plane(cut_plane)  # a malformed plane is the caller's error, not the image's
    where = _where(labels_image)
    rv_points = label_points(labels_image, int(rv_label), role="RV label")
    rv = rv_points.mean(axis=0)
    try:
        apex, base, centroid = _long_axis(v, f, cut_plane)
    except ValueError as exc:
        raise ImageError(f"{where}: RV label {rv_label}: {exc}") from None
    length = float(np.linalg.norm(base - apex))
    axis = (base - apex) / length
    offset = rv - centroid
    radial = offset - (offset @ axis) * axis
    spacing = min(np.linalg.norm(np.asarray(labels_image.affine, float)[:3, :3], axis=0))
    if np.linalg.norm(radial) <= 0.5 * spacing:
        raise ImageError(
            f"{where}: RV label {rv_label}: the centroid of the RV lies on the LV's long axis "
            f"({np.linalg.norm(radial):.3g} mm from it): the septal direction is undefined"
        )
    septal = radial / np.linalg.norm(radial)
    if septum == "insertion":
        septal, span = _insertion_bisector(rv_points, apex, axis, septal)
        if span > MAX_RV_SPAN:
            raise ImageError(
                f"{where}: RV label {rv_label}: the RV goes round the LV's long axis over "
                f"{span:.0f} degrees: no insertion points (septum='centroid' takes the "
                "direction of its centroid)"
            )
    middle = apex + 0.5 * length * axis
    septum = _first_crossing(middle, septal, v, f)
    if septum is None:
        heights = (v - apex) @ axis / length
        band = (heights >= _FALLBACK_BAND[0]) & (heights <= _FALLBACK_BAND[1])
        band &= _vertex_areas(v, f) > 0
        if not band.any():
            raise ImageError(f"{where}: RV label {rv_label}: the LV mesh has no vertex at mid-height")  # fmt: skip
        scores = np.where(band, (v - middle) @ septal, -np.inf)
        septum = v[int(np.argmax(scores))]
    try:
        return Landmarks(apex, base, septum)
    except LandmarkError as exc:
        raise ImageError(f"{where}: RV label {rv_label}: {exc}") from None
