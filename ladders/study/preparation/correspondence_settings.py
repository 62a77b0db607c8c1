"""The settings of the correspondence of meshes to an atlas (:class:`CorrespondenceSettings`).

One frozen dataclass holds every choice of :mod:`.correspondence`: the LDDMM
registration, the data term, the rigid alignment and its tolerances, the affine
pre-alignment and its landmark anchors, the end-systolic correspondence and the
thresholds that flag a mesh for inspection. Its :meth:`~CorrespondenceSettings.key`
identifies a run, so that a folder corresponded with other settings is not reused.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from manifolds.data_terms import CurrentDistance, VarifoldDistance
from manifolds.lddmm import RegistrationSettings
from manifolds.validation import check_float

__all__ = ["CorrespondenceSettings"]

_TERMS = {"varifold": VarifoldDistance, "current": CurrentDistance}
#: The settings that only flag a mesh for inspection (not part of :meth:`CorrespondenceSettings.key`).
_FLAGS = ("flag_mean_distance", "flag_hausdorff", "flag_axial_spread", "flag_landmark_disagreement")


def _default_registration() -> RegistrationSettings:
    return RegistrationSettings(
        sigma=20.0, control_points="grid", max_iter=300, stopping="shape", shape_tol=0.01
    )


@dataclass(frozen=True)
class CorrespondenceSettings:
    """Settings of the correspondence of meshes to an atlas (lengths in the atlas's unit).

    Attributes
    ----------
    registration : RegistrationSettings
        The LDDMM registration of the atlas onto a mesh (kernel width ``sigma``,
        control points, optimiser). Default: ``sigma = 20``, grid control points,
        at most 300 L-BFGS-B iterations, stopped when the deformed atlas moves by
        less than ``shape_tol = 0.01`` (per-vertex RMS, the atlas's unit).
    alpha : float
        Regularisation weight (``alpha^2`` multiplies ``||v||_H^2``).
    sigma_w : float
        Width of the data term's kernel: a few mean edge lengths, below the
        features to match (5 mm for cardiac meshes; ``docs/preparation.md``).
    weight : float or "landmarks"
        Weight of the data term (``"landmarks"``: ``alpha^2`` means what it means
        for meshes in correspondence).
    data_term : {"varifold", "current"}
    alignment : {"icp", "none"}
        Rigid alignment of end-diastole onto the atlas before the registration
        (:func:`~.rigid_fit.fit_rigid`, with landmarks where given).
    rotation_tolerance : float
        Turns about the long axis whose residual is within this fraction of the best
        are equally good; the smallest rotation among them is kept (``fit_rigid``'s
        ``tolerance``; 5 % lets two different ventricles keep the input's turn, where
        their own shapes prefer another by a few per cent).
    start_tolerance : float
        ICP fits from the different starts whose residual is within this fraction of
        the best are equally good; the smallest rotation among them is kept
        (``fit_rigid``'s ``start_tolerance``: a flipped fit between two different
        ventricles can fit a few per cent better than the true one).
    es_correspondence : {"normal", "registration"}
        How end-systole gets the atlas's vertices: the corresponded end-diastole
        moved by its affine fit, then along its normals onto the end-systolic surface
        (:func:`project_mesh`), or a registration.
    normal_max_distance : float or None
        Farthest normal motion looked for (default a fifth of the surface's extent).
    landmark_tolerance : float
        Apex and septal landmarks farther than this from their mesh are refused.
    prealign : {"affine", "none"}
        Move the template by the affine fit onto the mesh (:mod:`.affine`) before
        the registration, so that the deformation does not slide its vertices.
    anchor : {"axial", "points"}
        With landmarks, the apex and the base-plane centre anchor that affine fit
        (:func:`~.affine.affine_icp`): they set the stretch along the long axis, which a
        near-tubular wall cut at its base leaves loose. ``"axial"``: their heights along
        the subject's long axis only (the surfaces set the rest; an apex or a base
        centre placed a millimetre or two aside, as a label image's are, does not pull
        the fit sideways); ``"points"``: the whole points.
    anchor_weight : float
        Weight of each anchor, relative to the surface's point pairs; 0: the surfaces
        alone.
    scale : bool
        Fit a similarity (with ``"icp"``) instead of a rigid motion.
    final_procrustes : bool
        Align the corresponded pair onto the atlas by Procrustes on its vertices.
    es_template : {"ed", "atlas"}
        The template end-systole is registered from (``es_correspondence="registration"``).
    flag_mean_distance, flag_hausdorff : float
        A corresponded mesh farther than these from its input (mean surface
        distance, Hausdorff distance) is flagged for inspection.
    atlas_coarse_factor : float
        The atlas's registrations (:mod:`.atlas_registrations`) first match the surfaces
        with a data term this many times wider than ``sigma_w``, then at ``sigma_w`` from
        there (coarse to fine); 1: at ``sigma_w`` directly. A subject far from the current
        atlas otherwise falls into a local minimum of the narrow term, which subjects do
        changes between iterations, and the atlas's objective rises over its iterations
        (``docs/evidence/atlas_evidence.md``). The correspondence registers directly.
    flag_axial_spread : float
        Without landmarks, a fit whose turn about the long axis the surface leaves
        undetermined over more than this many degrees is flagged.
    flag_landmark_disagreement : float
        With landmarks, a surface fit that differs from the landmarks' frame by more
        than this many degrees is flagged.
    """

    registration: RegistrationSettings = field(default_factory=_default_registration)
    alpha: float = float(np.sqrt(0.1))
    sigma_w: float = 5.0
    weight: float | str = "landmarks"
    data_term: str = "varifold"
    alignment: str = "icp"
    prealign: str = "affine"
    anchor: str = "axial"
    anchor_weight: float = 0.1
    scale: bool = False
    final_procrustes: bool = True
    es_template: str = "ed"
    flag_mean_distance: float = 0.5
    flag_hausdorff: float = 3.0
    rotation_tolerance: float = 0.05
    start_tolerance: float = 0.10
    es_correspondence: str = "normal"
    normal_max_distance: float | None = None
    landmark_tolerance: float = 10.0
    atlas_coarse_factor: float = 3.0
    flag_axial_spread: float = 10.0
    flag_landmark_disagreement: float = 20.0

    def __post_init__(self):
        name = "CorrespondenceSettings"
        if not isinstance(self.registration, RegistrationSettings):
            raise TypeError(f"{name}: registration: expected RegistrationSettings")
        for key, minimum in (("alpha", 0.0), ("sigma_w", 0.0), ("flag_mean_distance", 0.0)):
            check_float(
                getattr(self, key), f"{name}: {key}", minimum=minimum, strict=key != "alpha"
            )
        check_float(self.anchor_weight, f"{name}: anchor_weight", minimum=0.0)
        check_float(self.atlas_coarse_factor, f"{name}: atlas_coarse_factor", minimum=1.0)
        for key in ("flag_hausdorff", "landmark_tolerance", "flag_axial_spread",
                    "flag_landmark_disagreement"):  # fmt: skip
            check_float(getattr(self, key), f"{name}: {key}", minimum=0.0, strict=True)
        check_float(self.rotation_tolerance, f"{name}: rotation_tolerance", minimum=0.0)
        check_float(self.start_tolerance, f"{name}: start_tolerance", minimum=0.0)
        if self.normal_max_distance is not None:
            check_float(self.normal_max_distance, f"{name}: normal_max_distance", minimum=0.0,
                        strict=True)  # fmt: skip
        for key, choices in (
            ("data_term", tuple(_TERMS)),
            ("alignment", ("icp", "none")),
            ("prealign", ("affine", "none")),
            ("es_template", ("ed", "atlas")),
            ("es_correspondence", ("normal", "registration")),
            ("anchor", ("axial", "points")),
        ):
            if getattr(self, key) not in choices:
                raise ValueError(f"{name}: {key}: expected one of {choices}, got {getattr(self, key)!r}")  # fmt: skip
        if isinstance(self.weight, str) and self.weight != "landmarks":
            raise ValueError(
                f"{name}: weight: expected a number or 'landmarks', got {self.weight!r}"
            )

    def replace(self, **changes) -> CorrespondenceSettings:
        """A copy with ``changes``."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        """JSON-ready fields (the registration settings as a dict)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["registration"] = self.registration.as_dict()
        return out

    def key(self) -> str:
        """Stable hash of the settings that make the result (the registration's key with its
        backend resolved). The thresholds that flag a mesh for inspection (``flag_*``) are
        left out: they only read the quality, which the table applies when it is written,
        so a folder corresponded before is reused whatever they are."""
        payload = self.as_dict()
        payload["registration"] = self.registration.key()
        default = CorrespondenceSettings.__dataclass_fields__
        for name in _FLAGS:  # as the defaults, so that keys written before stay valid
            payload[name] = default[name].default
        text = json.dumps(payload, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def data_term_for(self, vertices, faces, template_faces, width_factor: float = 1.0):
        """The data term towards the mesh ``(vertices, faces)`` for a template with
        ``template_faces``, of kernel width ``width_factor * sigma_w``."""
        return _TERMS[self.data_term](
            vertices, faces, template_faces, width_factor * self.sigma_w, weight=self.weight
        )
