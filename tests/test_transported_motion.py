"""The study stores each subject's transported motion; it reads back as tangent vectors at the atlas."""

import json

import numpy as np
import pytest

from ladders.study import StudyConfig, run_study
from ladders.study.errors import CohortError
from ladders.study.population import (
    NO_TRANSPORT,
    load_transported_motion,
    make_two_group_cohort,
    motions_from_results,
)
from ladders.study.running.pipeline import make_space
from ladders.study.running.result_codec import ResultSchemaError, decode, encode
from ladders.study.volume import enclosed_volume


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    data = make_two_group_cohort(n_subjects=4, n_vertices=241, seed=1)
    config = StudyConfig.build(alpha2=(1.0,))
    out = tmp_path_factory.mktemp("study")
    outcome = run_study(
        config, data.cohort.atlas, data.cohort.faces, data.cohort.subjects, out, progress=False,
        meshes=False,
    )  # fmt: skip
    return data, config, outcome, out


def test_pole_ladder_tangent_shoots_to_the_transported_atlas(study):
    data, config, outcome, _ = study
    atlas = data.cohort.atlas
    space = make_space(config, atlas, 1.0)
    for result in outcome.results:
        pair = result.pairs[0]
        for method in ("pole_ladder_residual", "pole_ladder_no_residual"):
            t = pair.transport(method)
            shot = space.exp(atlas, t.momenta_array())
            residual = t.residual_array()
            if method == "pole_ladder_residual":
                shot = shot + residual
            else:
                assert residual is None
            np.testing.assert_allclose(shot, atlas + t.displacement_array(), atol=1e-8)
        # the fanning scheme's momenta, carried to the atlas's control points, shoot close to T'
        fan = pair.transport("fanning")
        shot = space.exp(atlas, fan.momenta_array())
        d = fan.displacement_array()
        err = np.sqrt(np.mean(np.sum((shot - atlas - d) ** 2, axis=1)))
        assert err < 0.05 * np.sqrt(np.mean(np.sum(d**2, axis=1)))


def test_subject_motion_and_volume_ratio_are_stored(study):
    data, _, outcome, _ = study
    for subject, result in zip(data.cohort.subjects, outcome.results):
        pair = result.pairs[0]
        np.testing.assert_array_equal(
            np.reshape(pair.displacement_subject, (-1, 3)), subject.es - subject.ed
        )
        faces = data.cohort.faces
        expected = enclosed_volume(subject.es, faces) / enclosed_volume(subject.ed, faces)
        assert pair.volume_ratio_subject == pytest.approx(expected, rel=1e-12)
        assert 0.3 < pair.volume_ratio_subject < 0.6  # an ejection fraction of 40-70 %


def test_long_arrays_are_stored_exactly_and_compactly(study):
    _, _, outcome, _ = study
    pair = outcome.results[0].pairs[0]
    data = json.loads(json.dumps(encode(pair)))
    assert decode(data) == pair
    assert isinstance(data["transports"][0]["displacement"], dict)
    data["transports"][0]["displacement"] = {"float64_base64": "not base64!"}
    with pytest.raises(ResultSchemaError, match="displacement"):
        decode(data)


def test_motions_read_back_from_the_folder(study):
    data, _, outcome, out = study
    motions = load_transported_motion(out)
    names = [m.name for m in motions]
    assert NO_TRANSPORT in names and "lddmm/pole_ladder_residual/alpha2=1" in names
    assert len(motions) == 4  # none and three transports at one alpha^2
    direct = motions_from_results(outcome.results, data.cohort.atlas, data.cohort.faces)
    for a, b in zip(motions, direct):
        assert a.name == b.name and a.subjects == b.subjects
        np.testing.assert_array_equal(a.displacement, b.displacement)
        np.testing.assert_array_equal(a.strain, b.strain)
    none = motions[0]
    np.testing.assert_array_equal(none.displacement, data.cohort.es - data.cohort.ed)
    sub = motions[1].subset(["synthetic_003", "synthetic_000"])
    np.testing.assert_array_equal(sub.displacement[0], motions[1].displacement[3])
    with pytest.raises(CohortError, match="not in the transported motion"):
        motions[1].subset(["nobody"])


def test_not_a_study_folder_is_named(tmp_path):
    with pytest.raises(CohortError, match="not a study output folder"):
        load_transported_motion(tmp_path)
