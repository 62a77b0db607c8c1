"""Images of the cine route: numpy volumes with an affine as SimpleITK images, and masks.

An image is a numpy array ``(X, Y, Z)`` with a 4 x 4 affine from voxel indices to world
millimetres; :func:`image_from_array` gives the SimpleITK image whose physical space is
that world frame (see :mod:`.cine_tracking`'s conventions). :func:`wall_mask` marks the
voxels near a mesh, where the registrations' metric samples.
"""

from __future__ import annotations

import numpy as np

from ..imaging.rv_label import voxel_centres

__all__ = ["image_from_array", "wall_mask"]


def _sitk():
    try:
        import SimpleITK as sitk
    except ImportError as error:  # pragma: no cover - a declared dependency
        raise ImportError("cine tracking needs SimpleITK: pip install 'SimpleITK>=2.3'") from error
    return sitk


def _check_affine(affine, name: str = "affine") -> np.ndarray:
    try:
        a = np.asarray(affine, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a 4 x 4 matrix of numbers") from None
    if a.shape != (4, 4):
        raise ValueError(f"{name}: expected a 4 x 4 matrix, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: NaN or infinite entries")
    if not np.allclose(a[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name}: the last row must be (0, 0, 0, 1), got {a[3].tolist()}")
    if abs(np.linalg.det(a[:3, :3])) < 1e-9 * max(1.0, np.abs(a[:3, :3]).max() ** 3):
        raise ValueError(f"{name}: singular (voxels of zero size)")
    return a


def _check_volume(volume, name: str) -> np.ndarray:
    try:
        v = np.asarray(volume, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a 3-D array of intensities") from None
    if v.ndim != 3:
        raise ValueError(f"{name}: expected a 3-D array (X, Y, Z), got shape {v.shape}")
    if min(v.shape) < 2:
        raise ValueError(f"{name}: every axis needs at least 2 voxels, got shape {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError(f"{name}: NaN or infinite intensities")
    return v


def image_from_array(volume, affine):
    """A SimpleITK image of ``volume`` (X, Y, Z) whose physical space is the affine's world.

    ITK index ``(i, j, k)`` is ``volume[i, j, k]``; origin ``affine[:3, 3]``, spacing the
    column norms of ``affine[:3, :3]``, direction the normalised columns (no LPS/RAS
    flip: see the module's conventions).
    """
    sitk = _sitk()
    a = _check_affine(affine)
    v = _check_volume(volume, "volume")
    matrix = a[:3, :3]
    spacing = np.linalg.norm(matrix, axis=0)
    image = sitk.GetImageFromArray(np.ascontiguousarray(v.transpose(2, 1, 0), dtype=np.float32))
    image.SetSpacing(spacing.tolist())
    image.SetDirection((matrix / spacing).ravel().tolist())
    image.SetOrigin(a[:3, 3].tolist())
    return image


def _grid_affine(spacing) -> np.ndarray:
    """The affine from ``spacing``: a 4 x 4 affine, or 3 voxel sizes (origin 0, axes aligned)."""
    try:
        s = np.asarray(spacing, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("spacing: expected 3 voxel sizes in mm or a 4 x 4 affine") from None
    if s.shape == (4, 4):
        return _check_affine(s, "spacing")
    if s.shape == (3,):
        if not (np.isfinite(s).all() and (s > 0).all()):
            raise ValueError(f"spacing: expected 3 voxel sizes > 0 mm, got {s.tolist()}")
        a = np.eye(4)
        a[:3, :3] = np.diag(s)
        return a
    raise ValueError(
        f"spacing: expected 3 voxel sizes in mm or a 4 x 4 affine, got shape {s.shape}"
    )


def _check_mask(mask, shape, of: str) -> np.ndarray:
    m = np.asarray(mask)
    if m.shape != tuple(shape):
        raise ValueError(f"mask: shape {m.shape} differs from {of}'s {tuple(shape)}")
    if not np.isin(m, (0, 1)).all() or not m.any():
        raise ValueError("mask: expected 0 and 1 with at least one voxel set")
    return m.astype(np.uint8)


def _mask_image(mask: np.ndarray, reference):
    """The 0/1 ``mask`` as an 8-bit SimpleITK image on ``reference``'s grid."""
    sitk = _sitk()
    image = sitk.GetImageFromArray(np.ascontiguousarray(mask.transpose(2, 1, 0), dtype=np.uint8))
    image.CopyInformation(reference)
    return image


def wall_mask(shape, affine, vertices, distance: float) -> np.ndarray:
    """Voxels whose centre lies within ``distance`` mm of a vertex: where the metric samples.

    Parameters
    ----------
    shape : (int, int, int)
    affine : array (4, 4)
        Voxel indices to world mm.
    vertices : array (k, 3)
        World mm.
    distance : float
        mm.

    Returns
    -------
    ndarray of uint8, shape ``shape``
        1 inside, 0 outside.
    """
    from scipy.spatial import cKDTree

    world = voxel_centres(affine, shape)
    near = cKDTree(np.asarray(vertices, float)).query(world, distance_upper_bound=distance)[0]
    return np.isfinite(near).reshape(tuple(shape)).astype(np.uint8)
