"""The model of a cohort's covariates: age, sex and body size, and a group's anatomy shift.

:class:`Covariates` states how the covariates are distributed in each group (the
reference group and the others, shifted by ``imbalance``) and how they act on the
shapes (age and sex on the contraction, body size on every length);
:class:`AnatomyShift` changes a group's end-diastolic anatomy, its motion kept relative
to it. :func:`~.covariate_cohort.make_covariate_cohort` draws a cohort with them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from manifolds.validation import check_rng

from ..errors import CohortError

__all__ = ["AnatomyShift", "Covariates", "number"]

_CLIP = 3.0  # the standard normal draws are clipped to +-3


def number(value, name: str, low: float, high: float) -> float:
    """``value`` as a float in ``[low, high]``, or raise naming ``name``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = float("nan")
    if isinstance(value, bool) or not low <= x <= high:
        raise CohortError(f"{name}: expected a number in [{low:g}, {high:g}], got {value!r}")
    return x


def _check_fields(obj, bounds: dict) -> None:
    """Each field of the frozen dataclass ``obj`` as a float within its bounds."""
    for name, (low, high) in bounds.items():
        value = number(getattr(obj, name), f"{type(obj).__name__}.{name}", low, high)
        object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class AnatomyShift:
    """A change of the end-diastolic anatomy of a group, its motion parameters unchanged.

    The motion parameters (fractions and angles) are applied to the changed anatomy, so
    the motion is the same relative to it: ``scale`` and ``sphericity`` are linear maps
    ``diag(alpha, alpha, beta)`` of both shapes, which leave each subject's ES/ED volume
    ratio exactly unchanged; ``bulge`` changes it slightly (the cavity's weight per level).

    Attributes
    ----------
    scale : float, default 1.0
        Factor of every length (base radius ``a`` and long axis ``c``), in [0.5, 2].
    sphericity : float, default 1.0
        Extra factor of the base radius ``a`` alone (> 1: rounder), in [0.5, 2].
    bulge : float, default 0.0
        Added to the mid-ventricular bulge ``b`` (> 0: wider mid-ventricle), in [-0.2, 0.2].
    """

    scale: float = 1.0
    sphericity: float = 1.0
    bulge: float = 0.0

    def __post_init__(self):
        _check_fields(self, {"scale": (0.5, 2), "sphericity": (0.5, 2), "bulge": (-0.2, 0.2)})

    def apply(self, params):
        """``params`` (a ``SubjectParameters``) with the anatomy changed."""
        return replace(
            params,
            radius=params.radius * self.scale * self.sphericity,
            long_axis=params.long_axis * self.scale,
            bulge=params.bulge + self.bulge,
        )


@dataclass(frozen=True)
class Covariates:
    """Age, sex and body size: their distribution per group and their effect on the shapes.

    Per subject ``z_age, z_size ~ N(0, 1)`` clipped to +-3, and with ``d = imbalance``
    for every group but the first (0 for the first)::

        age       = age_mean + age_sd (z_age + d shift)          (years, rounded to 0.1)
        body_size = 1 + body_size_sd (z_size + d shift)          (rounded to 0.001)
        sex       = "M" for round((male_fraction + d sex_shift) n) of the n subjects

    Effects: ``r0`` and ``l`` are multiplied by
    ``k = (1 - age_effect (age - age_mean) / age_sd) (1 - sex_effect [sex == "M"])`` and
    ``a``, ``c`` by ``body_size``.

    Attributes
    ----------
    age_mean, age_sd : float
        The reference group's age distribution, in years (defaults 60 and 10).
    age_effect : float, default 0.1
        Relative reduction of the contraction per standard deviation of age, in [0, 0.15].
    body_size_sd : float, default 0.08
        Standard deviation of the body size (a length factor, mean 1), in [0, 0.15].
    male_fraction : float, default 0.5
    sex_effect : float, default 0.0
        Relative reduction of the males' contraction, in [-0.2, 0.2] (0: no effect).
    imbalance : float, default 0.0
        How much the other groups' covariates differ from the first group's, in [0, 1].
    shift : float, default 2.0
        The age and body-size shift at ``imbalance = 1``, in standard deviations.
    sex_shift : float, default 0.25
        The change of the fraction of males at ``imbalance = 1``.
    """

    age_mean: float = 60.0
    age_sd: float = 10.0
    age_effect: float = 0.1
    body_size_sd: float = 0.08
    male_fraction: float = 0.5
    sex_effect: float = 0.0
    imbalance: float = 0.0
    shift: float = 2.0
    sex_shift: float = 0.25

    def __post_init__(self):
        _check_fields(self, {
            "age_mean": (0, 150), "age_sd": (0.1, 50), "age_effect": (0, 0.15),
            "body_size_sd": (0, 0.15), "male_fraction": (0, 1), "sex_effect": (-0.2, 0.2),
            "imbalance": (0, 1), "shift": (-2, 2), "sex_shift": (-1, 1),
        })  # fmt: skip
        if not 0 <= self.male_fraction + self.imbalance * self.sex_shift <= 1:
            raise CohortError(
                f"Covariates.sex_shift: male_fraction + imbalance * sex_shift must lie in "
                f"[0, 1], got {self.male_fraction + self.imbalance * self.sex_shift:g}"
            )

    def group_means(self, shifted: bool) -> dict:
        """Expected age and body size and the fraction of males of a group."""
        d = self.imbalance if shifted else 0.0
        return {
            "age": self.age_mean + d * self.shift * self.age_sd,
            "body_size": 1.0 + d * self.shift * self.body_size_sd,
            "male_fraction": self.male_fraction + d * self.sex_shift,
        }

    def draw(self, n: int, shifted: bool, rng: np.random.Generator) -> dict:
        """The covariates of ``n`` subjects of one group (``shifted``: not the first).

        Returns
        -------
        dict
            ``age`` and ``body_size``, float arrays of shape ``(n,)``, and ``sex``, a
            list of ``"F"``/``"M"``.
        """
        rng = check_rng(rng)
        d = self.imbalance * self.shift if shifted else 0.0
        z = np.clip(rng.standard_normal((2, n)), -_CLIP, _CLIP) + d
        age = np.round(self.age_mean + self.age_sd * z[0], 1)
        size = np.round(1.0 + self.body_size_sd * z[1], 3)
        n_male = int(round(self.group_means(shifted)["male_fraction"] * n))
        sex = np.where(rng.permutation(n) < n_male, "M", "F").tolist()
        return {"age": age, "body_size": size, "sex": sex}

    def contraction_factor(self, age, sex) -> np.ndarray:
        """The factor ``k`` of ``r0`` and ``l`` (shape of ``age``; ``sex`` alike)."""
        male = np.asarray(sex) == "M"
        z = (np.asarray(age, dtype=float) - self.age_mean) / self.age_sd
        return (1.0 - self.age_effect * z) * (1.0 - self.sex_effect * male)

    def effects(self) -> dict:
        """JSON-ready truth: each covariate's model and coefficients, and the imbalance."""
        motion = "radial_contraction and longitudinal_shortening"
        age = "1 - age_effect * (age - age_mean) / age_sd"
        return {
            "model": asdict(self),
            "age": {"acts_on": motion, "factor": age,
                    "factor_per_year": -self.age_effect / self.age_sd},
            "sex": {"acts_on": motion, "factor": "1 - sex_effect if sex == 'M' else 1",
                    "male_factor": 1.0 - self.sex_effect},
            "body_size": {"acts_on": "every length of both shapes (radius and long_axis)",
                          "length_exponent": 1, "volume_exponent": 3},
            "imbalance": self.imbalance,
            "reference_group_means": self.group_means(False),
            "other_group_means": self.group_means(True),
        }  # fmt: skip
