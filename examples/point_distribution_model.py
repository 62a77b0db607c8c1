"""A third deformation model for the study: the point-distribution model (PDM), end to end.

The PDM is the Euclidean space of vertex positions: ``Exp_T(v) = T + v``,
``Log_T(S) = S - T`` (:class:`manifolds.Euclidean`). Its geodesic symmetry
``s_M(X) = 2M - X`` makes the pole ladder exact and the transport the identity,
``T' - T = S' - S``: the PDM is the study's baseline of no transport. Its symmetry
errors are round-off, its log is exact (the residual is zero: both variants agree),
and it has no fanning scheme (the study records it as skipped, with the reason).

Importing this file registers the model as ``pdm``; ``symladders study --plugin
THIS_FILE --deformation lddmm,svf,pdm`` runs the three models on one cohort. The
script does it end to end:

1. validates the model (:func:`ladders.study.deformations.validate_deformation_model`:
   the interface, the contract of every space, the ladder's convergence);
2. writes a two-group synthetic cohort with a planted hypokinesia (``symladders cohort``);
3. runs the study on it with LDDMM, SVF and the PDM (``symladders study``): Table 1 of
   each model, its paired statistics, and the comparison of SVF and the PDM with LDDMM;
4. compares the groups' transported motion of the three (``symladders analyze``).

Run ``python examples/point_distribution_model.py --output symladders-output/pdm``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ladders.study.cli import main as symladders
from ladders.study.deformations import (
    DeformationModel,
    register_deformation,
    validate_deformation_model,
)
from manifolds import Euclidean
from manifolds.point_distance import point_distance


class PointDistributionModel(DeformationModel):
    """The vertices' positions as a Euclidean space: no deformation, no regularisation.

    ``alpha^2`` and the kernel settings do not apply; the registration is exact
    (the default :meth:`~ladders.study.deformations.DeformationModel.register`:
    ``Log`` then ``Exp``, its norm ``|S - T|``), and the own transport (the fanning
    scheme) is left to the default, which raises :class:`NotImplementedError`.
    """

    name = "pdm"
    label = "PDM"

    def make_space(self, template, alpha2, settings):
        """``R^(k x d)`` with the template's shape."""
        return Euclidean(np.shape(template))

    def inverse_consistency(self, space, template, shape, distance="rms"):
        """The registration ``S -> T`` (a translation of every vertex by ``T - S``) applied
        to the registration ``T -> S`` of ``T``: exactly ``T`` again, up to round-off."""
        forward = space.exp(template, space.log(template, shape))
        back = space.exp(forward, space.log(shape, template))
        return float(point_distance(distance, space.point_shape)(back, template))


register_deformation(PointDistributionModel())


def main(argv=None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="symladders-output/pdm", help="folder written")
    parser.add_argument("--subjects", type=int, default=8, help="subjects of the cohort")
    parser.add_argument("--vertices", type=int, default=41, help="vertices per mesh")
    parser.add_argument("--alpha2", default="1", help="alpha^2 of the study (comma-separated)")
    parser.add_argument("--permutations", type=int, default=200, help="of the group tests")
    parser.add_argument("--jobs", type=int, default=1, help="parallel subjects of the study")
    args = parser.parse_args(argv)
    out = Path(args.output)

    report = validate_deformation_model("pdm")
    print(report.to_markdown())

    cohort = out / "cohort"
    steps = [
        ["cohort", "-o", str(cohort), "--subjects", str(args.subjects),
         "--vertices", str(args.vertices)],
        ["study", "--plugin", __file__, "--deformation", "lddmm,svf,pdm", "--meshes",
         str(cohort), "--alpha2", args.alpha2, "-o", str(out / "study"), "--jobs",
         str(args.jobs), "--no-progress", "--no-meshes"],
        ["analyze", str(out / "study"), "--groups", str(cohort / "groups.csv"),
         "--permutations", str(args.permutations), "--no-figures", "--no-progress",
         "-o", str(out / "analysis")],
    ]  # fmt: skip
    for step in steps:
        print("symladders", " ".join(step))
        status = symladders(step)
        if status != 0:
            raise SystemExit(f"symladders {step[0]} failed (exit status {status})")
    return out


if __name__ == "__main__":
    main()
