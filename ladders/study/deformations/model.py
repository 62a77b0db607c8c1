"""What the study needs of a deformation model: the interface :class:`DeformationModel`.

The paper's study compares symmetric components (the pole ladder with and without
residuals, the four symmetry errors, the area strain error of the transported
motion) on one deformation model at a time. What it asks of a model is small:

* :meth:`DeformationModel.make_space`: the shape space at one ``alpha^2`` (a
  :class:`manifolds.Connection`: ``exp``, and ``log`` as the registration of a
  template onto a target with the model's data term);
* :meth:`DeformationModel.register`: that registration's deformed template, its
  error, the deformation's norm and whether it converged (Table 1's registration
  rows); by default from ``log`` and ``exp``;
* :meth:`DeformationModel.inverse_consistency` (Table 1);
* :meth:`DeformationModel.residual_space`: the residual-augmented variant (eq. 4),
  by default :class:`manifolds.ResidualAugmented` over the space;
* optional: :meth:`DeformationModel.transport`, the model's own transport (the
  study's third: the fanning scheme for LDDMM, the SVF pole ladder by conjugation
  for SVF). A model without one raises :class:`NotImplementedError` naming its
  class, and the study records the transport as skipped with that reason.

The pole ladder itself needs nothing more: it is the generic
:func:`ladders.symmetry_errors` on :meth:`~DeformationModel.residual_space`.
A model is registered by name (:func:`~.registry.register_deformation`) and run with
``symladders study --deformation NAME``; :func:`~.validation.validate_deformation_model`
checks it before a study does.
"""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from manifolds.connection import Connection
from manifolds.point_distance import point_distance
from manifolds.residual import ResidualAugmented

__all__ = [
    "FANNING",
    "NAME_PATTERN",
    "COUNTERS",
    "DeformationModel",
    "Registration",
    "Transported",
]

#: Method name of the fanning scheme, the default name of a model's own transport.
FANNING = "fanning"
#: What a model's name must look like (it names result folders and ``--deformation`` values).
NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_-]*$")
#: The registration counters a space may keep (as attributes); absent ones count 0.
COUNTERS = (
    "n_registrations",
    "n_unconverged",
    "n_iterations",
    "n_flow_evaluations",
    "max_gradient_norm",
)


@dataclass(frozen=True)
class Registration:
    """A registration of a template onto a target, as the study reports it (Table 1).

    Attributes
    ----------
    deformed : ndarray, shape ``point_shape``
        The deformed template ``phi_1(T)``.
    rms_error : float
        Per-vertex RMS distance from ``deformed`` to the target.
    norm : float
        The size of the deformation (for kernel models the RKHS norm ``||v_0||_H``).
    converged : bool
        Whether the registration met its stopping rule (True for a closed form).
    """

    deformed: np.ndarray
    rms_error: float
    norm: float
    converged: bool = True


@dataclass(frozen=True)
class Transported:
    """What a model's own transport (:meth:`DeformationModel.transport`) gives.

    Attributes
    ----------
    transported : ndarray, shape ``point_shape``
        The atlas moved by the transported motion, ``T'``.
    tangent : ndarray or None
        The transported tangent's coordinates at the atlas (e.g. momenta at its
        control points), stored with the results; None when the transport gives no
        tangent of the space at ``T``.
    """

    transported: np.ndarray
    tangent: np.ndarray | None = None


class DeformationModel(ABC):
    """A deformation model the study runs on (see the module).

    Subclass it, set :attr:`name` and :attr:`label`, implement :meth:`make_space`
    and :meth:`inverse_consistency`, and register an instance
    (:func:`ladders.study.deformations.register_deformation`). Every other method
    has a default that holds for any :class:`manifolds.Connection`.

    Attributes
    ----------
    name : str
        The registry's key and the value of ``symladders study --deformation``
        (lower case letters, digits, ``_`` and ``-``, e.g. ``"lddmm"``); results
        record it, and a study of several models writes ``OUTPUT/<name>``.
    label : str
        What tables call the model, e.g. ``"LDDMM"``.
    transport_method : str
        Method name of the model's own transport in the results (``"fanning"``
        unless the model's is another: ``"svf_conjugation"``).
    transport_label : str
        What the tables call that transport.
    optimizes_control_points : bool
        Whether the model accepts ``--optimize-control-points``.
    """

    name: str = ""
    label: str = ""
    transport_method: str = FANNING
    transport_label: str = "fanning scheme"
    optimizes_control_points: bool = False

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"

    # ------------------------------------------------------------------ required
    @abstractmethod
    def make_space(self, template: np.ndarray, alpha2: float, settings) -> Connection:
        """The shape space of the study at one ``alpha^2``.

        Parameters
        ----------
        template : ndarray, shape (k, d)
            The atlas ``T`` (points of the space have its shape).
        alpha2 : float
            The regularisation ``alpha^2`` of eq. 3 (> 0); a model without one ignores it.
        settings : manifolds.lddmm.RegistrationSettings
            The study's registration settings (kernel width, control points,
            integrator, solver, stopping rule); a model uses those that apply to it.

        Returns
        -------
        manifolds.Connection
            ``exp`` and ``log`` (the registration) on points of shape ``template.shape``.
        """

    @abstractmethod
    def inverse_consistency(self, space, template, shape, distance="rms") -> float:
        """``d(phi_ST(phi_TS(T)), T)``: how far the registration ``S -> T`` composed with
        ``T -> S`` is from the identity on ``T`` (Table 1; 0 for an exact, invertible model).

        ``distance`` is a name or a callable of :func:`manifolds.point_distance.point_distance`.
        """

    # ------------------------------------------------------------------ defaults
    def check_settings(self, settings) -> None:
        """Refuse settings the model cannot run with (raise ``ValueError`` naming the
        setting); the default accepts every one but ``optimize_control_points`` unless
        :attr:`optimizes_control_points`."""
        if (
            getattr(settings, "optimize_control_points", False)
            and not self.optimizes_control_points
        ):
            raise ValueError(
                f"{type(self).__name__}: optimize_control_points: the {self.name} model keeps "
                "its control points fixed"
            )

    def register(self, space, template, target) -> Registration:
        """Register ``template`` onto ``target``; by default ``Log`` then ``Exp``.

        The norm is ``space.norm`` at the template (a Riemannian space), else the
        Frobenius norm of the tangent's array.
        """
        tangent = space.log(template, target)
        deformed = np.asarray(space.exp(template, tangent), dtype=float)
        norm_of = getattr(space, "norm", None)
        norm = norm_of(template, tangent) if norm_of is not None else np.linalg.norm(tangent)
        rms = point_distance("rms", np.shape(deformed))(deformed, target)
        return Registration(deformed, float(rms), float(norm), True)

    def residual_space(self, space, use_residuals: bool) -> Connection:
        """The space with the registration residual carried along (eq. 4), or with it
        set to zero (``use_residuals=False``): :class:`manifolds.ResidualAugmented`."""
        return ResidualAugmented(space, use_residuals=use_residuals)

    def tangent_coordinates(self, space, atlas, tangent) -> np.ndarray | None:
        """The array stored for a transported tangent at the atlas (the pole ladder's
        ``-Log_T(T'')``): the tangent itself when it is an array, else None (e.g. a
        tangent carrying its own control points)."""
        return tangent if isinstance(tangent, np.ndarray) else None

    def transport(self, space, atlas, subject, follow_up, n_steps: int) -> Transported:
        """The model's own transport of ``S -> S'`` (``subject -> follow_up``) to the atlas.

        Optional: the default raises :class:`NotImplementedError` naming the class, and
        the study records :attr:`transport_method` as skipped with that message.
        """
        raise NotImplementedError(
            f"{type(self).__name__}: no {self.transport_label} (it needs a flow of momenta "
            "along the geodesic S -> T); only the pole ladders transport this model's motion"
        )

    def counts(self, space) -> dict:
        """The space's registration counters (:data:`COUNTERS`; 0 where it keeps none)."""
        return {name: getattr(space, name, 0) for name in COUNTERS}

    def settings(self) -> dict:
        """Parameters of the model outside the registration settings, JSON-ready: they
        enter the results' key (a study with other values writes other results)."""
        return {}
