"""Whole cycles in the study and the analysis: every frame transported, tested per frame and on
the curve's peak and time to peak.

- :mod:`.frame_transport`: :func:`transport_frames`, a subject's frames (ED to frame
  ``t``) carried to the atlas by the pole ladder (Algorithm 1), the midpoint shared;
- :mod:`.cycle_study`: :func:`run_cycle_study`, every subject of a cohort, resumable,
  a failing subject recorded (``symladders cycle-study``);
- :mod:`.cycle_analysis`: :class:`CycleMotion`, every subject's motion through the cycle
  on the atlas and the curve of every vertex (:func:`load_cycle_motion`);
- :mod:`.cycle_responses`: what the tests run on, per frame, the peak and its time, and
  every vertex's trajectory on its principal components (:func:`cycle_responses`);
- :mod:`.cycle_model`: :func:`cycle_model`, a linear model's contrast tested per frame
  (FWER over vertices and frames), on the peak and its time and on the whole
  trajectory (Pillai's trace), with TFCE and AHA segments; :func:`compare_cycles`,
  two groups (``symladders cycle-analyze``).

See ``docs/tracking.md``, "The whole cycle in the study".
"""

from .cycle_analysis import CycleMotion, load_cycle_motion
from .cycle_model import SUMMARIES, CycleTests, compare_cycles, cycle_model
from .cycle_responses import (
    CycleResponses,
    TrajectoryComponents,
    cycle_responses,
    trajectory_components,
)
from .cycle_study import REPORT_FILE, CycleStudyOutcome, read_tracked_frames, run_cycle_study
from .frame_transport import FrameTransport, check_frames, transport_frames
from .peaks import curve_peaks

__all__ = [
    "CycleMotion",
    "CycleTests",
    "compare_cycles",
    "cycle_model",
    "SUMMARIES",
    "CycleResponses",
    "TrajectoryComponents",
    "cycle_responses",
    "trajectory_components",
    "curve_peaks",
    "load_cycle_motion",
    "REPORT_FILE",
    "CycleStudyOutcome",
    "read_tracked_frames",
    "run_cycle_study",
    "FrameTransport",
    "check_frames",
    "transport_frames",
]
