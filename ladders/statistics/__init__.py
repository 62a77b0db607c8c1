"""Population statistics: tangent vectors at one point, and two groups of per-vertex data.

Generic, like the rest of :mod:`ladders`: the tangent statistics use only the
connection API (``exp`` and the space's ``inner``), so they run on the sphere and
SPD matrices as on LDDMM momenta; the group tests take arrays.

- :mod:`.tangent_pca`: :func:`tangent_mean`, :func:`tangent_pca` (with the space's
  metric), :func:`mode_shapes`;
- :mod:`.amplitude`: :func:`normalize_amplitude` of a transported tangent vector;
- :mod:`.group_tests`: :func:`vertexwise_test` (Hotelling ``T^2`` or ``t`` per vertex,
  family-wise error by max-T permutation) and :func:`global_test`;
- :mod:`.classification`: :func:`cross_validated_auc` (scikit-learn);
- :mod:`.detection`: :func:`detection_power`, :func:`dice`, :func:`binomial_interval`.

``import ladders`` does not import this package (it loads scikit-learn).
"""

from .amplitude import normalize_amplitude
from .classification import ClassifierResult, cross_validated_auc
from .detection import binomial_interval, detection_power, dice
from .group_tests import GlobalTest, VertexwiseTest, check_groups, global_test, vertexwise_test
from .tangent_pca import METRICS, TangentPCA, mode_shapes, tangent_mean, tangent_pca

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
    "METRICS",
    "TangentPCA",
    "mode_shapes",
    "tangent_mean",
    "tangent_pca",
]
