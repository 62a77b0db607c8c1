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
  surfaces and motion (:func:`true_wall_maps`, :func:`true_epicardium`);
- :mod:`.cohort_wall`: every tracked subject's maps, per vertex and AHA segment, a
  resumable batch (:func:`run_wall_maps`, ``symladders wall``);
- :mod:`.wall_cycles`: a cohort's maps as the whole-cycle group tests take a measure
  (:func:`load_wall_cycles`, ``symladders cycle-analyze --measure thickening``).

See ``docs/wall_thickness_strain.md``.
"""

from .cohort_wall import SEGMENT_TABLE, WALL_REPORT, WallOutcome, run_wall_maps
from .maps import PEAK_SENSE, WALL_MEASURES, WallMaps, signed_peaks, wall_maps
from .strain import cardiac_directions, directional_stretch, surface_strains
from .thickness import WallThickness, thickening, wall_thickness
from .truth import true_endocardium, true_epicardium, true_wall_maps
from .wall_cycles import WALL_UNITS, WallCycles, load_wall_cycles

__all__ = [
    "SEGMENT_TABLE",
    "WALL_REPORT",
    "WallOutcome",
    "run_wall_maps",
    "WALL_UNITS",
    "WallCycles",
    "load_wall_cycles",
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
