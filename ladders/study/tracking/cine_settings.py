"""Settings of the cine route: the B-spline registrations and how their transforms combine."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["CineTrackingSettings"]

_METRICS = ("mean_squares", "mattes")
_OPTIMIZERS = ("lbfgsb", "gradient_descent")
_COMBINE = ("both", "forward")
_REFERENCES = ("ed", "consecutive")
_GRADIENTS = ("central_difference", "gaussian")


@dataclass(frozen=True)
class CineTrackingSettings:
    """Settings of the frame-to-frame B-spline registrations and their combination.

    Attributes
    ----------
    control_point_spacing : float, default 20.0
        Distance between the B-spline control points, mm (the FFD's only
        regularisation: a coarser grid gives a smoother deformation).
    metric : {"mean_squares", "mattes"}, default "mean_squares"
        Mean squared intensity difference (consecutive cine frames share their
        intensities) or Mattes mutual information (``histogram_bins`` bins).
    histogram_bins : int, default 32
    optimizer : {"lbfgsb", "gradient_descent"}, default "lbfgsb"
    iterations : int, default 30
        Iterations per resolution level.
    shrink_factors : tuple of int, default (2, 1)
        Down-sampling of the images per level, coarse to fine.
    smoothing_sigmas : tuple of float, default (2.0, 0.0)
        Gaussian smoothing per level, mm.
    image_gradient : {"central_difference", "gaussian"}, default "central_difference"
        How the metric's derivative takes the moving image's gradient. ITK's default,
        ``"gaussian"``, is a Gaussian derivative whose sigma is the image's *largest*
        voxel spacing (8 mm on a short-axis stack of 8 mm slices, in-plane too), which
        wipes out tagging lines a few mm apart and blurs the wall: the optimiser then
        follows a gradient that no longer matches its metric and stalls with the
        motion along the wall (the twist) unrecovered. ``"central_difference"``
        differentiates the moving image where it is sampled, the gradient of the
        metric being optimised (see ``docs/tracking_cine.md``).
    affine_stage : bool, default False
        Fit an affine transform first and the B-spline on top of it (the point map is
        ``A(B(x))``, :mod:`.cine_registration`), each started from its part of the
        neighbouring frame's fit. Without tags an image shows the motion of the wall
        along its normal only; the B-spline alone, moved by gradient steps from the
        identity, then leaves out the motion along the wall, and on an isotropic grid,
        whose wall normals tilt with the long axis, the shortening of the mid-wall is
        lost (on a plain isotropic series the error along the long axis was 4.4 mm at
        ES against 1.0 mm with the affine stage; ``docs/evidence/cine_evidence.md``,
        table ``cine_isotropic``).
    affine_iterations : int, default 100
        Iterations of the affine stage per resolution level (regular-step gradient
        descent); used with ``affine_stage`` only.
    sampling_percentage : float or None, default 0.05
        Fraction in ``(0, 1]`` of the voxels the metric samples at random (with
        ``seed``, the same samples at every run); None uses every voxel. ITK evaluates
        a B-spline transform's derivative densely (every sample touches every
        parameter), so the cost of an iteration is about samples x control points:
        every voxel with a fine grid is slow.
    mask_distance : float or None, default 4.0
        With ``reference="ed"``: the metric samples only the voxels of the ED frame (the
        fixed image of every registration) whose centre lies within this distance (mm)
        of an ED vertex, the neighbourhood of the wall that the tracking follows
        (``sampling_percentage`` is then a fraction of those voxels); None samples the
        whole image. On the whole-cycle cohort of short-axis stacks, 4 mm gave lower
        errors across the wall and along it than 10 mm, and the power of the group
        test its target (``docs/evidence/cycle_evidence.md``, table ``cycle_cine_mask``). Not used with ``reference="consecutive"``, whose fixed frames are
        not ED: there the wall has moved away from that region.
    seed : int, default 0
        Seed of the metric's random sampling (given to ITK as ``seed + 1``: ITK reads 0
        as "seed from the wall clock").
    reference : {"ed", "consecutive"}, default "ed"
        What a frame is registered to. ``"consecutive"``: to its neighbour, the
        transforms composed along the cycle (UK Biobank); a series of ``n`` frames takes
        ``n - 1`` registrations per chain. ``"ed"``: every frame ``t`` to ED directly
        (fixed = ED, moving = frame ``t``), the B-spline started from the transform
        fitted at the neighbouring frame of its chain, so that no composition
        accumulates drift (as 4Dsegment refines each frame against ED); ``n - 1``
        registrations in all.
    combine : {"both", "forward"}, default "both"
        With ``reference="consecutive"``: average the forward and backward chains (UK
        Biobank) or keep the forward one. With ``reference="ed"``: two chains from ED,
        forward over the first half of the cycle (to ``es_frame`` when given) and
        backward from the last frame over the rest, which run at the same time with
        ``jobs >= 2``; or one forward chain through every frame.
    threads : int, default 1
        Threads of each registration (1: bit-for-bit reproducible on a given machine;
        the image filters inside a registration use ITK's global default number of
        threads, the machine's cores, which also enters the result).
    jobs : int, default 1
        Registrations run at a time (joblib processes), with the same results whatever
        ``jobs``: a setting of the computation, not of the result (left out of
        :meth:`key`). With ``reference="consecutive"`` the registrations of a series
        are independent of each other (only moving the points along the chains is
        sequential); with ``reference="ed"`` each chain is sequential, so at most its
        two chains run at a time.
    """

    control_point_spacing: float = 20.0
    metric: str = "mean_squares"
    histogram_bins: int = 32
    optimizer: str = "lbfgsb"
    iterations: int = 30
    shrink_factors: tuple = (2, 1)
    smoothing_sigmas: tuple = (2.0, 0.0)
    image_gradient: str = "central_difference"
    affine_stage: bool = False
    affine_iterations: int = 100
    sampling_percentage: float | None = 0.05
    mask_distance: float | None = 4.0
    seed: int = 0
    reference: str = "ed"
    combine: str = "both"
    threads: int = 1
    jobs: int = 1

    def as_dict(self) -> dict:
        """JSON-ready fields, with ``route: "cine"``."""
        out = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}
        return {"route": "cine", **out}

    def key(self) -> str:
        """Stable hash of every setting (what a stored result depends on)."""
        fields = {k: v for k, v in self.as_dict().items() if k != "jobs"}
        if not self.affine_stage:  # keys of before the affine stage stay valid
            del fields["affine_stage"], fields["affine_iterations"]
        text = json.dumps(fields, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def __post_init__(self):
        cps = self.control_point_spacing
        if (
            isinstance(cps, bool)
            or not isinstance(cps, (int, float, np.number))
            or not (np.isfinite(cps) and cps > 0)
        ):
            raise ValueError(f"control_point_spacing: expected a length > 0 mm, got {cps!r}")
        if self.metric not in _METRICS:
            raise ValueError(f"metric: expected one of {_METRICS}, got {self.metric!r}")
        if self.optimizer not in _OPTIMIZERS:
            raise ValueError(f"optimizer: expected one of {_OPTIMIZERS}, got {self.optimizer!r}")
        if self.image_gradient not in _GRADIENTS:
            raise ValueError(
                f"image_gradient: expected one of {_GRADIENTS}, got {self.image_gradient!r}"
            )
        if self.reference not in _REFERENCES:
            raise ValueError(f"reference: expected one of {_REFERENCES}, got {self.reference!r}")
        if self.combine not in _COMBINE:
            raise ValueError(f"combine: expected one of {_COMBINE}, got {self.combine!r}")
        if not isinstance(self.affine_stage, bool | np.bool_):
            raise ValueError(f"affine_stage: expected True or False, got {self.affine_stage!r}")
        for name in ("histogram_bins", "iterations", "affine_iterations", "threads", "jobs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name}: expected an integer >= 1, got {value!r}")
        if (
            isinstance(self.seed, bool)
            or not isinstance(self.seed, (int, np.integer))
            or not (0 <= self.seed < 2**31 - 1)
        ):
            raise ValueError(f"seed: expected an integer in [0, 2^31 - 1), got {self.seed!r}")
        shrink, sigmas = tuple(self.shrink_factors), tuple(self.smoothing_sigmas)
        if not shrink or any(
            isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 1 for s in shrink
        ):
            raise ValueError(
                f"shrink_factors: expected integers >= 1, one per level, got {self.shrink_factors!r}"
            )
        if len(sigmas) != len(shrink) or any(
            not (np.isfinite(float(s)) and float(s) >= 0) for s in sigmas
        ):
            raise ValueError(
                f"smoothing_sigmas: expected {len(shrink)} numbers >= 0 mm (one per shrink "
                f"factor), got {self.smoothing_sigmas!r}"
            )
        d = self.mask_distance
        if d is not None and (
            isinstance(d, bool) or not isinstance(d, (int, float, np.number))
            or not (np.isfinite(d) and d > 0)
        ):  # fmt: skip
            raise ValueError(f"mask_distance: expected None or a distance > 0 mm, got {d!r}")
        p = self.sampling_percentage
        if p is not None and (
            isinstance(p, bool) or not isinstance(p, (int, float, np.number))
            or not (0 < p <= 1)
        ):  # fmt: skip
            raise ValueError(
                f"sampling_percentage: expected None or a fraction in (0, 1], got {p!r}"
            )
        object.__setattr__(self, "shrink_factors", tuple(int(s) for s in shrink))
        object.__setattr__(self, "smoothing_sigmas", tuple(float(s) for s in sigmas))
