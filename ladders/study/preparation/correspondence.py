"""Bring a subject's meshes into the atlas's vertex correspondence (any vertex count or format).

For one mesh (:func:`correspond_mesh`): align it rigidly onto the atlas (ICP,
or a transform given), move the atlas by an affine fit onto it (:mod:`.affine`),
register the atlas onto it with a surface data term
(varifold by default, :class:`~manifolds.data_terms.VarifoldDistance`) and
return the deformed atlas, which has the atlas's vertices, order and faces and
lies on the subject's surface, with its quality: the data term's distance
before and after, the Hausdorff and mean surface distances to the mesh, the
optimiser's convergence.

For a subject (:func:`correspond_subject`): the transform is estimated on
end-diastole and applied to end-systole as well, so the cardiac motion is kept
whole (both frames come from one scanner frame). End-systole is registered from
the corresponded end-diastole (a smaller deformation than from the atlas) by
default. The pair is finally aligned onto the atlas by Procrustes on the
corresponding vertices, and the composed transform is recorded.
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

from .affine import affine_icp, apply_affine
from .alignment import SimilarityTransform, icp_align, procrustes
from .surface_distance import surface_distances

__all__ = [
    "CorrespondenceSettings",
    "MeshCorrespondence",
    "SubjectCorrespondence",
    "correspond_mesh",
    "correspond_subject",
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
        Rigid alignment of end-diastole onto the atlas before the registration.
    prealign : {"affine", "none"}
        Move the template by the affine fit onto the mesh (:mod:`.affine`) before
        the registration, so that the deformation does not slide its vertices.
    scale : bool
        Fit a similarity (with ``"icp"``) instead of a rigid motion.
    final_procrustes : bool
        Align the corresponded pair onto the atlas by Procrustes on its vertices.
    es_template : {"ed", "atlas"}
        The template end-systole is registered from.
    flag_mean_distance, flag_hausdorff : float
        A corresponded mesh farther than these from its input (mean surface
        distance, Hausdorff distance) is flagged for inspection.
    """

    registration: RegistrationSettings = field(default_factory=_default_registration)
    alpha: float = float(np.sqrt(0.1))
    sigma_w: float = 5.0
    weight: float | str = "landmarks"
    data_term: str = "varifold"
    alignment: str = "icp"
    prealign: str = "affine"
    scale: bool = False
    final_procrustes: bool = True
    es_template: str = "ed"
    flag_mean_distance: float = 0.5
    flag_hausdorff: float = 3.0

    def __post_init__(self):
        name = "CorrespondenceSettings"
        if not isinstance(self.registration, RegistrationSettings):
            raise TypeError(f"{name}: registration: expected RegistrationSettings")
        for key, minimum in (("alpha", 0.0), ("sigma_w", 0.0), ("flag_mean_distance", 0.0)):
            check_float(
                getattr(self, key), f"{name}: {key}", minimum=minimum, strict=key != "alpha"
            )
        check_float(self.flag_hausdorff, f"{name}: flag_hausdorff", minimum=0.0, strict=True)
        for key, choices in (
            ("data_term", tuple(_TERMS)),
            ("alignment", ("icp", "none")),
            ("prealign", ("affine", "none")),
            ("es_template", ("ed", "atlas")),
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
        atlas's unit), ``converged``, ``n_iter``.
    registration : RegistrationResult
        The registration of the (affinely moved) template onto the mesh.
    affine : array, shape ``(4, 4)``
        The affine pre-alignment applied to the template (the identity without).
    """

    vertices: np.ndarray
    transform: SimilarityTransform
    quality: dict
    registration: RegistrationResult
    affine: np.ndarray = field(default_factory=lambda: np.eye(4))


def correspond_mesh(
    template_vertices,
    template_faces,
    mesh_vertices,
    mesh_faces,
    settings: CorrespondenceSettings | None = None,
    *,
    transform: SimilarityTransform | None = None,
    align_to=None,
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

    Returns
    -------
    MeshCorrespondence
    """
    settings = settings or CorrespondenceSettings()
    tv, tf = check_mesh(template_vertices, template_faces, "correspond_mesh: template")
    mv, mf = check_mesh(mesh_vertices, mesh_faces, "correspond_mesh: mesh")
    if transform is None:
        transform = SimilarityTransform.identity()
        if settings.alignment == "icp":
            av, af = (tv, tf) if align_to is None else align_to
            transform, _ = icp_align(mv, mf, av, af, scale=settings.scale)
    moved = transform.apply(mv)
    affine = affine_icp(tv, tf, moved, mf) if settings.prealign == "affine" else np.eye(4)
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
    return MeshCorrespondence(np.array(res.deformed), transform, quality, res, affine)


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
    atlas_vertices, atlas_faces, ed, es, settings: CorrespondenceSettings | None = None
) -> SubjectCorrespondence:
    """Correspond a subject's ED and ES meshes ``(vertices, faces)`` with one transform.

    The transform is estimated on ED (ICP onto the atlas) and applied to ES;
    ES is registered from the corresponded ED (``settings.es_template``). With
    ``settings.final_procrustes`` both results are then moved by the rigid
    Procrustes fit of the corresponded ED onto the atlas, which is composed
    into the recorded transform.
    """
    settings = settings or CorrespondenceSettings()
    av, af = check_mesh(atlas_vertices, atlas_faces, "correspond_subject: atlas")
    c_ed = correspond_mesh(av, af, *ed, settings)
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
