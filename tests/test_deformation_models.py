"""Deformation models as plugins: the registry, the study on a user's model, broken models
refused before any study, validation, plugins in worker processes."""

import pickle
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest

from ladders.study.area_strain import area_strain, area_strain_error
from ladders.study.cli import build_parser, main
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.deformations import (
    DeformationModel,
    DeformationModelError,
    LDDMMModel,
    check_deformation_model,
    deformation_model,
    deformation_names,
    parse_deformations,
    register_deformation,
    registry,
    unregister_deformation,
    validate_deformation_model,
)
from ladders.study.running import StudyConfig, compute_pair, run_study
from ladders.study.running.result_codec import decode, encode
from ladders.study.running.results import SkippedTransport
from ladders.study.study_run import run
from manifolds import Euclidean
from manifolds.point_distance import point_distance

COHORT = make_synthetic_cohort(n_subjects=2, grid=(8, 5), seed=0)

# A point-distribution model, and broken variants of it (each breaks one property).
PLUGIN = """
import numpy as np
from ladders.study.deformations import DeformationModel, register_deformation
from manifolds import Euclidean


class Flat(DeformationModel):
    name = "{name}"
    label = "FLAT"

    def make_space(self, template, alpha2, settings):
        return {space}(np.shape(template))

    def inverse_consistency(self, space, template, shape, distance="rms"):
        return 0.0


class DoubleLog(Euclidean):
    def log(self, point, other):
        return 2.0 * super().log(point, other)


class Bigger(Euclidean):
    def __init__(self, shape):
        super().__init__((shape[0] + 1, shape[1]))


register_deformation(Flat())
"""


def _plugin(tmp_path, name="flat", space="Euclidean"):
    path = tmp_path / f"{name.replace('-', '_')}_model.py"
    path.write_text(textwrap.dedent(PLUGIN.format(name=name, space=space)))
    return path


@pytest.fixture
def flat_model(tmp_path):
    """The point-distribution model, loaded from a plugin file; forgotten afterwards."""
    path = _plugin(tmp_path)
    registry.load_plugin(str(path))
    yield deformation_model("flat"), path
    unregister_deformation("flat")


class PDM(DeformationModel):
    name = "test-pdm"
    label = "PDM"

    def make_space(self, template, alpha2, settings):
        return Euclidean(np.shape(template))

    def inverse_consistency(self, space, template, shape, distance="rms"):
        back = space.exp(
            space.exp(template, space.log(template, shape)), space.log(shape, template)
        )
        return float(point_distance(distance, space.point_shape)(back, template))


def test_registry_names_both_lists_and_refusals():
    assert {"lddmm", "svf"} <= set(deformation_names())
    assert parse_deformations("both") == ("lddmm", "svf")
    assert parse_deformations("svf, lddmm") == ("svf", "lddmm")
    with pytest.raises(
        DeformationModelError, match=r"expected one of (.*, )?lddmm, (.*, )?svf.*'nope'"
    ):
        parse_deformations("lddmm,nope")
    with pytest.raises(DeformationModelError, match="named twice"):
        parse_deformations("lddmm,both")
    bad = PDM()
    bad.name = "Bad Name"
    with pytest.raises(DeformationModelError, match="PDM: name: expected lower-case"):
        register_deformation(bad)
    taken = PDM()
    taken.name = "lddmm"
    with pytest.raises(DeformationModelError, match="name 'lddmm' is taken by LDDMMModel"):
        register_deformation(taken)
    assert isinstance(deformation_model("lddmm"), LDDMMModel)
    with pytest.raises(ValueError, match="StudyConfig.deformation: expected one of"):
        StudyConfig(deformation="nope")


def test_built_in_configuration_is_recorded_as_before():
    """The model adds nothing to a built-in configuration's dict (its results' key)."""
    for name in ("lddmm", "svf"):
        config = StudyConfig(deformation=name)
        assert set(config.as_dict()) == {"registration", "registration_key", "alpha2",
                                         "fanning_steps", "deformation", "distance",
                                         "warm_starts"}  # fmt: skip
        assert config.model is deformation_model(name)
        assert pickle.loads(pickle.dumps(config)).model.name == name


def test_the_study_on_a_model_of_ones_own_is_the_identity_transport():
    """The PDM's pole ladder is exact and carries S' - S unchanged; its symmetry errors
    vanish; the model has no fanning scheme, recorded as skipped with the reason."""
    config = StudyConfig.build(alpha2=(1.0,), deformation=PDM())
    assert config.deformation == "test-pdm" and config.model.name == "test-pdm"
    subject = COHORT.subjects[0]
    pair = compute_pair(config, COHORT.atlas, COHORT.faces, subject, 1.0)
    assert pair.deformation == "test-pdm"
    assert [t.method for t in pair.transports] == ["pole_ladder_residual",
                                                   "pole_ladder_no_residual"]  # fmt: skip
    (skipped,) = pair.skipped_transports
    assert skipped.method == "fanning" and skipped.reason.startswith("PDM: no fanning scheme")
    motion = subject.es - subject.ed
    las = area_strain(COHORT.atlas, COHORT.atlas + motion, COHORT.faces)
    for t in pair.transports:
        np.testing.assert_allclose(t.displacement_array(), motion, rtol=0, atol=1e-10)
        assert t.ase == pytest.approx(area_strain_error(pair.las_subject, las), abs=1e-10)
        np.testing.assert_allclose(t.momenta_array(), motion, rtol=0, atol=1e-10)
    for errors in pair.errors:
        assert max(errors.midpoint_distance, errors.centrality, errors.involutivity,
                   errors.transvectivity) < 1e-10  # fmt: skip
    reg = pair.registration
    assert reg.error < 1e-12 and reg.inverse_consistency < 1e-12
    assert reg.rkhs_norm == pytest.approx(np.linalg.norm(subject.ed - COHORT.atlas), rel=1e-12)
    # stored and read back whole, the skipped transport with it
    assert decode(encode(pair)) == pair
    assert encode(pair)["skipped_transports"] == [{"method": "fanning", "reason": skipped.reason}]
    assert decode(encode(pair)).skipped_transports == (SkippedTransport("fanning", skipped.reason),)


def test_a_built_in_result_is_stored_without_the_new_field():
    config = StudyConfig.build(alpha2=(1.0,), sigma=20.0, max_iter=20, fanning_steps=2)
    pair = compute_pair(config, COHORT.atlas, COHORT.faces, COHORT.subjects[0], 1.0)
    assert pair.skipped_transports == () and pair.transports[2].method == "fanning"
    data = encode(pair)
    assert "skipped_transports" not in data  # a file as written before the field existed
    assert decode(data) == pair


class _Broken(PDM):
    """A PDM whose space breaks one property."""

    def __init__(self, name, space):
        self.name, self.space = name, space

    def make_space(self, template, alpha2, settings):
        return self.space(np.shape(template))


class _DoubleLog(Euclidean):
    def log(self, point, other):
        return 2.0 * super().log(point, other)


class _Bigger(Euclidean):
    def __init__(self, shape):
        super().__init__((shape[0] + 1, shape[1]))


class _ShortExp(Euclidean):
    def exp(self, point, tangent):
        return super().exp(point, tangent)[:-1]


@pytest.mark.parametrize(
    "space, prop",
    [
        (_DoubleLog, r"log inverts exp: Exp_T\(Log_T\(x\)\) is 1 of the displacement"),
        (_Bigger, r"point_shape: expected the template's shape \(41, 3\), got \(42, 3\)"),
        (_ShortExp, r"exp shape: expected shape \(41, 3\), got \(40, 3\)"),
    ],
)
def test_a_broken_model_is_refused_in_one_line_naming_it(space, prop, tmp_path):
    model = _Broken("broken", space)
    who = r"deformation model 'broken' \(_Broken\): "
    with pytest.raises(DeformationModelError, match=who + prop) as caught:
        check_deformation_model(model, COHORT.atlas)
    assert "\n" not in str(caught.value)
    with pytest.raises(DeformationModelError, match=who + prop):
        run(StudyConfig.build(alpha2=(1.0,), deformation=model), COHORT, tmp_path / "out",
            jobs=1, progress=False)  # fmt: skip
    assert not (tmp_path / "out").exists()  # refused before the study wrote anything


def test_cli_refuses_a_broken_plugin_before_any_study(tmp_path, capsys):
    path = _plugin(tmp_path, name="double-log", space="DoubleLog")
    try:
        out = tmp_path / "study"
        argv = ["study", "--deformation", "lddmm,double-log", "--plugin", str(path), "--subjects",
                "1", "--vertices", "30", "--alpha2", "1", "-o", str(out), "--no-progress"]  # fmt: skip
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1
        assert "deformation model 'double-log' (Flat): log inverts exp" in err
        assert not (out / "lddmm").exists()  # not even the first model's study started
        # the validation of the same model, on the command line: status 1, one line
        argv = ["validate", "--plugin", str(path), "--deformation", "double-log", "-o",
                str(tmp_path / "val")]  # fmt: skip
        assert main(argv) == 1
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "log inverts exp" in err
        assert (tmp_path / "val" / "deformation_double-log.md").is_file()
    finally:
        unregister_deformation("double-log")
    assert main(["study", "--deformation", "nope", "-o", str(out)]) == 2
    assert "argument --deformation: deformation: expected one of" in capsys.readouterr().err
    assert main(["study", "--plugin", str(tmp_path / "missing.py")]) == 2
    assert "missing.py: no such file" in capsys.readouterr().err


def test_validation_of_the_built_in_and_a_flat_model():
    report = validate_deformation_model(PDM(), raise_on_failure=False)
    assert report.ok, report.failures
    assert report.checks["ladder convergence"] == "passed (exact: a symmetric space)"
    assert report.reference == "parallel transport"
    assert report.checks["transport preserves inner product"] == "passed"
    assert np.all(report.convergence.errors < 1e-12)
    lddmm = validate_deformation_model("lddmm")
    assert (
        lddmm.checks["log of exp"] == "passed"
        and lddmm.checks["symmetry is involution"] == "passed"
    )
    assert lddmm.convergence.slope < -1.8  # second order (measured -2.19)
    with pytest.raises(DeformationModelError, match="'broken' .*: log inverts exp"):
        validate_deformation_model(_Broken("broken", _DoubleLog))
    broken = validate_deformation_model(_Broken("broken", _DoubleLog), raise_on_failure=False)
    assert not broken.ok and "interface" in broken.failures


def test_a_plugin_model_runs_in_worker_processes(flat_model, tmp_path, monkeypatch):
    """Pickled as its plugin and name: a worker that never imported the file loads it."""
    model, path = flat_model
    assert registry.plugin_source(model) == str(path.resolve())
    restored = pickle.loads(pickle.dumps(StudyConfig(deformation="flat"))).model
    assert restored is model  # in this process: the registered instance
    config = StudyConfig.build(alpha2=(1.0, 2.0), deformation="flat")
    outcome = run_study(config, COHORT.atlas, COHORT.faces, COHORT.subjects, tmp_path, jobs=2,
                        progress=False, meshes=False)  # fmt: skip
    assert not outcome.failures and len(outcome.computed) == 4
    for r in outcome.results:
        subject = next(s for s in COHORT.subjects if s.name == r.subject)
        for pair in r.pairs:
            assert pair.deformation == "flat"
            np.testing.assert_allclose(pair.transports[0].displacement_array(),
                                       subject.es - subject.ed, atol=1e-10)  # fmt: skip


def test_plugins_from_the_environment_and_entry_points(tmp_path, monkeypatch):
    path = _plugin(tmp_path, name="env-flat")
    monkeypatch.setenv(registry.PLUGINS_VARIABLE, str(path))
    try:
        assert "env-flat" in deformation_names()
        args = build_parser().parse_args(["study", "--deformation", "lddmm,env-flat"])
        assert args.deformation == "lddmm,env-flat"
    finally:
        unregister_deformation("env-flat")
    monkeypatch.delenv(registry.PLUGINS_VARIABLE)

    class Point(SimpleNamespace):
        def load(self):
            return self.loaded

    monkeypatch.setattr(registry, "_external_loaded", False)
    monkeypatch.setattr(registry, "_entry_points",
                        lambda: [Point(name="test-pdm", value="tests:PDM", loaded=PDM)])  # fmt: skip
    try:
        assert isinstance(deformation_model("test-pdm"), PDM)
    finally:
        unregister_deformation("test-pdm")
    wrong = Point(name="other", value="tests:PDM", loaded=PDM)
    monkeypatch.setattr(registry, "_external_loaded", False)
    monkeypatch.setattr(registry, "_entry_points", lambda: [wrong])
    try:
        with pytest.raises(DeformationModelError, match="named 'test-pdm', not 'other'"):
            deformation_names()
    finally:
        unregister_deformation("test-pdm")


def test_the_cycle_study_runs_on_a_model_of_ones_own(tmp_path):
    """Every frame's deformation carried to the atlas by the PDM's exact ladder: S_t - S_0."""
    from ladders.study.sequences import run_cycle_study, transport_frames

    subject = COHORT.subjects[1]
    frames = np.stack([subject.ed, 0.5 * (subject.ed + subject.es), subject.es])
    model = PDM()
    space = model.make_space(COHORT.atlas, 1.0, StudyConfig().registration)
    result = transport_frames(space, COHORT.atlas, frames, model=model)
    np.testing.assert_allclose(result.transported, COHORT.atlas + (frames - frames[0]), atol=1e-10)
    assert result.converged.all() and np.all(result.registration_rms < 1e-12)
    outcome = run_cycle_study(COHORT.atlas, COHORT.faces, {"s1": frames}, tmp_path,
                              deformation=model)  # fmt: skip
    assert outcome.computed == ["s1"] and not outcome.failures
    with np.load(tmp_path / "s1.npz") as stored:
        np.testing.assert_allclose(stored["transported"], result.transported, atol=1e-12)
