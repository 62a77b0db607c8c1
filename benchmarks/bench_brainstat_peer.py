"""The per-vertex linear model against BrainStat's SLM on the same data (a peer check).

    python benchmarks/bench_brainstat_peer.py --brainstat-python /path/to/python
    python benchmarks/bench_brainstat_peer.py --brainstat-python ... --publish

BrainStat (the MICA lab's Python successor of SurfStat, ``brainstat.stats.SLM``) is the
reference of surface-based linear models in neuroimaging. It is not a dependency of
this project (it brings VTK, nilearn and NiMARE); install it in its own environment
(``python -m venv bs && bs/bin/pip install brainstat``) and pass that environment's
interpreter. On the synthetic cohort with covariates (``make_covariate_cohort``,
20 + 20 subjects, imbalance 0.5, the default hypokinesia in the patients), for the
normal component of each subject's motion ``(S' - S) . n`` at the 1,009 atlas vertices
and the model ``group + age + sex + body_size``:

* this project: ``glm_test`` (the observed ``t`` of the contrast; 1 permutation, the
  statistic does not depend on them);
* BrainStat: ``SLM(FixedEffect(X), X @ c, correction=None).fit(Y)``, its ``t`` on the
  same design matrix ``X`` (this project's, intercept included) and contrast ``c``;

for the contrasts of the group and of age. Reported: the largest absolute and relative
difference of ``t`` over the vertices, and both degrees of freedom.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import contrast_matrix, design_matrix, glm_test  # noqa: E402
from ladders.study.population import DEFAULT_ABNORMALITY, Covariates, make_covariate_cohort  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

RUNNER = """
import sys
import numpy as np
import pandas as pd
from brainstat.stats.SLM import SLM
from brainstat.stats.terms import FixedEffect
d = np.load(sys.argv[1])
X, y, c = d["X"], d["y"], d["c"]
model = FixedEffect(pd.DataFrame(X, columns=[f"x{i}" for i in range(X.shape[1])]),
                    add_intercept=False)
slm = SLM(model, X @ c, correction=None)
slm.fit(y)
np.savez(sys.argv[2], t=np.asarray(slm.t, float).ravel(), df=np.asarray(slm.df, float).ravel())
"""
CONTRASTS = ("group[patients] - group[controls]", "age")
FORMULA = "group + age + sex + body_size"


def _brainstat_t(python: str, X, y, c, folder: Path) -> tuple[np.ndarray, float]:
    np.savez(folder / "in.npz", X=X, y=y, c=c)
    (folder / "runner.py").write_text(RUNNER)
    subprocess.run([python, str(folder / "runner.py"), str(folder / "in.npz"),
                    str(folder / "out.npz")], check=True, capture_output=True)  # fmt: skip
    out = np.load(folder / "out.npz")
    return out["t"], float(out["df"][0])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--brainstat-python", required=True,
                        help="the interpreter of an environment with brainstat installed")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    version = subprocess.run(
        [args.brainstat_python, "-c", "import brainstat; print(brainstat.__version__)"],
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    data = make_covariate_cohort(
        20, (("controls", None), ("patients", DEFAULT_ABNORMALITY)), Covariates(imbalance=0.5)
    )
    cohort = data.cohort
    normals = outward_vertex_normals(cohort.atlas, cohort.faces)
    y = np.einsum("nkd,kd->nk", cohort.es - cohort.ed, normals)
    design = design_matrix(data.design_table(), FORMULA, subjects=cohort.names)
    lines = [
        "| contrast | vertices | largest abs difference of t | largest relative difference "
        "| df (this project / BrainStat) |",
        "|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as scratch:
        for name in CONTRASTS:
            ours = glm_test(y, design, name, 1, np.random.default_rng(0))
            c = contrast_matrix(design, name)[1][0]
            theirs, df = _brainstat_t(args.brainstat_python, design.matrix, y, c, Path(scratch))
            diff = np.abs(ours.statistic - theirs)
            lines.append(
                f"| `{name}` | {y.shape[1]:,} | {diff.max():.1e} | "
                f"{(diff / np.maximum(np.abs(theirs), 1e-12)).max():.1e} | "
                f"{ours.df[-1]:g} / {df:g} |"
            )
    table = (
        f"BrainStat {version}; `make_covariate_cohort` 20 + 20 subjects, imbalance 0.5; "
        f"normal motion at every atlas vertex; model `{FORMULA}`.\n\n" + "\n".join(lines) + "\n"
    )
    print(table)
    if args.publish:
        publish("brainstat_peer", table,
                "python benchmarks/bench_brainstat_peer.py --brainstat-python PY --publish")  # fmt: skip


if __name__ == "__main__":
    main()
