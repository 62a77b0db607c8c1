"""The SVF model of the study (:class:`manifolds.lddmm.SVFLandmarks`), registered as ``svf``.

Registered the way a user's model is. Its own transport is the SVF pole ladder by
conjugation, ``exp(-v/2) o exp(u) o exp(v/2)`` applied to the atlas
(:func:`manifolds.lddmm.group_pole_ladder`, ``docs/svf.md``), which gives no tangent
of the space at ``T``.
"""

from __future__ import annotations

from manifolds.lddmm import SVFLandmarks, group_pole_ladder

from .lddmm import KernelModel
from .model import Transported
from .registry import register_deformation

__all__ = ["SVF_CONJUGATION", "SVFModel"]

#: Method name of the SVF pole ladder by conjugation.
SVF_CONJUGATION = "svf_conjugation"


class SVFModel(KernelModel):
    """Stationary velocity fields on landmarks (:class:`manifolds.lddmm.SVFLandmarks`); its
    own transport is the group pole ladder by conjugation."""

    name = "svf"
    label = "SVF"
    space_class = SVFLandmarks
    transport_method = SVF_CONJUGATION
    transport_label = "SVF pole ladder by conjugation"

    def transport(self, space, atlas, subject, follow_up, n_steps: int) -> Transported:
        """``exp(-v/2) o exp(u) o exp(v/2)`` applied to ``T``, ``v = Log_T(S)``, ``u = Log_S(S')``."""
        v, u = space.log(atlas, subject), space.log(subject, follow_up)
        return Transported(group_pole_ladder(space, atlas, v, u, base=subject))


register_deformation(SVFModel())
