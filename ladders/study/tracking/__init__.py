"""Motion through the whole cardiac cycle: a corresponded ED mesh followed through a label series.

- :mod:`.settings`: :class:`TrackingSettings` (method, ``refine_ed``, crop, meshing);
- :mod:`.surface_tracking`: :func:`track_surfaces`, the mesh followed from frame to
  frame through surfaces of any triangulation, with a quality per frame;
- :mod:`.label_series`: a subject's 4-D label series or folder of frames, found and
  checked (:func:`find_series`, :func:`open_series`, :class:`SeriesError`);
- :mod:`.base_planes`: :func:`estimate_base_planes`, the valve plane of every frame from a
  label series and the ED mesh's rim, where none is given (:func:`rim_plane`,
  :func:`thick_sliced`; the table is written by
  :func:`~ladders.study.imaging.plane_table.write_plane_table`);
- :mod:`.cohort_tracking`: :func:`track_cohort`, every subject of a folder of
  corresponded meshes, resumable, with provenance (``symladders track``);
- :mod:`.cine_settings`: :class:`CineTrackingSettings`;
- :mod:`.cine_images`: :func:`image_from_array` (numpy and affine to SimpleITK) and
  :func:`wall_mask` (the voxels near a mesh, where the metric samples);
- :mod:`.cine_tracking`: :func:`track_cine`, the ED mesh moved through cine intensity
  images by B-spline registrations (SimpleITK), every frame to ED or consecutive frames
  composed forward and backward through the cycle.

See ``docs/tracking.md`` and ``docs/tracking_cine.md``.
"""

from ..imaging.plane_table import PLANES_FILE
from .base_planes import (
    BasePlaneEstimate,
    estimate_base_planes,
    rim_plane,
    thick_sliced,
)
from .cine_images import image_from_array, wall_mask
from .cine_settings import CineTrackingSettings
from .cine_tracking import identity_bspline, register_frames, track_cine
from .cohort_tracking import REPORT_FILE, TrackingOutcome, TrackingTask, plan_tracking, track_cohort
from .label_series import LabelSeries, SeriesError, check_field_of_view, find_series, open_series
from .settings import METHODS, PLANE_ESTIMATES, TrackingSettings
from .surface_tracking import TrackedSurfaces, combine_weight, crop_surface, track_surfaces

__all__ = [
    "PLANES_FILE",
    "PLANE_ESTIMATES",
    "BasePlaneEstimate",
    "estimate_base_planes",
    "rim_plane",
    "thick_sliced",
    "CineTrackingSettings",
    "image_from_array",
    "register_frames",
    "track_cine",
    "wall_mask",
    "identity_bspline",
    "METHODS",
    "TrackingSettings",
    "TrackedSurfaces",
    "track_surfaces",
    "combine_weight",
    "crop_surface",
    "LabelSeries",
    "SeriesError",
    "check_field_of_view",
    "find_series",
    "open_series",
    "REPORT_FILE",
    "TrackingOutcome",
    "TrackingTask",
    "plan_tracking",
    "track_cohort",
]
