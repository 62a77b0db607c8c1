"""Label images (NIfTI) read with their world frame: one frame of a 3-D or 4-D segmentation.

:func:`read_label_image` reads a ``.nii`` or ``.nii.gz`` file through nibabel and
returns a :class:`LabelImage`: the integer labels of one frame and the image's
affine (voxel indices to world millimetres, the sform or qform the file states,
oblique orientations and flips included). Everything a label image can get wrong is
refused with an :class:`ImageError` naming the file: an unreadable file, labels that
are not integers, a 4-D series without a frame index or with one out of range, an
affine the file does not state (both codes 0) or that is singular.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import nibabel as nib
import numpy as np

from ..errors import MeshFolderError

__all__ = [
    "ImageError",
    "LabelImage",
    "read_label_image",
    "read_label_series",
    "IMAGE_SUFFIXES",
    "image_stem",
]

#: File suffixes of the label images read.
IMAGE_SUFFIXES = (".nii.gz", ".nii")


class ImageError(MeshFolderError):
    """A label image that cannot be turned into a mesh; the message names the file."""


def image_stem(path) -> str:
    """The file name without its image suffix (``case01_ed.nii.gz`` -> ``case01_ed``)."""
    name = Path(path).name
    for suffix in IMAGE_SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return Path(path).stem


@dataclass(frozen=True)
class LabelImage:
    """One frame of a label image and its world frame.

    Attributes
    ----------
    labels : ndarray of int, shape (i, j, k)
    affine : ndarray, shape (4, 4)
        Voxel indices ``(i, j, k, 1)`` to world coordinates in mm.
    path : Path
    frame : int or None
        The frame of a 4-D series (None for a 3-D image).
    """

    labels: np.ndarray
    affine: np.ndarray
    path: Path
    frame: int | None = None

    @property
    def spacing(self) -> tuple[float, float, float]:
        """Voxel size along each index axis, in mm (column norms of the affine)."""
        return tuple(float(s) for s in np.linalg.norm(self.affine[:3, :3], axis=0))

    @property
    def grid(self) -> tuple:
        """``(shape, affine)`` rounded, to compare the grids of two frames."""
        return self.labels.shape, tuple(np.round(self.affine, 6).ravel())


def _affine(img, path: Path) -> np.ndarray:
    header = img.header
    codes = (
        (int(header["sform_code"]), int(header["qform_code"])) if "sform_code" in header else (1, 1)
    )
    if codes == (0, 0):
        raise ImageError(
            f"{path}: no affine: the file states neither an sform nor a qform (both codes 0), so "
            "its world frame is unknown; set one with the tool that wrote it"
        )
    affine = np.asarray(img.affine, dtype=float)
    if affine.shape != (4, 4) or not np.isfinite(affine).all():
        raise ImageError(f"{path}: the affine is not a finite 4 x 4 matrix")
    det = float(np.linalg.det(affine[:3, :3]))
    if abs(det) < 1e-9:
        raise ImageError(f"{path}: singular affine (determinant {det:.3g}): voxels of zero size")
    return affine


def read_label_image(path, frame: int | None = None) -> LabelImage:
    """One frame of a NIfTI label image with its affine (see the module).

    Parameters
    ----------
    path : str or Path
        A ``.nii`` or ``.nii.gz`` file, 3-D or 4-D (the fourth axis indexes frames).
    frame : int, optional
        The frame of a 4-D series (0-based); required for a 4-D file, refused for a
        3-D one unless 0.

    Raises
    ------
    ImageError
    """
    path = Path(path)
    if not path.name.lower().endswith(IMAGE_SUFFIXES):
        raise ImageError(f"{path}: not a NIfTI file (.nii or .nii.gz)")
    try:
        img = nib.load(str(path))
        data = np.asanyarray(img.dataobj)
    except Exception as exc:  # noqa: BLE001 - nibabel raises many kinds for a bad file
        raise ImageError(f"{path}: cannot be read as NIfTI ({type(exc).__name__}: {exc})") from None
    affine = _affine(img, path)
    if data.ndim == 4 and data.shape[3] == 1 and frame in (None, 0):
        data, frame = data[..., 0], None
    if data.ndim == 4:
        if frame is None:
            raise ImageError(
                f"{path}: a 4-D series of {data.shape[3]} frames: name the frame (--frames ED,ES)"
            )
        if not 0 <= int(frame) < data.shape[3]:
            raise ImageError(
                f"{path}: frame {frame} out of range: the series has frames 0..{data.shape[3] - 1}"
            )
        data = data[..., int(frame)]
    elif data.ndim == 3:
        if frame not in (None, 0):
            raise ImageError(f"{path}: a 3-D image has no frame {frame}")
        frame = None
    else:
        raise ImageError(f"{path}: expected a 3-D or 4-D image, got {data.ndim} dimensions")
    return _label_image(data, affine, path, frame)


def _label_image(data, affine, path: Path, frame: int | None) -> LabelImage:
    """A 3-D array of one frame as a :class:`LabelImage`; refused unless its values are integers."""
    if not np.issubdtype(data.dtype, np.integer):
        values = np.asarray(data, dtype=float)
        if not np.isfinite(values).all() or np.any(values != np.round(values)):
            raise ImageError(
                f"{path}: not a label image: its values are not integers (a probability map or "
                "an intensity image?)"
            )
        data = values
    return LabelImage(
        np.asarray(data).astype(np.int64), affine, path, None if frame is None else int(frame)
    )


def read_label_series(path) -> list[LabelImage]:
    """Every frame of a 4-D NIfTI label series, the file read once (see :func:`read_label_image`).

    Raises
    ------
    ImageError
        Not a 4-D NIfTI file, or values that are not labels.
    """
    path = Path(path)
    if not path.name.lower().endswith(IMAGE_SUFFIXES):
        raise ImageError(f"{path}: not a NIfTI file (.nii or .nii.gz)")
    try:
        img = nib.load(str(path))
        data = np.asanyarray(img.dataobj)
    except Exception as exc:  # noqa: BLE001 - nibabel raises many kinds for a bad file
        raise ImageError(f"{path}: cannot be read as NIfTI ({type(exc).__name__}: {exc})") from None
    if data.ndim != 4:
        raise ImageError(f"{path}: expected a 4-D series, got {data.ndim} dimensions")
    affine = _affine(img, path)
    return [_label_image(data[..., t], affine, path, t) for t in range(data.shape[3])]
