"""The settings the documentation recommends, each with the measurement that decides it.

:data:`RECOMMENDED_ALPHA2`: the alpha^2 of the registrations whose transported motion
goes into group statistics. docs/population.md ("Which to use when") measures it on
the synthetic two-group cohort (40 subjects, a mild hypokinesia, a fifth of the
motion, in 4 AHA segments): the LDDMM pole ladder with residuals finds the region at
alpha^2 = 100 (power 0.98, Dice 0.98) and loses it at alpha^2 = 1 (power 0.23) and
0.01 (power 0.16), and it multiplies the spread between subjects at small alpha^2
(pooled SD in the region 1.34 mm at 100 against 2.87 mm at 1, 1.29 mm without
transport). ``symladders cycle-study`` transports at it by default and ``symladders
analyze`` reports its main motion (:func:`main_motion`: the terminal's line, the
figures) at the study's alpha^2 nearest it. ``symladders study`` keeps the paper's sweep (its Table 1).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

__all__ = ["RECOMMENDED_ALPHA2", "MAIN_METHOD", "main_motion"]

#: The alpha^2 of group statistics on a transported motion (see the module).
RECOMMENDED_ALPHA2 = 100.0
#: The transport of the main motion: the pole ladder with residuals (the paper's Algorithm 1).
MAIN_METHOD = "pole_ladder_residual"


def main_motion(items: Sequence, motion: Callable = lambda item: item.motion):
    """The item whose motion the docs tell users to read first: the pole ladder with
    residuals of the first deformation model among the items (LDDMM before SVF: their
    folders' order) at the alpha^2 nearest :data:`RECOMMENDED_ALPHA2` (on a log scale);
    the first item when no motion is the pole ladder with residuals.

    ``motion(item)`` is the item's :class:`~ladders.study.population.TransportedMotion`
    (with ``method``, ``deformation``, ``alpha2``).
    """
    ladders = [item for item in items if motion(item).method == MAIN_METHOD]
    if not ladders:
        return items[0]
    first = motion(ladders[0]).deformation
    return min(ladders, key=lambda item: (
        motion(item).deformation != first,
        abs(math.log(motion(item).alpha2 / RECOMMENDED_ALPHA2)),
    ))  # fmt: skip
