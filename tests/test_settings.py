"""RegistrationSettings: validation, stable key, and the spaces' and study's use of it."""

import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest

from ladders.study.running.pipeline import StudyConfig
from manifolds.errors import ManifoldError
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings, SVFLandmarks


def test_settings_are_frozen_hashable_and_round_trip_through_a_dict():
    s = RegistrationSettings(sigma=20.0, control_points="grid", max_iter=50)
    with pytest.raises(AttributeError):
        s.sigma = 3.0
    assert hash(s) == hash(RegistrationSettings(sigma=20.0, control_points="grid", max_iter=50))
    back = RegistrationSettings.from_dict(json.loads(json.dumps(s.as_dict())))
    assert back == s and back.key() == s.key()


def test_key_changes_with_every_field_and_with_the_backend():
    base = RegistrationSettings(sigma=1.0)
    changes = {
        "sigma": 2.0,
        "control_points": "grid",
        "control_point_spacing": 0.5,
        "optimize_control_points": True,
        "integrator": "rk2",
        "n_steps": 11,
        "stopping": "shape",
        "shape_tol": 1e-4,
        "ftol": 1e-8,
        "max_iter": 7,
        "rel_ridge": 1e-3,
    }
    keys = {base.key()}
    for name, value in changes.items():
        keys.add(base.replace(**{name: value}).key())
    assert len(keys) == len(changes) + 1
    assert base.replace(kernel_backend="numpy").key() != base.replace(kernel_backend="numba").key()
    # "auto" is resolved: it names the backend that runs
    assert base.key() == base.replace(kernel_backend=base.resolved_backend()).key()


def test_key_leaves_out_the_spacing_while_it_is_the_default():
    """Settings that set neither ``control_point_spacing`` nor ``control_point_indices``
    keep the key they had before the fields existed (the study's result folders are
    named by it)."""
    base = RegistrationSettings(sigma=20.0, control_points="grid", stopping="shape")
    payload = base.as_dict()
    del payload["control_point_spacing"], payload["control_point_indices"]
    payload.update(kernel_backend=base.resolved_backend(), schema=1)
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=repr)
    assert base.key() == hashlib.sha256(text.encode()).hexdigest()[:20]
    assert base.replace(control_point_spacing=20.0).key() != base.key()


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
