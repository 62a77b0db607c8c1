"""Units and poses of a cohort: what the report says, a cohort converted, the meshes an atlas
is made of, near-round meshes that are not posed and the poses that must be stopped."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ladders.study import write_mesh
from ladders.study.cohort import Cohort
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.preparation import (
    UnitsError,
    check_cohort_units,
    check_units_and_pose,
    mesh_size,
    principal_frame,
    read_atlas_inputs,
    remesh,
    second_moments,
)
from ladders.study.preparation.pose_angle import moments_angle


@pytest.fixture(scope="module")
def cohort():
    return make_synthetic_cohort(3, n_vertices=150, seed=0)


def in_metres(cohort, name="synthetic_001") -> Cohort:
    subjects = [s if s.name != name else type(s)(s.name, s.ed / 1000, s.es / 1000)
                for s in cohort.subjects]  # fmt: skip
    return Cohort(cohort.atlas, cohort.faces, subjects)


def cohort_meshes(cohort) -> dict:
    return {s.name: {"ed": (s.ed, cohort.faces)} for s in cohort.subjects}


def test_the_report_says_whether_units_were_checked_detected_or_given(cohort):
    metres = in_metres(cohort)
    meshes = cohort_meshes(metres)
    checked = check_units_and_pose(cohort.atlas, cohort.faces, cohort_meshes(cohort))
    assert checked.how == "checked" and checked.converted() == {}
    assert "every mesh's size and pose were checked" in checked.describe()
    detected = check_units_and_pose(cohort.atlas, cohort.faces, meshes, units="auto")
    assert detected.how == "detected" and detected.converted() == {"synthetic_001": "m"}
    assert "Converted to mm: synthetic_001 (from m)" in detected.describe()
    given = check_units_and_pose(cohort.atlas, cohort.faces, meshes, units="mm", allow_scale=True)
    assert given.how == "given" and given.accepted_scale == ["synthetic_001:ed"]
    assert "accepted as they are: synthetic_001:ed" in given.describe()
    record = detected.as_dict()
    assert record["how"] == "detected" and record["factors"]["synthetic_001"] == 1000.0


def test_the_error_in_one_line_names_the_flags(cohort):
    meshes = cohort_meshes(in_metres(cohort))
    with pytest.raises(UnitsError) as info:
        check_units_and_pose(cohort.atlas, cohort.faces, meshes)
    assert "units='m'" in str(info.value)  # the API's spelling
    line = info.value.for_command_line()
    assert "\n" not in line and "synthetic_001:ed: size" in line and "likely in m" in line
    assert "--units" in line and "--allow-scale" in line and "units='m'" not in line
    far = {"a": {"ed": (cohort.subjects[0].ed + [500.0, 0, 0], cohort.faces)}}
    with pytest.raises(UnitsError) as info:
        check_units_and_pose(cohort.atlas, cohort.faces, far)
    assert info.value.kind == "pose" and "--allow-pose" in info.value.for_command_line()


def test_a_cohort_is_converted_into_the_atlas_unit(cohort):
    same, report = check_cohort_units(cohort)
    assert same is cohort and report.factors["synthetic_000"] == 1.0
    metres = in_metres(cohort)
    with pytest.raises(UnitsError, match="synthetic_001:es"):
        check_cohort_units(metres)
    converted, report = check_cohort_units(metres, units="auto")
    assert report.assumed_units == {
        "synthetic_000": "mm",
        "synthetic_001": "m",
        "synthetic_002": "mm",
    }
    for s, original in zip(converted.subjects, cohort.subjects):
        np.testing.assert_allclose(s.es, original.es, rtol=1e-12)
    moved = Cohort(cohort.atlas, cohort.faces, [
        type(s)(s.name, s.ed + [400.0, 0, 0], s.es + [400.0, 0, 0]) for s in cohort.subjects
    ])  # fmt: skip
    with pytest.raises(UnitsError, match="far from the atlas's pose"):
        check_cohort_units(moved)
    _, report = check_cohort_units(moved, allow_pose=True)
    # the ED meshes are placed against the atlas, the ES meshes against their ED (moved too)
    assert report.accepted_pose == [f"{s.name}:ed" for s in cohort.subjects]
    es_alone = Cohort(cohort.atlas, cohort.faces, [
        type(s)(s.name, s.ed, s.es + [400.0, 0, 0]) for s in cohort.subjects
    ])  # fmt: skip
    _, report = check_cohort_units(es_alone, allow_pose=True)
    assert report.accepted_pose == [f"{s.name}:es" for s in cohort.subjects]


def test_the_meshes_of_an_atlas_are_read_in_the_unit_of_the_median_mesh(cohort, tmp_path):
    seg, sizes = tmp_path / "seg", []
    seg.mkdir()
    for i, s in enumerate(cohort.subjects):
        v, f = remesh(s.ed, cohort.faces, 300)
        write_mesh(seg / f"{s.name}_ed.ply", v / (1000 if i == 0 else 1), f)  # no ES
        sizes.append(mesh_size(v, f))
    (seg / "broken_ed.ply").write_text("not a mesh")
    with pytest.raises(UnitsError, match=r"synthetic_000:ed: size .*likely in m\b"):
        read_atlas_inputs(seg)
    inputs = read_atlas_inputs(seg, units="auto")
    assert inputs.names == ["synthetic_000", "synthetic_001", "synthetic_002"]
    assert list(inputs.skipped) == ["broken"] and "MeshFolderError" in inputs.skipped["broken"]
    # the median of the three (synthetic_000, read in metres, is the smallest)
    assert inputs.reference == ["synthetic_001", "synthetic_002"][int(np.argmin(sizes[1:]))]
    for (v, f), size in zip(inputs.meshes, sizes):
        assert mesh_size(v, f) == pytest.approx(size, rel=1e-9)  # all in mm
    (tmp_path / "broken").mkdir()
    (tmp_path / "broken" / "x_ed.ply").write_text("not a mesh")
    with pytest.raises(ValueError, match="none of the 1 ED mesh"):
        read_atlas_inputs(tmp_path / "broken")


# ------------------------------------------------------------------ pose of near-round meshes
@pytest.fixture(scope="module")
def round_subject():
    """The cohort of ``symladders cohort --subjects 45 --seed 31`` (its end-diastoles), and its
    subject whose principal axis the former check took for a pose 57 degrees away."""
    cohort = make_synthetic_cohort(45, seed=31)
    return cohort, next(s for s in cohort.subjects if s.name == "synthetic_036")


def _principal_axis_angle(v, f, atlas, faces) -> float:
    axis, atlas_axis = principal_frame(v, f)[1][:, 0], principal_frame(atlas, faces)[1][:, 0]
    return float(np.degrees(np.arccos(min(1.0, abs(axis @ atlas_axis)))))


def test_a_near_round_subject_is_not_taken_for_a_posed_one(round_subject):
    cohort, s = round_subject
    eigenvalues = np.linalg.eigvalsh(second_moments(s.ed, cohort.faces)[1])[::-1]
    assert (eigenvalues[0] - eigenvalues[1]) / eigenvalues[0] < 0.1  # its long axis: arbitrary
    assert _principal_axis_angle(s.ed, cohort.faces, cohort.atlas, cohort.faces) > 45.0
    report = check_units_and_pose(cohort.atlas, cohort.faces,
                                  {s.name: {"ed": (s.ed, cohort.faces)}})  # fmt: skip
    (size,) = report.meshes
    assert size.measure == "correspondence" and size.angle < 5.0
    v, f = remesh(s.ed, cohort.faces, 1000)  # another triangulation: the second moments
    (size,) = check_units_and_pose(cohort.atlas, cohort.faces, {s.name: {"ed": (v, f)}}).meshes
    assert size.measure == "moments" and size.angle < 20.0
    whole = {x.name: {"ed": (x.ed, cohort.faces)} for x in cohort.subjects}
    assert max(m.angle for m in check_units_and_pose(cohort.atlas, cohort.faces, whole).meshes) < 5


def test_the_moments_angle_is_the_angle_between_long_axes_of_prolate_shapes():
    tensor = np.diag([1.0, 0.3, 0.3])  # long axis x
    for degrees in (0.0, 20.0, 60.0, 90.0):
        turn = Rotation.from_euler("y", degrees, degrees=True).as_matrix()
        turned = turn @ (2 * tensor) @ turn.T  # the scale does not count
        assert moments_angle(turned, tensor) == pytest.approx(degrees, abs=1e-6)
    # a rounder shape turned by 90 degrees: sin^2 scaled by the ratio of the anisotropies
    rounder = np.diag([0.5, 0.4, 0.4])
    turn = Rotation.from_euler("y", 90, degrees=True).as_matrix()
    ratio = (0.1 / 1.3) / (0.7 / 1.6)  # (s_1 - s_3) / (a_1 - a_3), each tensor over its trace
    expected = np.degrees(np.arcsin(np.sqrt(ratio)))
    assert moments_angle(turn @ rounder @ turn.T, tensor) == pytest.approx(expected, abs=1e-6)
    assert moments_angle(np.eye(3), tensor) == 0.0 and moments_angle(tensor, np.eye(3)) == 0.0


@pytest.mark.parametrize("change", ["metres", "turned", "turned, remeshed", "moved"])
def test_what_the_pose_check_must_stop_is_stopped_in_one_line(round_subject, change):
    """Metres, a turn by 90 degrees across the long axis and a move by one atlas size across
    it: each stops the check before any registration, naming the mesh."""
    cohort, _ = round_subject
    s = cohort.subjects[0]
    v, f = s.ed, cohort.faces
    centre, axes = principal_frame(cohort.atlas, cohort.faces)
    if change == "metres":
        v = v / 1000.0
    elif change.startswith("turned"):
        turn = Rotation.from_rotvec(np.pi / 2 * axes[:, 1]).as_matrix()
        middle = second_moments(v, f)[0]
        v = (v - middle) @ turn.T + middle
        if change.endswith("remeshed"):
            v, f = remesh(v, f, 1000)
    else:
        v = v + mesh_size(cohort.atlas, cohort.faces) * axes[:, 2]
    with pytest.raises(UnitsError) as info:
        check_units_and_pose(cohort.atlas, cohort.faces, {s.name: {"ed": (v, f)}})
    line = info.value.for_command_line()
    assert "\n" not in line and f"{s.name}:ed: size" in line
    assert info.value.kind == ("scale" if change == "metres" else "pose")
