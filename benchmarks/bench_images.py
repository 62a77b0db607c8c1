"""Ground truth of label images to meshes: the synthetic ventricles voxelised, meshed, measured.

    python benchmarks/bench_images.py [--subjects 5] [--publish]

Each ED and ES mesh of the first subjects of the built-in cohort is closed at its
base (the label is the cavity up to the valve plane), voxelised exactly
(:func:`ladders.study.imaging.voxelize`) at three acquisitions, written as NIfTI and
read back, then meshed by :func:`ladders.study.imaging.extract_surface` and cut at
the base plane:

* ``iso 1 mm``: isotropic 1 mm voxels;
* ``SAX 1.5 x 1.5 x 8 mm``: a short-axis stack, slices across the long axis;
* ``oblique SAX``: the same stack tilted by 20 degrees and flipped left-right.

Measured against the true (open) surface: the mean and 95th percentile of the
distances of each surface's vertices to the other surface (both directions pooled),
in mm, and the error of the enclosed volume (the extracted surface before the cut
against the true surface closed at its base). For the thick slices, several
smoothing settings are compared (mask smoothing in voxels, Taubin iterations), and
the cut at the base plane itself instead of half a slice below it (``cut_margin``).
Targets at 1 mm: mean distance at most 0.3 mm, volume within 2 %.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort import make_synthetic_cohort  # noqa: E402
from ladders.study.imaging import (  # noqa: E402
    MeshingSettings,
    close_surface,
    extract_surface,
    read_label_image,
    short_axis_affine,
    voxelize,
    write_label_image,
)
from ladders.study.preparation.surface_distance import distances_to_surface  # noqa: E402
from ladders.study.volume import enclosed_volume  # noqa: E402

ACQUISITIONS = {
    "iso 1 mm": (1.0, 1.0, 0.0, False),
    "SAX 1.5 x 1.5 x 8 mm": (1.5, 8.0, 0.0, False),
    "oblique SAX (20°, flipped)": (1.5, 8.0, 20.0, True),
}
DEFAULT = MeshingSettings()
THICK_SETTINGS = {
    "default (mask 0.5 voxel, Taubin 20)": DEFAULT,
    "no smoothing": MeshingSettings(mask_sigma=0.0, taubin_iterations=0),
    "Taubin 20 only": MeshingSettings(mask_sigma=0.0),
    "mask 1 voxel, Taubin 20": MeshingSettings(mask_sigma=1.0),
    "mask 0.5 voxel, Taubin 100": MeshingSettings(taubin_iterations=100),
    "mask 1 voxel, Taubin 100": MeshingSettings(mask_sigma=1.0, taubin_iterations=100),
    "default, cut at the base plane itself (cut_margin 0)": MeshingSettings(cut_margin=0.0),
}


def _grid(vertices, in_plane, thickness, tilt, flip, margin=6.0):
    """An affine and a shape covering the mesh with ``margin`` mm (in index space)."""
    base = short_axis_affine(np.zeros(3), in_plane, thickness, tilt, flip)
    inverse = np.linalg.inv(base[:3, :3])
    index = vertices @ inverse.T
    pad = margin / np.array([in_plane, in_plane, thickness])
    lo = np.floor(index.min(axis=0) - pad)
    hi = np.ceil(index.max(axis=0) + pad)
    affine = base.copy()
    affine[:3, 3] = base[:3, :3] @ lo
    return affine, tuple(int(n) for n in hi - lo + 1)


def measure(vertices, faces, acquisition, settings, folder: Path) -> dict:
    in_plane, thickness, tilt, flip = ACQUISITIONS[acquisition]
    affine, shape = _grid(vertices, in_plane, thickness, tilt, flip)
    start = time.perf_counter()
    labels = voxelize(vertices, faces, affine, shape, label=1)
    path = write_label_image(folder / "image.nii.gz", labels, affine)
    image = read_label_image(path)
    base_z = vertices[:, 2].max()
    cut = MeshingSettings(**{**settings.as_dict(), "cut_plane": (0.0, 0.0, base_z, 0.0, 0.0, 1.0)})
    v, f, report = extract_surface(image, 1, cut)
    seconds = time.perf_counter() - start
    distances = np.concatenate([distances_to_surface(v, vertices, faces),
                                distances_to_surface(vertices, v, f)])  # fmt: skip
    closed_v, closed_f = close_surface(vertices, faces)
    volume_error = report.volume_after_smoothing / enclosed_volume(closed_v, closed_f) - 1.0
    return {"mean": distances.mean(), "p95": np.percentile(distances, 95),
            "volume": volume_error, "shrinkage": report.shrinkage, "seconds": seconds}  # fmt: skip


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=5)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    cohort = make_synthetic_cohort(args.subjects)
    shapes = [(f"{s.name} {p}", getattr(s, p)) for s in cohort.subjects for p in ("ed", "es")]
    runs = [(a, "default (mask 0.5 voxel, Taubin 20)", DEFAULT) for a in ACQUISITIONS]
    runs += [(a, name, st) for a in list(ACQUISITIONS)[1:2] for name, st in THICK_SETTINGS.items()
             if st is not DEFAULT]  # fmt: skip
    rows = ["| acquisition | smoothing | mean distance | 95th percentile | volume error "
            "(mean, worst) | smoothing's volume change | time per mesh |",
            "|---|---|---|---|---|---|---|"]  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        for acquisition, name, settings in runs:
            results = [
                measure(v, cohort.faces, acquisition, settings, Path(tmp)) for _, v in shapes
            ]
            mean = np.mean([r["mean"] for r in results])
            p95 = np.mean([r["p95"] for r in results])
            vol = np.array([r["volume"] for r in results])
            shrink = np.mean([r["shrinkage"] for r in results])
            seconds = np.mean([r["seconds"] for r in results])
            line = (f"| {acquisition} | {name} | {mean:.3f} mm | {p95:.3f} mm | "
                    f"{100 * vol.mean():+.2f} %, {100 * vol[np.argmax(abs(vol))]:+.2f} % | "
                    f"{100 * shrink:+.2f} % | {seconds:.2f} s |")  # fmt: skip
            print(line, flush=True)
            rows.append(line)
    note = (f"{len(shapes)} meshes (ED and ES of {args.subjects} subjects of the built-in "
            "cohort, 1,009 vertices); distances both ways to the true open surface, pooled; "
            "the volume of the cavity closed at the base plane.")  # fmt: skip
    if args.publish:
        publish("images_ground_truth", note + "\n\n" + "\n".join(rows),
                "python benchmarks/bench_images.py --publish")  # fmt: skip


if __name__ == "__main__":
    main()
