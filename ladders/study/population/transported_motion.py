"""The transported motion of a cohort on the atlas, read from a study's results.

For every transport method of the study (the pole ladder with and without
residuals, the deformation model's own: the fanning scheme, the SVF conjugation)
and every ``alpha^2``, a
:class:`TransportedMotion` stacks the subjects' transported motion on the atlas:
the displacement ``T' - T`` of every atlas vertex, the local area strain from
``T`` to ``T'``, the normal wall motion from ``T`` to ``T'`` (computed when first
asked for, :attr:`TransportedMotion.wall_motion`) and, where the transport gives a
tangent vector of the space at ``T``, its momenta at the atlas's control points and its residual. The method
``"none"`` is the motion without transport: each subject's own displacement
``S' - S`` and area strain, vertex by vertex (the meshes being in correspondence
with the atlas), in the subject's frame.

:func:`motions_from_results` builds them from typed results;
:func:`load_transported_motion` from a study's output folder.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..cohort.mesh_folder import natural_key
from ..errors import CohortError
from ..meshes.mesh_io import read_mesh
from ..running.result_codec import ResultSchemaError, decode
from ..running.results import TRANSPORT_LABELS, FailedPair, PairResult, SubjectResults
from ..running.runner import ATLAS_FILE
from ..wall_motion import normal_wall_motion

__all__ = [
    "NO_TRANSPORT",
    "TransportedMotion",
    "StudyResults",
    "motions_from_results",
    "load_study_results",
    "load_transported_motion",
    "wall_motion_on_atlas",
]

#: The method name of the motion without transport (each subject's ``S' - S``).
NO_TRANSPORT = "none"
_LABELS = {**TRANSPORT_LABELS, NO_TRANSPORT: "no transport (S' - S of the corresponded meshes)"}


def wall_motion_on_atlas(atlas, faces, displacement) -> tuple[np.ndarray, np.ndarray]:
    """The normal wall motion from the atlas ``T`` to ``T + d`` of every displacement ``d``.

    For each subject, :func:`~ladders.study.wall_motion.normal_wall_motion` from the
    atlas to the surface ``T' = T + d`` with the atlas's faces: the signed distance
    along the atlas's outward vertex normal from each atlas vertex to ``T'``.

    Parameters
    ----------
    atlas : array, shape (k, 3)
    faces : int array, shape (f, 3)
    displacement : array, shape (n, k, 3)
        ``T' - T`` per subject, in the atlas's unit.

    Returns
    -------
    distance : ndarray, shape (n, k)
        The signed normal wall motion (negative inward), in the atlas's unit.
    hit : ndarray of bool, shape (n, k)
        Whether the normal line met ``T'`` (elsewhere, e.g. past the rim of a surface
        open at its base, the motion is that to the closest point of ``T'``).
    """
    atlas = np.asarray(atlas, dtype=float)
    d = np.asarray(displacement, dtype=float)
    if d.ndim != 3 or d.shape[1:] != atlas.shape or atlas.ndim != 2 or atlas.shape[1] != 3:
        raise ValueError(
            f"displacement: expected shape (n, {atlas.shape[0]}, 3) for an atlas of shape "
            f"(k, 3), got {d.shape} with an atlas of shape {atlas.shape}"
        )
    if not np.all(np.isfinite(d)):
        raise ValueError("displacement: expected finite values")
    distance = np.empty(d.shape[:2])
    hit = np.empty(d.shape[:2], dtype=bool)
    for i, di in enumerate(d):
        projection = normal_wall_motion(atlas, faces, atlas + di, faces)
        distance[i], hit[i] = projection.distance, projection.hit
    return distance, hit


@dataclass(frozen=True)
class TransportedMotion:
    """The motion of ``n`` subjects on the atlas by one transport at one ``alpha^2``.

    Attributes
    ----------
    method : str
        A transport method of the study, or ``"none"``.
    deformation : str
        The study's deformation model (``"lddmm"``, ``"svf"``, any registered name;
        also for ``"none"``, whose values do not depend on it).
    alpha2 : float or None
        None for ``"none"``.
    subjects : tuple of str
    atlas : ndarray, shape (k, 3)
    faces : ndarray of int, shape (f, 3)
    displacement : ndarray, shape (n, k, 3)
        ``T' - T`` per subject (``S' - S`` for ``"none"``), in the meshes' unit.
    strain : ndarray, shape (n, k)
        Local area strain ``T -> T'`` (``S -> S'`` for ``"none"``).
    momenta : ndarray, shape (n, n_cp, 3), or None
        The transported tangents' momenta at the atlas's control points.
    residual : ndarray, shape (n, k, 3), or None
        Their residual part (pole ladder with residuals).
    registration : dict or None
        The registration settings of the study (``RegistrationSettings.as_dict()``).
    volume_ratio : ndarray, shape (n,), or None
        ``V(S') / V(S)`` of each subject (for the amplitude normalisation).

    Notes
    -----
    :attr:`wall_motion` (and :attr:`wall_motion_hit`) are computed from ``atlas``,
    ``faces`` and ``displacement`` when first read, then kept: a motion with another
    displacement (a rescaled one, :func:`~.group_comparison.normalize_motion`) is a
    new :class:`TransportedMotion` with its own wall motion.
    """

    method: str
    deformation: str
    alpha2: float | None
    subjects: tuple
    atlas: np.ndarray
    faces: np.ndarray
    displacement: np.ndarray
    strain: np.ndarray
    momenta: np.ndarray | None = None
    residual: np.ndarray | None = None
    registration: dict | None = None
    volume_ratio: np.ndarray | None = None

    @property
    def label(self) -> str:
        """What the method is, e.g. ``"pole ladder, with residuals"``."""
        return _LABELS.get(self.method, self.method)

    @cached_property
    def _wall(self) -> tuple[np.ndarray, np.ndarray]:
        return wall_motion_on_atlas(self.atlas, self.faces, self.displacement)

    @property
    def wall_motion(self) -> np.ndarray:
        """Normal wall motion ``(n, k)`` from the atlas ``T`` to ``T' = T + displacement``.

        Per subject and atlas vertex, the signed distance along the atlas's outward
        normal to the surface ``T'`` (same faces), negative inward
        (:func:`wall_motion_on_atlas`). For ``"none"``, ``T'`` is the atlas moved by
        the subject's own ``S' - S``.
        """
        return self._wall[0]

    @property
    def wall_motion_hit(self) -> np.ndarray:
        """Whether each atlas vertex's normal line met ``T'``, ``(n, k)`` booleans."""
        return self._wall[1]

    @property
    def name(self) -> str:
        """A short identifier: ``<deformation>/<method>/alpha2=<a>`` (``none`` alone)."""
        if self.method == NO_TRANSPORT:
            return NO_TRANSPORT
        return f"{self.deformation}/{self.method}/alpha2={self.alpha2:g}"

    def subset(self, subjects) -> TransportedMotion:
        """The motion of ``subjects`` only, in that order (names must be present)."""
        index = {s: i for i, s in enumerate(self.subjects)}
        missing = [s for s in subjects if s not in index]
        if missing:
            raise CohortError(f"subjects: not in the transported motion: {missing}")
        rows = [index[s] for s in subjects]

        def take(a):
            return None if a is None else a[rows]

        out = TransportedMotion(
            self.method, self.deformation, self.alpha2, tuple(subjects), self.atlas, self.faces,
            self.displacement[rows], self.strain[rows], take(self.momenta), take(self.residual),
            self.registration, take(self.volume_ratio),
        )  # fmt: skip
        if "_wall" in self.__dict__:  # already computed: the rows of the same surfaces
            out.__dict__["_wall"] = tuple(a[rows] for a in self._wall)
        return out


@dataclass(frozen=True)
class StudyResults:
    """One configuration's results read from a study folder.

    Attributes
    ----------
    config : dict
        Its ``config.json`` (the study's settings).
    atlas, faces : ndarray
    subjects : list of SubjectResults
    failures : list of FailedPair
    folder : Path
    """

    config: dict
    atlas: np.ndarray
    faces: np.ndarray
    subjects: list
    failures: list
    folder: Path

    @property
    def deformation(self) -> str:
        """The deformation model's name (``"lddmm"`` for results written before it was recorded)."""
        return self.config.get("config", {}).get("deformation", "lddmm")


def _stack(arrays) -> np.ndarray | None:
    if any(a is None for a in arrays):
        return None
    return np.stack(arrays)


def motions_from_results(
    results: list[SubjectResults], atlas, faces, deformation: str = "lddmm", registration=None
) -> list[TransportedMotion]:
    """Every (method, ``alpha^2``) of ``results`` as a :class:`TransportedMotion`, and ``"none"``.

    Only the subjects with a result at every ``alpha^2`` of the others take part
    (a subject with a failed pair is left out of every motion, so that all
    motions hold the same subjects).
    """
    atlas = np.asarray(atlas, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    dim = atlas.shape[1]
    sweeps = [set(r.alpha2) for r in results if r.pairs]
    if not sweeps:
        raise CohortError("results: no successful (subject, alpha^2) pair to analyse")
    alphas = sorted(set.union(*sweeps))
    complete = [r for r in results if set(r.alpha2) == set(alphas)]
    if not complete:
        raise CohortError("results: no subject has a result at every alpha^2 of the study")
    names = tuple(r.subject for r in complete)
    first = complete[0].at(alphas[0])
    ratios = np.array([r.at(alphas[0]).volume_ratio_subject for r in complete])
    motions = [
        TransportedMotion(
            NO_TRANSPORT, deformation, None, names, atlas, faces,
            np.stack([np.reshape(r.at(alphas[0]).displacement_subject, (-1, dim)) for r in complete]),
            np.stack([np.asarray(r.at(alphas[0]).las_subject) for r in complete]),
            volume_ratio=ratios,
        )
    ]  # fmt: skip
    for a2 in alphas:
        pairs: list[PairResult] = [r.at(a2) for r in complete]
        for method in (t.method for t in first.transports):
            ts = [p.transport(method) for p in pairs]
            motions.append(
                TransportedMotion(
                    method, deformation, float(a2), names, atlas, faces,
                    np.stack([t.displacement_array(dim) for t in ts]),
                    np.stack([np.asarray(t.las) for t in ts]),
                    _stack([t.momenta_array(dim) for t in ts]),
                    _stack([t.residual_array(dim) for t in ts]),
                    registration,
                    ratios,
                )
            )  # fmt: skip
    return motions


def _read_pair(path: Path) -> PairResult | FailedPair:
    try:
        return decode(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError) as exc:
        what = str(exc) if isinstance(exc, ResultSchemaError) else f"unreadable ({exc})"
        raise CohortError(
            f"{path}: {what}; run the study again into this folder to recompute it"
        ) from None


def load_study_results(output) -> list[StudyResults]:
    """Every configuration's results in a study's output folder (``results/<config>/``)."""
    output = Path(output)
    root = output / "results"
    configs = sorted(p for p in root.glob("*/config.json")) if root.is_dir() else []
    if not configs:
        raise CohortError(
            f"{output}: not a study output folder (no results/<config>/config.json); "
            "give the folder that `symladders study -o` wrote"
        )
    out = []
    for cfg in configs:
        folder = cfg.parent
        atlas_file = folder / ATLAS_FILE
        if not atlas_file.is_file():
            raise CohortError(
                f"{folder}: no {ATLAS_FILE}: written by an older version; run the study "
                "again into this folder"
            )
        atlas, faces = read_mesh(atlas_file)
        by_subject: dict[str, list] = {}
        for path in folder.glob("*/alpha2=*.json"):
            by_subject.setdefault(path.parent.name, []).append(_read_pair(path))
        subjects, failures = [], []
        for name in sorted(by_subject, key=natural_key):
            results = by_subject[name]
            fails = tuple(r for r in results if isinstance(r, FailedPair))
            failures += fails
            subjects.append(
                SubjectResults(name, tuple(r for r in results if isinstance(r, PairResult)), fails)
            )
        config = json.loads(cfg.read_text(encoding="utf-8"))
        out.append(StudyResults(config, atlas, faces, subjects, failures, folder))
    return out


def load_transported_motion(output) -> list[TransportedMotion]:
    """The transported motions of every configuration in a study's output folder.

    With several models (``--deformation lddmm,svf``, ``both``) the folder holds one
    study per model (``lddmm/``, ``svf/``, ...); pass one of them or the parent (every
    one is read, in the order of their names). The ``"none"`` motion appears once.
    """
    output = Path(output)
    folders = [output]
    if not (output / "results").is_dir():
        folders = sorted(p for p in output.iterdir() if (p / "results").is_dir())
        if not folders:
            folders = [output]  # load_study_results names the problem
    motions: list[TransportedMotion] = []
    for folder in folders:
        for study in load_study_results(folder):
            registration = study.config.get("config", {}).get("registration")
            for m in motions_from_results(
                study.subjects, study.atlas, study.faces, study.deformation, registration
            ):
                if m.method == NO_TRANSPORT and any(x.method == NO_TRANSPORT for x in motions):
                    continue
                motions.append(m)
    return motions
