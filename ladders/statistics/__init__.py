"""Population statistics: tangent vectors at one point, groups and linear models of vertices.

Generic, like the rest of :mod:`ladders`: the tangent statistics use only the
connection API (``exp`` and the space's ``inner``), so they run on the sphere and
SPD matrices as on LDDMM momenta; the group tests and the linear model take arrays.

- :mod:`.tangent_pca`: :func:`tangent_mean`, :func:`tangent_pca` (with the space's
  metric), :func:`mode_shapes`;
- :mod:`.amplitude`: :func:`normalize_amplitude` of a transported tangent vector;
- :mod:`.group_tests`: :func:`vertexwise_test` (Hotelling ``T^2`` or ``t`` per vertex,
  family-wise error by max-T permutation) and :func:`global_test`;
- :mod:`.classification`: :func:`cross_validated_auc` (scikit-learn);
- :mod:`.detection`: :func:`detection_power`, :func:`dice`, :func:`binomial_interval`;
- :mod:`.design`: :func:`design_matrix` (a table and a model formula, formulaic),
  :func:`contrast_matrix` (contrasts by name), :func:`read_design` (CSV);
- :mod:`.linear_model`: :func:`fit_statistic` (per-vertex least squares; ``t``, ``F``
  or Pillai's trace), :func:`contrast_bases`, :func:`pillai_f`, :func:`pillai_to_hotelling`;
- :mod:`.permutation_glm`: :func:`glm_test` (Freedman-Lane, Manly or Draper-Stoneman
  permutations, within blocks, family-wise error of the maximum, optional enhancement),
  :func:`permutation_indices`, :func:`permutation_chunks`, :func:`two_sided`,
  :func:`tfce_from_observed`;
- :mod:`.null_maps`: the statistic maps of chunks of permutations (one matrix product,
  closed-form per-vertex algebra compiled), which :func:`glm_test` runs;
- :mod:`.survival`: :func:`cross_validated_c_index` and
  :func:`cross_validated_c_index_from_motion` (Cox regression, lifelines; cross-validated
  C-index with a bootstrap interval), :func:`c_index`, :func:`simulate_survival`;
- :mod:`.surface_smoothing`: :func:`smooth_surface_data` and :class:`SurfaceSmoother`
  (heat-kernel smoothing of per-vertex maps by a full width at half maximum),
  :func:`fwhm_to_time`;
- :mod:`.tfce`: :func:`tfce` (threshold-free cluster enhancement on a mesh's
  adjacency), :func:`tfce_enhancer` (the ``enhance`` of :func:`glm_test`),
  :func:`tfce_step`, :func:`mesh_adjacency`.

``import ladders`` does not import this package (it loads scikit-learn).
"""

from .amplitude import normalize_amplitude
from .classification import ClassifierResult, cross_validated_auc
from .design import Design, contrast_matrix, design_matrix, read_design
from .detection import binomial_interval, detection_power, dice
from .group_tests import GlobalTest, VertexwiseTest, check_groups, global_test, vertexwise_test
from .linear_model import LinearFit, contrast_bases, fit_statistic, pillai_f, pillai_to_hotelling
from .permutation_glm import (
    METHODS,
    GLMTest,
    glm_test,
    permutation_chunks,
    permutation_indices,
    tfce_from_observed,
    two_sided,
)
from .surface_smoothing import SurfaceSmoother, fwhm_to_time, smooth_surface_data
from .survival import (
    SurvivalResult,
    c_index,
    cross_validated_c_index,
    cross_validated_c_index_from_motion,
    simulate_survival,
)
from .tangent_pca import METRICS, TangentPCA, mode_shapes, tangent_mean, tangent_pca
from .tfce import mesh_adjacency, tfce, tfce_enhancer, tfce_step

__all__ = [
    "normalize_amplitude",
    "ClassifierResult",
    "cross_validated_auc",
    "binomial_interval",
    "detection_power",
    "dice",
    "GlobalTest",
    "VertexwiseTest",
    "check_groups",
    "global_test",
    "vertexwise_test",
    "SurfaceSmoother",
    "fwhm_to_time",
    "smooth_surface_data",
    "METRICS",
    "TangentPCA",
    "mode_shapes",
    "tangent_mean",
    "tangent_pca",
    "Design",
    "contrast_matrix",
    "design_matrix",
    "read_design",
    "LinearFit",
    "contrast_bases",
    "fit_statistic",
    "pillai_f",
    "pillai_to_hotelling",
    "METHODS",
    "GLMTest",
    "glm_test",
    "permutation_indices",
    "permutation_chunks",
    "two_sided",
    "tfce_from_observed",
    "SurvivalResult",
    "c_index",
    "cross_validated_c_index",
    "cross_validated_c_index_from_motion",
    "simulate_survival",
    "mesh_adjacency",
    "tfce",
    "tfce_enhancer",
    "tfce_step",
]
