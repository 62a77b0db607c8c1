"""A synthetic right-ventricle label beside a left-ventricle label: the truth of the septum.

:func:`add_rv_label` writes a right-ventricle (RV) label into a label array that
holds a left-ventricle (LV) cavity label, against the LV's septal side: a crescent
shell that wraps the LV in a sector of the short-axis plane centred on a chosen
direction. In cylindrical coordinates about the LV's long axis (from ``apex`` to
``base``), a voxel centre gets the RV label when

* its height lies in ``heights`` (fractions of the apex-to-base length),
* its angle about the axis from ``septal_direction`` is at most ``half_angle``,
* its distance (world mm) to the nearest LV voxel centre is more than ``wall`` (the
  septal wall, left unlabelled) and at most ``wall + thickness``,
* and it is background (label 0): the RV never overwrites the LV or another label.

The sector is symmetric about the plane through the long axis and
``septal_direction``, so that the RV's centroid lies (up to the LV's own asymmetry
and the voxels) in that direction from the axis, which is what
:func:`~ladders.study.imaging.septum.landmarks_from_labels` measures. Distances are
measured between voxel centres in world coordinates (the full affine), so that
oblique and anisotropic grids are handled exactly to within half a voxel.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, spatial

__all__ = ["add_rv_label", "voxel_centres"]


def voxel_centres(affine, shape) -> np.ndarray:
    """World coordinates of the voxel centres of a grid, shape ``(prod(shape), 3)``, C order.

    Parameters
    ----------
    affine : array (4, 4)
        Voxel indices ``(i, j, k, 1)`` to world coordinates.
    shape : (int, int, int)
    """
    a = np.asarray(affine, dtype=float)
    if a.shape != (4, 4):
        raise ValueError(f"affine: expected a 4 x 4 matrix, got shape {a.shape}")
    index = np.indices(tuple(int(n) for n in shape), dtype=float).reshape(3, -1).T
    return index @ a[:3, :3].T + a[:3, 3]


def _unit(vector, name: str) -> np.ndarray:
    v = np.asarray(vector, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name}: expected 3 finite coordinates, got {vector!r}")
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ValueError(f"{name}: expected a non-zero vector")
    return v / n


def add_rv_label(
    labels,
    affine,
    apex,
    base,
    septal_direction,
    *,
    lv_label: int = 1,
    rv_label: int = 2,
    wall: float = 6.0,
    thickness: float = 10.0,
    half_angle: float = 70.0,
    heights: tuple[float, float] = (0.2, 0.95),
) -> np.ndarray:
    """A copy of ``labels`` with an RV crescent against the LV's septal side (see the module).

    Parameters
    ----------
    labels : int array, shape (i, j, k)
        A label image holding the LV cavity as ``lv_label``.
    affine : array (4, 4)
        Voxel indices to world coordinates (mm).
    apex, base : array (3,)
        The LV's apex and base-plane centre in world coordinates: its long axis.
    septal_direction : array (3,)
        Where the septum is, in world coordinates; its component along the long axis
        is ignored.
    lv_label, rv_label : int
        The LV label read and the RV label written (different).
    wall : float, default 6.0
        Gap between the LV cavity and the RV, in mm (the septal wall).
    thickness : float, default 10.0
        Radial thickness of the RV crescent, in mm.
    half_angle : float, default 70.0
        Half the angular extent of the crescent about the long axis, in degrees
        (0 < half_angle <= 180).
    heights : (float, float), default (0.2, 0.95)
        Extent of the crescent along the long axis, as fractions of the apex-to-base
        length (0 at the apex, 1 at the base).

    Returns
    -------
    ndarray, the dtype of ``labels``, shape of ``labels``

    Raises
    ------
    ValueError
        Naming the argument: a label array that is not 3-D integer or holds no
        ``lv_label``, equal labels, a direction along the long axis, a non-positive
        size, or a crescent with no voxel on the grid.
    """
    lab = np.asarray(labels)
    if lab.ndim != 3 or not np.issubdtype(lab.dtype, np.integer):
        raise ValueError(f"labels: expected a 3-D integer array, got {lab.dtype} {lab.shape}")
    if int(lv_label) == int(rv_label):
        raise ValueError(f"rv_label: must differ from lv_label ({lv_label})")
    lv = lab == int(lv_label)
    if not lv.any():
        raise ValueError(f"labels: no voxel has the LV label {lv_label}")
    for name, value in (("wall", wall), ("thickness", thickness)):
        if not np.isfinite(value) or value < 0 or (name == "thickness" and value == 0):
            raise ValueError(f"{name}: expected a finite length in mm > 0, got {value}")
    if not 0 < half_angle <= 180:
        raise ValueError(f"half_angle: expected degrees in (0, 180], got {half_angle}")
    low, high = (float(h) for h in heights)
    if not low < high:
        raise ValueError(f"heights: expected (low, high) with low < high, got {heights}")
    apex = np.asarray(apex, dtype=float)
    axis = _unit(np.asarray(base, dtype=float) - apex, "base - apex")
    length = float(np.linalg.norm(np.asarray(base, dtype=float) - apex))
    d = _unit(septal_direction, "septal_direction")
    d = d - (d @ axis) * axis
    if np.linalg.norm(d) < 1e-6:
        raise ValueError("septal_direction: parallel to the long axis (from apex to base)")
    d /= np.linalg.norm(d)
    e3 = np.cross(axis, d)

    world = voxel_centres(affine, lab.shape)
    rel = world - apex
    h = rel @ axis / length
    angle = np.degrees(np.abs(np.arctan2(rel @ e3, rel @ d)))
    candidate = (h >= low) & (h <= high) & (angle <= half_angle) & (lab.ravel() == 0)
    # the LV's surface voxels are enough to measure the distance to the LV
    surface = lv & ~ndimage.binary_erosion(lv)
    tree = spatial.cKDTree(world[surface.ravel()])
    dist, _ = tree.query(world[candidate], distance_upper_bound=wall + thickness + 1.0)
    rv = np.zeros(lab.size, dtype=bool)
    rv[candidate] = (dist > wall) & (dist <= wall + thickness)
    if not rv.any():
        raise ValueError(
            "labels: the RV crescent has no voxel on this grid (too small a grid, or the "
            "crescent lies outside it)"
        )
    out = lab.copy()
    out[rv.reshape(lab.shape)] = int(rv_label)
    return out
