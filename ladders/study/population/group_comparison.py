"""Where does the motion of two groups differ on the atlas, and how well does it separate them?

:func:`compare_groups` takes one :class:`~.transported_motion.TransportedMotion`
(the subjects' motion on the atlas by one transport at one ``alpha^2``) and the
subjects' groups, and runs:

* per vertex, a Hotelling ``T^2`` test of the displacement vectors, a ``t`` test of
  their component along the atlas's outward normal (the motion a surface shows: a
  correspondence of segmentations lets vertices slide along the surface, which adds
  noise to the tangential components only), a ``t`` test of the local area
  strain and a ``t`` test of the normal wall motion (the signed distance along the
  atlas's normal from ``T`` to the surface ``T'``,
  :attr:`~.transported_motion.TransportedMotion.wall_motion`), each with its
  family-wise error controlled by permuting the group labels (maximum statistic
  over the vertices, :func:`ladders.statistics.vertexwise_test`);
* a tangent PCA of the displacements at the atlas (the flat metric of the point
  distribution model, :func:`ladders.statistics.tangent_pca`) and a global
  permutation test on the first ``n_components`` scores
  (:func:`ladders.statistics.global_test`);
* a cross-validated classifier of the group from the displacements, with its AUC
  and a confidence interval (:func:`ladders.statistics.cross_validated_auc`).

With ``normalize="volume"`` each transported displacement is first rescaled so
that the atlas's relative volume change equals the subject's own (the subject's
ejection fraction is kept): the amplitude normalisation of transported
deformations of Guigui, Moceri, Sermesant and Pennec (ISBI 2021), in the point
distribution model of the atlas (:func:`ladders.statistics.normalize_amplitude`).
The scale is searched in ``[0, 16]`` (:data:`VOLUME_SCALE_BRACKET`): a transport
that keeps less than a sixteenth of the subject's volume change has lost the motion,
and its normalisation fails, naming the subject. The motion without transport is
normalised too: each ``S' - S``, applied to the atlas, is scaled to the subject's volume
change there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ladders.statistics import (
    ClassifierResult,
    GlobalTest,
    TangentPCA,
    VertexwiseTest,
    check_groups,
    cross_validated_auc,
    global_test,
    normalize_amplitude,
    tangent_pca,
    vertexwise_test,
)
from manifolds.euclidean import Euclidean
from manifolds.validation import check_int, check_rng

from ..area_strain import area_strain
from ..errors import CohortError
from ..volume import enclosed_volume
from ..wall_motion import outward_vertex_normals
from .transported_motion import TransportedMotion

__all__ = [
    "NORMALIZATIONS",
    "VERTEX_TESTS",
    "GroupComparison",
    "compare_groups",
    "normalize_motion",
]

#: Amplitude normalisations of the transported displacements.
NORMALIZATIONS = (None, "volume")
#: The per-vertex tests of a :class:`GroupComparison` (its attributes of those names).
VERTEX_TESTS = ("displacement", "normal", "strain", "wall_motion")


@dataclass(frozen=True)
class GroupComparison:
    """The comparison of two groups' motion on the atlas (:func:`compare_groups`).

    Attributes
    ----------
    motion : TransportedMotion
        The motion compared (after normalisation, if any).
    labels : ndarray of bool, shape (n,)
        True for the first group (``groups[0]``).
    groups : tuple of str
        The two group names, the first one tested against the second.
    displacement : VertexwiseTest
        Hotelling ``T^2`` of the displacement vectors at every atlas vertex.
    strain : VertexwiseTest
        ``t`` of the local area strain at every vertex (positive: larger in the first group).
    normal : VertexwiseTest
        ``t`` of the displacement's component along the atlas's outward vertex normal.
    wall_motion : VertexwiseTest
        ``t`` of the normal wall motion: the signed distance along the atlas's outward
        normal from ``T`` to the surface ``T'`` (positive: the first group's wall moves
        farther outward, or less far inward).
    pca : TangentPCA
        Tangent PCA of the displacements at the atlas (flat metric).
    global_test : GlobalTest
        Hotelling ``T^2`` of the first PCA scores, with its permutation p-value.
    classifier : ClassifierResult
        Cross-validated AUC of the group from the displacements.
    normalization : str or None
    scales : ndarray, shape (n,), or None
        The normalisation's scale of each subject's displacement.
    """

    motion: TransportedMotion
    labels: np.ndarray
    groups: tuple
    displacement: VertexwiseTest
    strain: VertexwiseTest
    normal: VertexwiseTest
    wall_motion: VertexwiseTest
    pca: TangentPCA
    global_test: GlobalTest
    classifier: ClassifierResult
    normalization: str | None = None
    scales: np.ndarray | None = None

    def group_mean(self, which: int, quantity: str = "displacement") -> np.ndarray:
        """Mean displacement ``(k, 3)``, strain or wall motion ``(k,)`` of group ``which`` (0 or 1).

        ``quantity`` is ``"displacement"``, ``"strain"`` or ``"wall_motion"``.
        """
        if which not in (0, 1):
            raise ValueError(f"which: expected 0 or 1, got {which!r}")
        if quantity not in ("displacement", "strain", "wall_motion"):
            raise ValueError(
                f"quantity: expected 'displacement', 'strain' or 'wall_motion', got {quantity!r}"
            )
        data = getattr(self.motion, quantity)
        mask = self.labels if which == 0 else ~self.labels
        return data[mask].mean(axis=0)

    def detected(self, alpha: float = 0.05, test: str = "displacement") -> np.ndarray:
        """Vertices whose family-wise corrected p-value is below ``alpha`` in ``test``
        (``"displacement"``, ``"normal"``, ``"strain"`` or ``"wall_motion"``)."""
        if test not in VERTEX_TESTS:
            raise ValueError(f"test: expected one of {VERTEX_TESTS}, got {test!r}")
        return getattr(self, test).p_fwer < alpha


#: Where the volume normalisation's scale is searched.
VOLUME_SCALE_BRACKET = (0.0, 16.0)


def _volume_scale(space, atlas, faces, displacement, target, subject: str = "") -> float:
    base = enclosed_volume(atlas, faces)

    def ratio(shape):
        return enclosed_volume(shape, faces) / base

    try:
        _, scale = normalize_amplitude(
            space, atlas, displacement, ratio, target, bracket=VOLUME_SCALE_BRACKET
        )
    except ValueError as exc:
        raise CohortError(
            f"normalize='volume': no scale of subject {subject}'s transported motion reaches "
            f"its volume ratio {target:.4g} ({exc})"
        ) from None
    return scale


def normalize_motion(
    motion: TransportedMotion, volume_ratios=None
) -> tuple[TransportedMotion, np.ndarray]:
    """Every transported displacement rescaled to keep the subject's relative volume change.

    Parameters
    ----------
    motion : TransportedMotion
    volume_ratios : array, shape (n,), optional
        ``V(S') / V(S)`` of each subject; default ``motion.volume_ratio`` (from
        ``PairResult.volume_ratio_subject``).

    Returns
    -------
    TransportedMotion, ndarray of shape (n,)
        The motion with ``T' - T`` scaled by ``lambda_i`` such that
        ``V(T + lambda_i (T'_i - T)) / V(T) = V(S'_i) / V(S_i)``, and the scales.
        Its area strain and its wall motion are those of the rescaled surfaces
        ``T + lambda_i (T'_i - T)`` (the wall motion computed when first read).
        The motion without transport is scaled the same way: its ``S'_i - S_i``,
        which the analysis applies to the atlas, is brought to the subject's own
        volume change on the atlas (the normalisation with no transport at all; for
        groups whose anatomy differs it is as close to the ideal transport as the best
        transports, ``docs/evidence/population_evidence.md``).
    """
    n = len(motion.subjects)
    if volume_ratios is None:
        volume_ratios = motion.volume_ratio
    if volume_ratios is None:
        raise CohortError("normalize='volume': the motion has no subject volume ratios")
    ratios = np.asarray(volume_ratios, dtype=float)
    if ratios.shape != (n,) or not np.all(np.isfinite(ratios) & (ratios > 0)):
        raise CohortError(f"volume_ratios: expected {n} positive numbers, got {ratios.shape}")
    space = Euclidean(motion.atlas.shape)
    scales = np.array(
        [
            _volume_scale(space, motion.atlas, motion.faces, d, r, s)
            for d, r, s in zip(motion.displacement, ratios, motion.subjects)
        ]
    )
    scaled = motion.displacement * scales[:, None, None]
    strain = _strain(motion.atlas, motion.faces, scaled)
    out = TransportedMotion(
        motion.method, motion.deformation, motion.alpha2, motion.subjects, motion.atlas,
        motion.faces, scaled, strain, None, None, motion.registration, ratios,
    )  # fmt: skip
    return out, scales


def _strain(atlas, faces, displacement) -> np.ndarray:
    return np.stack([area_strain(atlas, atlas + d, faces) for d in displacement])


def compare_groups(
    motion: TransportedMotion,
    labels,
    groups: tuple = ("patients", "controls"),
    n_permutations: int = 10000,
    n_components: int = 5,
    rng: np.random.Generator | None = None,
    normalize: str | None = None,
    volume_ratios=None,
    progress: bool = False,
    n_splits: int = 5,
) -> GroupComparison:
    """Compare the motion of two groups on the atlas (see the module).

    Parameters
    ----------
    motion : TransportedMotion
    labels : array of bool, shape (n,)
        True for the subjects of ``groups[0]``.
    groups : (str, str)
        Names of the two groups, for the reports.
    n_permutations : int, default 10000
        Permutations of the group labels of each test.
    n_components : int, default 5
        PCA scores in the global test and in the classifier.
    rng : numpy.random.Generator
        Draws of the permutations and of the cross-validation folds (required:
        the results depend on it).
    normalize : {None, "volume"}
        Amplitude normalisation (module docstring).
    volume_ratios : array, shape (n,), optional
        For ``"volume"``: ``V(S') / V(S)`` per subject; default ``motion.volume_ratio``.
    progress : bool
        Progress bars over the permutations.
    n_splits : int, default 5
        Folds of the stratified cross-validation (at most the smaller group's size).

    Returns
    -------
    GroupComparison
    """
    rng = check_rng(rng)
    labels = check_groups(labels, len(motion.subjects))
    n_components = check_int(n_components, "n_components", minimum=1)
    if normalize not in NORMALIZATIONS:
        raise CohortError(f"normalize: expected one of {NORMALIZATIONS}, got {normalize!r}")
    scales = None
    if normalize == "volume":
        motion, scales = normalize_motion(motion, volume_ratios)
    n = len(labels)
    n_components = min(n_components, n - 2)
    wall_motion = motion.wall_motion  # computed before any draw (the slowest input)
    displacement = vertexwise_test(
        motion.displacement, labels, n_permutations, rng=rng, progress=progress
    )
    strain = vertexwise_test(motion.strain, labels, n_permutations, rng=rng, progress=progress)
    along = np.einsum(
        "nkd,kd->nk", motion.displacement, outward_vertex_normals(motion.atlas, motion.faces)
    )
    normal = vertexwise_test(along, labels, n_permutations, rng=rng, progress=progress)
    space = Euclidean(motion.atlas.shape)
    pca = tangent_pca(space, motion.atlas, motion.displacement, n_components, metric="flat")
    k = min(n_components, pca.scores.shape[1])
    global_ = global_test(pca.scores[:, :k], labels, n_permutations, rng=rng)
    smallest = int(min(labels.sum(), (~labels).sum()))
    classifier = cross_validated_auc(  # fewer folds for small groups (each fold needs both)
        motion.displacement.reshape(n, -1), labels, n_splits=max(2, min(n_splits, smallest)),
        n_components=k, rng=rng,
    )  # fmt: skip
    # drawn last, so that the other tests' draws are those of a comparison without it
    wall = vertexwise_test(wall_motion, labels, n_permutations, rng=rng, progress=progress)
    return GroupComparison(
        motion, labels, tuple(groups), displacement, strain, normal, wall, pca, global_,
        classifier, normalize, scales,
    )  # fmt: skip
