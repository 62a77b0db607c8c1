"""A subject's wall maps through the cycle: thickness, thickening and strain per vertex and segment.

:func:`wall_maps` takes a subject's endocardium at every frame (tracked, in the atlas's
vertex correspondence) and its epicardium at every frame (any triangulation) and gives,
per endocardial vertex and frame, a :class:`WallMaps`:

* ``thickness``: the wall thickness (mm, :func:`~.thickness.wall_thickness`);
* ``thickening``: ``T(t) - T(0)`` (mm) and ``radial``: ``T(t) / T(0) - 1``, the radial
  strain (:func:`~.thickness.thickening`);
* ``circumferential``, ``longitudinal``: the endocardium's Lagrangian strains of its ED
  directions (:func:`~.strain.surface_strains`);

every strain dimensionless (``-0.2`` is 20 % shortening). The epicardium of every frame
is first cut at the plane of that frame's endocardial rim (the base: the rim's centroid
and least-squares plane, :func:`~ladders.study.population.valve_planes`): the lid a
label image gives the myocardium at the valve plane, and any epicardium above the base
the endocardium ends at, would otherwise be the closest epicardium of the basal
vertices. :data:`WALL_MEASURES` names
them with their units and :data:`PEAK_SENSE` the sense of their systolic peak:
thickness, thickening and radial strain peak at their largest value, the
circumferential and longitudinal strain at their most negative. :meth:`WallMaps.peak`
is the peak of every vertex's curve over the cycle, refined between frames by the
parabola through the peak frame and its neighbours
(:func:`~ladders.study.sequences.curve_peaks`; the cycle periodic); an AHA segment's
curve is the mean over its vertices at every frame, and its peak the peak of that
curve (:meth:`WallMaps.segment_peaks`), as strain per segment is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..imaging.surface_extraction import cut_at_plane
from ..population.cycle_images import valve_planes
from ..population.segment_table import segment_means
from ..sequences.peaks import curve_peaks
from ..volume import boundary_vertices
from .strain import surface_strains
from .thickness import thickening, wall_thickness

__all__ = ["WALL_MEASURES", "PEAK_SENSE", "WallMaps", "wall_maps", "signed_peaks"]

#: The measures of a :class:`WallMaps` and their units (strains dimensionless).
WALL_MEASURES = {
    "thickness": "mm",
    "thickening": "mm",
    "radial": "strain",
    "circumferential": "strain",
    "longitudinal": "strain",
}

#: The sense of each measure's systolic peak: +1 its largest value, -1 its most negative.
PEAK_SENSE = {"thickness": 1, "thickening": 1, "radial": 1, "circumferential": -1,
              "longitudinal": -1}  # fmt: skip


def _measure_name(name: str) -> str:
    if name not in WALL_MEASURES:
        raise ValueError(f"measure: expected one of {list(WALL_MEASURES)}, got {name!r}")
    return name


def signed_peaks(curves, sense: int) -> np.ndarray:
    """The peak of curves ``(..., n_frames, k)`` in the sense ``+1`` (largest) or ``-1``
    (most negative), refined by the parabola through the peak frame (three frames or
    more; with two, the larger or smaller value), shape ``(..., k)``."""
    x = np.asarray(curves, dtype=np.float64)
    if sense not in (1, -1):
        raise ValueError(f"sense: expected +1 or -1, got {sense!r}")
    if x.shape[-2] < 3:
        return sense * np.max(sense * x, axis=-2)
    return sense * curve_peaks(-sense * x)[0]


@dataclass(frozen=True)
class WallMaps:
    """One subject's wall maps at every frame and endocardial vertex (see the module).

    Attributes
    ----------
    thickness : ndarray, shape (n_frames, k)
        mm.
    circumferential, longitudinal : ndarray, shape (n_frames, k)
        Strain ``lambda - 1`` (0 at frame 0).
    on_rim : ndarray of bool, shape (n_frames, k)
        The thickness was measured to the epicardium's rim (:mod:`.thickness`).
    epicardium : ndarray, shape (n_frames, k, 3), or None
        The paired epicardial points (the endocardium's triangulation on the epicardium).
    """

    thickness: np.ndarray
    circumferential: np.ndarray
    longitudinal: np.ndarray
    on_rim: np.ndarray
    epicardium: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        """Number of frames."""
        return int(self.thickness.shape[0])

    @property
    def thickening(self) -> np.ndarray:
        """``T(t) - T(0)``, mm, shape ``(n_frames, k)``."""
        return thickening(self.thickness)[0]

    @property
    def radial(self) -> np.ndarray:
        """The radial strain ``T(t) / T(0) - 1``, shape ``(n_frames, k)``."""
        return thickening(self.thickness)[1]

    def measure(self, name: str) -> np.ndarray:
        """The map of a measure of :data:`WALL_MEASURES`, shape ``(n_frames, k)``."""
        return np.asarray(getattr(self, _measure_name(name)), dtype=np.float64)

    def peak(self, name: str) -> np.ndarray:
        """Every vertex's systolic peak of a measure (:data:`PEAK_SENSE`), shape ``(k,)``."""
        return signed_peaks(self.measure(name), PEAK_SENSE[_measure_name(name)])

    def segment_curves(self, name: str, segments) -> np.ndarray:
        """The mean over each AHA segment's vertices at every frame, shape ``(n_frames, 17)``.

        ``segments`` (shape ``(k,)``) is each vertex's segment in 1..17 (every segment
        with a vertex, :func:`~ladders.study.population.aha_segments`)."""
        return segment_means(self.measure(name), segments)

    def segment_peaks(self, name: str, segments) -> np.ndarray:
        """The peak of each segment's mean curve, shape ``(17,)``."""
        return signed_peaks(self.segment_curves(name, segments), PEAK_SENSE[name])

    def as_arrays(self) -> dict:
        """The fields as arrays (for ``numpy.savez``; :meth:`from_arrays` reads them back)."""
        out = {"thickness": self.thickness, "circumferential": self.circumferential,
               "longitudinal": self.longitudinal, "on_rim": self.on_rim}  # fmt: skip
        if self.epicardium is not None:
            out["epicardium"] = self.epicardium
        return out

    @classmethod
    def from_arrays(cls, arrays) -> WallMaps:
        """From :meth:`as_arrays`' fields (a dict or an open ``.npz``)."""
        epicardium = arrays["epicardium"] if "epicardium" in arrays else None
        return cls(np.asarray(arrays["thickness"], float), np.asarray(arrays["circumferential"],
                   float), np.asarray(arrays["longitudinal"], float),
                   np.asarray(arrays["on_rim"], bool),
                   None if epicardium is None else np.asarray(epicardium, float))  # fmt: skip


def _below(vertices, faces, plane, frame: int):
    """The epicardium's triangles below the plane (on the apex's side)."""
    v, f = cut_at_plane(np.asarray(vertices, float), np.asarray(faces, np.int64), plane)
    if len(f) == 0:
        raise ValueError(f"epicardia: frame {frame}: no epicardium below the endocardium's rim")
    return v, f


def wall_maps(endocardium, faces, epicardia, apex, base, scale: float = 1.0,
              cut_at_rim: bool = True) -> WallMaps:  # fmt: skip
    """A subject's wall maps at every frame (see the module).

    Parameters
    ----------
    endocardium : array, shape (n_frames, k, 3)
        The endocardium at every frame in vertex correspondence (frame 0 at ED).
    faces : int array, shape (f, 3)
        Its triangles (outward normals).
    epicardia : sequence of (vertices (m_t, 3), faces (g_t, 3))
        The epicardium at every frame, in the endocardium's frame.
    apex, base : array, shape (3,)
        The long axis in that frame (the circumferential and longitudinal directions).
    scale : float, default 1.0
        The frame's scale relative to mm (thicknesses are divided by it; strains do not
        depend on it).
    cut_at_rim : bool, default True
        Cut every epicardium at the plane of the endocardium's rim (see the module);
        an endocardium without a rim (closed) is not cut at.

    Returns
    -------
    WallMaps

    Raises
    ------
    ValueError
        Misshaped input, a number of epicardia other than of frames, a degenerate mesh,
        a thickness at ED that is not > 0.
    """
    x = np.asarray(endocardium, dtype=np.float64)
    if x.ndim != 3 or x.shape[-1] != 3 or len(x) == 0:
        raise ValueError(f"endocardium: expected shape (n_frames, k, 3), got {x.shape}")
    epicardia = list(epicardia)
    if len(epicardia) != len(x):
        raise ValueError(f"epicardia: expected one epicardium per frame ({len(x)}), got "
                         f"{len(epicardia)}")  # fmt: skip
    if cut_at_rim and len(boundary_vertices(faces)) >= 3:
        planes = valve_planes(x, faces)
        epicardia = [_below(v, f, plane, t) for t, ((v, f), plane) in
                     enumerate(zip(epicardia, planes))]  # fmt: skip
    measured = [wall_thickness(x[t], *epicardia[t], scale=scale) for t in range(len(x))]
    thick = np.stack([m.thickness for m in measured])
    thickening(thick)  # refuses a thickness at ED that is not > 0
    circ, lon = surface_strains(x, faces, apex, base)
    return WallMaps(thick, circ, lon, np.stack([m.on_rim for m in measured]),
                    np.stack([m.points for m in measured]))  # fmt: skip
