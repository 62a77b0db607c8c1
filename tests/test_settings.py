"""RegistrationSettings: validation, stable key, and the spaces' and study's use of it."""

import dataclasses
import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest

import manifolds.lddmm.settings as settings_module
from ladders.study.running.pipeline import StudyConfig
from manifolds.errors import ManifoldError
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings, SVFLandmarks, numba_available
from manifolds.numerics.solvers import SolverOptions, StoppingRule


def test_settings_are_frozen_hashable_and_round_trip_through_a_dict():
    s = RegistrationSettings(sigma=20.0, control_points="grid", max_iter=50)
    with pytest.raises(AttributeError):
        s.sigma = 3.0
    assert hash(s) == hash(RegistrationSettings(sigma=20.0, control_points="grid", max_iter=50))
    back = RegistrationSettings.from_dict(json.loads(json.dumps(s.as_dict())))
    assert back == s and back.key() == s.key()


#: For every field, settings where it is in effect, and a second value.
FLIPS = {
    "sigma": ({}, 2.0),
    "control_points": ({}, "grid"),
    "control_point_spacing": ({"control_points": "grid"}, 0.5),
    "control_point_indices": ({"control_points": "vertices"}, (1, 4, 9)),
    "optimize_control_points": ({}, True),
    "control_point_scale": ({"optimize_control_points": True}, 3.0),
    "integrator": ({}, "rk2"),
    "n_steps": ({}, 11),
    "solver": ({}, "gauss-newton"),
    "stopping": ({}, "shape"),
    "shape_tol": ({"stopping": "shape"}, 1e-4),
    "ftol": ({}, 1e-8),
    "gtol": ({}, 1e-6),
    "max_iter": ({}, 7),
    "max_corrections": ({}, 10),
    "max_line_search": ({}, 5),
    "max_inner": ({"solver": "gauss-newton"}, 5),
    "joint_metric": ({"optimize_control_points": True}, False),
    "refresh_every": ({"optimize_control_points": True}, 3),
    "precondition": ({}, False),
    "rel_ridge": ({}, 1e-3),
    "kernel_backend": ({"kernel_backend": "numpy"}, "numba"),
    "auto_threshold": ({}, 10),
    "max_control_points": ({}, 10),
    "blas_threads": ({}, 2),
}
#: Settings under which the field does not change a result (so the key must not move).
IDLE = {
    "control_point_spacing": {"control_points": "dense"},
    "control_point_scale": {},
    "shape_tol": {},
    "ftol": {"stopping": "shape"},
    "gtol": {"stopping": "shape"},
    "max_corrections": {"solver": "gauss-newton"},
    "max_line_search": {"solver": "gauss-newton"},
    "max_inner": {},
    "joint_metric": {},
    "refresh_every": {"optimize_control_points": True, "joint_metric": False},
    "rel_ridge": {"precondition": False},
    "auto_threshold": {"control_points": "grid"},
    "max_control_points": {},
}


def test_every_field_is_flipped_by_the_test():
    assert set(FLIPS) == {f.name for f in dataclasses.fields(RegistrationSettings)}


@pytest.mark.parametrize("name", sorted(FLIPS))
def test_the_key_moves_exactly_with_the_fields_that_change_a_result(name):
    """Flip each field where it is in effect (the key changes) and where it is not (the
    key stays): the key names what a result depends on, and nothing else."""
    base, value = FLIPS[name]
    settings = RegistrationSettings(sigma=1.0, **base)
    flipped = settings.replace(**{name: value})
    if name == "max_control_points":  # a budget: refuses, never changes a result
        assert flipped.key() == settings.key()
        assert name not in settings.in_effect()
        return
    if name == "kernel_backend" and not numba_available():
        pytest.skip("numba is not installed")
    assert name in settings.in_effect()
    assert flipped.key() != settings.key()
    if name in IDLE:
        idle = RegistrationSettings(sigma=1.0, **IDLE[name])
        assert name not in idle.in_effect()
        assert idle.replace(**{name: value}).key() == idle.key()


def test_the_key_has_the_backend_that_runs_and_the_library_version(monkeypatch):
    base = RegistrationSettings(sigma=1.0)
    # "auto" is resolved: it names the backend that runs
    assert base.key() == base.replace(kernel_backend=base.resolved_backend()).key()
    before = base.key()
    monkeypatch.setattr(settings_module, "library_version", lambda: "99.0")
    assert base.key() != before
    payload = {n: base.as_dict()[n] for n in base.in_effect()}
    payload.update(kernel_backend=base.resolved_backend(), schema=2, library_version="99.0")
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=repr)
    assert base.key() == hashlib.sha256(text.encode()).hexdigest()[:20]


def test_the_solvers_options_and_rule_come_from_the_settings():
    s = RegistrationSettings(sigma=1.0, max_corrections=7, stopping="shape", shape_tol=0.01)
    assert s.solver_options() == SolverOptions(max_corrections=7)
    rule = s.stopping_rule()
    assert (rule.kind, rule.shape_tol, rule.max_iter) == ("shape", 0.01, 500)
    # the defaults are written once, in the solvers' options and the rule
    d = RegistrationSettings(sigma=1.0)
    assert d.solver_options() == SolverOptions()
    assert (d.ftol, d.gtol, d.shape_tol, d.max_iter) == (
        StoppingRule().ftol,
        StoppingRule().gtol,
        StoppingRule().shape_tol,
        StoppingRule().max_iter,
    )
    with pytest.raises(ValueError, match="max_inner"):
        SolverOptions(max_inner=0)


def test_vertex_indices_round_trip_and_enter_the_key():
    s = RegistrationSettings(sigma=10.0, control_points="vertices")
    fixed = s.replace(control_point_indices=np.array([4, 1, 9]))
    assert fixed.control_point_indices == (4, 1, 9)
    assert RegistrationSettings.from_dict(json.loads(json.dumps(fixed.as_dict()))) == fixed
    assert fixed.key() != s.key() != fixed.replace(control_point_indices=(4, 1, 8)).key()


def test_spacing_is_the_policy_default_unless_given():
    s = RegistrationSettings(sigma=10.0, control_points="vertices")
    assert s.spacing == pytest.approx(7.0)
    assert s.replace(control_point_spacing=4.0).spacing == 4.0
    assert s.replace(control_points="grid").spacing == 10.0
    assert s.replace(control_points="finegrid").spacing == 5.0
    assert s.replace(control_points="dense").spacing is None


def test_key_is_stable_across_processes():
    code = (
        "from manifolds.lddmm import RegistrationSettings as R;"
        "print(R(sigma=20.0, control_points=[[0.0, 1.0, 2.0]], stopping='shape').key())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    here = RegistrationSettings(sigma=20.0, control_points=[[0.0, 1.0, 2.0]], stopping="shape")
    assert out.stdout.strip() == here.key()


def test_array_policy_is_stored_as_a_tuple_and_given_back_as_an_array():
    cp = np.arange(6.0).reshape(2, 3)
    s = RegistrationSettings(sigma=1.0, control_points=cp)
    assert isinstance(s.control_points, tuple)
    np.testing.assert_array_equal(s.control_points_policy, cp)


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"sigma": 0.0}, "sigma"),
        ({"control_points": "sparse"}, "control_points"),
        ({"control_point_spacing": 0.0}, "control_point_spacing"),
        ({"control_point_indices": (0, 1)}, "control_point_indices"),  # not 'vertices'
        ({"control_points": "vertices", "control_point_indices": (0, -1)}, "control_point_indices"),
        ({"control_points": "vertices", "control_point_indices": (2, 2)}, "control_point_indices"),
        ({"control_points": "vertices", "control_point_indices": (0.5,)}, "control_point_indices"),
        ({"control_points": "vertices", "control_point_indices": ()}, "control_point_indices"),
        ({"control_point_spacing": float("inf")}, "control_point_spacing"),
        ({"control_points": np.zeros((2, 4))}, "control_points"),
        ({"integrator": "rk3"}, "integrator"),
        ({"solver": "bfgs"}, "solver"),
        ({"stopping": "never"}, "stopping"),
        ({"shape_tol": float("nan")}, "shape_tol"),
        ({"max_iter": 0}, "max_iter"),
        ({"kernel_backend": "cuda"}, "kernel_backend"),
        ({"precondition": "yes"}, "precondition"),
        ({"unknown": 1}, "unknown"),
    ],
)
def test_bad_settings_name_the_field(changes, name):
    with pytest.raises(ManifoldError, match=name):
        RegistrationSettings(sigma=1.0).replace(**changes)


def test_spaces_build_settings_from_keywords_and_resolve_their_integrator():
    lddmm = LDDMMLandmarks(10, 3, sigma=2.0, alpha=1.0, control_points="grid", n_steps=5)
    assert lddmm.settings == RegistrationSettings(
        sigma=2.0, control_points="grid", n_steps=5, integrator="euler"
    )
    svf = SVFLandmarks(10, 3, alpha=1.0, settings=RegistrationSettings(sigma=2.0))
    assert svf.settings.integrator == "rk4" and svf.integrator.name == "rk4"
    over = LDDMMLandmarks(10, 3, alpha=1.0, settings=lddmm.settings, max_iter=9)
    assert over.settings.max_iter == 9 and over.settings.n_steps == 5
    with pytest.raises(ManifoldError, match="alpha"):
        LDDMMLandmarks(10, 3, sigma=2.0)
    with pytest.raises(ManifoldError, match="optimize_control_points"):
        SVFLandmarks(10, 3, sigma=2.0, alpha=1.0, optimize_control_points=True)


def test_study_configuration_carries_the_settings_and_their_key():
    config = StudyConfig.build(alpha2=(1.0,), sigma=10.0, max_iter=30, fanning_steps=3)
    assert config.registration.sigma == 10.0 and config.fanning_steps == 3
    d = config.as_dict()
    assert d["registration_key"] == config.registration.key()
    assert d["registration"]["max_iter"] == 30


def test_the_settings_are_made_of_parts_that_validate_themselves():
    from manifolds.lddmm.settings_parts import (
        PARTS,
        ControlPointSettings,
        FlowSettings,
        KernelSettings,
        OptimizerSettings,
        StoppingSettings,
    )

    flat = {f.name for f in dataclasses.fields(RegistrationSettings)}
    owned = [f for part in PARTS.values() for f in part.__dataclass_fields__]
    assert sorted(owned) == sorted(flat)  # every field in exactly one part
    default = RegistrationSettings(sigma=1.0)
    for name, part in PARTS.items():
        got = getattr(default, name)
        assert isinstance(got, part)
        for f in part.__dataclass_fields__:
            field = part.__dataclass_fields__[f]
            if f != "sigma":  # the default is the part's, written once
                assert getattr(default, f) == field.default
            assert getattr(got, f) == getattr(default, f)
    s = RegistrationSettings.from_parts(
        KernelSettings(sigma=10.0),
        ControlPointSettings(control_points="vertices", control_point_spacing=7.0),
        FlowSettings(integrator="RK4", n_steps=4),
        OptimizerSettings(max_corrections=20),
        StoppingSettings(stopping="shape", shape_tol=1e-4),
    )
    assert s == RegistrationSettings(
        sigma=10.0, control_points="vertices", control_point_spacing=7.0, integrator="rk4",
        n_steps=4, max_corrections=20, stopping="shape", shape_tol=1e-4,
    )  # fmt: skip
    assert s.flow_settings == FlowSettings("rk4", 4) and s.stopping_rule().kind == "shape"
    for bad, match in (
        (lambda: KernelSettings(sigma=-1.0), "KernelSettings: sigma"),
        (lambda: ControlPointSettings(control_point_indices=(1, 2)), "control_point_indices"),
        (lambda: FlowSettings(n_steps=0), "FlowSettings: n_steps"),
        (lambda: OptimizerSettings(solver="adam"), "OptimizerSettings: solver"),
        (lambda: StoppingSettings(stopping="never"), "StoppingSettings: stopping"),
        (lambda: RegistrationSettings(sigma=1.0, max_iter=0), "max_iter"),
        (lambda: RegistrationSettings.from_parts(FlowSettings()), "expected a KernelSettings"),
    ):
        with pytest.raises(ManifoldError, match=match):
            bad()
