"""The epicardium followed through the cycle beside the endocardium, for the wall thickness.

Wall thickness needs the epicardium at every frame (:mod:`ladders.study.wall`). Two
ways, as the endocardium is followed:

* label series (:func:`track_epicardium`): every frame's epicardium is meshed
  (:func:`~ladders.study.imaging.extract_epicardium`: the outer surface of the cavity
  and myocardium labels, cut at the frame's valve plane like the endocardium), and
  frame 0's surface, the ED epicardium, is followed through them by
  :func:`~.surface_tracking.track_surfaces` with the endocardium's settings and valve
  planes: one triangulation of the epicardium at every frame;
* cine series (:func:`track_cine_with_epicardium`): the ED epicardium (a mesh of the ED
  frame's segmentation, ``symladders mesh --myocardium-label``) is moved by the same
  B-spline registrations as the endocardium: both meshes' vertices are moved by each
  frame's transform, the metric sampling the voxels within ``mask_distance`` of either
  surface (the wall and its two borders). The metric restricted to the endocardium's
  surroundings leaves the epicardium behind (measured on a series of 3 mm voxels: 1.8 mm
  off the true epicardium at ES, against 0.56 mm with both surfaces' voxels and 3.3 mm
  unmoved, ``tests/test_wall_tracking.py``); sampling the wall hardly changes the
  endocardium's result (0.43 mm off its true surface, 0.42 mm tracked alone).

The thickness is measured at every frame to that frame's epicardium (closest points),
so the epicardium's own correspondence through the frames does not enter it.
"""

from __future__ import annotations

import numpy as np

from ..imaging.epicardium import EPICARDIUM_FOLDER, extract_epicardium
from .cine_settings import CineTrackingSettings
from .cine_tracking import track_cine
from .settings import TrackingSettings
from .surface_tracking import TrackedSurfaces, track_surfaces

__all__ = ["EPICARDIUM_FOLDER", "track_epicardium", "track_cine_with_epicardium"]


def track_epicardium(
    images,
    cavity_label: int,
    myocardium_label: int,
    settings: TrackingSettings,
    meshing=None,
    base_planes=None,
) -> tuple[TrackedSurfaces, list[dict]]:
    """Mesh every frame's epicardium and follow frame 0's through them (see the module).

    Parameters
    ----------
    images : sequence of LabelImage
        The series' frames, frame 0 at ED.
    cavity_label, myocardium_label : int
    settings : TrackingSettings
        The endocardium's tracking settings.
    meshing : sequence of MeshingSettings, optional
        Each frame's meshing settings (its valve plane); default ``settings.meshing``.
    base_planes : array, shape (n_frames, 6), optional
        As :func:`track_surfaces`'s (the valve plane of every frame).

    Returns
    -------
    tracked : TrackedSurfaces
        The epicardium at every frame (the triangulation of frame 0's surface).
    reports : list of dict
        Each frame's :class:`~ladders.study.imaging.SurfaceReport` as a dict.

    Raises
    ------
    ImageError
        The myocardium label is absent in a frame (naming the file and frame).
    ValueError
        A surface the mesh cannot follow.
    """
    images = list(images)
    meshing = [settings.meshing] * len(images) if meshing is None else list(meshing)
    surfaces, reports = [], []
    for image, frame_meshing in zip(images, meshing):
        v, f, report = extract_epicardium(image, cavity_label, myocardium_label, frame_meshing)
        surfaces.append((v, f))
        reports.append(report.as_dict())
    tracked = track_surfaces(*surfaces[0], surfaces, settings, base_planes=base_planes)
    return tracked, reports


def track_cine_with_epicardium(
    series, affine, endocardium, epicardium, settings: CineTrackingSettings,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The endocardium and the epicardium moved through a cine series together.

    Parameters
    ----------
    series : array (n_frames, X, Y, Z)
    affine : array (4, 4)
    endocardium : array (k, 3)
        The ED endocardium, world mm.
    epicardium : array (m, 3)
        The ED epicardium, world mm.
    settings : CineTrackingSettings

    Returns
    -------
    endocardium, epicardium : ndarrays, shapes (n_frames, k, 3) and (n_frames, m, 3)
        World mm.
    """
    endo = np.asarray(endocardium, dtype=np.float64)
    epi = np.asarray(epicardium, dtype=np.float64)
    moved = track_cine(series, affine, np.concatenate([endo, epi]), settings)  # both's voxels
    return moved[:, : len(endo)], moved[:, len(endo) :]
