"""Typed study results with chosen numbers, for the tests of the report and statistics."""

from ladders.study import running as r


def fake_pair(
    subject, alpha2, errors, ase, registration, unit="mm (per-vertex RMS)", other="fanning"
):
    """A pair result: ``errors[variant]`` the four errors, ``ase[method]`` the ASE of
    ``pole_ladder_residual``, ``pole_ladder_no_residual`` and ``other``; ``registration``
    ``(error, rkhs_norm, inverse_consistency, converged)``."""
    error, norm, inverse, converged = registration
    return r.PairResult(
        subject=subject,
        alpha2=alpha2,
        settings_key="test",
        deformation="lddmm",
        unit=unit,
        registration=r.RegistrationSummary(error, error, norm, converged, inverse),
        errors=tuple(r.VariantErrors(v, *errors[v]) for v in ("residual", "no_residual")),
        transports=tuple(
            r.TransportResult(m, ase[m], (0.0, 0.0))
            for m in ("pole_ladder_residual", "pole_ladder_no_residual", other)
        ),
        las_subject=(0.0, 0.0),
        counts=r.RegistrationCounts(13, 0, 100, 200, 1e-8),
        seconds=1.0,
        kernel_backend="numpy",
    )


def fake_subject(subject, pairs, failures=()):
    """Results of one subject from its pairs (and ``(alpha2, error)`` failures)."""
    failed = tuple(r.FailedPair(subject, a, error, "", 0.0) for a, error in failures)
    return r.SubjectResults(subject, tuple(pairs), failed)
