"""The compiled null maps of the permutation test against the refit of the permuted data."""

import numpy as np
import pytest

from ladders.statistics import (
    contrast_bases,
    contrast_matrix,
    design_matrix,
    fit_statistic,
    glm_test,
    permutation_chunks,
    permutation_indices,
)
from ladders.statistics.null_maps import NullMaps


def _cohort(n: int, rng: np.random.Generator):
    table = {
        "subject": [f"s{i:03d}" for i in range(n)],
        "group": [("a", "b", "c")[i % 3] for i in range(n)],
        "age": list(rng.normal(60.0, 8.0, n)),
        "site": list(rng.choice(["x", "y"], n)),
    }
    return table


def _permuted_refit(y, x, c, perm, method):
    """The statistic of the data permuted as the definition of the method says, refitted."""
    inverse = np.argsort(perm)  # row i of the permuted data is row inverse[i] of the original
    if method == "manly":
        return fit_statistic(y[inverse], x, c).statistic
    u_z, _ = contrast_bases(x, c)
    flat = y.reshape(y.shape[0], -1)
    fitted = u_z @ (u_z.T @ flat)
    moved = (fitted + (flat - fitted)[inverse]).reshape(y.shape)
    return fit_statistic(moved, x, c).statistic


CASES = [  # formula, contrast, d, method, blocks
    ("group + age", "age", 1, "freedman_lane", None),  # t
    ("group + age", "group", 1, "freedman_lane", None),  # F
    ("group + age", "age", 3, "freedman_lane", None),  # Pillai, q = 1
    ("group + age + site", "group", 3, "freedman_lane", "site"),  # Pillai, q = 2, blocks
    ("group + age + site", "age", 2, "freedman_lane", "site"),
    ("group + age", "age", 3, "freedman_lane", "site"),  # blocks not in the design
    ("0 + group + age", "group[b] - group[a]", 3, "freedman_lane", None),  # no intercept column
    ("group + age", "age", 3, "manly", None),
    ("group + age + site", "group", 1, "manly", "site"),
]


@pytest.mark.parametrize("formula, spec, d, method, blocks", CASES)
def test_null_maps_equal_the_refit_of_the_permuted_data(formula, spec, d, method, blocks):
    rng = np.random.default_rng(11)
    n, k = 45, 17
    table = _cohort(n, rng)
    design = design_matrix(table, formula)
    x = design.matrix
    c = contrast_matrix(design, spec)[1]
    y = rng.standard_normal((n, k, d)) + 0.4 * x[:, 1, None, None] * rng.standard_normal((k, d))
    y[:, 3] = 2.5  # a vertex without variance: statistic 0 in every map
    labels = None if blocks is None else np.array(table[blocks])
    null = NullMaps(y, x, c, method, d == 1, 0.0, labels)
    perm = permutation_indices(n, 12, rng, labels)
    maps = null.maps(perm)
    reference = np.array([_permuted_refit(y[..., 0] if d == 1 else y, x, c, p, method)
                          for p in perm])  # fmt: skip
    scale = np.abs(reference).max()
    np.testing.assert_allclose(maps, reference, rtol=0, atol=1e-10 * scale)
    assert np.all(maps[:, 3] == 0.0)


def test_invariant_nuisance_directions_leave_the_product():
    """The intercept (and, within blocks, the blocks' indicators when the design has them)
    projects every permuted residual to zero: one row fewer per nuisance direction."""
    rng = np.random.default_rng(3)
    n = 30
    table = _cohort(n, rng)
    y = rng.standard_normal((n, 4, 1))
    for formula, blocks, rows in [("group + age", None, 3),  # [age | intercept, group b, c]
                                  ("group + age + site", None, 4),
                                  ("group + age + site", "site", 3),  # both site indicators
                                  ("group + age", "site", 3),  # only their sum, the intercept
                                  ("0 + group + age", None, 3)]:  # fmt: skip
        design = design_matrix(table, formula)
        c = contrast_matrix(design, "age")[1]
        labels = None if blocks is None else np.array(table[blocks])
        null = NullMaps(y, design.matrix, c, "freedman_lane", True, 0.0, labels)
        assert null.basis.shape == (rows, n), formula


@pytest.mark.parametrize("blocks", [None, "site"])
def test_permutations_of_a_seed_do_not_depend_on_the_chunks(blocks):
    """Drawn 7 at a time (within blocks the stream depends on it), served in any chunks."""
    labels = None if blocks is None else np.array(_cohort(20, np.random.default_rng(4))[blocks])
    stream = np.random.default_rng(9)
    drawn = np.concatenate([permutation_indices(20, m, stream, labels) for m in (7, 7, 7, 7, 5)])
    for size in (1, 3, 7, 10, 40):
        chunks = list(permutation_chunks(20, 33, np.random.default_rng(9), labels, size, 7))
        assert [len(p) for p in chunks] == [size] * (33 // size) + [33 % size] * (33 % size > 0)
        np.testing.assert_array_equal(np.concatenate(chunks), drawn)


def test_glm_test_p_values_do_not_depend_on_the_chunk_size():
    rng = np.random.default_rng(5)
    n = 40
    table = _cohort(n, rng)
    design = design_matrix(table, "group + age + site")
    y = rng.standard_normal((n, 25, 3)) + 0.3 * design.matrix[:, 3, None, None]
    runs = [glm_test(y, design, "age", 150, np.random.default_rng(2), chunk_size=size)
            for size in (None, 1, 64)]  # fmt: skip
    for run in runs[1:]:
        np.testing.assert_allclose(run.max_null, runs[0].max_null, rtol=1e-12)
        np.testing.assert_array_equal(run.p_fwer, runs[0].p_fwer)
