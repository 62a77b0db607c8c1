"""The inputs of ``symladders run``: the subjects table, the settings file, the model they imply.

Every refusal is one line naming the file, the line and the column (or the key); the
defaults are the stated rules (formula: the covariates, group first; contrasts: each
group against the reference, or the F test over three groups).
"""

import csv
import os

import nibabel as nib
import numpy as np
import pytest

from ladders.study.route import (
    SETTINGS,
    Fingerprints,
    RouteSettingsError,
    SubjectsTableError,
    read_route_settings,
    read_subjects_table,
    route_model,
    settings_template,
)


def _nifti(path, frames=None):
    shape = (4, 4, 4) if frames is None else (4, 4, 4, frames)
    data = np.zeros(shape, np.int16)
    data[1:3, 1:3, 1:3] = 1
    nib.save(nib.Nifti1Image(data, np.eye(4)), str(path))
    return path.name


def _table(folder, header, rows, name="subjects.csv"):
    path = folder / name
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
    return path


@pytest.fixture
def images(tmp_path):
    _nifti(tmp_path / "a_ed.nii.gz")
    _nifti(tmp_path / "a_es.nii.gz")
    _nifti(tmp_path / "b.nii.gz", frames=5)
    _nifti(tmp_path / "c.nii.gz", frames=2)
    return tmp_path


def test_a_valid_table_is_read_with_its_kinds_of_images(images):
    path = _table(images, ["subject", "image", "ed_image", "es_image", "es_frame", "group", "age"],
                  [["s1", "", "a_ed.nii.gz", "a_es.nii.gz", "", "controls", "60"],
                   ["s2", "b.nii.gz", "", "", "3", "patients", "71.5"],
                   ["s3", "c.nii.gz", "", "", "", "patients", "55"]])  # fmt: skip
    table = read_subjects_table(path)
    assert table.subjects == ["s1", "s2", "s3"]
    assert table.covariates == ["group", "age"]
    s1, s2, s3 = table.entries
    assert s1.series is None and s1.ed_image == (images / "a_ed.nii.gz").resolve()
    assert s2.n_frames == 5 and s2.es_frame == 3 and s2.ed_frame is None and s2.tracked
    assert s3.n_frames == 2 and not s3.tracked  # two frames: ED and ES, nothing to track
    assert [e.subject for e in table.tracked] == ["s2"]
    assert table.column("age") == ["60", "71.5", "55"]


@pytest.mark.parametrize(
    "header, row, line, column, words",
    [
        (["subject", "image"], ["s1", "missing.nii.gz"], 2, "image", "no such file"),
        (["subject", "image"], ["s1", "a_ed.nii.gz"], 2, "image", "3-D image"),
        (["subject", "ed_image", "es_image"], ["s1", "b.nii.gz", "a_es.nii.gz"], 2, "ed_image",
         "4-D series"),
        (["subject", "image", "ed_image", "es_image"], ["s1", "b.nii.gz", "a_ed.nii.gz", ""], 2,
         "ed_image", "not both"),
        (["subject", "ed_image", "es_image"], ["s1", "a_ed.nii.gz", ""], 2, "es_image", "together"),
        (["subject", "image"], ["s1", ""], 2, "image", "no image"),
        (["subject", "image", "es_frame"], ["s1", "b.nii.gz", "5"], 2, "es_frame",
         "outside the series' 5 frames"),
        (["subject", "image", "ed_frame"], ["s1", "b.nii.gz", "first"], 2, "ed_frame",
         "expected a frame index"),
        (["subject", "ed_image", "es_image", "ed_frame"], ["s1", "a_ed.nii.gz", "a_es.nii.gz", "0"],
         2, "ed_frame", "goes with a series"),
        (["subject", "image", "ed_frame", "es_frame"], ["s1", "b.nii.gz", "2", "2"], 2, "es_frame",
         "same frame"),
        (["subject", "image", "age"], ["s1", "b.nii.gz", ""], 2, "age", "empty covariate"),
        (["subject", "image"], ["s 1", "b.nii.gz"], 2, "subject", "must start with a letter"),
        (["subject", "image", "apex_x"], ["s1", "b.nii.gz", "1"], 1, "apex_y", "all nine"),
        (["subject", "image", "image"], ["s1", "b.nii.gz", "b.nii.gz"], 1, None, "named twice"),
        (["name", "image"], ["s1", "b.nii.gz"], 1, None, "missing column 'subject'"),
    ],
)  # fmt: skip
def test_a_table_refuses_what_it_cannot_use(images, header, row, line, column, words):
    path = _table(images, header, [row])
    with pytest.raises(SubjectsTableError) as info:
        read_subjects_table(path)
    message = str(info.value)
    assert "\n" not in message
    where = f"{path}, line {line}" + ("" if column is None else f", column {column!r}")
    assert where in message, message
    assert words in message, message


def test_a_duplicate_subject_names_both_lines(images):
    path = _table(images, ["subject", "image"], [["s1", "b.nii.gz"], ["s2", "c.nii.gz"],
                                                 ["s1", "c.nii.gz"]])  # fmt: skip
    with pytest.raises(
        SubjectsTableError, match=r"line 4, column 'subject': .* \(the first is line 2\)"
    ):
        read_subjects_table(path)


def test_incomplete_landmarks_and_a_landmark_that_is_not_a_number(images):
    columns = [f"{n}_{c}" for n in ("apex", "base", "septum") for c in "xyz"]
    good = [str(float(i)) for i in range(9)]
    path = _table(images, ["subject", "image", *columns], [["s1", "b.nii.gz", *good],
                                                           ["s2", "c.nii.gz", *([""] * 9)]])  # fmt: skip
    table = read_subjects_table(path)
    np.testing.assert_array_equal(table.entries[0].landmarks, np.arange(9.0).reshape(3, 3))
    assert table.entries[1].landmarks is None and table.has_landmarks
    bad = good[:4] + ["x"] + good[5:]
    path = _table(images, ["subject", "image", *columns], [["s1", "b.nii.gz", *bad]])
    with pytest.raises(
        SubjectsTableError, match=r"line 2, column 'base_y': expected a finite number"
    ):
        read_subjects_table(path)


def _settings(folder, text):
    path = folder / "study.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_settings_take_their_defaults(tmp_path):
    s = read_route_settings(_settings(tmp_path, 'subjects = "subjects.csv"\n'))
    for section, keys in SETTINGS.items():
        for key, spec in keys.items():
            if (section, key) not in (("", "subjects"), ("", "output")):
                assert s[section][key] == spec.default, (section, key)
    assert s.subjects == (tmp_path / "subjects.csv").resolve()
    assert s.output == (tmp_path / "study_results").resolve()
    assert s["transport"]["alpha2"] == 100.0 and s["atlas"]["subset"] == 50


def test_the_template_reads_back_as_the_defaults(tmp_path):
    path = _settings(tmp_path, settings_template())
    s = read_route_settings(path)
    assert s.given == {"": {"subjects": (tmp_path / "subjects.csv").resolve()}}
    assert s["model"]["permutations"] == 10000 and s["images"]["label"] == 1


@pytest.mark.parametrize(
    "text, key, words",
    [
        ("", "subjects", "missing"),
        ('subjects = "s.csv"\n[image]\nlabel = 1\n', "[image]", "did you mean 'images'"),
        ('subjects = "s.csv"\n[images]\nlabels = 1\n', "images.labels", "did you mean 'label'"),
        ('subjects = "s.csv"\nlabel = 1\n', "label", "a key of a section"),
        ('subjects = "s.csv"\n[images]\nlabel = "1"\n', "images.label", "whole number"),
        ('subjects = "s.csv"\n[model]\ntfce = 1\n', "model.tfce", "true or false"),
        ('subjects = "s.csv"\n[images]\nrv_label = 1\n', "images.rv_label", "must differ"),
        ('subjects = "s.csv"\n[transport]\nalpha2 = 0\n', "transport.alpha2", "positive"),
        ('subjects = "s.csv"\n[model]\nalpha = 1.5\n', "model.alpha", "level in (0, 1)"),
        ('subjects = "s.csv"\n[model]\noutcome = ["time"]\n', "model.outcome", "two columns"),
        ('subjects = "s.csv"\n[execution]\nbackend = "spark"\n', "execution.backend", "loky, dask"),
        ('subjects = "s.csv"\n[execution]\nscheduler = "tcp://h:1"\n', "execution.scheduler",
         "goes with backend"),
    ],
)  # fmt: skip
def test_the_settings_refuse_naming_the_key(tmp_path, text, key, words):
    path = _settings(tmp_path, text)
    with pytest.raises(RouteSettingsError) as info:
        read_route_settings(path)
    assert f"{path}, {key}:" in str(info.value) and words in str(info.value), str(info.value)


def test_a_settings_file_that_is_not_toml(tmp_path):
    with pytest.raises(RouteSettingsError, match="not a TOML file"):
        read_route_settings(_settings(tmp_path, "subjects = \n"))


def _model(folder, header, rows, settings_text=""):
    table_path = _table(folder, header, rows)
    path = _settings(folder, f'subjects = "{table_path.name}"\n{settings_text}')
    settings = read_route_settings(path)
    table = read_subjects_table(settings.subjects, ignore=settings["model"]["ignore"])
    return route_model(table, settings)


def test_the_model_a_table_implies(images):
    rows = [["s1", "b.nii.gz", "patients", "60", "F"], ["s2", "c.nii.gz", "controls", "70", "M"]]
    m = _model(images, ["subject", "image", "age", "group", "sex"],
               [[r[0], r[1], r[3], r[2], r[4]] for r in rows])  # fmt: skip
    assert m.formula == "group + age + sex"  # group first, then the table's order
    assert m.contrasts == ["group[patients] - group[controls]"]
    assert m.groups == ["controls", "patients"] and m.reference == "controls"
    m = _model(images, ["subject", "image", "group"],
               [["s1", "b.nii.gz", "a"], ["s2", "c.nii.gz", "b"], ["s3", "c.nii.gz", "c"]],
               '[model]\nreference = "b"\n')  # fmt: skip
    assert m.contrasts == ["group", "group[a] - group[b]", "group[c] - group[b]"]
    m = _model(images, ["subject", "image", "age", "site"],
               [["s1", "b.nii.gz", "60", "x"], ["s2", "c.nii.gz", "70", "y"]],
               '[model]\nblocks = "site"\n')  # fmt: skip
    assert m.formula == "age" and m.contrasts == ["age"] and m.groups == []
    m = _model(images, ["subject", "image"], [["s1", "b.nii.gz"]])
    assert m.formula is None and m.contrasts == []


def test_a_column_the_model_would_ignore_is_refused(images):
    header = ["subject", "image", "group", "bmi", "notes"]
    rows = [["s1", "b.nii.gz", "a", "20", "x"], ["s2", "c.nii.gz", "b", "25", "y"]]
    with pytest.raises(SubjectsTableError, match=r"line 1, column 'bmi': not in the model 'group'"):
        _model(images, header, rows, '[model]\nformula = "group"\nignore = ["notes"]\n')
    m = _model(images, header, rows, '[model]\nformula = "group"\nignore = ["notes", "bmi"]\n')
    assert m.formula == "group"
    with pytest.raises(
        RouteSettingsError, match=r"model.formula: column 'weight' is not a covariate"
    ):
        _model(images, header, rows, '[model]\nformula = "group + weight"\nignore = ["notes"]\n')
    with pytest.raises(SubjectsTableError, match=r"column 'nothing': listed under 'ignore'"):
        _model(images, header, rows, '[model]\nignore = ["nothing"]\n')
    with pytest.raises(RouteSettingsError, match=r"model.reference: 'c' is not a group"):
        _model(images, header, rows, '[model]\nreference = "c"\nignore = ["notes"]\n')


def test_fingerprints_follow_content_not_time(tmp_path):
    folder = tmp_path / "f"
    folder.mkdir()
    (folder / "a.csv").write_text("x\n1\n")
    prints = Fingerprints()
    first = prints.paths([folder])
    (folder / "a.csv").write_text("x\n1\n")  # the same bytes again, a new time
    os.utime(folder / "a.csv", ns=(1, 1))
    assert prints.paths([folder]) == first
    (folder / "a.csv").write_text("x\n2\n")
    assert prints.paths([folder]) != first
    assert prints.paths([tmp_path / "absent"]) is None
    cached = Fingerprints(prints.cache)  # a later run's cache
    assert cached.paths([folder]) == prints.paths([folder])
