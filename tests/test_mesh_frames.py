"""``symladders mesh`` on 4-D series: ED and ES given, tabled, or found (ES: the frame of
least cavity volume), recorded; cut planes per frame; tables refused in one line."""

import csv
import json

import numpy as np
import pytest

from ladders.study.cli import main
from ladders.study.imaging import write_series
from ladders.study.imaging.series_frames import least_volume_frame
from ladders.study.meshes import read_mesh
from ladders.study.volume import enclosed_volume

#: Anisotropic voxels (a short-axis stack): 1.5 x 1.5 x 2 mm.
AFFINE = np.diag([1.5, 1.5, 2.0, 1.0])
#: The cavity's half-widths in voxels per frame: least at frame 3 (ES), largest at 0 (ED).
HALF = (7, 6, 5, 3, 4, 6)


def _series(path, half=HALF, shift=0):
    frames = []
    for h in half:
        labels = np.zeros((20, 20, 14), np.int16)
        labels[
            10 - h : 10 + h, 10 - h + shift : 10 + h + shift, 7 - h // 2 - 1 : 7 + h // 2 + 1
        ] = 1
        frames.append(labels)
    return write_series(path, frames, AFFINE)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    folder = tmp_path_factory.mktemp("series")
    _series(folder / "p1.nii.gz")
    _series(folder / "p2.nii.gz", half=(6, 6, 2, 4, 5))  # least at frame 2
    return sorted(folder.glob("*.nii.gz"))


def _rows(folder):
    with open(folder / "meshing.csv", encoding="utf-8") as fh:
        return {r["mesh"]: r for r in csv.DictReader(fh)}


def test_the_least_volume_frame_is_the_true_end_systole(images):
    frame, volumes = least_volume_frame(images[0], 1)
    voxel = 1.5 * 1.5 * 2.0
    counts = [(2 * h) ** 2 * (2 * (h // 2) + 2) for h in HALF]
    assert frame == 3 == int(np.argmin(counts))
    np.testing.assert_allclose(volumes, np.array(counts) * voxel, rtol=1e-12)
    assert least_volume_frame(images[1], 1)[0] == 2


def test_without_frames_a_series_is_meshed_at_frame_0_and_its_least_volume(images, tmp_path):
    out = tmp_path / "auto"
    argv = ["mesh", *map(str, images), "--label", "1", "-o", str(out), "--vertices", "0",
            "--no-progress", "--jobs", "1"]  # fmt: skip
    assert main(argv) == 0
    rows = _rows(out)
    assert {(m, rows[m]["frame"], rows[m]["frame_choice"]) for m in rows} == {
        ("p1_ed.vtk", "0", "first frame"), ("p1_es.vtk", "3", "least volume"),
        ("p2_ed.vtk", "0", "first frame"), ("p2_es.vtk", "2", "least volume"),
    }  # fmt: skip
    record = json.loads((out / "p1_es.json").read_text())
    assert record["frame"] == 3 and record["frame_choice"] == "least volume"
    assert int(np.argmin(record["cavity_volumes_mm3"])) == 3
    ed, es = (enclosed_volume(*read_mesh(out / f"p1_{p}.vtk")) for p in ("ed", "es"))
    assert es < 0.4 * ed  # the ES mesh is the small cavity (frame 3), not another frame
    assert main(argv) == 0  # a rerun reuses the four meshes
    assert {r["status"] for r in _rows(out).values()} == {"skipped"}


def test_the_frames_given_or_tabled_are_used_and_recorded(images, tmp_path):
    assert main(["mesh", str(images[0]), "--label", "1", "--frames", "1,4", "-o",
                 str(tmp_path / "given"), "--no-progress", "--jobs", "1"]) == 0  # fmt: skip
    rows = _rows(tmp_path / "given")
    assert (rows["p1_ed.vtk"]["frame"], rows["p1_es.vtk"]["frame"]) == ("1", "4")
    assert rows["p1_es.vtk"]["frame_choice"] == "given"
    table = tmp_path / "frames.csv"
    table.write_text("subject,ed,es\np2,1,4\n")  # p1 has no row: found
    assert main(["mesh", *map(str, images), "--label", "1", "--frames", str(table), "-o",
                 str(tmp_path / "table"), "--no-progress", "--jobs", "1"]) == 0  # fmt: skip
    rows = _rows(tmp_path / "table")
    assert (rows["p2_ed.vtk"]["frame"], rows["p2_es.vtk"]["frame"]) == ("1", "4")
    assert rows["p2_es.vtk"]["frame_choice"] == "table"
    assert (rows["p1_es.vtk"]["frame"], rows["p1_es.vtk"]["frame_choice"]) == ("3", "least volume")


@pytest.mark.parametrize(
    ("flag", "text", "message"),
    [
        ("--frames", "subject,ed,es\np1,0,6\n", "line 2, column 'es': es 6 is outside the series 'p1'"),
        ("--frames", "subject,ed,es\np3,0,1\n", "line 2, column 'subject': unknown series 'p3'"),
        ("--frames", "subject,ed,es,note\np1,0,1,x\n", "line 1, column 'note': not used"),
        ("--cut-planes", "image,frame,x,y,z,nx,ny,nz\np1,3,0,0,9,0,0,1\np1,3,0,0,8,0,0,1\n",
         "line 3, column 'image': a second row for image 'p1', frame 3"),
        ("--cut-planes", "image,frame,x,y,z,nx,ny,nz\np1,6,0,0,9,0,0,1\n",
         "line 2, column 'frame': frame 6 is outside the image 'p1'"),
        ("--cut-planes", "image,x,y,z,nx,ny,nz\nq.nii.gz,0,0,9,0,0,1\n",
         "line 2, column 'image': unknown image 'q.nii.gz'"),
    ],
)  # fmt: skip
def test_a_table_it_cannot_use_stops_the_command_in_one_line(
    images, tmp_path, capsys, flag, text, message
):
    table = tmp_path / "t.csv"
    table.write_text(text)
    argv = ["mesh", *map(str, images), "--label", "1", flag, str(table), "-o", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"symladders mesh: error: {flag}: ") and str(table) in err
    assert message in err and "\n" not in err
    assert not (tmp_path / "o").exists()  # refused before any work


def test_a_plane_for_one_frame_cuts_that_frame_only(images, tmp_path):
    table = tmp_path / "planes.csv"
    # frame 0 (ED, voxel centres at z = 6 to 20 mm) cut at 10 mm; frame 3 (ES, 10 to 16 mm) whole
    table.write_text("image,frame,x,y,z,nx,ny,nz\np1,0,0,0,10,0,0,1\n")
    assert main(["mesh", str(images[0]), "--label", "1", "--cut-planes", str(table), "-o",
                 str(tmp_path / "o"), "--vertices", "0", "--cut-margin", "0", "--no-progress",
                 "--jobs", "1"]) == 0  # fmt: skip
    ed = read_mesh(tmp_path / "o" / "p1_ed.vtk")[0]
    es = read_mesh(tmp_path / "o" / "p1_es.vtk")[0]
    assert ed[:, 2].max() < 11.0 and es[:, 2].max() > 16.0  # within the smoothing of a voxel
    records = [json.loads((tmp_path / "o" / f"p1_{p}.json").read_text()) for p in ("ed", "es")]
    assert records[0]["settings"]["cut_plane"] == [0, 0, 10, 0, 0, 1]
    assert records[1]["settings"]["cut_plane"] is None


def _worker_address(_):
    from distributed import get_worker

    return get_worker().address


def test_the_backend_flags_send_a_batch_to_the_dask_scheduler(images, tmp_path, capsys):
    """``--backend dask --scheduler ADDRESS``: every run_batch of the block runs on the
    cluster's workers, and the command's results are those of the local processes."""
    distributed = pytest.importorskip("distributed")
    from argparse import Namespace

    from ladders.study.batch import run_batch
    from ladders.study.cli.common_arguments import parallel_backend

    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  protocol="tcp://", dashboard_address=None) as cluster:  # fmt: skip
        args = Namespace(backend="dask", scheduler=cluster.scheduler_address)
        worker = next(iter(cluster.workers.values())).address
        with parallel_backend(args, "mesh"):
            assert (
                list(run_batch(_worker_address, [(i,) for i in range(3)], jobs=2)) == [worker] * 3
            )
        common = ["--label", "1", "--vertices", "0", "--no-progress", "--jobs", "2"]
        assert main(["mesh", str(images[1]), *common, "-o", str(tmp_path / "dask"),
                     "--backend", "dask", "--scheduler", cluster.scheduler_address]) == 0  # fmt: skip
        capsys.readouterr()
        assert main(["mesh", str(images[0]), "--label", "1", "--scheduler",
                     cluster.scheduler_address, "-o", str(tmp_path / "x")]) == 2  # fmt: skip
        assert "--scheduler: needs --backend dask" in capsys.readouterr().err
    assert main(["mesh", str(images[1]), *common, "-o", str(tmp_path / "loky")]) == 0
    for name in ("p2_ed", "p2_es"):
        np.testing.assert_array_equal(read_mesh(tmp_path / "dask" / f"{name}.vtk")[0],
                                      read_mesh(tmp_path / "loky" / f"{name}.vtk")[0])  # fmt: skip
