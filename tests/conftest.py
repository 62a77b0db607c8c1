"""Fixtures shared by several test files."""

import pytest

from ladders.study import StudyConfig, run_study
from ladders.study.population import (
    DEFAULT_ABNORMALITY,
    make_two_group_cohort,
    write_two_group_cohort,
)


@pytest.fixture(scope="session")
def default_study(tmp_path_factory):
    """The documented default: 40 subjects, 20 patients with the default abnormality, alpha^2 = 1."""
    data = make_two_group_cohort()
    assert len(data.cohort) == 40 and data.labels.sum() == 20
    assert data.region.abnormality == DEFAULT_ABNORMALITY
    out = tmp_path_factory.mktemp("population")
    cohort = data.cohort
    run_study(StudyConfig.build(alpha2=(1.0,)), cohort.atlas, cohort.faces, cohort.subjects,
              out / "study", jobs=2, progress=False, meshes=False)  # fmt: skip
    write_two_group_cohort(data, out / "meshes")
    return data, out
