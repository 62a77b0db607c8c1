"""The epicardium of a label image: the outer surface of the myocardium, cavity included.

A segmentation of the left ventricle labels its cavity (the blood pool) and its
myocardium; the epicardium is the outer boundary of the two together.
:func:`epicardial_image` marks the union of the two labels, with every enclosed hole
filled (a voxel of background inside the ventricle, e.g. an unlabelled papillary
muscle, would otherwise give a small inner surface), as one label, the myocardium's;
:func:`extract_epicardium` meshes it as :func:`~.surface_extraction.extract_surface`
meshes any label (largest component, smoothing, decimation, the cut at the valve
plane, which opens the epicardium at the base as it opens the endocardium). The
report's label is the myocardium's and its voxels those of the filled union.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..cohort.mesh_folder import EPICARDIUM_FOLDER
from .label_images import ImageError, LabelImage
from .surface_extraction import MeshingSettings, SurfaceReport, extract_surface

__all__ = ["EPICARDIUM_FOLDER", "epicardial_image", "extract_epicardium"]


def _label(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise ImageError(f"{name}: expected a label (an int >= 0), got {value!r}")
    return int(value)


def epicardial_image(image: LabelImage, cavity_label: int, myocardium_label: int) -> LabelImage:
    """The image with the cavity and the myocardium as one label, the myocardium's.

    Parameters
    ----------
    image : LabelImage
    cavity_label, myocardium_label : int
        The left ventricle's blood pool and myocardium (e.g. 1 and 2).

    Returns
    -------
    LabelImage
        ``myocardium_label`` on the union of the two labels with its enclosed holes
        filled, 0 elsewhere; the same affine, path and frame.

    Raises
    ------
    ImageError
        The two labels are equal, or the myocardium is absent (naming the file, the
        frame and the labels present).
    """
    cavity = _label(cavity_label, "cavity_label")
    myocardium = _label(myocardium_label, "myocardium_label")
    if cavity == myocardium:
        raise ImageError(f"myocardium_label: must differ from the cavity's label ({cavity})")
    where = f"{image.path}{'' if image.frame is None else f' frame {image.frame}'}"
    wall = image.labels == myocardium
    if not wall.any():
        present = [int(v) for v in np.unique(image.labels) if v != 0][:10]
        shown = present or "none"
        raise ImageError(
            f"{where}: myocardium label {myocardium} is absent; labels present: {shown}"
        )
    union = ndimage.binary_fill_holes(wall | (image.labels == cavity))
    labels = np.where(union, myocardium, 0).astype(np.int64)
    return LabelImage(labels, image.affine, image.path, image.frame)


def extract_epicardium(
    image: LabelImage,
    cavity_label: int,
    myocardium_label: int,
    settings: MeshingSettings | None = None,
) -> tuple[np.ndarray, np.ndarray, SurfaceReport]:
    """The epicardium of ``image`` in world mm (see the module).

    Parameters
    ----------
    image : LabelImage
    cavity_label, myocardium_label : int
    settings : MeshingSettings, optional
        As for the endocardium (the same cut plane opens both at the valve plane).

    Returns
    -------
    vertices : ndarray, shape (m, 3)
    faces : ndarray of int, shape (g, 3)
        Outward normals.
    report : SurfaceReport

    Raises
    ------
    ImageError
        As :func:`epicardial_image`.
    """
    union = epicardial_image(image, cavity_label, myocardium_label)
    return extract_surface(union, int(myocardium_label), settings)
