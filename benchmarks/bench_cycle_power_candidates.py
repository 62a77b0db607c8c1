"""What could give back the power the tracking of label series costs: analyses tried against the truth.

    python benchmarks/bench_cycle_power_candidates.py WORK_NO_PLANES WORK_PLANES [--publish]

Reads what ``bench_cycle_routes.py --work WORK`` tracked for the mild cohort with the
landmark table (one row group per folder: e.g. the label series tracked without the
valve planes, and with the valve plane of every frame estimated from the images,
``symladders track``'s default) and, on the same 40 subjects, the true frames. The
tracking's errors of each subject's peak raise the threshold of the maximum statistic
and shrink the planted region's group difference (``bench_cycle_route_causes.py``);
each analysis below is one way a model could give that back, tested on the tracked
series and on the true frames alike (:func:`candidate_rows`):

* other summaries of each vertex's curve than its peak (:func:`window_mean`,
  :func:`amplitude`): they average over frames, against an error that changes from
  frame to frame (``bench_cycle_power.py``'s second table keeps the curves to their
  first Fourier harmonics instead);
* the subjects weighted in the model (weighted least squares by whitening, the weight
  tied to its subject under Freedman-Lane's permutations): by their tracking's
  residual, as the route records it, or by the truth (each subject's true error
  variance added to the motion's own variance between subjects), the weights a
  perfect quality measure would give;
* the tracking residual as a covariate;
* the maps smoothed on the atlas and the apical cap left out (``cycle-analyze --fwhm``,
  ``--exclude-segments 17``), the existing options.

Every analysis is run in :data:`STREAMS` permutation streams: a mild effect near the
detection limit has many vertices near the threshold, and the power moves between
streams by a few hundredths.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_cycle_routes as routes  # noqa: E402
from bench_cycle_power import COHORT, PERMUTATIONS  # noqa: E402
from bench_cycle_route_causes import tracking_of  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.statistics import (  # noqa: E402
    SurfaceSmoother,
    binomial_interval,
    detection_power,
    glm_test,
)
from ladders.statistics.tfce import mesh_adjacency  # noqa: E402
from ladders.study.meshes.mesh_io import read_mesh  # noqa: E402
from ladders.study.sequences import CycleMotion, curve_peaks  # noqa: E402
from ladders.study.sequences.cycle_responses import sub_faces  # noqa: E402

#: Frames either side of the pooled mean curve's peak averaged by the window summary.
WINDOW = 3
#: Permutation streams per candidate (the power's spread between streams shows its
#: Monte Carlo error); null: random 10-against-10 splits of the controls.
STREAMS, NULL_SPLITS, NULL_PERMUTATIONS = 3, 100, 500


def window_mean(curves: np.ndarray, half: int = WINDOW) -> np.ndarray:
    """Inward motion ``(n, k)`` averaged over the ``2 half + 1`` frames around the frame where
    the vertex's mean curve over every subject (labels unused) moves inward most."""
    y = -np.asarray(curves)
    n_frames = y.shape[1]
    at = np.argmax(y.mean(axis=0), axis=0)  # (k,)
    frames = (at[None, :] + np.arange(-half, half + 1)[:, None]) % n_frames
    return np.take_along_axis(y, frames[None], axis=1).mean(axis=1)


def amplitude(curves: np.ndarray) -> np.ndarray:
    """Each curve's least-squares multiple of its vertex's mean curve over every subject,
    times that mean curve's peak inward motion (mm; ``(n, k)``)."""
    y = -np.asarray(curves)
    mean = y.mean(axis=0)
    norm = (mean * mean).sum(axis=0)
    ok = norm > 1e-12
    return np.where(ok, (y * mean).sum(axis=1) / np.where(ok, norm, 1.0), 0.0) * mean.max(axis=0)


def _quality(root: Path, names) -> np.ndarray:
    """Each subject's tracking residual: the RMS distance its ED mesh moved onto frame 0's
    surface (``quality[0]["onto_surface_rms"]`` of its tracking record, mm)."""
    return np.array([json.loads((root / "tracked" / f"{s}.json").read_text())["quality"][0]
                     ["onto_surface_rms"] for s in names])  # fmt: skip


def _candidate_test(y, labels, weights, covariate, tested, faces, seed, null_tfce=False):
    """Max-t and TFCE (Freedman-Lane, weighted least squares by whitening): the tests of one
    stream, and (stream 0) the null FWER of max-t on random halves of the controls, and of
    TFCE with ``null_tfce``."""
    y = y[:, tested]
    adjacency = mesh_adjacency(sub_faces(faces, tested), int(tested.sum()))

    def model(lab, w, cov):
        x = np.c_[np.ones(len(lab)), lab.astype(float)]
        if cov is not None:
            x = np.c_[x, cov - cov.mean()]
        root = np.sqrt(w / w.mean())[:, None]
        return x * root, root

    x, root = model(labels, weights, covariate)
    contrast = np.zeros((1, x.shape[1]))
    contrast[0, 1] = 1.0
    rng = np.random.default_rng(seed)
    test = glm_test(y * root, x, contrast, PERMUTATIONS, rng, tfce=adjacency)
    if seed:
        return test, None
    hits, controls = np.zeros(2, dtype=int), np.flatnonzero(~labels)
    for _ in range(NULL_SPLITS):
        order = rng.permutation(controls)
        keep = np.sort(order[:20])
        cov = None if covariate is None else covariate[keep]
        xs, rs = model(np.isin(keep, order[:10]), weights[keep], cov)
        null = glm_test(y[keep] * rs, xs, contrast, NULL_PERMUTATIONS, rng,
                        tfce=adjacency if null_tfce else None)  # fmt: skip
        hits += [null.significant(0.05).any(),
                 null_tfce and null.significant(0.05, enhanced=True).any()]  # fmt: skip
    return test, [(h / NULL_SPLITS, *binomial_interval(int(h), NULL_SPLITS)) for h in
                  hits[: 1 + null_tfce]]  # fmt: skip


def candidate_rows(works, n: int, n_frames: int) -> list[tuple]:
    """Per motion (the true frames, then each folder's tracked label series) and analysis: the
    threshold, the region's mean ``|t|``, max-t and TFCE power (mean and range over
    :data:`STREAMS` permutation streams), max-t's null FWER, and the summary's error
    against the same summary of the true frames (SD over the subjects, mean over the
    vertices). Finished rows are kept in ``power_candidates.json`` of the first folder: a
    rerun resumes (delete it after a change of the analyses)."""
    c = routes._cycles(COHORT, n, n_frames)
    root0 = Path(works[0]) / f"{COHORT}_landmarks"
    # finished rows, kept so that an interrupted run resumes
    cache = Path(works[0]) / "power_candidates.json"
    done = json.loads(cache.read_text()) if cache.is_file() else {}
    atlas, faces = read_mesh(root0 / "cohort" / "atlas.vtk")
    region = c.data.region.affected
    everywhere = np.ones(len(atlas), dtype=bool)
    no_cap = ~routes._apical_cap(atlas, faces)
    smoother = SurfaceSmoother(atlas, faces, 10.0)
    motions = [("true frames (meshes in correspondence)", None, list(c.names))]
    for work in works:
        root = Path(work) / f"{COHORT}_landmarks"
        motions.append((f"label series with landmarks, {tracking_of(root)}", root,
                        routes._tracked(root, c)[:2]))  # fmt: skip
    out = []
    for label, root, tracked in motions:
        names = tracked if root is None else tracked[0]
        rows_of = [c.names.index(s) for s in names]
        labels = np.array([c.patients[i] for i in rows_of])
        truth = CycleMotion(tuple(names), c.frames[rows_of] - c.frames[rows_of, :1], atlas,
                            faces).normal()  # fmt: skip
        curves = truth if root is None else CycleMotion(
            tuple(names), tracked[1] - tracked[1][:, :1], atlas, faces).normal()  # fmt: skip
        true_peaks = curve_peaks(truth)[0]
        peaks = curve_peaks(curves)[0]
        ones = np.ones(len(names))
        analyses = [
            ("peak (the default)", peaks, true_peaks, ones, None, everywhere),
            ("peak, without segment 17", peaks, true_peaks, ones, None, no_cap),
            (f"mean over the {2 * WINDOW + 1} frames around the mean curve's peak",
             window_mean(curves), window_mean(truth), ones, None, everywhere),
            ("amplitude on the vertex's mean curve", amplitude(curves), amplitude(truth), ones,
             None, everywhere),
            ("peak, maps smoothed 10 mm FWHM, without segment 17",
             curve_peaks(smoother(curves))[0], curve_peaks(smoother(truth))[0], ones, None, no_cap),
        ]  # fmt: skip
        if root is not None:
            residual = _quality(root, names)
            error = peaks - true_peaks
            within = np.mean([true_peaks[g].var(axis=0, ddof=1).mean() for g in (labels, ~labels)])
            analyses += [
                ("peak, subjects weighted by 1 / their tracking residual^2", peaks, None,
                 1.0 / residual**2, None, everywhere),
                ("peak, subjects weighted by the truth: 1 / (within-group variance + their "
                 "error's variance)", peaks, None, 1.0 / (within + error.var(axis=1)), None,
                 everywhere),
                ("peak, the tracking residual as a covariate", peaks, None, ones, residual,
                 everywhere),
            ]  # fmt: skip
        for name, y, y_true, weights, covariate, tested in analyses:
            key = f"{label} | {name}"
            if key in done:
                out.append(tuple(done[key]))
                continue
            reg = region[tested]
            # the null of TFCE for the analyses the library offers (the slower part)
            offered = name.startswith("peak") and weights is ones and covariate is None
            runs = [_candidate_test(y, labels, weights, covariate, tested, faces, seed,
                                    offered) for seed in range(STREAMS)]  # fmt: skip
            maxt = [detection_power(t.significant(0.05)[reg], reg[reg]) for t, _ in runs]
            tfce = [detection_power(t.significant(0.05, enhanced=True)[reg], reg[reg])
                    for t, _ in runs]  # fmt: skip
            first = runs[0][0]
            error = None if y_true is None or root is None else float(
                (y - y_true).std(axis=0, ddof=1).mean())  # fmt: skip
            out.append((label, name, float(np.quantile(first.max_null, 0.95)),
                        float(np.abs(first.statistic[reg]).mean()), maxt, tfce, runs[0][1],
                        error))  # fmt: skip
            print(out[-1], flush=True)
            done[key] = out[-1]
            cache.write_text(json.dumps(done, indent=1))
    return out


def _candidate_table(rows) -> str:
    lines = [
        "| motion | analysis | FWER threshold of the maximum |t| | mean |t| over the region | "
        "max-t power: mean [range] | TFCE power: mean [range] | null FWER [95 % CI]: max-t; "
        "TFCE | "
        "error against the truth's same summary: SD over the subjects (mm) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, name, threshold, mean_t, maxt, tfce, null, error in rows:
        rate = "; ".join(f"{r[0]:.2f} [{r[1]:.2f}, {r[2]:.2f}]" for r in null)
        err = "truth" if label.startswith("true") else ("–" if error is None else f"{error:.2f}")
        lines.append(f"| {label} | {name} | {threshold:.2f} | {mean_t:.2f} | "
                     f"{np.mean(maxt):.2f} [{min(maxt):.2f}, {max(maxt):.2f}] | "
                     f"{np.mean(tfce):.2f} [{min(tfce):.2f}, {max(tfce):.2f}] | {rate} | "
                     f"{err} |")  # fmt: skip
    note = (
        "The whole-cycle mild hypokinesia (a fifth of the motion in segments 7, 8, 13, 14), "
        "20 patients against 20 controls, 25 frames, short-axis label series of "
        "1.5 x 1.5 x 8 mm (`cycle_routes`' cohort, correspondence with the landmark table, "
        "tracking by projection with refine_ed, without the valve planes or with the valve "
        "plane of every frame estimated from the images, `symladders track`'s default), no "
        "transport. Each analysis tests the group at every vertex tested by Freedman-Lane "
        f"permutations (the maximum statistic and TFCE, {PERMUTATIONS:,} permutations, FWER "
        f"5 %) in {STREAMS} permutation streams: the power's mean and range over them (its "
        "Monte Carlo spread), the threshold and the region's |t| of the first. Null: "
        f"{NULL_SPLITS} random 10-against-10 splits of the controls ({NULL_PERMUTATIONS} "
        "permutations each; TFCE's for the analyses `cycle-analyze` offers). Summaries: the peak (`curve_peaks`); the inward motion "
        f"averaged over the {2 * WINDOW + 1} frames around the frame where the vertex's mean "
        "curve over every subject peaks; each curve's least-squares multiple of the vertex's "
        "mean curve (in mm of its peak). Weights: weighted least squares by whitening the "
        "model, the subject's weight tied to it under the permutations; the tracking "
        "residual is the RMS distance the subject's ED mesh moved onto its frame 0's "
        "surface (its tracking record), the record most correlated with the subject's "
        "true error of the peak; the truth's weights use the true peaks' within-group "
        "variance (mean over the vertices) and each subject's true error variance over the "
        "vertices. Last column: the tracked summary minus the same summary of the true "
        "frames."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("work", type=Path, nargs="+",
                        help="--work folders of bench_cycle_routes.py (one row group each)")  # fmt: skip
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    table = _candidate_table(candidate_rows(args.work, 40, 25))
    print("\n" + table)
    if args.publish:
        publish("cycle_power_candidates", table, "python benchmarks/bench_cycle_power_candidates.py "
                "WORK_NO_PLANES WORK_PLANES --publish")  # fmt: skip


if __name__ == "__main__":
    main()
