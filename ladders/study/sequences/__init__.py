"""Whole cycles in the study and the analysis: every frame transported, tested per frame and on
the curve's peak and time to peak.

- :mod:`.frame_transport`: :func:`transport_frames`, a subject's frames (ED to frame
  ``t``) carried to the atlas by the pole ladder (Algorithm 1), the midpoint shared;
- :mod:`.cycle_study`: :func:`run_cycle_study`, every subject of a cohort, resumable,
  a failing subject recorded (``symladders cycle-study``);
- :mod:`.cycle_analysis`: :func:`compare_cycles`, two groups tested per frame (FWER
  over vertices and frames) and on the peak inward motion and its time
  (``symladders cycle-analyze``).

See ``docs/tracking.md``, "The whole cycle in the study".
"""

from .cycle_analysis import CycleMotion, CycleTests, compare_cycles, load_cycle_motion
from .cycle_study import REPORT_FILE, CycleStudyOutcome, read_tracked_frames, run_cycle_study
from .frame_transport import FrameTransport, check_frames, transport_frames
from .peaks import curve_peaks

__all__ = [
    "CycleMotion",
    "CycleTests",
    "compare_cycles",
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
