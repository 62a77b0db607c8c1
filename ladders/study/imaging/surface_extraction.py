"""One label of a label image to a surface mesh in world millimetres.

:func:`extract_surface` keeps the largest connected component of the label (the
others are counted in the report), smooths the binary mask with a Gaussian of
``mask_sigma`` voxels (anti-aliasing: the zero-crossing of a smoothed mask sits near
the true boundary between voxel centres instead of on a staircase), runs
scikit-image's marching cubes on it in index space, maps the vertices to world
millimetres with the image's full affine (orientation, spacing, flips; the faces
are reversed when the affine flips handedness so that the normals point outward),
smooths the surface with Taubin's volume-preserving filter (trimesh), decimates it to
a target vertex count (fast-simplification), and optionally cuts it at a plane (e.g.
the valve plane of a ventricle), where it removes the lid that closed the label. The
:class:`SurfaceReport` says what was dropped, whether the surface is closed, its
holes and non-manifold edges, and the shrinkage by smoothing.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import fast_simplification
import numpy as np
import trimesh
from scipy import ndimage
from skimage.measure import marching_cubes

from ..volume import enclosed_volume
from .label_images import ImageError, LabelImage

__all__ = [
    "MeshingSettings",
    "SurfaceReport",
    "extract_surface",
    "cut_at_plane",
    "remove_lid",
    "largest_component",
    "voxel_extent",
]


@dataclass(frozen=True)
class MeshingSettings:
    """Settings of :func:`extract_surface` (recorded with every mesh).

    Attributes
    ----------
    mask_sigma : float
        Standard deviation of the Gaussian smoothing of the binary mask before marching
        cubes, in voxels of each axis (0: none): anti-aliasing at the image's own
        resolution, so that thick slices are smoothed across their thickness.
    taubin_iterations : int
        Iterations of Taubin smoothing of the surface (0: none).
    taubin_lambda, taubin_nu : float
        Taubin's shrink and inflate factors (``nu`` slightly above ``lambda``).
    n_vertices : int or None
        Target vertex count of the decimation (None: no decimation).
    cut_plane : tuple of 6 floats or None
        ``(x, y, z, nx, ny, nz)`` in world mm: the faces whose centroid is on the side
        the normal points to are removed (an open surface, e.g. at a valve plane).
    cut_margin : float
        How far the cut plane is moved against its normal before the cut, in voxel
        extents along the normal (the voxel's width in that direction, from the
        affine: 8 mm across 8 mm slices, 1 mm for 1 mm voxels). A label that stops at
        the valve plane gives a surface closed by a lid within half a voxel of that
        plane, above or below it; the default 0.5 removes the lid whichever side it
        falls, and with it that strip of wall at the base (with a plane exactly at the
        base of an 8 mm short-axis stack the lid stays on about half of the meshes:
        mean surface distance 0.7-1.3 mm instead of 0.3-0.4 mm,
        ``benchmarks/bench_images.py``). 0: cut at the plane as given.
    lid_angle : float or None
        The other way to remove the lid (default None: not used): cut at the
        (moved) plane, then remove the faces within ``lid_depth`` voxel extents below
        it whose normal is within ``lid_angle`` degrees of the plane's normal, with the
        small pieces this leaves apart from the wall (e.g. ``cut_margin=0,
        lid_angle=45``). It keeps the wall up to the lid's rounded edge: at 1.5 mm
        voxels the rim sits about half as far below the true base, but the
        corresponded vertices are not closer to their true material points
        (``benchmarks/bench_image_route.py``).
    lid_depth : float
        How far below the plane the lid is looked for, in voxel extents (default 1).
    keep_largest : bool
        Keep the largest connected component of the label only.
    """

    mask_sigma: float = 0.5
    taubin_iterations: int = 20
    taubin_lambda: float = 0.5
    taubin_nu: float = 0.53
    n_vertices: int | None = 2000
    cut_plane: tuple | None = None
    cut_margin: float = 0.5
    lid_angle: float | None = None
    lid_depth: float = 1.0
    keep_largest: bool = True

    def __post_init__(self):
        if not np.isfinite(self.mask_sigma) or self.mask_sigma < 0:
            raise ValueError(f"mask_sigma: expected a number of voxels >= 0, got {self.mask_sigma}")
        if int(self.taubin_iterations) < 0:
            raise ValueError(
                f"taubin_iterations: expected an int >= 0, got {self.taubin_iterations}"
            )
        if self.n_vertices is not None and int(self.n_vertices) < 10:
            raise ValueError(f"n_vertices: expected at least 10 (or None), got {self.n_vertices}")
        if self.cut_plane is not None:
            plane = tuple(float(v) for v in self.cut_plane)
            if len(plane) != 6 or not np.isfinite(plane).all() or not np.any(plane[3:]):
                raise ValueError(
                    f"cut_plane: expected (x, y, z, nx, ny, nz) with a non-zero normal, got {self.cut_plane}"
                )
            object.__setattr__(self, "cut_plane", plane)
        if not np.isfinite(self.cut_margin) or self.cut_margin < 0:
            raise ValueError(
                f"cut_margin: expected a number of voxel extents >= 0, got {self.cut_margin}"
            )

        if self.lid_angle is not None and not 0.0 <= self.lid_angle < 90.0:
            raise ValueError(
                f"lid_angle: expected degrees in [0, 90) (or None), got {self.lid_angle}"
            )
        if not np.isfinite(self.lid_depth) or self.lid_depth < 0:
            raise ValueError(
                f"lid_depth: expected a number of voxel extents >= 0, got {self.lid_depth}"
            )

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        out = asdict(self)
        out["cut_plane"] = None if self.cut_plane is None else list(self.cut_plane)
        return out


@dataclass(frozen=True)
class SurfaceReport:
    """What :func:`extract_surface` did and found (units: mm, mm^3, voxels)."""

    label: int
    voxels: int
    components: int
    dropped_components: int
    dropped_voxels: int
    closed: bool
    boundary_loops: int
    non_manifold_edges: int
    volume_before_smoothing: float
    volume_after_smoothing: float
    n_vertices: int
    n_faces: int
    faces_cut: int = 0
    cut_requested: bool = False

    @property
    def shrinkage(self) -> float:
        """Relative volume change by the surface smoothing (negative: it shrank)."""
        if self.volume_before_smoothing == 0:
            return 0.0
        return self.volume_after_smoothing / self.volume_before_smoothing - 1.0

    def as_dict(self) -> dict:
        """JSON-ready fields, with the shrinkage."""
        return {**asdict(self), "shrinkage": self.shrinkage}

    def describe(self) -> str:
        """One line for the report."""
        dropped = (
            f"dropped {self.dropped_components} other component(s) of {self.dropped_voxels} voxels"
            if self.dropped_components
            else "one component"
        )
        surface = "closed" if self.closed else f"open ({self.boundary_loops} boundary loop(s))"
        extra = (
            f", {self.non_manifold_edges} non-manifold edge(s)" if self.non_manifold_edges else ""
        )
        if self.closed and self.faces_cut == 0 and self.cut_requested:
            extra += ", the cut plane does not cross the surface"
        elif self.faces_cut:
            extra += f", {self.faces_cut} faces cut off"

        return (
            f"label {self.label}: {self.voxels} voxels, {dropped}; {surface}{extra}; "
            f"{self.n_vertices} vertices; smoothing changed the volume by {100 * self.shrinkage:+.2f} %"
        )


def _edge_counts(faces: np.ndarray) -> tuple[int, int]:
    """Boundary edges (one face) and non-manifold edges (three or more faces)."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int((counts == 1).sum()), int((counts > 2).sum())


def cut_at_plane(vertices, faces, plane) -> tuple[np.ndarray, np.ndarray]:
    """The faces whose centroid lies below ``plane`` (opposite its normal), unused vertices dropped."""
    point, normal = np.asarray(plane[:3], float), np.asarray(plane[3:], float)
    normal = normal / np.linalg.norm(normal)
    centroids = vertices[faces].mean(axis=1)
    keep = (centroids - point) @ normal <= 0.0
    mesh = trimesh.Trimesh(vertices, faces[keep], process=False)
    mesh.remove_unreferenced_vertices()
    return np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)


def remove_lid(vertices, faces, plane, depth: float, angle: float):
    """Remove the lid closing a surface at ``plane``.

    The faces whose centroid lies less than ``depth`` (mm) below the plane and whose
    normal is within ``angle`` degrees of the plane's normal are removed; of what is
    left, the largest connected piece is kept (the removal can leave bits of the lid's
    rim apart from the wall).

    Parameters
    ----------
    vertices : ndarray, shape (k, 3)
    faces : ndarray of int, shape (f, 3)
        Outward normals.
    plane : sequence of 6 floats
        ``(x, y, z, nx, ny, nz)``; the normal points out of the surface through the lid.
    depth : float
        mm below the plane.
    angle : float
        Degrees.

    Returns
    -------
    vertices, faces : the surface without its lid, unused vertices dropped.
    """
    point, normal = np.asarray(plane[:3], float), np.asarray(plane[3:], float)
    normal = normal / np.linalg.norm(normal)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    height = (mesh.triangles_center - point) @ normal
    facing = mesh.face_normals @ normal > np.cos(np.radians(angle))
    kept = trimesh.Trimesh(vertices, faces[~((height > -depth) & facing)], process=False)
    pieces = kept.split(only_watertight=False)
    if len(pieces) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    largest = max(pieces, key=lambda piece: len(piece.faces))
    return np.asarray(largest.vertices, float), np.asarray(largest.faces, np.int64)


def _boundary_loops(faces: np.ndarray) -> int:
    """Number of boundary loops (connected sets of boundary edges), by union-find."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    parent: dict[int, int] = {}

    def find(a: int) -> int:
        while parent.setdefault(a, a) != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in boundary.tolist():
        parent[find(a)] = find(b)
    return len({find(a) for a in boundary.ravel().tolist()})


def largest_component(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """The largest connected component of a boolean mask (26-connectivity) and the number of
    components; an empty mask is returned as it is (0 components)."""
    components, n_components = ndimage.label(mask, structure=np.ones((3, 3, 3)))
    if n_components <= 1:
        return np.asarray(mask, dtype=bool), int(n_components)
    sizes = np.bincount(components.ravel())[1:]
    return components == int(np.argmax(sizes)) + 1, int(n_components)


def extract_surface(
    image: LabelImage, label: int, settings: MeshingSettings | None = None
) -> tuple[np.ndarray, np.ndarray, SurfaceReport]:
    """The surface of ``label`` in ``image`` in world mm (see the module).

    Returns
    -------
    vertices : ndarray, shape (k, 3)
    faces : ndarray of int, shape (f, 3)
        Outward normals (for a closed surface).
    report : SurfaceReport

    Raises
    ------
    ImageError
        The label is absent (an empty mask), naming the file and the labels present.
    """
    settings = settings or MeshingSettings()
    label = int(label)
    mask = image.labels == label
    voxels = int(mask.sum())
    if voxels == 0:
        present = [int(v) for v in np.unique(image.labels) if v != 0][:10]
        raise ImageError(
            f"{image.path}{'' if image.frame is None else f' frame {image.frame}'}: label {label} "
            f"is absent (empty mask); labels present: {present or 'none'}"
        )
    largest, n_components = largest_component(mask)
    dropped_components, dropped_voxels = 0, 0
    if n_components > 1 and settings.keep_largest:
        dropped_components = n_components - 1
        dropped_voxels = int(voxels - largest.sum())
        mask = largest
    field = np.pad(mask.astype(float), 2)
    if settings.mask_sigma > 0:
        field = ndimage.gaussian_filter(field, settings.mask_sigma, mode="constant")
        if field.max() <= 0.5:
            field = np.pad(mask.astype(float), 2)  # too thin a structure to smooth
    verts, faces, _, _ = marching_cubes(field, 0.5, allow_degenerate=False)
    verts = verts - 2.0
    world = verts @ image.affine[:3, :3].T + image.affine[:3, 3]
    faces = np.asarray(faces, dtype=np.int64)
    if np.linalg.det(image.affine[:3, :3]) < 0:
        faces = faces[:, ::-1]
    if enclosed_volume(world, faces) < 0:  # marching cubes' orientation convention
        faces = faces[:, ::-1]
    before = enclosed_volume(world, faces)
    mesh = trimesh.Trimesh(world, faces, process=False)
    if settings.taubin_iterations > 0:
        trimesh.smoothing.filter_taubin(
            mesh, lamb=settings.taubin_lambda, nu=settings.taubin_nu,
            iterations=int(settings.taubin_iterations),
        )  # fmt: skip
    world, faces = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
    after = enclosed_volume(world, faces)
    if settings.n_vertices is not None and len(world) > settings.n_vertices:
        reduction = 1.0 - settings.n_vertices / len(world)
        world, faces = fast_simplification.simplify(world, faces, target_reduction=reduction)
        world, faces = np.asarray(world, float), np.asarray(faces, np.int64)
    n_before_cut = len(faces)
    if settings.cut_plane is not None:
        plane = _shifted_plane(settings, image.affine)
        world, faces = cut_at_plane(world, faces, plane)
        if settings.lid_angle is not None and len(faces):
            depth = settings.lid_depth * voxel_extent(plane[3:], image.affine)
            world, faces = remove_lid(world, faces, plane, depth, settings.lid_angle)
    boundary, non_manifold = _edge_counts(faces)
    report = SurfaceReport(
        label, voxels, int(n_components), dropped_components, dropped_voxels, boundary == 0,
        _boundary_loops(faces) if boundary else 0, non_manifold, float(before),
        float(after), len(world), len(faces), n_before_cut - len(faces),
        settings.cut_plane is not None,
    )  # fmt: skip
    return world, faces, report


def _shifted_plane(settings: MeshingSettings, affine: np.ndarray) -> tuple:
    """The cut plane moved ``cut_margin`` voxel extents against its normal."""
    point = np.asarray(settings.cut_plane[:3], float)
    normal = np.asarray(settings.cut_plane[3:], float)
    normal = normal / np.linalg.norm(normal)
    point = point - settings.cut_margin * voxel_extent(normal, affine) * normal
    return (*point, *normal)


def voxel_extent(normal, affine: np.ndarray) -> float:
    """A voxel's width along the unit vector ``normal`` (mm)."""
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    return float(np.abs(normal @ np.asarray(affine, float)[:3, :3]).sum())
