"""How deep a kernel sum sits below the study's pair computation.

A reader follows ``compute_pair`` down to the compiled loop of a kernel sum: the
registration (its start and its iterations) must reach it in at most 9 calls of the
project's own functions, none of them a pure forwarding layer, for the forward pass (the
Hamiltonian right-hand side) and for the adjoint pass (its vector-Jacobian product).
The study reaches the space through its deformation model
(:class:`~ladders.study.deformations.DeformationModel`, which turns the space's
registration into the study's record): one call, the only one above the space's.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from ladders.study.cohort import make_synthetic_cohort
from ladders.study.running import StudyConfig
from ladders.study.running.pipeline import compute_pair
from manifolds.kernels.backends import backend_available
from manifolds.lddmm.settings import RegistrationSettings

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = (str(ROOT / "manifolds"), str(ROOT / "ladders"))
MAX_CALLS = 9


def _project_chain() -> list[str]:
    """Project functions on the stack, from ``compute_pair`` down to the caller's caller."""
    frame = sys._getframe(2)  # the function that calls the kernel loop
    chain = []
    while frame is not None:
        code = frame.f_code
        if code.co_filename.startswith(PACKAGES):
            chain.append(code.co_qualname if hasattr(code, "co_qualname") else code.co_name)
            if code.co_name == "compute_pair":
                return chain[::-1]
        frame = frame.f_back
    return []


def _recording(loops: dict, name: str, chains: list):
    serial, parallel = loops[name]

    def serial_rec(*args):
        chains.append(_project_chain())
        return serial(*args)

    def parallel_rec(*args):
        chains.append(_project_chain())
        return parallel(*args)

    return serial_rec, parallel_rec


@pytest.mark.skipif(not backend_available("numba"), reason="the compiled loops need numba")
@pytest.mark.parametrize("sum_name", ["hamiltonian_rhs", "hamiltonian_vjp"])
def test_the_registrations_reach_a_kernel_sum_in_at_most_8_calls(monkeypatch, sum_name):
    from manifolds.lddmm import kernels_numba

    chains: list = []
    monkeypatch.setitem(
        kernels_numba.LOOPS, sum_name, _recording(kernels_numba.LOOPS, sum_name, chains)
    )
    cohort = make_synthetic_cohort(n_subjects=1, grid=(6, 4), seed=0)
    config = StudyConfig(registration=RegistrationSettings(sigma=10.0, kernel_backend="numba"))
    compute_pair(config, cohort.atlas, cohort.faces, cohort.subjects[0], 1.0)
    # The registration T -> S of the pair: its start and its iterations.
    direct = [c for c in chains if c[2:3] == ["KernelLandmarkSpace.register"]]
    assert direct, f"no kernel sum reached from the registration: {chains[:3]}"
    longest = max(direct, key=len)
    assert len(longest) <= MAX_CALLS, " -> ".join(longest)
    assert longest[:4] == ["compute_pair", "KernelModel.register", "KernelLandmarkSpace.register",
                           "register"]  # fmt: skip
    assert sum("minimize_lbfgsb" in c for c in direct) > 0.6 * len(direct)
