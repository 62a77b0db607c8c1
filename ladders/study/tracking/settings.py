"""Settings of the tracking of a corresponded end-diastolic mesh through a cardiac cycle."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from manifolds.validation import check_float, check_int

from ..imaging.surface_extraction import MeshingSettings
from ..preparation.correspondence_settings import CorrespondenceSettings

__all__ = ["TrackingSettings", "METHODS", "PLANE_ESTIMATES"]

#: How a frame's mesh is moved onto the frame's surface.
METHODS = ("projection", "registration")
#: When :func:`~.cohort_tracking.track_cohort` estimates the valve planes of a subject
#: given none: on thick slices (``"auto"``), for every series, or never.
PLANE_ESTIMATES = ("auto", "always", "never")


def _default_correspondence() -> CorrespondenceSettings:
    # no rigid re-alignment between frames (one scanner frame), no final Procrustes
    return CorrespondenceSettings(alignment="none", final_procrustes=False)


@dataclass(frozen=True)
class TrackingSettings:
    """How :func:`~.surface_tracking.track_surfaces` follows a mesh (lengths in mm).

    Attributes
    ----------
    method : {"projection", "registration"}
        ``"projection"``: the previous frame's mesh is moved by its affine fit onto the
        frame's surface (:func:`~ladders.study.preparation.affine.affine_icp`), then
        each vertex along its normal onto that surface, as
        :func:`~ladders.study.preparation.correspondence.project_mesh` does;
        ``"registration"``: the previous frame's mesh is registered onto the frame's
        surface (LDDMM with a varifold term, as
        :func:`~ladders.study.preparation.correspondence.correspond_mesh` does, with
        the transform fixed to the identity: the frames share the scanner frame).
    refine_ed : bool, default True
        Also move the ED mesh onto every frame directly and combine the two results
        (:func:`~.surface_tracking.combine_weight`): limits the drift of the chain. The
        default since it was measured to lower the error along the long axis at ES on
        8 mm and 1.5 mm label series, with valve planes given, estimated or absent, at
        roughly one and a half times the time (generated ``base_planes`` in
        ``docs/tracking.md``).
    project_ed : bool
        First move the ED mesh along its normals onto frame 0's surface, extracted like
        every other frame's, so that the motion is measured between surfaces extracted
        alike. Without it, the ED mesh given (e.g. corresponded on a surface meshed with
        other settings) is frame 0, and the difference between the two extractions of
        end-diastole enters every frame's motion as a lasting error (measured in
        ``docs/tracking.md``).
    crop_distance : float or None
        Triangles of a frame's surface farther than this (mm) from the mesh that is
        moved onto it are left out (the lid that closes a label at the valve plane,
        other structures); it must exceed the motion between two frames. None: the
        whole surface.
    affine_iterations : int
        At most this many steps of the affine fit per frame.
    affine_tol : float
        The affine fit stops when its matrix changes by less than this (relative).
    normal_max_distance : float or None
        Farthest normal motion looked for (default a fifth of the surface's extent).
    max_detour : float or None
        A normal intersection farther from the vertex than the closest point of the
        frame's surface by more than this (mm) is taken for another part of the surface
        (near the apex, a line across the narrow cavity or past the staircase of thick
        slices) and the vertex takes the closest point instead
        (:func:`~ladders.study.wall_motion.normal_wall_motion`); None: no such test.
        Between two frames, after the affine fit, a vertex moves by a millimetre or so.
    correspondence : CorrespondenceSettings
        The registration of ``method="registration"`` (its ``alignment`` is ``"none"``,
        its ``final_procrustes`` False).
    estimate_planes : {"auto", "always", "never"}
        Whether :func:`~.cohort_tracking.track_cohort` estimates the valve plane of every
        frame from the images (:func:`~.base_planes.estimate_base_planes`) for a subject
        given no plane: ``"always"`` (the default: the estimate lowers the error along
        the long axis on isotropic series as on thick slices, docs/tracking.md),
        ``"auto"`` on thick slices only (:func:`~.base_planes.thick_sliced`: the largest
        voxel spacing at least twice the smallest), ``"never"``.
        The planes then cut the frames' surfaces and anchor the affine fits as given
        planes do.
    meshing : MeshingSettings
        How :func:`~.cohort_tracking.track_cohort` meshes each frame of a label series
        (:func:`~ladders.study.imaging.surface_extraction.extract_surface`). Default:
        ``MeshingSettings(mask_sigma=1.5)``, more smoothing than ``symladders mesh``'s
        0.5 voxel: measured on 8 mm short-axis series, it lowers the error of the peak
        inward motion and its spread across subjects, and raises the power of the peak
        test (generated ``tracking_variants`` in ``docs/tracking.md``).
    """

    method: str = "projection"
    refine_ed: bool = True
    project_ed: bool = True
    crop_distance: float | None = 8.0
    affine_iterations: int = 15
    affine_tol: float = 1e-3
    normal_max_distance: float | None = None
    max_detour: float | None = 2.0
    correspondence: CorrespondenceSettings = field(default_factory=_default_correspondence)
    estimate_planes: str = "always"
    meshing: MeshingSettings = field(default_factory=lambda: MeshingSettings(mask_sigma=1.5))

    def __post_init__(self):
        name = "TrackingSettings"
        if self.method not in METHODS:
            raise ValueError(f"{name}: method: expected one of {METHODS}, got {self.method!r}")
        if self.estimate_planes not in PLANE_ESTIMATES:
            raise ValueError(f"{name}: estimate_planes: expected one of {PLANE_ESTIMATES}, got "
                             f"{self.estimate_planes!r}")  # fmt: skip
        for key in ("refine_ed", "project_ed"):
            if not isinstance(getattr(self, key), bool | np.bool_):
                raise ValueError(
                    f"{name}: {key}: expected True or False, got {getattr(self, key)!r}"
                )
        for key in ("crop_distance", "normal_max_distance", "max_detour"):
            if getattr(self, key) is not None:
                check_float(getattr(self, key), f"{name}: {key}", minimum=0.0,
                            strict=key != "max_detour")  # fmt: skip
        check_int(self.affine_iterations, f"{name}: affine_iterations", minimum=1)
        check_float(self.affine_tol, f"{name}: affine_tol", minimum=0.0, strict=True)
        if not isinstance(self.correspondence, CorrespondenceSettings):
            raise TypeError(f"{name}: correspondence: expected CorrespondenceSettings")
        if not isinstance(self.meshing, MeshingSettings):
            raise TypeError(f"{name}: meshing: expected MeshingSettings")

    def replace(self, **changes) -> TrackingSettings:
        """A copy with ``changes``."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """JSON-ready fields (the nested settings as dicts)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["refine_ed"] = bool(self.refine_ed)
        out["correspondence"] = self.correspondence.as_dict()
        out["meshing"] = self.meshing.as_dict()
        return out

    def key(self) -> str:
        """Stable hash of every setting (what a stored result depends on)."""
        payload = self.as_dict()
        payload["correspondence"] = self.correspondence.key()
        text = json.dumps(payload, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:16]
