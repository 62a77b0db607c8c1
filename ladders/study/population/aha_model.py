"""The AHA 17-segment model on any atlas mesh, placed by three anatomical landmarks.

:func:`aha_segments` gives every vertex of a mesh its segment of the American
Heart Association's model (Cerqueira et al., Circulation 2002) from the apex,
the centre of the base plane and a point of the septal wall, with the same
rings and sectors as the synthetic cohort's parametrisation
(:mod:`ladders.study.cohort.aha_segments`):

* the long axis ``a`` runs from the apex to the base-plane centre; a vertex
  ``x`` has the normalised height ``u = (x - apex) . a / |base - apex|``,
  clipped to ``[0, 1]`` (0 at the apex, 1 on the base plane);
* the rings are those of ``RING_HEIGHTS``: apex ``u < 0.10`` (segment 17),
  apical ``[0.10, 0.40)`` (13-16), mid ``[0.40, 0.70)`` (7-12), basal
  ``[0.70, 1]`` (1-6);
* the septal direction ``s`` is the septal point's offset from the apex
  projected onto the short-axis plane (orthogonal to ``a``), normalised; the
  lateral direction is ``-s`` and the anterior direction ``s x a`` (the cross
  product of the septal direction with the long axis, in this order). The
  circumferential angle of a vertex is measured in the short-axis plane from the
  lateral direction towards the anterior one, so that the septum is at 180
  degrees and the anterior wall at 90, as in the synthetic cohort: there
  ``a = +z`` (apex at the origin, base at ``z = c``) and ``s = -x``, hence
  ``s x a = +y``. Seen from the base looking down the long axis towards the
  apex, the anterior wall is up, the septum left and the lateral wall right,
  and the angle increases counter-clockwise: segments 1 to 6 follow each other
  counter-clockwise from the anterior wall through the septum.

The sign of the anterior direction is a convention that only the landmarks fix:
a mirrored mesh (with mirrored landmarks) exchanges anterior and inferior.

:func:`read_aha_landmarks` reads the landmarks from a small JSON file or from
the project's landmark table (:func:`~ladders.study.preparation.landmarks.read_landmarks`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..cohort.aha_segments import AHA_SEGMENTS, RING_HEIGHTS
from ..errors import CohortError
from ..preparation.landmarks import LandmarkError, Landmarks, read_landmarks

__all__ = [
    "AHA_NAMES",
    "N_SEGMENTS",
    "AHA_JSON_KEYS",
    "aha_frame",
    "aha_segments",
    "read_aha_landmarks",
]

#: Number of segments of the model.
N_SEGMENTS = 17

#: ``segment number -> name`` in the standard order ("basal anterior" ... "apex").
AHA_NAMES = {
    number: ring if ring == "apex" else f"{ring} {sector}"
    for number, (ring, sector, _, _) in sorted(AHA_SEGMENTS.items())
}

# Rounding of the height and of the angle (degrees) before the segments are assigned.
_HEIGHT_DIGITS = 9
_ANGLE_DIGITS = 7

#: The keys of a JSON landmark file (:func:`read_aha_landmarks`).
AHA_JSON_KEYS = ("apex", "base_centre", "septal_point")


def _point(value, name: str) -> np.ndarray:
    p = np.asarray(value, dtype=float)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise CohortError(f"{name}: expected 3 finite coordinates, got {np.asarray(value)!r}")
    return p


def aha_frame(apex, base_centre, septal_point) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The long axis, septal and anterior unit vectors and the apex-to-base length.

    Parameters
    ----------
    apex, base_centre, septal_point : array, shape (3,)

    Returns
    -------
    axis, septal, anterior : ndarray, shape (3,)
        ``axis`` from the apex to the base-plane centre, ``septal`` the septal
        point's direction orthogonal to it, ``anterior = septal x axis`` (module).
    length : float
        Distance from the apex to the base-plane centre.

    Raises
    ------
    CohortError
        Non-finite or misshaped points, the apex on the base-plane centre or the
        septal point on the long axis, naming the arguments.
    """
    apex = _point(apex, "apex")
    base = _point(base_centre, "base_centre")
    septum = _point(septal_point, "septal_point")
    offset = base - apex
    length = float(np.linalg.norm(offset))
    scale = max(float(np.abs(apex).max()), float(np.abs(base).max()), 1.0)
    if length <= 1e-12 * scale:
        raise CohortError("apex, base_centre: the apex and the base-plane centre coincide")
    axis = offset / length
    radial = septum - apex
    radial = radial - (radial @ axis) * axis
    if np.linalg.norm(radial) <= 1e-6 * length:
        raise CohortError("septal_point: lies on the long axis (no septal direction)")
    septal = radial / np.linalg.norm(radial)
    return axis, septal, np.cross(septal, axis), length


def _check_faces(faces, k: int) -> None:
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
        raise CohortError(f"faces: expected integer triangles (f, 3), got {f.dtype} {f.shape}")
    if f.size and (f.min() < 0 or f.max() >= k):
        raise CohortError(f"faces: vertex indices must lie in 0..{k - 1}, got {f.min()}..{f.max()}")


def _labels(u: np.ndarray, angle_deg: np.ndarray) -> np.ndarray:
    """Segment of each (height, angle) pair, the boundaries as in ``segment_of``."""
    out = np.full(u.shape, N_SEGMENTS, dtype=np.int64)
    for number, (ring, _, centre, width) in AHA_SEGMENTS.items():
        if ring == "apex":
            continue
        low, high = RING_HEIGHTS[ring]
        in_ring = (u >= low) & ((u < high) if ring != "basal" else (u <= high))
        offset = (angle_deg - centre + 180.0) % 360.0 - 180.0
        out[in_ring & (np.abs(offset) <= 0.5 * width)] = number
    return out


def aha_segments(vertices, apex, base_centre, septal_point, faces=None) -> np.ndarray:
    """The AHA segment (1..17) of every vertex of a left-ventricle mesh (see the module).

    Parameters
    ----------
    vertices : array, shape (k, 3)
        The mesh's vertices (e.g. the atlas), in the landmarks' coordinates.
    apex, base_centre, septal_point : array, shape (3,)
        The landmarks: the apex, the centre of the base plane and any point of
        the septal wall.
    faces : int array, shape (f, 3), optional
        The mesh's triangles; only checked against the vertices (the segments
        depend on the vertices and the landmarks alone).

    Returns
    -------
    ndarray of int, shape (k,)
        Segment numbers in 1..17. Heights below the apex count as the apex and
        above the base plane as the basal ring. A coarse mesh may leave a segment
        without a vertex; :func:`~.segment_table.segment_table` refuses it.

    Raises
    ------
    CohortError
        Misshaped or non-finite vertices or landmarks, degenerate landmarks or faces
        that do not index the vertices, naming the argument.
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise CohortError(f"vertices: expected an array (k, 3), got shape {v.shape}")
    if not np.isfinite(v).all():
        raise CohortError("vertices: contain NaN or infinite coordinates")
    if faces is not None:
        _check_faces(faces, len(v))
    axis, septal, anterior, length = aha_frame(apex, base_centre, septal_point)
    r = v - np.asarray(apex, dtype=float)
    u = np.clip((r @ axis) / length, 0.0, 1.0)
    angle = np.degrees(np.arctan2(r @ anterior, -(r @ septal))) % 360.0
    # a vertex on a boundary (up to rounding) goes to the same side whatever the pose
    return _labels(np.round(u, _HEIGHT_DIGITS), np.round(angle, _ANGLE_DIGITS) % 360.0)


def _json_landmarks(path: Path) -> Landmarks:
    try:
        data = json.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError) as exc:
        raise LandmarkError(f"landmarks: cannot read {path}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise LandmarkError(f"landmarks {path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise LandmarkError(f"landmarks {path}: expected a JSON object with keys {AHA_JSON_KEYS}")
    missing = [key for key in AHA_JSON_KEYS if key not in data]
    if missing:
        raise LandmarkError(
            f"landmarks {path}: missing key(s) {missing}; expected {list(AHA_JSON_KEYS)}"
        )
    points = []
    for key in AHA_JSON_KEYS:
        try:
            points.append(_point(data[key], key))
        except (CohortError, TypeError, ValueError):
            raise LandmarkError(
                f"landmarks {path}: {key}: expected 3 finite coordinates, got {data[key]!r}"
            ) from None
    try:
        aha_frame(*points)
        return Landmarks(*points)
    except CohortError as exc:
        raise LandmarkError(f"landmarks {path}: {exc}") from None


def read_aha_landmarks(path, subject: str = "atlas") -> Landmarks:
    """The landmarks that place the AHA segments on a mesh, from a file.

    Two formats, told apart by the file's suffix:

    * ``.json``: one object with three points in the mesh's coordinates::

          {"apex": [0, 0, 0], "base_centre": [0, 0, 85], "septal_point": [-24, 0, 40]}

    * anything else: the project's landmark table (a CSV file, see
      :mod:`ladders.study.preparation.landmarks`), of which the row ``subject``
      (default ``atlas``) is used.

    Parameters
    ----------
    path : str or Path
    subject : str, default "atlas"
        The row of a landmark table.

    Returns
    -------
    Landmarks
        ``apex``, ``base`` (the base-plane centre) and ``septum``, each ``(3,)``.

    Raises
    ------
    LandmarkError
        An unreadable file, a missing key, column or row, or degenerate
        landmarks; the message names the file and the culprit.
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        return _json_landmarks(path)
    table = read_landmarks(path)
    if subject not in table:
        names = sorted(table)
        shown = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
        raise LandmarkError(f"landmarks {path}: no row {subject!r} (rows: {shown})")
    return table[subject]
