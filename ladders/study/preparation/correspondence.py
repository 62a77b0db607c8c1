"""Bring a subject's meshes into the atlas's vertex correspondence (any vertex count or format).

For one mesh (:func:`correspond_mesh`): align it rigidly onto the atlas
(:func:`~.rigid_fit.fit_rigid`: ICP that keeps the input's own turn about the
long axis where the surface cannot tell, or anatomical landmarks; or a transform
given), move the atlas by an affine fit onto it (:mod:`.affine`),
register the atlas onto it with a surface data term
(varifold by default, :class:`~manifolds.data_terms.VarifoldDistance`) and
return the deformed atlas, which has the atlas's vertices, order and faces and
lies on the subject's surface, with its quality: the data term's distance
before and after, the Hausdorff and mean surface distances to the mesh, the
optimiser's convergence.

For a subject (:func:`correspond_subject`): the transform is estimated on
end-diastole and applied to end-systole as well, so the cardiac motion is kept
whole (both frames come from one scanner frame). End-systole follows what the
surfaces show (``es_correspondence="normal"``, the default, :func:`project_mesh`):
the corresponded end-diastole is moved by its affine fit onto the end-systolic
surface (the global shortening and contraction), then each vertex along its
normal onto that surface (:func:`~ladders.study.wall_motion.normal_wall_motion`),
so the regional motion across the wall is kept whole and no regional motion
along the wall is invented. With
``"registration"`` end-systole is registered from the corresponded end-diastole
like end-diastole from the atlas: the smallest deformation then slides the
vertices along the wall and loses most of the normal motion of a regional
abnormality (``docs/preparation.md``). The pair is finally aligned onto the
atlas by Procrustes on the corresponding vertices, and the composed transform is
recorded.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from manifolds.data_terms import CurrentDistance, VarifoldDistance
from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.lddmm import RegistrationResult, RegistrationSettings, register
from manifolds.validation import check_float

from ..wall_motion import normal_wall_motion
from .affine import affine_icp, apply_affine
from .alignment import SimilarityTransform, procrustes
from .landmarks import Landmarks
from .rigid_fit import AlignmentFit, fit_rigid
from .surface_distance import surface_distances

__all__ = [
    "CorrespondenceSettings",
    "MeshCorrespondence",
    "SubjectCorrespondence",
    "correspond_mesh",
    "correspond_subject",
    "project_mesh",
]

_TERMS = {"varifold": VarifoldDistance, "current": CurrentDistance}


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
        """Stable hash of every setting (the registration's key with its backend resolved)."""
        payload = self.as_dict()
        payload["registration"] = self.registration.key()
        text = json.dumps(payload, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def data_term_for(self, vertices, faces, template_faces):
        """The data term towards the mesh ``(vertices, faces)`` for a template with ``template_faces``."""
        return _TERMS[self.data_term](
            vertices, faces, template_faces, self.sigma_w, weight=self.weight
        )


@dataclass
class MeshCorrespondence:
    """The atlas deformed onto one mesh.

    Attributes
    ----------
    vertices : array, shape ``(k, 3)``
        The corresponded mesh: the atlas's vertex order and faces, on the mesh's surface,
        in the atlas's frame.
    transform : SimilarityTransform
        Maps the input mesh (in the atlas's unit) into the atlas's frame.
    quality : dict
        ``distance_before``, ``distance_after`` (the data term's distance, unweighted),
        ``hausdorff``, ``mean_surface_distance`` (to the aligned input mesh, the
        atlas's unit), ``converged``, ``n_iter``; for an end-diastole aligned here,
        the alignment's ``alignment``, ``axial_spread_deg`` and
        ``landmark_disagreement_deg``; for a normal projection ``normal_hit_fraction``.
    registration : RegistrationResult or None
        The registration of the (affinely moved) template onto the mesh (None for a
        normal projection).
    affine : array, shape ``(4, 4)``
        The affine pre-alignment applied to the template (the identity without).
    alignment : AlignmentFit or None
        The rigid alignment estimated on this mesh (None when a transform was given).
    """

    vertices: np.ndarray
    transform: SimilarityTransform
    quality: dict
    registration: RegistrationResult | None
    affine: np.ndarray = field(default_factory=lambda: np.eye(4))
    alignment: AlignmentFit | None = None


def correspond_mesh(
    template_vertices,
    template_faces,
    mesh_vertices,
    mesh_faces,
    settings: CorrespondenceSettings | None = None,
    *,
    transform: SimilarityTransform | None = None,
    align_to=None,
    landmarks: Landmarks | None = None,
    template_landmarks: Landmarks | None = None,
) -> MeshCorrespondence:
    """Deform a template (the atlas) onto a mesh with any triangulation (see the module).

    Parameters
    ----------
    template_vertices, template_faces : arrays ``(k, 3)``, ``(f, 3)``
        The template registered (the atlas, or a subject's corresponded ED).
    mesh_vertices, mesh_faces : arrays ``(m, 3)``, ``(g, 3)``
        The mesh, in the atlas's unit and in its own frame.
    settings : CorrespondenceSettings, optional
    transform : SimilarityTransform, optional
        Moves the mesh into the atlas's frame; estimated by ICP onto ``align_to``
        (default the template) when not given and ``settings.alignment == "icp"``.
    align_to : tuple of arrays, optional
        ``(vertices, faces)`` of the surface to align onto.
    landmarks, template_landmarks : Landmarks, optional
        Both or neither: the mesh's landmarks (in its own frame) and those of the
        surface aligned onto; they fix the turn about the long axis, and their apex
        and base-plane centre anchor the affine fit (``settings.anchor_weight``).

    Returns
    -------
    MeshCorrespondence
    """
    settings = settings or CorrespondenceSettings()
    tv, tf = check_mesh(template_vertices, template_faces, "correspond_mesh: template")
    mv, mf = check_mesh(mesh_vertices, mesh_faces, "correspond_mesh: mesh")
    fit = None
    if transform is None:
        transform = SimilarityTransform.identity()
        if settings.alignment == "icp":
            av, af = (tv, tf) if align_to is None else align_to
            fit = fit_rigid(mv, mf, av, af, scale=settings.scale,
                            tolerance=settings.rotation_tolerance,
                            start_tolerance=settings.start_tolerance, source_landmarks=landmarks,
                            target_landmarks=template_landmarks)  # fmt: skip
            transform = fit.transform
    moved = transform.apply(mv)
    anchors = None
    if landmarks is not None and template_landmarks is not None:
        anchors = (np.array([template_landmarks.apex, template_landmarks.base]),
                   transform.apply(np.array([landmarks.apex, landmarks.base])))  # fmt: skip
    direction = None
    if anchors is not None and settings.anchor == "axial":
        direction = anchors[1][1] - anchors[1][0]
    affine = (affine_icp(tv, tf, moved, mf, anchors=anchors, anchor_weight=settings.anchor_weight,
                         anchor_direction=direction) if settings.prealign == "affine"
              else np.eye(4))  # fmt: skip
    term = settings.data_term_for(moved, mf, tf)
    start = apply_affine(affine, tv)
    res = register(start, term, settings.alpha, settings.registration, warn=False)
    quality = {
        "distance_before": float(term.distance(tv) / np.sqrt(term.weight)),
        "distance_after": float(term.distance(res.deformed) / np.sqrt(term.weight)),
        **{
            k: v
            for k, v in surface_distances(res.deformed, tf, moved, mf).items()
            if k in ("hausdorff", "mean_surface_distance")
        },
        "converged": bool(res.converged),
        "n_iter": int(res.n_iter),
    }
    if fit is not None:
        quality.update(alignment=fit.method, axial_spread_deg=fit.axial_spread,
                       landmark_disagreement_deg=fit.landmark_disagreement)  # fmt: skip
    return MeshCorrespondence(np.array(res.deformed), transform, quality, res, affine, fit)


def project_mesh(
    template_vertices, template_faces, mesh_vertices, mesh_faces, transform: SimilarityTransform,
    settings: CorrespondenceSettings | None = None,
) -> MeshCorrespondence:  # fmt: skip
    """Move a corresponded template onto a mesh: its affine fit, then along its normals.

    The affine fit of the template onto the mesh (:mod:`.affine`, with
    ``settings.prealign == "affine"``) carries the global change of shape, a
    ventricle's longitudinal shortening and radial contraction included; each vertex
    of the affinely moved template then moves along its normal onto the mesh
    (:func:`~ladders.study.wall_motion.normal_wall_motion`), which keeps the regional
    motion across the wall whole and invents no regional motion along it.

    Parameters
    ----------
    template_vertices, template_faces : arrays ``(k, 3)``, ``(f, 3)``
        The corresponded end-diastole, in the atlas's frame.
    mesh_vertices, mesh_faces : arrays ``(m, 3)``, ``(g, 3)``
        The end-systolic mesh in its own frame; ``transform`` moves it into the atlas's.
    transform : SimilarityTransform
    settings : CorrespondenceSettings, optional

    Returns
    -------
    MeshCorrespondence
        Its vertices are the projections; ``quality`` has the surface distances to the
        mesh and ``normal_hit_fraction`` (vertices whose normal met the surface).
    """
    settings = settings or CorrespondenceSettings()
    tv, tf = check_mesh(template_vertices, template_faces, "project_mesh: template")
    mv, mf = check_mesh(mesh_vertices, mesh_faces, "project_mesh: mesh")
    moved = transform.apply(mv)
    affine = affine_icp(tv, tf, moved, mf) if settings.prealign == "affine" else np.eye(4)
    start = apply_affine(affine, tv)
    proj = normal_wall_motion(start, tf, moved, mf, max_distance=settings.normal_max_distance)
    quality = {
        **{
            k: v
            for k, v in surface_distances(proj.points, tf, moved, mf).items()
            if k in ("hausdorff", "mean_surface_distance")
        },
        "converged": True,
        "n_iter": 0,
        "normal_hit_fraction": proj.hit_fraction,
    }
    return MeshCorrespondence(proj.points, transform, quality, None, affine)


@dataclass
class SubjectCorrespondence:
    """A subject's ED and ES meshes in correspondence with the atlas.

    Attributes
    ----------
    ed, es : MeshCorrespondence
        Their ``vertices`` are in the atlas's frame after the final alignment.
    transform : SimilarityTransform
        The one transform applied to both input meshes (recorded per subject).
    """

    ed: MeshCorrespondence
    es: MeshCorrespondence
    transform: SimilarityTransform


def correspond_subject(
    atlas_vertices, atlas_faces, ed, es, settings: CorrespondenceSettings | None = None, *,
    landmarks: Landmarks | None = None, atlas_landmarks: Landmarks | None = None,
) -> SubjectCorrespondence:  # fmt: skip
    """Correspond a subject's ED and ES meshes ``(vertices, faces)`` with one transform.

    The transform is estimated on ED (:func:`~.rigid_fit.fit_rigid` onto the atlas,
    with the subject's ``landmarks`` and the ``atlas_landmarks`` where given) and
    applied to ES. ES is the corresponded ED moved along its normals onto the ES
    surface (``settings.es_correspondence == "normal"``), or registered from the
    corresponded ED (``settings.es_template``). With
    ``settings.final_procrustes`` both results are then moved by the rigid
    Procrustes fit of the corresponded ED onto the atlas, which is composed
    into the recorded transform.
    """
    settings = settings or CorrespondenceSettings()
    av, af = check_mesh(atlas_vertices, atlas_faces, "correspond_subject: atlas")
    c_ed = correspond_mesh(av, af, *ed, settings, landmarks=landmarks,
                           template_landmarks=atlas_landmarks)  # fmt: skip
    if settings.es_correspondence == "normal":
        c_es = project_mesh(c_ed.vertices, af, *es, c_ed.transform, settings)
    else:
        template = c_ed.vertices if settings.es_template == "ed" else av
        c_es = correspond_mesh(template, af, *es, settings, transform=c_ed.transform)
    transform = c_ed.transform
    if settings.final_procrustes:
        fit = procrustes(c_ed.vertices, av)
        for c in (c_ed, c_es):
            c.vertices = fit.apply(c.vertices)
        transform = fit.compose(transform)
    c_ed.transform = c_es.transform = transform
    return SubjectCorrespondence(c_ed, c_es, transform)
