"""Per-vertex general linear model: statistics against statsmodels, permutation inference."""

import numpy as np
import pytest
import statsmodels.api as sm
from hypothesis import given, settings
from hypothesis import strategies as st
from statsmodels.multivariate.manova import MANOVA

from ladders.statistics import (
    METHODS,
    binomial_interval,
    contrast_bases,
    contrast_matrix,
    design_matrix,
    fit_statistic,
    glm_test,
    permutation_indices,
    pillai_to_hotelling,
    read_design,
    two_sided,
    vertexwise_test,
)


def _table(n: int, rng: np.random.Generator) -> dict:
    return {
        "subject": [f"s{i:02d}" for i in range(n)],
        "group": ["patients" if i % 3 else "controls" for i in range(n)],
        "age": list(rng.normal(60.0, 8.0, n)),
        "sex": list(rng.choice(["F", "M"], n)),
        "site": list(rng.choice(["a", "b", "c"], n)),
    }


@pytest.fixture(scope="module")
def cohort():
    rng = np.random.default_rng(0)
    table = _table(40, rng)
    design = design_matrix(table, "group + age + sex + site")
    return rng, table, design


SCALAR_CONTRASTS = ["group[patients] - group[controls]", "age", "site[c] - site[b]", "site"]


@pytest.mark.parametrize("spec", SCALAR_CONTRASTS)
def test_t_f_and_coefficients_equal_statsmodels_ols(cohort, spec):
    rng, _, design = cohort
    x = design.matrix
    y = rng.standard_normal((40, 6)) + 0.05 * x[:, 2:3] + 0.7 * x[:, 1:2]
    name, c = contrast_matrix(design, spec)
    fit = fit_statistic(y, x, c)
    assert fit.kind == ("F" if spec == "site" else "t") and name == spec
    for v in range(6):
        ols = sm.OLS(y[:, v], x).fit()
        np.testing.assert_allclose(fit.coefficients[:, v], ols.params, rtol=1e-8, atol=1e-8)
        ref = ols.f_test(c) if fit.kind == "F" else ols.t_test(c)
        value = np.squeeze(ref.fvalue if fit.kind == "F" else ref.tvalue)
        np.testing.assert_allclose(fit.statistic[v], value, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(fit.p_value[v], np.squeeze(ref.pvalue), rtol=1e-8, atol=1e-12)
    assert fit.df == ((2.0, 34.0) if spec == "site" else (34.0,))


@pytest.mark.parametrize("spec", ["group[patients]", "site", "age"])
def test_pillai_trace_equals_statsmodels_manova(cohort, spec):
    rng, _, design = cohort
    x = design.matrix
    y = rng.standard_normal((40, 4, 3)) + 0.4 * x[:, 1, None, None] * [1.0, -0.5, 0.0]
    _, c = contrast_matrix(design, spec)
    fit = fit_statistic(y, x, c)
    assert fit.kind == "pillai"
    for v in range(3):
        table = MANOVA(y[:, v], x).mv_test([("h", c)]).results["h"]["stat"]
        row = table.loc["Pillai's trace"]
        np.testing.assert_allclose(fit.statistic[v], float(row["Value"]), rtol=1e-9)
        np.testing.assert_allclose(fit.p_value[v], float(row["Pr > F"]), rtol=1e-7)
        assert fit.df == (float(row["Num DF"]), float(row["Den DF"]))


def _two_groups(rng, n=24, k=15, d=None):
    table = {
        "subject": [f"p{i}" for i in range(n)],
        "group": ["b"] * (n // 2) + ["a"] * (n - n // 2),
    }
    rng.shuffle(table["group"])
    shape = (n, k) if d is None else (n, k, d)
    data = rng.standard_normal(shape)
    first = np.array(table["group"]) == "a"
    data[first, :4] += 2.0
    return design_matrix(table, "group"), data, first


@pytest.mark.parametrize("d", [None, 3])
def test_two_group_model_is_the_two_sample_test(d):
    rng = np.random.default_rng(3)
    design, data, first = _two_groups(rng, d=d)
    p = 1500
    glm = glm_test(data, design, "group[a] - group[b]", p, rng=np.random.default_rng(10))
    ridge = 0.0 if d is None else 1e-9  # the same regularisation of the scatter
    ref = vertexwise_test(data, first, p, rng=np.random.default_rng(11), ridge=ridge)
    if d is None:
        assert glm.kind == "t"
        np.testing.assert_allclose(glm.statistic, ref.statistic, rtol=0, atol=1e-10)
    else:
        assert glm.kind == "pillai"
        t2 = pillai_to_hotelling(glm.statistic, 22)
        np.testing.assert_allclose(t2, ref.statistic, rtol=1e-10, atol=1e-10)
        exact = fit_statistic(data, design.matrix, [[0.0, -1.0]])  # without regularisation
        plain = vertexwise_test(data, first, 1, rng=np.random.default_rng(0), ridge=0.0)
        np.testing.assert_allclose(exact.hotelling(), plain.statistic, rtol=1e-10)
    np.testing.assert_allclose(glm.p_uncorrected, ref.p_uncorrected, rtol=1e-9, atol=1e-14)
    pf = ref.p_fwer
    tolerance = 4.0 * np.sqrt(pf * (1.0 - pf) / p) + 1.0 / p
    assert np.all(np.abs(glm.p_fwer - pf) < tolerance)
    assert glm.significant(0.05).any()


def _null_rejections(rng, n_sets=200, n=30, k=6, permutations=99):
    """Family-wise rejections at 5 % of the adjusted and unadjusted models, null data."""
    counts = {"group + age": 0, "group": 0}
    for _ in range(n_sets):
        group = rng.permutation(np.arange(n) % 2).astype(float)
        age = 1.2 * group + 0.6 * rng.standard_normal(n)  # imbalanced between the groups
        y = 2.0 * age[:, None] + rng.standard_normal((n, k))  # no effect of group
        for formula in counts:
            columns = [np.ones(n), group, age][: 3 if "age" in formula else 2]
            contrast = np.eye(len(columns))[1]
            test = glm_test(y, np.column_stack(columns), contrast, permutations, rng=rng)
            counts[formula] += bool(test.p_fwer.min() <= 0.05)
    return counts


def test_freedman_lane_controls_the_family_wise_error_with_a_correlated_nuisance():
    n_sets = 200
    counts = _null_rejections(np.random.default_rng(2024), n_sets)
    low, high = binomial_interval(counts["group + age"], n_sets)
    assert low <= 0.05 <= high, counts
    assert counts["group"] / n_sets > binomial_interval(round(0.05 * n_sets), n_sets)[1], counts
    assert counts["group"] > 0.5 * n_sets, counts


def test_permutations_stay_within_their_blocks():
    rng = np.random.default_rng(5)
    blocks = rng.choice(["site1", "site2", "site3"], 23)
    perms = permutation_indices(23, 500, rng, blocks)
    assert perms.shape == (500, 23)
    assert np.array_equal(np.sort(perms, axis=1), np.broadcast_to(np.arange(23), perms.shape))
    assert np.all(blocks[perms] == blocks[None, :])
    assert len({tuple(row) for row in perms}) > 400  # random, not the identity


@pytest.mark.parametrize("method", METHODS)
def test_blocks_equal_to_the_groups_leave_every_statistic_unchanged(method):
    rng = np.random.default_rng(6)
    design, data, first = _two_groups(rng)
    test = glm_test(data, design, "group[b]", 200, rng=rng, method=method, blocks=first)
    np.testing.assert_allclose(test.max_null, np.abs(test.statistic).max(), rtol=1e-10)
    assert test.p_fwer[np.argmax(np.abs(test.statistic))] == 1.0


def test_methods_agree_on_the_observed_map_and_give_valid_p_values(cohort):
    rng, _, design = cohort
    y = rng.standard_normal((40, 12, 2))
    tests = [glm_test(y, design, "site", 99, rng=rng, method=m) for m in METHODS]
    for test in tests:
        np.testing.assert_allclose(test.statistic, tests[0].statistic, rtol=1e-12)
        assert test.kind == "pillai" and test.df == tests[0].df and test.method in METHODS
        assert np.all((test.p_fwer >= 1 / 100) & (test.p_fwer <= 1.0))


def test_identity_enhancement_gives_the_same_corrected_p_values(cohort):
    rng, _, design = cohort
    y = rng.standard_normal((40, 30))
    y[:, :5] += 0.5 * design.matrix[:, 1:2]
    calls = []

    def identity(maps):
        calls.append(maps.shape)
        return maps.copy()

    kwargs = {"n_permutations": 300, "chunk_size": 128}
    plain = glm_test(y, design, "group[patients]", rng=np.random.default_rng(8), **kwargs)
    test = glm_test(
        y, design, "group[patients]", rng=np.random.default_rng(8), enhance=identity, **kwargs
    )
    assert calls[0] == (1, 30) and calls[1] == (128, 30) and calls[-1] == (44, 30)
    np.testing.assert_array_equal(test.p_fwer_enhanced, test.p_fwer)
    np.testing.assert_array_equal(test.p_fwer, plain.p_fwer)
    np.testing.assert_array_equal(test.enhanced, test.statistic)
    both = glm_test(y, design, "group[patients]", rng=np.random.default_rng(8),
                    enhance=two_sided(identity), **kwargs)  # fmt: skip
    np.testing.assert_allclose(both.enhanced, test.statistic, rtol=0, atol=0)
    np.testing.assert_array_equal(both.p_fwer_enhanced, test.p_fwer)
    np.testing.assert_array_equal(both.significant(0.05, enhanced=True), test.significant(0.05))


def test_smoothing_enhancement_is_applied_to_every_permutation(cohort):
    rng, _, design = cohort
    y = rng.standard_normal((40, 20))

    def smooth(maps):
        return (maps + np.roll(maps, 1, axis=1) + np.roll(maps, -1, axis=1)) / 3.0

    test = glm_test(y, design, "age", 200, rng=rng, enhance=smooth)
    np.testing.assert_allclose(test.enhanced, smooth(test.statistic[None])[0])
    assert test.max_null_enhanced.shape == (200,)
    assert np.all(test.max_null_enhanced <= test.max_null + 1e-12)  # an average of |t|


@settings(max_examples=25, deadline=None)
@given(scale=st.floats(0.01, 100.0), sign=st.sampled_from([-1.0, 1.0]), shift=st.floats(-1e3, 1e3))
def test_t_is_invariant_under_an_affine_change_of_a_covariate(scale, sign, shift):
    rng = np.random.default_rng(9)
    n = 25
    x = np.column_stack([np.ones(n), np.arange(n) % 2, rng.normal(50.0, 10.0, n)])
    y = rng.standard_normal((n, 7)) + 0.02 * x[:, 2:3]
    moved = x.copy()
    moved[:, 2] = sign * scale * x[:, 2] + shift
    for c in ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]):
        a, b = fit_statistic(y, x, c), fit_statistic(y, moved, c)
        expected = a.statistic * (sign if c[2] else 1.0)
        np.testing.assert_allclose(b.statistic, expected, rtol=1e-8, atol=1e-8)
    u_z, u_x = contrast_bases(x, [0.0, 1.0, 0.0])
    np.testing.assert_allclose(
        np.hstack([u_z, u_x]).T @ np.hstack([u_z, u_x]), np.eye(3), atol=1e-12
    )


def test_contrasts_by_name(cohort):
    _, _, design = cohort
    columns = design.columns
    assert columns[:3] == ["Intercept", "group[T.patients]", "age"]
    assert design.factors["site"] == ["a", "b", "c"] and design.factors["group"][0] == "controls"
    _, diff = contrast_matrix(design, "group[patients] - group[controls]")
    _, level = contrast_matrix(design, "group[patients]")
    np.testing.assert_array_equal(diff, level)
    _, site = contrast_matrix(design, "site")
    assert site.shape == (2, len(columns))
    _, mixed = contrast_matrix(design, "site[c] - 0.5*site[b]")
    assert (
        mixed[0, columns.index("site[T.c]")] == 1.0 and mixed[0, columns.index("site[T.b]")] == -0.5
    )
    name, custom = contrast_matrix(design, np.eye(len(columns))[2])
    assert custom.shape == (1, len(columns)) and name == "contrast"


def test_reference_level_and_subject_order(cohort):
    _, table, _ = cohort
    order = table["subject"][::-1]
    design = design_matrix(table, "~ group + site", subjects=order, reference={"site": "c"})
    assert design.subjects == order and design.factors["site"] == ["c", "a", "b"]
    assert "site[T.a]" in design.columns and "site[T.c]" not in design.columns
    assert design.matrix[0, design.columns.index("site[T.a]")] == float(table["site"][-1] == "a")


def test_read_design_round_trip(tmp_path, cohort):
    _, table, design = cohort
    path = tmp_path / "design.csv"
    lines = [",".join(table)] + [",".join(str(table[c][i]) for c in table) for i in range(40)]
    path.write_text("\n".join(lines) + "\n")
    again = design_matrix(read_design(path), design.formula)
    np.testing.assert_allclose(again.matrix, design.matrix, rtol=1e-12)
    with pytest.raises(ValueError, match="nowhere.csv"):
        read_design(tmp_path / "nowhere.csv")


def _bad(table, **change):
    bad = {name: list(values) for name, values in table.items()}
    for name, (index, value) in change.items():
        bad[name][index] = value
    return bad


def test_bad_tables_name_the_culprit(cohort):
    _, table, design = cohort
    with pytest.raises(
        ValueError, match=r"unknown column 'weight'.*available: subject, group, age"
    ):
        design_matrix(table, "group + weight")
    with pytest.raises(ValueError, match=r"'age': missing value for subject 's03'"):
        design_matrix(_bad(table, age=(3, None)), "group + age")
    with pytest.raises(ValueError, match=r"'age': missing value for subject 's05'"):
        design_matrix(_bad(table, age=(5, float("nan"))), "group + age")
    with pytest.raises(ValueError, match=r"'age': non-numeric value 'sixty' for subject 's07'"):
        design_matrix(_bad(table, age=(7, "sixty")), "group + age")
    constant = dict(table, scanner=["X"] * 40)
    with pytest.raises(ValueError, match=r"'scanner' is constant"):
        design_matrix(constant, "group + scanner")
    with pytest.raises(ValueError, match=r"'age', 'age2' are collinear"):
        design_matrix(dict(table, age2=[2.0 * a + 1.0 for a in table["age"]]), "group + age + age2")
    twice = _bad(table, subject=(4, "s00"))
    with pytest.raises(ValueError, match=r"subject 's00' is listed twice"):
        design_matrix(twice, "group")
    with pytest.raises(ValueError, match=r"level 'z' of column 'site'"):
        design_matrix(table, "site", reference={"site": "z"})
    with pytest.raises(
        ValueError, match=r"unknown level 'nurses' of 'group' \(levels: controls, patients\)"
    ):
        contrast_matrix(design, "group[nurses] - group[controls]")
    with pytest.raises(ValueError, match=r"unknown term 'weight' \(columns: Intercept"):
        contrast_matrix(design, "weight")
    with pytest.raises(ValueError, match=r"is zero"):
        contrast_matrix(design, "group[controls]")


def test_bad_arguments_of_the_test(cohort):
    rng, _, design = cohort
    y = rng.standard_normal((40, 5))
    with pytest.raises(TypeError, match="rng"):
        glm_test(y, design, "age", 10)
    with pytest.raises(ValueError, match="method"):
        glm_test(y, design, "age", 10, rng=rng, method="shuffle")
    with pytest.raises(ValueError, match="blocks"):
        glm_test(y, design, "age", 10, rng=rng, blocks=[0, 1])
    with pytest.raises(ValueError, match="X: expected"):
        glm_test(y[:30], design, "age", 10, rng=rng)
    with pytest.raises(ValueError, match="needs a Design"):
        glm_test(y, design.matrix, "age", 10, rng=rng)


def test_tfce_shortcut_and_effect_are_those_of_the_explicit_route():
    """``glm_test(tfce=adjacency)`` equals the explicit ``enhance`` built from the observed
    map, and the returned effect is the fit's ``C B``; both routes at once are refused."""
    import trimesh

    from ladders.statistics import fit_statistic, mesh_adjacency, tfce_from_observed

    mesh = trimesh.creation.icosphere(subdivisions=2)
    k = len(mesh.vertices)
    adjacency = mesh_adjacency(mesh.faces, k)
    rng = np.random.default_rng(3)
    n = 24
    table = {"subject": [f"s{i}" for i in range(n)], "group": ["a", "b"] * (n // 2)}
    design = design_matrix(table, "group")
    y = rng.standard_normal((n, k)) + 0.8 * (np.arange(n) % 2)[:, None] * (
        mesh.vertices[:, 2] > 0.5
    )
    short = glm_test(
        y, design, "group[b] - group[a]", 200, np.random.default_rng(1), tfce=adjacency
    )
    fit = fit_statistic(y, design.matrix, contrast_matrix(design, "group[b] - group[a]")[1])
    explicit = glm_test(y, design, "group[b] - group[a]", 200, np.random.default_rng(1),
                        enhance=tfce_from_observed(fit.statistic, fit.kind, adjacency))  # fmt: skip
    np.testing.assert_array_equal(short.p_fwer_enhanced, explicit.p_fwer_enhanced)
    np.testing.assert_allclose(short.enhanced, explicit.enhanced, rtol=1e-12)
    np.testing.assert_allclose(short.effect, fit.effect, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="tfce"):
        glm_test(y, design, "group", 10, np.random.default_rng(0), tfce=adjacency,
                 enhance=lambda m: m)  # fmt: skip
