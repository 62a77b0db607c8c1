"""The typed results of the study: one :class:`PairResult` per (subject, ``alpha^2``).

A pair's result holds the registration ``T -> S`` (:class:`RegistrationSummary`),
the four symmetry errors of each variant (:class:`VariantErrors`), one
:class:`TransportResult` per transport method (its area strain error and map),
the subject's own strain map and the registration counters of the space
(:class:`RegistrationCounts`). A pair that raised is a :class:`FailedPair`; a
subject's pairs over the sweep are a :class:`SubjectResults`.

Every class is a frozen dataclass of numbers, strings and tuples, so results
compare with ``==`` and hash. Only :mod:`ladders.study.running.store` writes them
to JSON and reads them back, with the :data:`SCHEMA_VERSION` of this module.

Transport methods are named for what they are:

=============================  ==================================================
``pole_ladder_residual``       pole ladder (Algorithm 1) with residuals
``pole_ladder_no_residual``    pole ladder without residuals
``fanning``                    the fanning scheme (LDDMM study)
``svf_conjugation``            the SVF pole ladder by conjugation (SVF study)
=============================  ==================================================

A model's own transport may have another name (its ``transport_method``); one the
model does not have is a :class:`SkippedTransport` of the pair, with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, fields

import numpy as np

from ..deformations import FANNING, SVF_CONJUGATION, transport_label
from ..deformations.model import COUNTERS

__all__ = [
    "SCHEMA_VERSION",
    "VARIANTS",
    "ERROR_NAMES",
    "REGISTRATION_MEASURES",
    "POLE_LADDER",
    "FANNING",
    "SVF_CONJUGATION",
    "TRANSPORT_LABELS",
    "VariantErrors",
    "RegistrationSummary",
    "RegistrationCounts",
    "TransportResult",
    "SkippedTransport",
    "PairResult",
    "FailedPair",
    "SubjectResults",
]

#: Version of the layout of a stored pair result; a file of another version is recomputed.
#: Version 3 adds the transported motion (displacements, momenta, residuals) and stores
#: long arrays as base64 float64.
SCHEMA_VERSION = 3

VARIANTS = ("residual", "no_residual")
ERROR_NAMES = ("midpoint_distance", "centrality", "involutivity", "transvectivity")
#: Measures of the registration ``T -> S``, shared by both variants.
REGISTRATION_MEASURES = ("registration_error", "registration_norm", "inverse_consistency")

#: The pole ladder's transport method of each variant.
POLE_LADDER = {variant: f"pole_ladder_{variant}" for variant in VARIANTS}
#: What each transport method is, for tables and figure legends.
TRANSPORT_LABELS = {
    POLE_LADDER["residual"]: "pole ladder, with residuals",
    POLE_LADDER["no_residual"]: "pole ladder, without residuals",
    FANNING: "fanning scheme",
    SVF_CONJUGATION: "SVF pole ladder by conjugation",
}


def _floats(values) -> tuple[float, ...]:
    return tuple(float(v) for v in np.asarray(values, dtype=float).ravel())


def _bad_numbers(prefix: str, obj) -> list[str]:
    """Dotted names of the float fields of a dataclass that are NaN or infinite."""
    out = []
    for f in fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, float) and not math.isfinite(value):
            out.append(f"{prefix}{f.name}")
        elif isinstance(value, tuple) and value and isinstance(value[0], float):
            if not all(math.isfinite(v) for v in value):
                out.append(f"{prefix}{f.name}")
    return out


@dataclass(frozen=True)
class VariantErrors:
    """The four symmetry errors of one variant (``"residual"`` or ``"no_residual"``)."""

    variant: str
    midpoint_distance: float
    centrality: float
    involutivity: float
    transvectivity: float


@dataclass(frozen=True)
class RegistrationSummary:
    """The registration ``T -> S`` shared by both variants.

    Attributes
    ----------
    error : float
        ``d(phi_1(T), S)`` in the study's distance (the pair's ``unit``).
    rms : float
        The same as a per-vertex RMS distance.
    rkhs_norm : float
        ``||v_0||_H`` of the registration.
    converged : bool
        Whether it met the stopping rule.
    inverse_consistency : float
        See :meth:`manifolds.lddmm.KernelLandmarkSpace.inverse_consistency`.
    """

    error: float
    rms: float
    rkhs_norm: float
    converged: bool
    inverse_consistency: float

    def measure(self, name: str) -> float:
        """One of :data:`REGISTRATION_MEASURES` (or ``"converged"`` as 1.0 / 0.0)."""
        values = {
            "registration_error": self.error,
            "registration_norm": self.rkhs_norm,
            "inverse_consistency": self.inverse_consistency,
            "converged": float(self.converged),
        }
        return values[name]


@dataclass(frozen=True)
class RegistrationCounts:
    """Counters of the registrations a space computed (cache hits excluded).

    Attributes
    ----------
    n_registrations, non_converged, n_iterations, n_flow_evaluations : int
        Registrations, those that stopped before meeting the stopping rule,
        optimiser iterations and flow passes (forward, adjoint, tangent-linear).
    max_gradient_norm : float
        Largest final gradient among them.
    """

    n_registrations: int = 0
    non_converged: int = 0
    n_iterations: int = 0
    n_flow_evaluations: int = 0
    max_gradient_norm: float = 0.0

    @classmethod
    def of_space(cls, space) -> RegistrationCounts:
        """The counters a space keeps as attributes (e.g. a
        :class:`~manifolds.lddmm.KernelLandmarkSpace`; 0 for those it does not keep)."""
        return cls.of_counters({name: getattr(space, name, 0) for name in COUNTERS})

    @classmethod
    def of_counters(cls, counters: dict) -> RegistrationCounts:
        """From a model's counters (:meth:`~ladders.study.deformations.DeformationModel.counts`)."""
        return cls(
            n_registrations=int(counters.get("n_registrations", 0)),
            non_converged=int(counters.get("n_unconverged", 0)),
            n_iterations=int(counters.get("n_iterations", 0)),
            n_flow_evaluations=int(counters.get("n_flow_evaluations", 0)),
            max_gradient_norm=float(counters.get("max_gradient_norm", 0.0)),
        )

    @classmethod
    def total(cls, counts: Iterable[RegistrationCounts]) -> RegistrationCounts:
        """Sums of the counters (the largest gradient for ``max_gradient_norm``)."""
        counts = list(counts)
        return cls(
            n_registrations=sum(c.n_registrations for c in counts),
            non_converged=sum(c.non_converged for c in counts),
            n_iterations=sum(c.n_iterations for c in counts),
            n_flow_evaluations=sum(c.n_flow_evaluations for c in counts),
            max_gradient_norm=max((c.max_gradient_norm for c in counts), default=0.0),
        )


@dataclass(frozen=True)
class TransportResult:
    """One transport of the subject's motion to the atlas, ``T -> T'``.

    Attributes
    ----------
    method : str
        See the module docstring.
    ase : float
        Area strain error ``||LAS_T' - LAS_S||_2``.
    las : tuple of float
        Local area strain from ``T`` to ``T'`` at every vertex.
    displacement : tuple of float
        The transported motion as a displacement of the atlas, ``T' - T``, flattened
        from ``(k, d)`` (:meth:`displacement_array`).
    momenta : tuple of float
        The transported tangent vector's momenta at the atlas's control points,
        flattened from ``(n_cp, d)``; empty when the transport gives no tangent of the
        space at ``T`` (the SVF conjugation) or its tangents carry their own control
        points (optimised control points). For the pole ladder, ``-Log_T(T'')`` with
        ``T'' = s_M(S')``; for the fanning scheme, the transported momenta carried
        to the atlas's control points (see :func:`~ladders.study.running.pipeline.compute_pair`).
    residual : tuple of float
        The residual part ``delta`` of the transported tangent (eq. 4), flattened from
        ``(k, d)``; empty when it has none (no residuals, fanning, conjugation).
    """

    method: str
    ase: float
    las: tuple[float, ...]
    displacement: tuple[float, ...] = ()
    momenta: tuple[float, ...] = ()
    residual: tuple[float, ...] = ()

    def __post_init__(self):
        for name in ("las", "displacement", "momenta", "residual"):
            object.__setattr__(self, name, _floats(getattr(self, name)))

    def displacement_array(self, dim: int = 3) -> np.ndarray:
        """``T' - T`` as an array ``(k, dim)``."""
        return np.asarray(self.displacement, dtype=float).reshape(-1, dim)

    def momenta_array(self, dim: int = 3) -> np.ndarray | None:
        """The transported momenta ``(n_cp, dim)``, or None when not stored."""
        if not self.momenta:
            return None
        return np.asarray(self.momenta, dtype=float).reshape(-1, dim)

    def residual_array(self, dim: int = 3) -> np.ndarray | None:
        """The transported residual ``(k, dim)``, or None when the tangent has none."""
        if not self.residual:
            return None
        return np.asarray(self.residual, dtype=float).reshape(-1, dim)

    @property
    def label(self) -> str:
        """What the method is, e.g. ``"pole ladder, with residuals"``."""
        return method_label(self.method)


def method_label(method: str) -> str:
    """What a transport method is: :data:`TRANSPORT_LABELS`, else the registered model's
    ``transport_label``, else the method's name."""
    return TRANSPORT_LABELS.get(method) or transport_label(method) or method


@dataclass(frozen=True)
class SkippedTransport:
    """A transport the pair's deformation model does not have, and why (its message)."""

    method: str
    reason: str


@dataclass(frozen=True)
class _Pair:
    """What names a pair: its subject and ``alpha^2``."""

    subject: str
    alpha2: float

    def __post_init__(self):
        object.__setattr__(self, "alpha2", float(self.alpha2))


@dataclass(frozen=True)
class PairResult(_Pair):
    """The result of one subject at one ``alpha^2`` (computed by
    :func:`ladders.study.running.pipeline.compute_pair`).

    Attributes
    ----------
    subject : str
    alpha2 : float
    settings_key : str
        :meth:`manifolds.lddmm.RegistrationSettings.key` of the registrations.
    deformation : str
        ``"lddmm"`` or ``"svf"``.
    unit : str
        Unit of the distances, e.g. ``"mm (per-vertex RMS)"``.
    registration : RegistrationSummary
    errors : tuple of VariantErrors
        One per variant, in the order of :data:`VARIANTS`.
    transports : tuple of TransportResult
        The two pole ladders, then the model's own transport: the fanning scheme
        (LDDMM), the SVF conjugation (SVF), none when the model has none.
    las_subject : tuple of float
        Local area strain from ``S`` to ``S'``.
    counts : RegistrationCounts
    seconds : float
    kernel_backend : str
        The kernel backend that ran.
    displacement_subject : tuple of float
        The subject's own motion ``S' - S``, flattened from ``(k, d)``: the motion
        without transport, in the subject's frame.
    volume_ratio_subject : float
        ``V(S') / V(S)``, the volumes enclosed by the subject's meshes
        (:func:`ladders.study.volume.enclosed_volume`): one minus its ejection fraction.
    skipped_transports : tuple of SkippedTransport
        The model's transports it does not have (stored only when there is one, so a
        file written before the field existed reads as none skipped).
    """

    settings_key: str
    deformation: str
    unit: str
    registration: RegistrationSummary
    errors: tuple[VariantErrors, ...]
    transports: tuple[TransportResult, ...]
    las_subject: tuple[float, ...]
    counts: RegistrationCounts
    seconds: float
    kernel_backend: str
    displacement_subject: tuple[float, ...] = ()
    volume_ratio_subject: float = 1.0
    skipped_transports: tuple[SkippedTransport, ...] = ()

    status = "ok"
    #: Fields a stored result may lack (written before they existed), read as their default.
    optional_fields = ("skipped_transports",)

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "errors", tuple(self.errors))
        object.__setattr__(self, "transports", tuple(self.transports))
        object.__setattr__(self, "skipped_transports", tuple(self.skipped_transports))
        object.__setattr__(self, "las_subject", _floats(self.las_subject))
        object.__setattr__(self, "displacement_subject", _floats(self.displacement_subject))

    def variant(self, name: str) -> VariantErrors:
        """The errors of the variant ``name`` (``"residual"`` or ``"no_residual"``)."""
        for errors in self.errors:
            if errors.variant == name:
                return errors
        raise KeyError(f"variant: expected one of {VARIANTS}, got {name!r}")

    def transport(self, method: str) -> TransportResult:
        """The transport ``method`` (e.g. ``"pole_ladder_residual"``, ``"fanning"``)."""
        for transport in self.transports:
            if transport.method == method:
                return transport
        known = [t.method for t in self.transports]
        raise KeyError(f"method: expected one of {known}, got {method!r}")

    @property
    def other_transport(self) -> TransportResult | None:
        """The transport that is not a pole ladder (fanning, SVF conjugation), or None."""
        return next((t for t in self.transports if t.method not in POLE_LADDER.values()), None)

    def measure(self, row: str, name: str) -> float:
        """A number of the result by its row and measure in the tables.

        ``row`` is a variant or a transport method; ``name`` one of
        :data:`ERROR_NAMES` (variants), ``"ase"`` (a variant's pole ladder, or the
        method's), :data:`REGISTRATION_MEASURES` or ``"converged"`` (any row).
        """
        if name in (*REGISTRATION_MEASURES, "converged"):
            return self.registration.measure(name)
        if name == "ase":
            return self.transport(POLE_LADDER.get(row, row)).ase
        if name not in ERROR_NAMES:
            raise KeyError(f"name: unknown measure {name!r}")
        return float(getattr(self.variant(row), name))

    def non_finite_fields(self) -> list[str]:
        """Dotted names of the numbers that are NaN or infinite (empty for a sound result)."""
        bad = _bad_numbers("registration.", self.registration)
        for errors in self.errors:
            bad += _bad_numbers(f"{errors.variant}.", errors)
        for transport in self.transports:
            bad += _bad_numbers(f"{transport.method}.", transport)
        bad += _bad_numbers("", self)
        return bad


@dataclass(frozen=True)
class FailedPair(_Pair):
    """A (subject, ``alpha^2``) whose computation raised: its error and traceback."""

    error: str
    traceback: str
    seconds: float

    status = "failed"


@dataclass(frozen=True)
class SubjectResults:
    """One subject's pairs over the sweep: the results and the failures."""

    subject: str
    pairs: tuple[PairResult, ...] = ()
    failures: tuple[FailedPair, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "pairs", tuple(sorted(self.pairs, key=lambda p: p.alpha2)))
        object.__setattr__(self, "failures", tuple(self.failures))

    @property
    def alpha2(self) -> tuple[float, ...]:
        """The ``alpha^2`` with a result, increasing."""
        return tuple(p.alpha2 for p in self.pairs)

    def at(self, alpha2: float) -> PairResult | None:
        """The result at ``alpha2``, or None (failed or not in the sweep)."""
        return next((p for p in self.pairs if p.alpha2 == float(alpha2)), None)

    @property
    def non_converged_registrations(self) -> int:
        """Registrations of the successful pairs that stopped before the stopping rule."""
        return sum(p.counts.non_converged for p in self.pairs)

    @property
    def seconds(self) -> float:
        """Compute time of the successful pairs."""
        return float(sum(p.seconds for p in self.pairs))
