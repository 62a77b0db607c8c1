"""From label images to surface meshes in world millimetres: where cardiac data starts.

- :mod:`.label_images`: one frame of a NIfTI label image with its affine
  (:func:`read_label_image`), and what can be wrong with it (:class:`ImageError`);
- :mod:`.surface_extraction`: one label to a surface (largest component, marching
  cubes in the image's world frame, Taubin smoothing, a cut plane, decimation) with a
  report (:func:`extract_surface`, :class:`MeshingSettings`);
- :mod:`.epicardium`: the outer surface of the myocardium, cavity included
  (:func:`extract_epicardium`), the surface wall thickness is measured to;
- :mod:`.mesh_images`: a batch of images to a folder the study reads, resumable,
  with provenance (:func:`mesh_label_images`);
- :mod:`.septum`: the landmarks of a meshed left ventricle, its septum placed by
  the right ventricle's label (:func:`landmarks_from_labels`);
- :mod:`.voxelize`: label images of known surfaces, the ground truth
  (:func:`voxelize`, :func:`short_axis_affine`, :func:`write_label_image`), and
  :mod:`.rv_label`: a right-ventricle label beside them (:func:`add_rv_label`);
- :mod:`.cine`: label and intensity images of the synthetic ventricle through the
  cycle, rendered from the known motion, and 4-D series (:func:`render_labels`,
  :func:`render_cine`, :func:`write_series`).
"""

from .cine import (
    BACKGROUND,
    BLOOD_POOL,
    MYOCARDIUM,
    TagGrid,
    ed_labels,
    render_cine,
    render_labels,
    tag_pattern,
    write_series,
)
from .epicardium import EPICARDIUM_FOLDER, epicardial_image, extract_epicardium
from .label_images import (
    IMAGE_SUFFIXES,
    ImageError,
    LabelImage,
    image_stem,
    read_label_image,
    read_label_series,
)
from .mesh_images import REPORT_FILE, MeshingOutcome, MeshingTask, mesh_label_images, plan_meshing
from .plane_table import (
    PLANES_FILE,
    check_plane_table,
    planes_by_image,
    read_plane_table,
    write_plane_table,
)
from .rv_label import add_rv_label, voxel_centres
from .septum import label_centroid, label_points, landmarks_from_labels, lv_apex_and_base
from .series_frames import FRAME_CHOICES, least_volume_frame, read_frames_table
from .surface_extraction import (
    MeshingSettings,
    SurfaceReport,
    cut_at_plane,
    extract_surface,
    largest_component,
    remove_lid,
    voxel_extent,
)
from .voxelize import close_surface, short_axis_affine, voxelize, write_label_image

__all__ = [
    "IMAGE_SUFFIXES",
    "ImageError",
    "LabelImage",
    "image_stem",
    "read_label_image",
    "read_label_series",
    "REPORT_FILE",
    "MeshingOutcome",
    "MeshingTask",
    "mesh_label_images",
    "plan_meshing",
    "read_plane_table",
    "write_plane_table",
    "PLANES_FILE",
    "check_plane_table",
    "planes_by_image",
    "FRAME_CHOICES",
    "least_volume_frame",
    "read_frames_table",
    "MeshingSettings",
    "SurfaceReport",
    "cut_at_plane",
    "remove_lid",
    "extract_surface",
    "EPICARDIUM_FOLDER",
    "epicardial_image",
    "extract_epicardium",
    "largest_component",
    "voxel_extent",
    "close_surface",
    "short_axis_affine",
    "voxelize",
    "write_label_image",
    "add_rv_label",
    "voxel_centres",
    "label_centroid",
    "landmarks_from_labels",
    "label_points",
    "lv_apex_and_base",
    "BACKGROUND",
    "BLOOD_POOL",
    "MYOCARDIUM",
    "TagGrid",
    "ed_labels",
    "render_cine",
    "render_labels",
    "tag_pattern",
    "write_series",
]
