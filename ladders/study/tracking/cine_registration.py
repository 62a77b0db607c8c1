"""One registration of the cine route: an optional affine stage, then the B-spline (FFD).

:func:`register_images` fits the transform ``T`` with ``moving(T(x)) ~ fixed(x)`` (points
of the fixed frame moved to the same material in the moving frame; see
:mod:`.cine_tracking`'s conventions) with SimpleITK:

* with ``settings.affine_stage``, an affine transform ``A`` first (12 parameters,
  regular-step gradient descent with scales from the physical shift), then the cubic
  B-spline ``B`` on the control grid of :func:`identity_bspline` fitted on top of it
  (ITK's moving initial transform): ``T(x) = A(B(x))``, a
  ``SimpleITK.CompositeTransform``;
* without it, the B-spline alone, started from the identity.

Both stages share the metric, its sampling and its mask, the image gradient and the
resolution pyramid of the settings. ``initial`` (a transform this function returned
for a frame of the same grid) is the starting point of each stage: its affine part
starts the affine stage and its B-spline the B-spline's.

Why the affine stage: without tags an image shows the motion of a smooth wall only
along its normal (the aperture problem), so a B-spline fitted from the identity by
gradient steps moves the wall along its normals and leaves out the motion along it; on
an isotropic grid the wall's normals tilt with the long axis and the shortening of the
mid-wall is then lost, even reversed. The affine stage fits the global shortening
from the whole wall (the base and the apex included) before the B-spline refines it
(``docs/evidence/cine_evidence.md``, table ``cine_isotropic``).
"""

from __future__ import annotations

import numpy as np

from .cine_images import _sitk
from .cine_settings import CineTrackingSettings

__all__ = ["identity_bspline", "register_images"]


def identity_bspline(image, control_point_spacing: float):
    """The identity cubic B-spline transform on the control grid the registrations use.

    The grid covers ``image``'s extent with ``round(extent / control_point_spacing)``
    intervals per axis (at least one).

    Parameters
    ----------
    image : SimpleITK.Image
        The fixed image (:func:`~.cine_images.image_from_array`).
    control_point_spacing : float
        mm.

    Returns
    -------
    SimpleITK.BSplineTransform
    """
    sitk = _sitk()
    size = np.asarray(image.GetSize(), dtype=float)
    extent = (size - 1.0) * np.asarray(image.GetSpacing())
    mesh = [max(1, int(round(e / control_point_spacing))) for e in extent]
    return sitk.BSplineTransformInitializer(image, mesh, 3)


def _method(fixed_image, settings: CineTrackingSettings, mask):
    """A registration method with the settings' metric, sampling, mask and pyramid."""
    sitk = _sitk()
    method = sitk.ImageRegistrationMethod()
    if settings.metric == "mean_squares":
        method.SetMetricAsMeanSquares()
    else:
        method.SetMetricAsMattesMutualInformation(numberOfHistogramBins=settings.histogram_bins)
    if settings.image_gradient == "central_difference":  # not ITK's smoothed default
        method.MetricUseMovingImageGradientFilterOff()
        method.MetricUseFixedImageGradientFilterOff()
    if settings.sampling_percentage is None:
        method.SetMetricSamplingStrategy(method.NONE)
    else:
        method.SetMetricSamplingStrategy(method.RANDOM)
        fraction = float(settings.sampling_percentage)
        if mask is not None:  # ITK draws from every voxel, then drops those outside
            inside = float(sitk.GetArrayViewFromImage(mask).mean())
            fraction = min(1.0, fraction / inside)
        # SimpleITK reads a seed of 0 as "seed from the wall clock": shift by one
        method.SetMetricSamplingPercentage(fraction, int(settings.seed) + 1)
    if mask is not None:
        method.SetMetricFixedMask(mask)
    method.SetInterpolator(sitk.sitkLinear)
    levels = len(settings.shrink_factors)
    # a level may not shrink an axis below 4 voxels (short-axis stacks have few slices)
    smallest = int(min(fixed_image.GetSize()))
    shrink = [max(1, min(s, smallest // 4)) for s in settings.shrink_factors]
    method.SetShrinkFactorsPerLevel(shrink)
    method.SetSmoothingSigmasPerLevel(list(settings.smoothing_sigmas[:levels]))
    method.SmoothingSigmasAreSpecifiedInPhysicalUnitsOn()
    method.SetNumberOfThreads(int(settings.threads))
    return method


def _parts(initial):
    """The affine and the B-spline parts of a transform :func:`register_images` returned."""
    sitk = _sitk()
    if initial is None:
        return None, None
    if isinstance(initial, sitk.CompositeTransform):
        return initial.GetNthTransform(0), initial.GetNthTransform(1)
    return None, initial


def _centre(fixed_image, mask) -> tuple:
    """Centre of the affine stage's matrix: the mask's centroid, else the image's centre."""
    sitk = _sitk()
    if mask is None:
        size = np.asarray(fixed_image.GetSize(), dtype=float)
        return fixed_image.TransformContinuousIndexToPhysicalPoint(((size - 1.0) / 2).tolist())
    index = np.argwhere(sitk.GetArrayViewFromImage(mask) > 0)[:, ::-1].mean(axis=0)
    return fixed_image.TransformContinuousIndexToPhysicalPoint(index.tolist())


def _affine_stage(fixed_image, moving_image, settings: CineTrackingSettings, initial, mask):
    sitk = _sitk()
    affine = sitk.AffineTransform(3)
    if initial is None:
        affine.SetCenter(_centre(fixed_image, mask))
    else:
        affine.SetFixedParameters(initial.GetFixedParameters())
        affine.SetParameters(initial.GetParameters())
    method = _method(fixed_image, settings, mask)
    method.SetOptimizerAsRegularStepGradientDescent(
        learningRate=1.0, minStep=1e-3, numberOfIterations=settings.affine_iterations
    )  # steps of at most 1 mm of shift, halved at each turn
    method.SetOptimizerScalesFromPhysicalShift()
    method.SetInitialTransform(affine, inPlace=True)
    method.Execute(fixed_image, moving_image)
    return affine


def register_images(
    fixed_image, moving_image, settings: CineTrackingSettings, initial=None, mask=None
):
    """The transform fitted from ``fixed`` to ``moving`` (see the module).

    Parameters
    ----------
    fixed_image, moving_image : SimpleITK.Image
        Two frames of one grid (:func:`~.cine_images.image_from_array`).
    settings : CineTrackingSettings
    initial : SimpleITK transform, optional
        A transform this function returned for a frame of the same grid: each stage
        starts from its part of it. None starts from the identity.
    mask : SimpleITK.Image, optional
        8-bit, 0 and 1 on the fixed grid: the voxels the metric samples
        (``sampling_percentage`` is then a fraction of them).

    Returns
    -------
    SimpleITK.BSplineTransform or SimpleITK.CompositeTransform
        ``T`` with ``moving(T(x)) ~ fixed(x)``; with ``settings.affine_stage``, the
        composite ``A(B(x))`` of the affine ``A`` and the B-spline ``B``.
    """
    sitk = _sitk()
    initial_affine, initial_bspline = _parts(initial)
    affine = None
    if settings.affine_stage:
        affine = _affine_stage(fixed_image, moving_image, settings, initial_affine, mask)
    transform = identity_bspline(fixed_image, settings.control_point_spacing)
    if initial_bspline is not None:
        transform.SetParameters(initial_bspline.GetParameters())
    method = _method(fixed_image, settings, mask)
    if settings.optimizer == "lbfgsb":
        method.SetOptimizerAsLBFGSB(
            gradientConvergenceTolerance=1e-6,
            numberOfIterations=settings.iterations,
            maximumNumberOfCorrections=7,
            maximumNumberOfFunctionEvaluations=4 * settings.iterations,
            costFunctionConvergenceFactor=1e7,
        )
    else:
        method.SetOptimizerAsGradientDescent(
            learningRate=1.0,
            numberOfIterations=settings.iterations,
            convergenceMinimumValue=1e-7,
            convergenceWindowSize=10,
            estimateLearningRate=method.EachIteration,
        )
        method.SetOptimizerScalesFromPhysicalShift()
    if affine is not None:
        method.SetMovingInitialTransform(affine)
    method.SetInitialTransform(transform, inPlace=True)
    method.Execute(fixed_image, moving_image)
    if affine is None:
        return transform
    return sitk.CompositeTransform([affine, transform])  # the B-spline first, then A
