"""Typed study results with chosen numbers, for the tests of the report and statistics."""

from ladders.study.running import (
    FailedPair,
    PairResult,
    RegistrationCounts,
    RegistrationSummary,
    SubjectResults,
    TransportResult,
    VariantErrors,
)


def fake_pair(
    subject, alpha2, errors, ase, registration, unit="mm (per-vertex RMS)", other="fanning"
):
    """A pair result: ``errors[variant]`` the four errors, ``ase[method]`` the ASE of
    ``pole_ladder_residual``, ``pole_ladder_no_residual`` and ``other``; ``registration``
    ``(error, rkhs_norm, inverse_consistency, converged)``."""
    error, norm, inverse, converged = registration
    return PairResult(
        subject=subject,
        alpha2=alpha2,
        settings_key="test",
        deformation="lddmm",
        unit=unit,
        registration=RegistrationSummary(error, error, norm, converged, inverse),
        errors=tuple(VariantErrors(v, *errors[v]) for v in ("residual", "no_residual")),
        transports=tuple(
            TransportResult(m, ase[m], (0.0, 0.0))
            for m in ("pole_ladder_residual", "pole_ladder_no_residual", other)
        ),
        las_subject=(0.0, 0.0),
        counts=RegistrationCounts(13, 0, 100, 200, 1e-8),
        seconds=1.0,
        kernel_backend="numpy",
    )


def fake_subject(subject, pairs, failures=()):
    """Results of one subject from its pairs (and ``(alpha2, error)`` failures)."""
    failed = tuple(FailedPair(subject, a, error, "", 0.0) for a, error in failures)
    return SubjectResults(subject, tuple(pairs), failed)
