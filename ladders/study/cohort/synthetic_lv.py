"""Synthetic left-ventricle cohort: a parametric model and its seeded generator.

:func:`make_synthetic_cohort` builds a :class:`~ladders.cohort.Cohort` from a
parametric model of the left-ventricle endocardium: a prolate half-ellipsoid,
apex at the origin and open at the base plane, with subject-specific size,
eccentricity and wall shape, and an end-systolic motion made of longitudinal
shortening, radial contraction and a base-to-apex twist. The model, its
parameter ranges and the atlas are described in ``docs/evidence/synthetic_cohort.md``. Units are
millimetres.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from .cohort import Cohort, CohortError, Subject

__all__ = [
    "SyntheticLVModel",
    "SubjectParameters",
    "MotionModulation",
    "grid_shape",
    "lv_grid",
    "lv_shapes",
    "make_synthetic_cohort",
]

#: Ratio ``n_longitude / n_latitude`` giving near-isotropic cells at the base.
GRID_ASPECT = 1.7


@dataclass(frozen=True)
class SyntheticLVModel:
    """Parameter ranges of the synthetic left-ventricle model (all uniform draws).

    Lengths are in millimetres, rotations in degrees, the other ranges are
    dimensionless fractions. See ``docs/evidence/synthetic_cohort.md`` for the formulas.

    Attributes
    ----------
    radius : (float, float)
        End-diastole base radius ``a`` (semi-minor axis of the ellipsoid).
    long_axis : (float, float)
        End-diastole apex-to-base length ``c`` (semi-major axis).
    bulge : (float, float)
        Coefficient ``b`` of the mid-ventricular ``sin(2 theta)`` radial term.
    harmonic_amplitude : float
        The coefficients of ``cos(m phi)`` and ``sin(m phi)`` are drawn in
        ``[-A/m, A/m]``, ``m = 1..n_harmonics``.
    n_harmonics : int
        Number of azimuthal harmonics of the wall shape.
    longitudinal_shortening : (float, float)
        Fraction ``l`` by which the apex-to-base length shortens at end-systole.
    radial_contraction : (float, float)
        Mean fraction ``r0`` by which the distance to the long axis shrinks.
    contraction_heterogeneity : (float, float)
        Amplitude ``delta`` of the azimuthal variation of the radial contraction.
    contraction_gradient : (float, float)
        Apex-to-base gradient ``gamma`` of the radial contraction.
    apex_rotation : (float, float)
        Rotation of the apex about ``+z`` in degrees (counterclockwise, positive).
    base_rotation : (float, float)
        Rotation of the base about ``+z`` in degrees, applied with a minus sign.
    """

    radius: tuple[float, float] = (18.0, 32.0)
    long_axis: tuple[float, float] = (72.0, 98.0)
    bulge: tuple[float, float] = (-0.05, 0.10)
    harmonic_amplitude: float = 0.10
    n_harmonics: int = 3
    longitudinal_shortening: tuple[float, float] = (0.12, 0.18)
    radial_contraction: tuple[float, float] = (0.25, 0.33)
    contraction_heterogeneity: tuple[float, float] = (0.0, 0.15)
    contraction_gradient: tuple[float, float] = (-0.10, 0.10)
    apex_rotation: tuple[float, float] = (4.0, 9.0)
    base_rotation: tuple[float, float] = (2.0, 6.0)


_RANGES = (
    "radius",
    "long_axis",
    "bulge",
    "longitudinal_shortening",
    "radial_contraction",
    "contraction_heterogeneity",
    "contraction_gradient",
    "apex_rotation",
    "base_rotation",
)


@dataclass(frozen=True)
class SubjectParameters:
    """Parameters of one shape pair of the synthetic model (see :class:`SyntheticLVModel`).

    ``harmonics`` has shape ``(n_harmonics, 2)``: the ``cos(m phi)`` and
    ``sin(m phi)`` coefficients of harmonic ``m = row + 1``.
    ``heterogeneity_phase`` (radians) is where the radial contraction peaks.
    """

    radius: float
    long_axis: float
    bulge: float
    harmonics: np.ndarray
    longitudinal_shortening: float
    radial_contraction: float
    contraction_heterogeneity: float
    heterogeneity_phase: float
    contraction_gradient: float
    apex_rotation: float
    base_rotation: float

    @classmethod
    def draw(cls, model: SyntheticLVModel, rng: np.random.Generator) -> SubjectParameters:
        """Draw one subject's parameters with ``rng`` (fixed order of draws)."""
        values = {name: float(rng.uniform(*getattr(model, name))) for name in _RANGES}
        bound = model.harmonic_amplitude / np.arange(1, model.n_harmonics + 1)
        harmonics = rng.uniform(-1.0, 1.0, size=(model.n_harmonics, 2)) * bound[:, None]
        phase = float(rng.uniform(0.0, 2.0 * np.pi))
        return cls(harmonics=harmonics, heterogeneity_phase=phase, **values)

    @classmethod
    def mean(cls, model: SyntheticLVModel) -> SubjectParameters:
        """Mid-range parameters with no harmonics and no heterogeneity (the atlas)."""
        values = {name: 0.5 * sum(getattr(model, name)) for name in _RANGES}
        values["contraction_heterogeneity"] = 0.0
        return cls(harmonics=np.zeros((model.n_harmonics, 2)), heterogeneity_phase=0.0, **values)

    def as_dict(self) -> dict:
        """Plain dictionary of the parameters (harmonics as a nested list)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out["harmonics"] = np.asarray(self.harmonics).tolist()
        return out


def grid_shape(n_vertices: int) -> tuple[int, int]:
    """``(n_longitude, n_latitude)`` of the grid with about ``n_vertices`` vertices.

    The mesh has ``1 + n_longitude * n_latitude`` vertices (apex plus rings);
    the ratio ``n_longitude / n_latitude`` is kept near ``GRID_ASPECT``.
    """
    n = int(n_vertices)
    if n < 10:
        raise CohortError(f"n_vertices: need at least 10 vertices, got {n_vertices}")
    n_lat = max(2, int(round(np.sqrt((n - 1) / GRID_ASPECT))))
    n_lon = max(3, int(round((n - 1) / n_lat)))
    return n_lon, n_lat


def lv_grid(
    n_longitude: int, n_latitude: int, model: SyntheticLVModel | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Parametric coordinates and triangles of the (longitude x latitude) grid.

    Vertex 0 is the apex; ring ``j = 1..n_latitude`` holds vertices
    ``1 + (j-1) n_longitude ...``, the last ring being the open base. The polar
    angles are spaced uniformly in arc length along the mean shape's meridian.
    The longitude decreases along a ring so that the faces, oriented with
    outward normals, list the vertices for the first time in increasing order.

    Returns
    -------
    theta : ndarray, shape (k,)
        Polar angle from the apex, ``0`` at the apex, ``pi/2`` on the base.
    phi : ndarray, shape (k,)
        Longitude (radians).
    faces : ndarray of int, shape (2 n_longitude n_latitude - n_longitude, 3)
    """
    n_lon, n_lat = int(n_longitude), int(n_latitude)
    if n_lon < 3 or n_lat < 1:
        raise CohortError(
            f"grid: need n_longitude >= 3 and n_latitude >= 1, got ({n_lon}, {n_lat})"
        )
    p = SubjectParameters.mean(model or SyntheticLVModel())
    fine = np.linspace(0.0, 0.5 * np.pi, 4001)
    seg = np.hypot(np.diff(p.radius * np.sin(fine)), np.diff(p.long_axis * np.cos(fine)))
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    ring_theta = np.interp(np.linspace(0.0, arc[-1], n_lat + 1)[1:], arc, fine)
    ring_phi = -2.0 * np.pi * np.arange(n_lon) / n_lon
    theta = np.concatenate([[0.0], np.repeat(ring_theta, n_lon)])
    phi = np.concatenate([[0.0], np.tile(ring_phi, n_lat)])

    i = np.arange(n_lon)
    nxt = (i + 1) % n_lon
    tris = [np.stack([np.zeros(n_lon, dtype=np.int64), 1 + i, 1 + nxt], axis=1)]
    for j in range(n_lat - 1):
        a, b = 1 + j * n_lon, 1 + (j + 1) * n_lon
        quad = np.empty((2 * n_lon, 3), dtype=np.int64)
        quad[0::2] = np.stack([a + i, b + i, b + nxt], axis=1)
        quad[1::2] = np.stack([a + i, b + nxt, a + nxt], axis=1)
        tris.append(quad)
    return theta, phi, np.concatenate(tris).astype(np.int64)


@dataclass(frozen=True)
class MotionModulation:
    """Per-vertex changes of the end-systolic motion (a regional abnormality).

    Each array has one value per vertex of the grid, shape ``(k,)``. The
    end-systolic motion of :func:`lv_shapes` becomes, at every vertex,
    ``r -> radial * r``, ``l -> longitudinal * l`` and ``psi -> rotation * psi + twist``:
    ``radial = longitudinal = rotation = 1`` and ``twist = 0`` leave the motion unchanged.

    Attributes
    ----------
    radial : ndarray, shape (k,)
        Factor of the radial contraction (dimensionless; 0 is akinetic).
    longitudinal : ndarray, shape (k,)
        Factor of the longitudinal shortening (dimensionless).
    twist : ndarray, shape (k,)
        Rotation about the long axis added to ``psi``, in degrees.
    rotation : ndarray, shape (k,), or None
        Factor of the rotation ``psi`` (None: 1).
    """

    radial: np.ndarray
    longitudinal: np.ndarray
    twist: np.ndarray
    rotation: np.ndarray | None = None


def lv_shapes(
    params: SubjectParameters,
    theta: np.ndarray,
    phi: np.ndarray,
    modulation: MotionModulation | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """End-diastole and end-systole vertices of one subject on a parametric grid.

    End-diastole, with ``u = 1 - cos(theta)`` the normalised height::

        rho = a sin(theta) [1 + b sin(2 theta) + sin(theta) sum_m (p_m cos m phi + q_m sin m phi)]
        (x, y, z) = (rho cos phi, rho sin phi, c u)

    End-systole: ``z' = (1 - l) z``, ``rho' = (1 - r) rho`` with
    ``r = r0 (1 + delta cos(phi - phi0)) (1 + gamma (1 - 2u))``, and a rotation
    about ``+z`` by ``psi = tau_apex (1 - u) - tau_base u``.

    Parameters
    ----------
    params : SubjectParameters
    theta, phi : ndarray, shape (k,)
        Parametric coordinates from :func:`lv_grid`.
    modulation : MotionModulation, optional
        A regional change of the end-systolic motion (the end-diastolic shape is
        unchanged); see :mod:`ladders.study.cohort.planted_effect`.

    Returns
    -------
    ed, es : ndarray, shape (k, 3)
    """
    theta = np.asarray(theta, dtype=float)
    phi = np.asarray(phi, dtype=float)
    s = np.sin(theta)
    u = 1.0 - np.cos(theta)
    m = np.arange(1, len(params.harmonics) + 1)[:, None]
    h = np.asarray(params.harmonics)
    wave = (h[:, :1] * np.cos(m * phi) + h[:, 1:] * np.sin(m * phi)).sum(axis=0)
    rho = params.radius * s * (1.0 + params.bulge * np.sin(2.0 * theta) + s * wave)
    z = params.long_axis * u
    ed = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=-1)

    r = (
        params.radial_contraction
        * (1.0 + params.contraction_heterogeneity * np.cos(phi - params.heterogeneity_phase))
        * (1.0 + params.contraction_gradient * (1.0 - 2.0 * u))
    )
    shortening = np.full_like(z, params.longitudinal_shortening)
    psi_deg = params.apex_rotation * (1.0 - u) - params.base_rotation * u
    if modulation is not None:
        r = r * modulation.radial
        shortening = shortening * modulation.longitudinal
        if modulation.rotation is not None:
            psi_deg = psi_deg * modulation.rotation
        psi_deg = psi_deg + modulation.twist
    psi = np.deg2rad(psi_deg)
    rho_es = (1.0 - r) * rho
    es = np.stack(
        [
            rho_es * np.cos(phi + psi),
            rho_es * np.sin(phi + psi),
            (1.0 - shortening) * z,
        ],
        axis=-1,
    )
    return ed, es


def _seed_sequence(seed) -> np.random.SeedSequence:
    if isinstance(seed, np.random.Generator):
        return np.random.SeedSequence(int(seed.integers(0, 2**63)))
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
        return np.random.SeedSequence(int(seed))
    raise CohortError(f"seed: expected a non-negative int or a numpy Generator, got {seed!r}")


def make_synthetic_cohort(
    n_subjects: int = 138,
    n_vertices: int = 1009,
    seed: int | np.random.Generator = 0,
    model: SyntheticLVModel | None = None,
    grid: tuple[int, int] | None = None,
) -> Cohort:
    """Synthetic cohort of left-ventricle-like meshes in vertex correspondence.

    Subject ``i`` is drawn with its own generator, built from the child
    ``SeedSequence(seed, spawn_key=(i,))``: it does not depend on ``n_subjects``,
    so a small cohort is the head of a larger one with the same seed. The
    atlas is the shape of the mid-range parameters without wall harmonics.

    Parameters
    ----------
    n_subjects : int
        Number of subjects (the paper's study has 138).
    n_vertices : int
        Approximate number of vertices per mesh, rounded to the grid
        ``1 + n_longitude * n_latitude`` by :func:`grid_shape`: the default 1009
        is the grid (42, 24) exactly (mean edge 3.9 mm on the atlas; 241 gives 8 mm),
        and 1000 rounds to it. Ignored
        when ``grid`` is given.
    seed : int or numpy.random.Generator
        Seed of all random draws.
    model : SyntheticLVModel, optional
        Parameter ranges; defaults to ``SyntheticLVModel()``.
    grid : (int, int), optional
        Explicit ``(n_longitude, n_latitude)``.

    Returns
    -------
    Cohort
        Atlas ``(k, 3)``, faces ``(f, 3)`` and subjects with ``ed``, ``es`` of
        shape ``(k, 3)`` and their drawn ``parameters``.
    """
    model = model or SyntheticLVModel()
    n_subjects = int(n_subjects)
    if n_subjects < 0:
        raise CohortError(f"n_subjects: must be non-negative, got {n_subjects}")
    n_lon, n_lat = grid if grid is not None else grid_shape(n_vertices)
    theta, phi, faces = lv_grid(n_lon, n_lat, model)
    root = _seed_sequence(seed)
    atlas, _ = lv_shapes(SubjectParameters.mean(model), theta, phi)
    subjects = []
    for i in range(n_subjects):
        child = np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, i))
        params = SubjectParameters.draw(model, np.random.default_rng(child))
        ed, es = lv_shapes(params, theta, phi)
        subjects.append(Subject(f"synthetic_{i:03d}", ed, es, params))
    source = f"make_synthetic_cohort(n_subjects={n_subjects}, grid=({n_lon}, {n_lat}))"
    return Cohort(atlas, faces, subjects, source)
