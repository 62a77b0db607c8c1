"""Every input table is read by one reader that refuses what it cannot use, in one line
naming the file, the line (the header is line 1) and the column."""

import numpy as np
import pytest

from ladders.statistics import read_design
from ladders.study.cohort import read_groups
from ladders.study.cohort.cohort_table import read_cohort_table
from ladders.study.errors import CohortError, MeshFolderError
from ladders.study.imaging.plane_table import check_plane_table, planes_by_image, read_plane_table
from ladders.study.imaging.series_frames import read_frames_table
from ladders.study.imaging.voxelize import write_label_image
from ladders.study.population.analysis import check_groups_table
from ladders.study.population.model_design import check_design_table
from ladders.study.preparation.landmarks import LandmarkError, read_landmarks
from ladders.tables import Column, TableError, read_table

LANDMARKS = "subject,apex_x,apex_y,apex_z,base_x,base_y,base_z,septum_x,septum_y,septum_z\n"
PLANE = "0,0,80,0,0,1"


def _read(kind, path):
    return {
        "groups": read_groups,
        "design": read_design,
        "landmarks": read_landmarks,
        "planes": read_plane_table,
        "cohort": read_cohort_table,
    }[kind](path)


#: (table, text, the message's expected end: line, column and what is wrong)
REFUSALS = [
    # a second row for one key
    ("groups", "subject,group\na,x\nb,y\na,y\n",
     r"line 4, column 'subject': a second row for subject 'a' \(the first is line 2\)"),
    ("design", "subject,age\na,60\na,61\n", r"line 3, column 'subject': a second row for subject 'a'"),
    ("landmarks", LANDMARKS + "a,0,0,0,0,0,80,-20,0,40\na,0,0,0,0,0,80,-20,0,40\n",
     r"line 3, column 'subject': a second row for subject 'a'"),
    ("planes", f"image,x,y,z,nx,ny,nz,frame\np1,{PLANE},3\np1,{PLANE},3\n",
     r"line 3, column 'image': a second row for image 'p1', frame 3 \(the first is line 2\)"),
    ("planes", f"image,x,y,z,nx,ny,nz\np1.nii.gz,{PLANE}\np1.nii.gz,{PLANE}\n",
     r"line 3, column 'image': a second row for image 'p1.nii.gz'"),
    # a column that would be ignored
    ("groups", "subject,group,age\na,x,60\n", r"line 1, column 'age': not used by this table"),
    ("landmarks", LANDMARKS.strip() + ",note\na,0,0,0,0,0,80,-20,0,40,x\n",
     r"line 1, column 'note': not used"),
    ("planes", f"image,x,y,z,nx,ny,nz,time\np1,{PLANE},0.3\n", r"line 1, column 'time': not used"),
    ("cohort", "subject,ed,es,site\na,a.vtk,b.vtk,x\n", r"line 1, column 'site': not used"),
    # a non-numeric value
    ("landmarks", LANDMARKS + "a,0,0,0,0,0,top,-20,0,40\n",
     r"line 2, column 'base_z': expected a finite number, got 'top'"),
    ("planes", "image,x,y,z,nx,ny,nz\np1,0,0,nan,0,0,1\n",
     r"line 2, column 'z': expected a finite number, got 'nan'"),
    ("planes", f"image,x,y,z,nx,ny,nz,frame\np1,{PLANE},ES\n",
     r"line 2, column 'frame': expected a frame index \(an integer >= 0, 0-based\), got 'ES'"),
    ("planes", f"image,x,y,z,nx,ny,nz,frame\np1,{PLANE},-1\n", r"line 2, column 'frame'"),
    # a missing required column, an empty value, a row longer than the header
    ("groups", "subject,kind\na,x\n", r"line 1: missing column 'group' \(expected the columns subject,group"),
    ("design", "name,age\na,60\n", r"line 1: missing column 'subject'"),
    ("planes", "image,x,y,z,nx,ny\np1,0,0,80,0,0\n", r"line 1: missing column 'nz'"),
    ("cohort", "subject,ed\na,a.vtk\n", r"line 1: missing column 'es'"),
    ("groups", "subject,group\na,\n", r"line 2, column 'group': empty value"),
    ("design", "subject,age\n,60\n", r"line 2, column 'subject': empty value"),
    ("groups", "subject,group\na,x,y\n", r"line 2: 3 values for 2 columns"),
    ("groups", "subject,group,Subject\na,x,a\n", r"line 1, column 'Subject': named twice"),
    ("groups", "subject,group\n", r"no data row below the header"),
    ("groups", "", r"empty file"),
]  # fmt: skip

ERRORS = {"groups": CohortError, "landmarks": LandmarkError, "cohort": MeshFolderError}


@pytest.mark.parametrize(("kind", "text", "message"), REFUSALS)
def test_each_table_refuses_in_one_line_naming_file_line_and_column(tmp_path, kind, text, message):
    path = tmp_path / f"{kind}.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ERRORS.get(kind, TableError), match=message) as info:
        _read(kind, path)
    text = str(info.value)
    assert "\n" not in text and str(path) in text  # one line, naming the file


def test_a_table_read_back_keeps_its_values_order_and_lines(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("\ufeffName , Value,frame\n\nb, 2.5 ,\na,-1e3,4\n")  # BOM, spaces, a blank line
    table = read_table(path, [Column("name"), Column("value", "number"),
                              Column("frame", "frame", required=False)], what="t", key=["name"])  # fmt: skip
    assert table.rows == [{"name": "b", "value": 2.5, "frame": None},
                          {"name": "a", "value": -1000.0, "frame": 4}]  # fmt: skip
    assert table.lines == [3, 4] and table.columns == ("name", "value", "frame")
    assert table.where(1, "value") == f"t {path}, line 4, column 'value'"


def test_the_cut_plane_table_refuses_unknown_images_and_frames_outside_their_series(tmp_path):
    path = tmp_path / "planes.csv"
    path.write_text(f"image,frame,x,y,z,nx,ny,nz\np1,,{PLANE}\np1,2,0,0,70,0,0,1\nq,0,{PLANE}\n")
    table = read_plane_table(path)
    planes = planes_by_image(table)
    assert planes == {"p1": {"all": (0, 0, 80, 0, 0, 1), "2": (0, 0, 70, 0, 0, 1)},
                      "q": {"0": (0, 0, 80, 0, 0, 1)}}  # fmt: skip
    check_plane_table(table, {"p1": 3, "q": None})  # q: a 3-D image, frame 0 only
    with pytest.raises(
        TableError, match=r"line 3, column 'frame': frame 2 is outside the image 'p1' \(2 frames"
    ):
        check_plane_table(table, {"p1": 2, "q": None})
    with pytest.raises(
        TableError, match=r"line 4, column 'image': unknown image 'q' \(known: p1\)"
    ):
        check_plane_table(table, {"p1": 3})


def test_unknown_subjects_are_named_with_their_line(tmp_path):
    groups = tmp_path / "groups.csv"
    groups.write_text("subject,group\na,x\nb,x\nc,x\nzz,y\nd,y\ne,y\nf,y\n")
    with pytest.raises(
        CohortError, match=rf"groups table {groups}, line 5, column 'subject': unknown subject 'zz'"
    ):
        check_groups_table(list("abcdefg"), read_groups(groups))
    known = {s: g for s, g in read_groups(groups).items() if s != "zz"}
    labels, names, kept = check_groups_table(list("abcdefz"), known)
    assert names == ("x", "y") and kept == list("abcdef") and labels.sum() == 3
    design = tmp_path / "design.csv"
    design.write_text("subject,age\na,1\nb,2\nq,3\n")
    with pytest.raises(
        CohortError, match=rf"design table {design}, line 4, column 'subject': unknown subject 'q'"
    ):
        check_design_table(read_design(design), list("abc"))


def test_the_frames_table_names_series_and_refuses_frames_beyond_them(tmp_path):
    ball = np.zeros((6, 6, 6), np.int16)
    ball[2:4, 2:4, 2:4] = 1
    series = tmp_path / "p1.nii.gz"
    from ladders.study.imaging import write_series

    write_series(series, [ball] * 4, np.eye(4))
    write_label_image(tmp_path / "p2_ed.nii.gz", ball, np.eye(4))
    images = [series, tmp_path / "p2_ed.nii.gz"]
    path = tmp_path / "frames.csv"
    path.write_text("subject,ed,es\np1,0,3\n")
    assert read_frames_table(path, images) == {"p1": (0, 3)}
    for text, message in [
        ("subject,ed,es\np1,0,4\n", r"line 2, column 'es': es 4 is outside the series 'p1' \(4 frames: 0 to 3\)"),
        ("subject,ed,es\np2_ed,0,1\n", r"line 2, column 'subject': unknown series 'p2_ed' \(known: p1\)"),
        ("subject,ed,es\np1,0,1\np1,0,2\n", r"line 3, column 'subject': a second row for subject 'p1'"),
        ("subject,ed,es\np1,first,2\n", r"line 2, column 'ed': expected a frame index"),
        ("subject,es\np1,2\n", r"line 1: missing column 'ed'"),
    ]:  # fmt: skip
        path.write_text(text)
        with pytest.raises(TableError, match=message):
            read_frames_table(path, images)
