"""A linear model of the transported motion on the atlas: covariates, several groups, TFCE, AHA.

:func:`compare_model` is :func:`~.group_comparison.compare_groups` generalised to
any design (:func:`ladders.statistics.design_matrix`, e.g. ``"group + age + sex"``)
and contrast (``"group[patients] - group[controls]"``, ``"age"``, or ``"group"``
for an F test over all its levels). At every atlas vertex it tests, by
:func:`ladders.statistics.glm_test` (Freedman-Lane permutations, maximum statistic
over the vertices for the family-wise error):

* the displacement vectors ``T' - T`` (Pillai's trace, multivariate);
* their component along the atlas's outward normal, the area strain and the normal
  wall motion (``t`` for a one-row contrast, ``F`` otherwise).

Options:

* ``tfce=True``: threshold-free cluster enhancement on the atlas's triangle
  adjacency (:func:`ladders.statistics.tfce`, ``H = 2``, ``E = 1``, both tails
  of a ``t``), with its own family-wise error from the same permutations;
* ``fwhm``: every subject's maps smoothed on the atlas by the heat kernel of that full
  width at half maximum (mm; :class:`ladders.statistics.SurfaceSmoother`, each
  component of the displacement alike) before the tests, vertex and segment alike;
* ``segments``: the AHA segment of each atlas vertex
  (:func:`~.aha_model.aha_segments`): the same model on each subject's mean over each
  of the 17 segments, corrected over the segments.

For the two-group design ``"group"`` and the contrast of the two levels, the
statistics are those of :func:`~.group_comparison.compare_groups` (``t`` equal,
Pillai's ``V`` a monotone map of Hotelling's ``T^2``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ladders.statistics import (
    Design,
    SurfaceSmoother,
    contrast_matrix,
    glm_test,
    mesh_adjacency,
)
from manifolds.validation import check_int, check_rng

from ..errors import CohortError
from ..wall_motion import outward_vertex_normals
from .segment_table import segment_means
from .transported_motion import TransportedMotion

__all__ = ["MODEL_TESTS", "TFCE_HEIGHT", "TFCE_EXTENT", "ModelComparison", "compare_model",
           "contrast_effects", "model_responses", "model_tests"]  # fmt: skip

#: The per-vertex tests of a :class:`ModelComparison`.
MODEL_TESTS = ("displacement", "normal", "strain", "wall_motion")
#: TFCE's height and extent exponents on a surface (FSL PALM's ``-tfce2D``; those of
#: :func:`ladders.statistics.tfce_from_observed`).
TFCE_HEIGHT, TFCE_EXTENT = 2.0, 1.0


@dataclass(frozen=True)
class ModelComparison:
    """One contrast of the linear model tested on one motion (:func:`compare_model`).

    Attributes
    ----------
    motion : TransportedMotion
    design : Design
    contrast : str
        The contrast's name.
    tests : dict of str to GLMTest
        Per test of :data:`MODEL_TESTS`, the per-vertex test (with the TFCE map and
        its p-values when asked for).
    effects : dict of str to ndarray
        The contrast's estimate per vertex, ``(k,)`` for the scalars and ``(k, 3)``
        for the displacement, for one-row contrasts (an F test has none: empty).
    segments : ndarray of int, shape (k,), or None
        The AHA segment (1-17) of each atlas vertex.
    segment_tests : dict of str to GLMTest, or None
        The same tests on the subjects' segment means, corrected over the 17 segments.
    segment_effects : dict of str to ndarray, or None
    """

    motion: TransportedMotion
    design: Design
    contrast: str
    tests: dict
    effects: dict
    segments: np.ndarray | None = None
    segment_tests: dict | None = None
    segment_effects: dict | None = None

    def detected(self, alpha: float = 0.05, test: str = "normal", tfce: bool = False):
        """Vertices whose family-wise corrected p-value (of the TFCE map if ``tfce``) is below
        ``alpha``."""
        if test not in MODEL_TESTS:
            raise ValueError(f"test: expected one of {MODEL_TESTS}, got {test!r}")
        result = self.tests[test]
        if tfce and result.p_fwer_enhanced is None:
            raise ValueError("tfce: this comparison was made without TFCE")
        return result.significant(alpha, enhanced=tfce)


def model_responses(motion: TransportedMotion, fwhm: float | None = None) -> dict:
    """The responses of the per-vertex tests: ``{name: (n, k, 3) or (n, k)}``; with
    ``fwhm`` (mm), smoothed on the atlas (the displacement component by component)."""
    normals = outward_vertex_normals(motion.atlas, motion.faces)
    responses = {
        "displacement": motion.displacement,
        "normal": np.einsum("nkd,kd->nk", motion.displacement, normals),
        "strain": motion.strain,
        "wall_motion": motion.wall_motion,
    }
    if fwhm is None:
        return responses
    smoother = SurfaceSmoother(motion.atlas, motion.faces, fwhm)
    smoothed = {t: smoother(r) for t, r in responses.items() if t != "displacement"}
    vectors = np.moveaxis(smoother(np.moveaxis(motion.displacement, -1, -2)), -1, -2)
    return {"displacement": vectors, **smoothed}


def contrast_effects(tests: dict) -> dict:
    """``{name: the contrast's estimate per vertex (and component)}`` of the tests of a
    one-row contrast (an F test has none: left out)."""
    return {name: r.effect[0] for name, r in tests.items() if r.effect.shape[0] == 1}


def model_tests(
    responses: dict,
    design: Design,
    contrast,
    n_permutations: int,
    rng: np.random.Generator,
    *,
    method: str = "freedman_lane",
    blocks=None,
    adjacency=None,
    progress: bool = False,
) -> dict:
    """Each response tested for one contrast of the linear model, one permutation stream.

    Parameters
    ----------
    responses : dict
        ``{name: array (n, k) or (n, k, d)}``, the rows in the order of the design's.
    design : Design
    contrast : str or array
    n_permutations : int
    rng : numpy.random.Generator
    method : str
        :data:`ladders.statistics.METHODS`.
    blocks : array, shape (n,), optional
        Exchangeability blocks.
    adjacency : dict, optional
        ``{name: sparse (k, k)}``: threshold-free cluster enhancement of that response's
        maps on this graph (``H = 2``, ``E = 1``; a response without one: none).
    progress : bool

    Returns
    -------
    dict
        ``{name: GLMTest}`` in the order of ``responses``.
    """
    adjacency = adjacency or {}
    return {name: glm_test(y, design, contrast, n_permutations, rng, method, blocks,
                           tfce=adjacency.get(name), progress=progress)
            for name, y in responses.items()}  # fmt: skip


def compare_model(
    motion: TransportedMotion,
    design: Design,
    contrast,
    n_permutations: int = 10000,
    rng: np.random.Generator | None = None,
    *,
    tfce: bool = False,
    segments=None,
    blocks=None,
    method: str = "freedman_lane",
    progress: bool = False,
    fwhm: float | None = None,
) -> ModelComparison:
    """Test one contrast of a linear model at every atlas vertex (see the module).

    Parameters
    ----------
    motion : TransportedMotion
        Its subjects in the order of ``design.subjects``.
    design : Design
        From :func:`ladders.statistics.design_matrix` on the subjects of ``motion``.
    contrast : str or array, shape (q, p)
        :func:`ladders.statistics.contrast_matrix`.
    n_permutations : int, default 10000
    rng : numpy.random.Generator
        Draws the permutations (required).
    tfce : bool
        Also the TFCE maps and their family-wise p-values.
    segments : int array, shape (k,), optional
        The AHA segment of each atlas vertex: also the segment tests.
    blocks : array, shape (n,), optional
        Exchangeability blocks (e.g. the site): permutations within blocks only.
    method : {"freedman_lane", "manly", "draper_stoneman"}
    progress : bool
    fwhm : float, optional
        Smooth every subject's maps on the atlas first (mm, full width at half maximum).

    Returns
    -------
    ModelComparison
    """
    rng = check_rng(rng)
    n_permutations = check_int(n_permutations, "n_permutations", minimum=1)
    if list(design.subjects) != list(motion.subjects):
        raise CohortError("design: its subjects are not the motion's, in the motion's order")
    name, c = contrast_matrix(design, contrast)
    responses = model_responses(motion, fwhm)
    graph = mesh_adjacency(motion.faces, motion.atlas.shape[0]) if tfce else None
    options = {"method": method, "blocks": blocks, "progress": progress}
    tests = model_tests(responses, design, c, n_permutations, rng,
                        adjacency={t: graph for t in MODEL_TESTS} if tfce else None,
                        **options)  # fmt: skip
    effects = contrast_effects(tests)
    segment_tests = segment_effects = None
    if segments is not None:
        segments = np.asarray(segments)
        means = {t: segment_means(responses[t], segments) for t in MODEL_TESTS}
        segment_tests = model_tests(means, design, c, n_permutations, rng, **options)
        segment_effects = contrast_effects(segment_tests)
    return ModelComparison(motion, design, name, tests, effects, segments, segment_tests,
                           segment_effects)  # fmt: skip
