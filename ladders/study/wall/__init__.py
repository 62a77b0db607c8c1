"""Wall thickness, thickening and strain of the left ventricle, per vertex and per AHA segment.

- :mod:`.thickness`: each endocardial vertex paired with its closest point on the
  epicardium, the distance the wall thickness (:func:`wall_thickness`), and the
  thickening from end-diastole (:func:`thickening`);
- :mod:`.strain`: the circumferential and longitudinal directions from the long axis
  (:func:`cardiac_directions`) and the Lagrangian stretch of a tracked surface along
  them (:func:`directional_stretch`, :func:`surface_strains`);
- :mod:`.maps`: a subject's maps through the cycle (:func:`wall_maps`,
  :class:`WallMaps`), their peaks and AHA segment curves;
- :mod:`.truth`: the synthetic ventricle's true maps, from the generator's exact
  surfaces and motion (:func:`true_wall_maps`, :func:`true_epicardium`).

See ``docs/wall_thickness_strain.md``.
"""

from .maps import PEAK_SENSE, WALL_MEASURES, WallMaps, signed_peaks, wall_maps
from .strain import cardiac_directions, directional_stretch, surface_strains
from .thickness import WallThickness, thickening, wall_thickness
from .truth import true_endocardium, true_epicardium, true_wall_maps

__all__ = [
    "PEAK_SENSE",
    "WALL_MEASURES",
    "WallMaps",
    "signed_peaks",
    "wall_maps",
    "cardiac_directions",
    "directional_stretch",
    "surface_strains",
    "WallThickness",
    "thickening",
    "wall_thickness",
    "true_endocardium",
    "true_epicardium",
    "true_wall_maps",
]
