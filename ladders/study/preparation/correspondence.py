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

from dataclasses import dataclass, field

import numpy as np

from manifolds.data_terms.mesh_geometry import check_mesh
from manifolds.lddmm import RegistrationResult, register

from ..wall_motion import normal_wall_motion
from .affine import affine_icp, apply_affine
from .alignment import SimilarityTransform, procrustes
from .correspondence_settings import CorrespondenceSettings
from .landmarks import Landmarks
from .rigid_fit import AlignmentFit, fit_rigid
from .surface_distance import surface_distances

__all__ = [
    "MeshCorrespondence",
    "SubjectCorrespondence",
    "correspond_mesh",
    "correspond_subject",
    "project_mesh",
]


#: The surface distances of a correspondence's quality (the template's rim aware).
QUALITY_DISTANCES = ("hausdorff", "mean_surface_distance", "beyond_rim_fraction")


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
        atlas's unit, leaving out the mesh's vertices beyond the template's rim, e.g.
        a label's lid: :func:`~.surface_distance.surface_distances`),
        ``beyond_rim_fraction`` (the fraction of them), ``converged``, ``n_iter``; for an end-diastole aligned here,
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
            for k, v in surface_distances(res.deformed, tf, moved, mf, skip_beyond_rim=True).items()
            if k in QUALITY_DISTANCES
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
            for k, v in surface_distances(proj.points, tf, moved, mf, skip_beyond_rim=True).items()
            if k in QUALITY_DISTANCES
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
