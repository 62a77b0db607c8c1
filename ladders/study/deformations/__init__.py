"""Deformation models of the study: the interface, the registry and the built-in models.

- :mod:`.model`: :class:`DeformationModel`, what the study needs of a model;
- :mod:`.registry`: models by name (:func:`register_deformation`,
  :func:`deformation_model`), plugins (``SYMLADDERS_PLUGINS``, ``--plugin``) and the
  entry-point group ``symladders.deformations``;
- :mod:`.lddmm`, :mod:`.svf`: the built-in models, registered as ``lddmm`` and ``svf``
  the way a user's model is;
- :mod:`.validation`: :func:`check_deformation_model` (before a study) and
  :func:`validate_deformation_model` (the contract and the ladder's convergence).
"""

from . import lddmm, svf  # noqa: F401  (registers the built-in models)
from .lddmm import KernelModel, LDDMMModel
from .model import FANNING, DeformationModel, Registration, Transported
from .registry import (
    BOTH,
    ENTRY_POINT_GROUP,
    PLUGINS_VARIABLE,
    DeformationModelError,
    deformation_model,
    deformation_names,
    load_plugin,
    parse_deformations,
    register_deformation,
    transport_label,
    unregister_deformation,
)
from .svf import SVF_CONJUGATION, SVFModel
from .validation import (
    CHECK_ALPHA2,
    ModelValidation,
    check_deformation_model,
    validate_deformation_model,
)

__all__ = [
    "DeformationModel",
    "Registration",
    "Transported",
    "FANNING",
    "SVF_CONJUGATION",
    "KernelModel",
    "LDDMMModel",
    "SVFModel",
    "BOTH",
    "ENTRY_POINT_GROUP",
    "PLUGINS_VARIABLE",
    "DeformationModelError",
    "register_deformation",
    "unregister_deformation",
    "deformation_model",
    "deformation_names",
    "parse_deformations",
    "load_plugin",
    "transport_label",
    "CHECK_ALPHA2",
    "ModelValidation",
    "check_deformation_model",
    "validate_deformation_model",
]
