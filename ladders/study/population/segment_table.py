"""Two groups compared segment by segment of the AHA 17-segment model.

:func:`segment_table` averages a per-vertex quantity over the vertices of each
AHA segment (:func:`~.aha_model.aha_segments`), one mean per subject and
segment, and compares the two groups on those means with
:func:`ladders.statistics.vertexwise_test`: Student's ``t`` for a scalar
(area strain, normal wall motion), Hotelling's ``T^2`` for a vector (the
displacement's mean vector in the segment). The permutation's maximum statistic
over the 17 segments controls the family-wise error over the segments. The
result, a :class:`SegmentTable`, writes itself as Markdown or CSV.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass

import numpy as np

from ladders.statistics import VertexwiseTest, check_groups, vertexwise_test
from manifolds.validation import check_rng

from ..errors import CohortError
from .aha_model import AHA_NAMES, N_SEGMENTS

__all__ = ["SEGMENT_COLUMNS", "SegmentTable", "segment_means", "segment_table"]

#: Columns of :meth:`SegmentTable.to_csv` (the two means are named after the groups).
SEGMENT_COLUMNS = (
    "segment", "name", "n_vertices", "mean_<group 0>", "mean_<group 1>", "difference",
    "statistic", "p", "p_fwer",
)  # fmt: skip


def _check_segments(segments, k: int) -> np.ndarray:
    s = np.asarray(segments)
    if s.shape != (k,) or not np.issubdtype(s.dtype, np.integer):
        raise CohortError(f"segments: expected {k} integer labels (one per vertex), got {s.shape}")
    if s.min() < 1 or s.max() > N_SEGMENTS:
        raise CohortError(f"segments: labels must lie in 1..{N_SEGMENTS}, got {s.min()}..{s.max()}")
    counts = np.bincount(s, minlength=N_SEGMENTS + 1)[1:]
    empty = [int(i) + 1 for i in np.flatnonzero(counts == 0)]
    if empty:
        raise CohortError(
            f"segments: segment(s) {empty} have no vertex; the mesh is too coarse for the "
            "17-segment model (refine it)"
        )
    return s


def segment_means(quantity, segments) -> np.ndarray:
    """The mean of a per-vertex quantity over each segment's vertices, per subject.

    Parameters
    ----------
    quantity : array, shape (n, k) or (n, k, d)
        Per subject and vertex, a scalar or a vector.
    segments : int array, shape (k,)
        The segment (1..17) of each vertex; every segment must have a vertex.

    Returns
    -------
    ndarray, shape (n, 17) or (n, 17, d)
        Column ``j`` is segment ``j + 1`` (an unweighted mean over its vertices).
    """
    x = np.asarray(quantity, dtype=float)
    if x.ndim not in (2, 3):
        raise CohortError(
            f"quantity: expected per-vertex values (n, k) or vectors (n, k, d), got {x.shape}"
        )
    s = _check_segments(segments, x.shape[1])
    members = s[None, :] == np.arange(1, N_SEGMENTS + 1)[:, None]  # (17, k)
    weights = members / members.sum(axis=1, keepdims=True)
    return np.einsum("jk,nk...->nj...", weights, x)


@dataclass(frozen=True)
class SegmentTable:
    """Per-segment comparison of two groups (:func:`segment_table`).

    Attributes
    ----------
    groups : (str, str)
        The two group names; the first is tested against the second.
    n_vertices : ndarray of int, shape (17,)
        Vertices of each segment.
    means : ndarray, shape (n, 17) or (n, 17, d)
        Each subject's segment means.
    group_means : ndarray, shape (2, 17) or (2, 17, d)
        The groups' mean of the segment means.
    summary : ndarray, shape (2, 17)
        The scalar shown for each group mean: the mean itself for a scalar; for a
        vector, its component along the outward normal when normals were given
        (the mean normal component over the segment), otherwise its length.
    difference : ndarray, shape (17,)
        ``summary[0] - summary[1]`` for a scalar or with normals; the length of the
        difference of the mean vectors otherwise.
    test : VertexwiseTest
        The test on ``means``: ``statistic``, ``p_uncorrected`` and ``p_fwer`` (over
        the 17 segments), each ``(17,)``.
    """

    groups: tuple
    n_vertices: np.ndarray
    means: np.ndarray
    group_means: np.ndarray
    summary: np.ndarray
    difference: np.ndarray
    test: VertexwiseTest

    @property
    def statistic(self) -> np.ndarray:
        """``t`` (signed, scalars) or Hotelling's ``T^2`` (vectors) per segment, (17,)."""
        return self.test.statistic

    @property
    def p(self) -> np.ndarray:
        """Uncorrected p-value per segment, (17,)."""
        return self.test.p_uncorrected

    @property
    def p_fwer(self) -> np.ndarray:
        """p-value corrected over the 17 segments (max-statistic permutation), (17,)."""
        return self.test.p_fwer

    def significant(self, alpha: float = 0.05) -> np.ndarray:
        """Segments (numbers 1..17) whose corrected p-value is below ``alpha``."""
        return np.flatnonzero(self.p_fwer < alpha) + 1

    def columns(self) -> tuple[str, ...]:
        """The column names, the means named after the groups."""
        g0, g1 = self.groups
        return (*SEGMENT_COLUMNS[:3], f"mean_{g0}", f"mean_{g1}", *SEGMENT_COLUMNS[5:])

    def rows(self) -> list[tuple]:
        """One tuple per segment, in the order of :meth:`columns`."""
        return [
            (
                j + 1,
                AHA_NAMES[j + 1],
                int(self.n_vertices[j]),
                float(self.summary[0, j]),
                float(self.summary[1, j]),
                float(self.difference[j]),
                float(self.statistic[j]),
                float(self.p[j]),
                float(self.p_fwer[j]),
            )  # fmt: skip
            for j in range(N_SEGMENTS)
        ]

    def to_csv(self) -> str:
        """The table as CSV text (columns of :meth:`columns`, numbers to 10 digits)."""
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(self.columns())
        for row in self.rows():
            writer.writerow([v if isinstance(v, (int, str)) else f"{v:.10g}" for v in row])
        return out.getvalue()

    def to_markdown(self) -> str:
        """The table as a Markdown table (numbers to 4 significant digits)."""
        lines = ["| " + " | ".join(self.columns()) + " |", "|" + "---|" * len(self.columns())]
        for row in self.rows():
            cells = [v if isinstance(v, (int, str)) else f"{v:.4g}" for v in row]
            lines.append("| " + " | ".join(str(c) for c in cells) + " |")
        return "\n".join(lines) + "\n"


def segment_table(
    quantity,
    labels,
    segments,
    groups: tuple = ("patients", "controls"),
    n_permutations: int = 10000,
    rng: np.random.Generator | None = None,
    normals=None,
) -> SegmentTable:
    """Compare two groups on the segment means of a per-vertex quantity (see the module).

    Parameters
    ----------
    quantity : array, shape (n, k) or (n, k, 3)
        Per subject and atlas vertex: a scalar (area strain, wall motion, normal
        component) or a vector (displacement).
    labels : array of bool or 0/1, shape (n,)
        True for the subjects of ``groups[0]``; at least 3 per group (5 subjects
        in all for vectors).
    segments : int array, shape (k,)
        The AHA segment of each vertex (:func:`~.aha_model.aha_segments`); every
        one of the 17 must have a vertex, else :class:`CohortError` names the
        empty ones (no NaN is ever produced).
    groups : (str, str)
        The two group names (the mean columns are named after them).
    n_permutations : int, default 10000
        Permutations of the labels (:func:`ladders.statistics.vertexwise_test`).
    rng : numpy.random.Generator
        Draws the permutations (required).
    normals : array, shape (k, 3), optional
        Outward unit normals of the atlas: for a vector quantity the table shows
        the mean normal component of each segment (the test stays on the vectors).

    Returns
    -------
    SegmentTable
    """
    rng = check_rng(rng)
    x = np.asarray(quantity, dtype=float)
    if x.ndim not in (2, 3) or (x.ndim == 3 and x.shape[2] != 3):
        raise CohortError(
            f"quantity: expected per-vertex values (n, k) or vectors (n, k, 3), got {x.shape}"
        )
    if not np.isfinite(x).all():
        raise CohortError("quantity: contains NaN or infinite values")
    if len(tuple(groups)) != 2:
        raise CohortError(f"groups: expected two names, got {groups!r}")
    mask = check_groups(labels, x.shape[0])
    means = segment_means(x, segments)
    seg = np.asarray(segments)
    n_vertices = np.bincount(seg, minlength=N_SEGMENTS + 1)[1:]
    group_means = np.stack([means[mask].mean(axis=0), means[~mask].mean(axis=0)])
    if x.ndim == 2:
        summary = group_means
        difference = summary[0] - summary[1]
    elif normals is not None:
        nv = np.asarray(normals, dtype=float)
        if nv.shape != (x.shape[1], 3):
            raise CohortError(f"normals: expected an array ({x.shape[1]}, 3), got {nv.shape}")
        along = segment_means(np.einsum("nkd,kd->nk", x, nv), seg)
        summary = np.stack([along[mask].mean(axis=0), along[~mask].mean(axis=0)])
        difference = summary[0] - summary[1]
    else:
        summary = np.linalg.norm(group_means, axis=-1)
        difference = np.linalg.norm(group_means[0] - group_means[1], axis=-1)
    test = vertexwise_test(means, mask, n_permutations, rng=rng)
    return SegmentTable(tuple(groups), n_vertices, means, group_means, summary, difference, test)
