"""StudyConfig refuses a bad field when it is built, before any registration; run() checks units."""

import numpy as np
import pytest

from ladders.study import StudyConfig, make_synthetic_cohort, run
from manifolds.errors import ManifoldError


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"deformation": "ldmm"}, "deformation"),
        ({"alpha2": (1.0, 0.0)}, "alpha2"),
        ({"alpha2": (-1.0,)}, "alpha2"),
        ({"alpha2": (float("nan"),)}, "alpha2"),
        ({"alpha2": ()}, "alpha2"),
        ({"alpha2": (1.0, 1.0)}, "repeated"),
        ({"alpha2": ("1",)}, "alpha2"),
        ({"alpha2": 1.0}, "alpha2"),
        ({"distance": "manhattan"}, "distance"),
        ({"fanning_steps": 0}, "fanning_steps"),
        ({"fanning_steps": 2.5}, "fanning_steps"),
        ({"warm_starts": "yes"}, "warm_starts"),
    ],
)
def test_bad_fields_raise_at_construction(fields, match):
    with pytest.raises(ValueError, match=match):
        StudyConfig(**fields)


def test_good_fields_are_normalised():
    config = StudyConfig(alpha2=[np.float64(1), 2], fanning_steps=np.int64(3))
    assert config.alpha2 == (1.0, 2.0) and isinstance(config.alpha2[0], float)


def test_run_refuses_a_sigma_in_another_unit_before_any_registration(tmp_path):
    cohort = make_synthetic_cohort(1, n_vertices=241)
    with pytest.raises(ManifoldError, match="sigma"):
        run(StudyConfig.build(sigma=0.01), cohort, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def test_run_writes_the_report(tmp_path):
    cohort = make_synthetic_cohort(1, n_vertices=241)
    done = run(StudyConfig(alpha2=(1.0,)), cohort, tmp_path / "out", jobs=1, progress=False,
               meshes=False)  # fmt: skip
    assert not done.outcome.failures
    assert (tmp_path / "out" / "summary.md").is_file()
    assert any(str(p).endswith("summary.md") for p in done.report.values())
