"""A subject's label series: the frames of a cardiac cycle, found, checked and read one by one.

A series is given in one of two layouts, in the folder of images:

* ``<subject>.nii.gz`` (or ``.nii``): one 4-D NIfTI file, frames on the fourth axis
  (as :func:`~ladders.study.imaging.cine.write_series` writes them);
* ``<subject>/``: a folder of 3-D NIfTI files, one per frame, each name ending in its
  frame number (``frame_00.nii.gz``, ``sa_1.nii``, ``07.nii.gz``); the numbers must
  run without a gap, the first one is end-diastole.

:func:`find_series` maps subject names to their files; :func:`open_series` checks a
series before anything is computed and refuses, in one line naming the file, what
would make its tracking wrong: a 3-D image where a series is expected, a series of
one frame, frames missing or given twice, frames on different grids (shapes or
affines), a file that is not a label image. :func:`check_field_of_view` refuses an
ED mesh that lies outside the series' field of view (a mesh of another subject, or
not in the images' world frame).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import nibabel as nib
import numpy as np

from ..imaging.label_images import (
    IMAGE_SUFFIXES,
    ImageError,
    LabelImage,
    image_stem,
    read_label_image,
    read_label_series,
)

__all__ = ["SeriesError", "LabelSeries", "find_series", "open_series", "check_field_of_view"]

_NUMBER = re.compile(r"(\d+)$")


class SeriesError(ImageError):
    """A label series that cannot be tracked; the message names the file and the problem."""


@dataclass(frozen=True)
class LabelSeries:
    """The frames of one subject's label series (checked by :func:`open_series`).

    Attributes
    ----------
    files : tuple of Path
        One 4-D file, or one 3-D file per frame in frame order.
    n_frames : int
    shape : tuple of 3 int
        The grid of every frame (voxels).
    affine : ndarray, shape (4, 4)
        Voxel indices to world mm, shared by every frame.
    """

    files: tuple
    n_frames: int
    shape: tuple
    affine: np.ndarray

    @property
    def four_d(self) -> bool:
        """One 4-D file (else one 3-D file per frame)."""
        return len(self.files) == 1

    @property
    def name(self) -> str:
        """The series' file, or its folder of frames."""
        return str(self.files[0] if self.four_d else self.files[0].parent)

    def intensities(self) -> np.ndarray:
        """Every frame's voxel values as floats, shape ``(n_frames, *shape)`` (cine images).

        Raises
        ------
        SeriesError
            A value is not finite.
        """
        if self.four_d:
            data = np.asarray(nib.load(str(self.files[0])).dataobj, dtype=float)
            frames = np.moveaxis(data, 3, 0)
        else:
            frames = np.stack([
                np.asarray(nib.load(str(p)).dataobj, dtype=float).reshape(self.shape)
                for p in self.files
            ])  # fmt: skip
        if not np.isfinite(frames).all():
            raise SeriesError(f"{self.name}: NaN or infinite intensities")
        return frames

    def frames(self) -> list[LabelImage]:
        """Every frame in order, each file read once (a 4-D file is not read per frame)."""
        if self.four_d:
            return read_label_series(self.files[0])
        return [self.frame(t) for t in range(self.n_frames)]

    def frame(self, t: int) -> LabelImage:
        """Frame ``t`` (0-based, 0 is end-diastole) as a label image with its affine."""
        if not 0 <= int(t) < self.n_frames:
            raise SeriesError(f"{self.name}: frame {t} out of range 0..{self.n_frames - 1}")
        if self.four_d:
            return read_label_image(self.files[0], int(t))
        image = read_label_image(self.files[int(t)])
        return LabelImage(image.labels, image.affine, image.path, int(t))


def _is_image(path: Path) -> bool:
    return (
        path.is_file()
        and not path.name.startswith(".")
        and path.name.lower().endswith(IMAGE_SUFFIXES)
    )


def find_series(images) -> dict[str, Path | str]:
    """``{subject: source}`` of the series in ``images`` (see the module).

    Parameters
    ----------
    images : path or iterable of paths
        A folder of series, or series given one by one (4-D files, folders of frames).

    Returns
    -------
    dict
        Per subject, its 4-D file or its folder of frames, or a string saying why it has
        none usable (two series for one subject).
    """
    if isinstance(images, str | Path):
        root = Path(images)
        if not root.is_dir():
            raise SeriesError(f"images: {root} is not a folder")
        entries = sorted(p for p in root.iterdir() if not p.name.startswith("."))
    else:
        entries = sorted(Path(p) for p in images)
    found: dict[str, list[Path]] = {}
    for path in entries:
        if path.is_dir() and any(_is_image(p) for p in path.iterdir()):
            found.setdefault(path.name, []).append(path)
        elif _is_image(path):
            found.setdefault(image_stem(path), []).append(path)
    out: dict[str, Path | str] = {}
    for subject, sources in found.items():
        if len(sources) > 1:
            names = " and ".join(str(s) for s in sources)
            out[subject] = f"subject {subject!r}: two series, {names}: keep one"
        else:
            out[subject] = sources[0]
    return out


def _header(path: Path):
    try:
        img = nib.load(str(path))
        return img.shape, np.asarray(img.affine, dtype=float)
    except Exception as exc:  # noqa: BLE001 - nibabel raises many kinds for a bad file
        raise SeriesError(
            f"{path}: cannot be read as NIfTI ({type(exc).__name__}: {exc})"
        ) from None


def _open_four_d(path: Path, labels: bool = True) -> LabelSeries:
    shape, affine = _header(path)
    if len(shape) == 3 or (len(shape) == 4 and shape[3] == 1):
        raise SeriesError(
            f"{path}: a 3-D image, not a series: tracking needs the frames of the cycle on the "
            "fourth axis (or a folder of one 3-D file per frame)"
        )
    if len(shape) != 4:
        raise SeriesError(f"{path}: expected a 4-D series (x, y, z, frames), got shape {shape}")
    if labels:  # the affine, the label values: refused here, with the file named
        read_label_image(path, 0)
    return LabelSeries((path,), int(shape[3]), tuple(int(n) for n in shape[:3]), affine)


def _frame_number(path: Path) -> int:
    match = _NUMBER.search(image_stem(path))
    if match is None:
        raise SeriesError(
            f"{path}: a frame of a folder series must end in its frame number (e.g. frame_00.nii.gz)"
        )
    return int(match.group(1))


def _open_folder(files: tuple[Path, ...], labels: bool = True) -> LabelSeries:
    folder = files[0].parent
    numbered: dict[int, Path] = {}
    for path in files:
        number = _frame_number(path)
        if number in numbered:
            raise SeriesError(
                f"{folder}: frame {number} given twice, {numbered[number].name} and {path.name}"
            )
        numbered[number] = path
    numbers = sorted(numbered)
    if len(numbers) < 2:
        raise SeriesError(
            f"{folder}: a single frame ({files[0].name}): tracking needs the frames of the cycle"
        )
    missing = sorted(set(range(numbers[0], numbers[-1] + 1)) - set(numbers))
    if missing:
        shown = ", ".join(str(m) for m in missing[:10]) + (" ..." if len(missing) > 10 else "")
        raise SeriesError(
            f"{folder}: frame(s) {shown} missing (the folder has frames {numbers[0]} to "
            f"{numbers[-1]} with gaps)"
        )
    ordered = tuple(numbered[n] for n in numbers)
    shape0, affine0 = _header(ordered[0])
    for path in ordered:
        shape, affine = _header(path)
        if len(shape) == 4 and shape[3] == 1:
            shape = shape[:3]
        if len(shape) != 3:
            raise SeriesError(
                f"{path}: a frame of a folder series must be a 3-D image, got shape {shape}"
            )
        if tuple(shape) != tuple(shape0[:3]) or not np.allclose(affine, affine0, atol=1e-4):
            raise SeriesError(
                f"{path}: its grid differs from {ordered[0].name}'s (shape {tuple(shape)} vs "
                f"{tuple(shape0[:3])}, or another affine): every frame of a series must share one grid"
            )
    if labels:
        read_label_image(ordered[0])
    return LabelSeries(ordered, len(ordered), tuple(int(n) for n in shape0[:3]), affine0)


def open_series(source, labels: bool = True) -> LabelSeries:
    """Check a series (a 4-D file, or a folder of 3-D frame files) and describe it.

    ``labels=False`` accepts intensity images (cine), whose values are not labels.

    Raises
    ------
    SeriesError
        What makes the series unusable, in one line naming the file.
    """
    source = Path(source)
    if source.is_dir():
        files = tuple(sorted(p for p in source.iterdir() if _is_image(p)))
        if not files:
            raise SeriesError(f"{source}: a folder without NIfTI frames")
        return _open_folder(files, labels)
    if not _is_image(source):
        raise SeriesError(f"{source}: not a NIfTI file (.nii or .nii.gz) or a folder of frames")
    return _open_four_d(source, labels)


def check_field_of_view(vertices, series: LabelSeries, what: str = "ED mesh") -> None:
    """Refuse a mesh with vertices outside the series' field of view (a margin of one voxel).

    Parameters
    ----------
    vertices : array, shape (k, 3)
        World mm, the images' frame.
    series : LabelSeries
    what : str
        Names the mesh in the message.

    Raises
    ------
    SeriesError
    """
    v = np.asarray(vertices, dtype=float)
    index = (v - series.affine[:3, 3]) @ np.linalg.inv(series.affine[:3, :3]).T
    low, high = -1.5, np.asarray(series.shape, dtype=float) + 0.5
    outside = np.any((index < low) | (index > high), axis=1)
    if outside.any():
        raise SeriesError(
            f"{what}: {int(outside.sum())} of {len(v)} vertices lie outside the field of view of "
            f"{series.name} (grid {series.shape}): a mesh of another subject, or not in the images' "
            "world frame"
        )
