"""voxkit: exact voxelization, discrete 3D lines and discrete ray casting, from numpy.

The engine is the `voxkit` Rust library; this package is a thin layer over it:
numpy arrays in, numpy arrays out, the GIL released while the library works
(on all cores, through rayon).

>>> import voxkit
>>> vertices, faces = voxkit.load_mesh("data/meshes/obj/spot.obj")
>>> grid = voxkit.voxelize(vertices, faces, resolution=64, mode="thin")
>>> grid.dims, len(grid) > 0
((36, 63, 64), True)
>>> grid.indices().shape[1], grid.dense().shape
(3, (36, 63, 64))

Conventions (the library's): voxel ``(i, j, k)`` of a grid covers the world
box ``origin + [i, i+1] * voxel_size`` (per axis); ``origin`` is the world
position of the min corner of voxel ``(0, 0, 0)``. Arrays are indexed
``[x, y, z]``.

Errors carry the library's message: ``ValueError`` for bad input (NaN
coordinates, out-of-range indices, unknown formats or options),
``MemoryError`` when a request would exceed the memory limit (checked before
allocating; ``max_memory_mib``, default 4096), ``OSError`` (e.g.
``FileNotFoundError``) for I/O.
"""

from __future__ import annotations

import errno
import os
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np

from . import _voxkit

__all__ = [
    "VoxelGrid",
    "VoxelStore",
    "Volume",
    "load_grid",
    "open_store",
    "load_mesh",
    "line",
    "lines",
    "measure",
    "read_volume",
    "render",
    "voxelize",
    "write_png",
]

__version__ = "0.1.0"

PathLike = Union[str, "os.PathLike[str]"]
MeshLike = Any  # (vertices, faces), a trimesh.Trimesh, an open3d TriangleMesh, ...

_FLOATS = (np.dtype(np.float64), np.dtype(np.float32))
_INDEX_DTYPES = tuple(np.dtype(t) for t in (np.int64, np.int32, np.uint32, np.uint64))


def _vertices(v: Any) -> np.ndarray:
    a = np.asarray(v)
    if a.dtype not in _FLOATS:
        if a.dtype.kind not in "iuf":
            raise ValueError(f"vertices must be numeric, got dtype {a.dtype}")
        a = a.astype(np.float64)
    return a


def _faces(f: Any) -> np.ndarray:
    a = np.asarray(f)
    if a.dtype not in _INDEX_DTYPES:
        if a.dtype.kind not in "iu":
            raise ValueError(f"faces must be integer vertex indices, got dtype {a.dtype}")
        a = a.astype(np.int64)
    return a


def _mesh_arrays(mesh_or_vertices: MeshLike, faces: Any = None) -> Tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of arrays, a (vertices, faces) pair, a trimesh.Trimesh
    (``.vertices``/``.faces``) or an Open3D TriangleMesh (``.vertices``/
    ``.triangles``). Arrays already float64/float32 and int64/int32 are passed
    on as they are (no copy)."""
    m = mesh_or_vertices
    if faces is None:
        if hasattr(m, "vertices") and hasattr(m, "faces"):
            m, faces = m.vertices, m.faces
        elif hasattr(m, "vertices") and hasattr(m, "triangles"):
            m, faces = m.vertices, m.triangles
        elif isinstance(m, (tuple, list)) and len(m) == 2:
            m, faces = m
        else:
            raise TypeError(
                "expected (vertices, faces) arrays, a (vertices, faces) pair, or a mesh object "
                "with .vertices and .faces (trimesh) or .triangles (Open3D); "
                f"got {type(mesh_or_vertices).__name__}"
            )
    return _vertices(m), _faces(faces)


def _vec3(v: Any, what: str) -> Optional[Tuple[float, float, float]]:
    if v is None:
        return None
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"{what} must be three numbers, got {v!r}")
    return (float(a[0]), float(a[1]), float(a[2]))


def load_mesh(path: PathLike) -> Tuple[np.ndarray, np.ndarray]:
    """Read a mesh file with the library's validation, the format chosen by
    extension (any case): OBJ (``.obj``), glTF 2.0 (``.gltf``/``.glb``, default
    scene with node transforms), PLY (``.ply``, ascii or binary), STL (``.stl``,
    ascii or binary; coincident corners merged into shared vertices) or OFF
    (``.off``, as in ModelNet). Polygons are fan-triangulated; colours, normals
    and other per-vertex data are ignored.

    Returns ``(vertices (N, 3) float64, faces (M, 3) int64)``. Degenerate
    triangles are dropped; OBJ relative (negative) indices are resolved
    correctly; polylines are not returned.

    >>> v, f = voxkit.load_mesh("data/meshes/obj/spot.obj")
    >>> v.shape[1], f.shape[1], f.dtype
    (3, 3, dtype('int64'))
    """
    return _voxkit.load_mesh(os.fspath(path))


class VoxelGrid:
    """A voxel set in its world frame, as made by :func:`voxelize` or read by
    :func:`load_grid`.

    ``dims`` ``(nx, ny, nz)``, ``origin`` (world min corner of voxel 0, a
    float64 array), ``voxel_size``; ``len(grid)`` is the number of set voxels.

    >>> g = voxkit.voxelize(*voxkit.load_mesh("data/meshes/obj/spot.obj"), resolution=32)
    >>> idx = g.indices()                      # (K, 3) int32, sorted like np.argwhere
    >>> bool((np.argwhere(g.dense()) == idx).all())
    True
    >>> g.points()[0] - (g.origin + (idx[0] + 0.5) * g.voxel_size)
    array([0., 0., 0.])
    """

    __slots__ = ("_g",)

    def __init__(self, native: "_voxkit.Grid") -> None:
        self._g = native

    @property
    def dims(self) -> Tuple[int, int, int]:
        """Extents ``(nx, ny, nz)`` in voxels."""
        return self._g.dims

    @property
    def origin(self) -> np.ndarray:
        """World position of the min corner of voxel (0, 0, 0), shape (3,)."""
        return np.array(self._g.origin, dtype=np.float64)

    @property
    def voxel_size(self) -> float:
        """Voxel edge length in world units."""
        return self._g.voxel_size

    @property
    def stats(self) -> Optional[dict]:
        """Counts and timings of the voxelization that made this grid (the
        library's own: ``voxelize_ms``, ``quantize_ms``, ``kernel_ms``,
        ``triangles``, ``voxels``, ``bricks``, ...), or ``None`` for a loaded
        grid."""
        return self._g.stats()

    def __len__(self) -> int:
        return len(self._g)

    def __eq__(self, other: object) -> bool:
        """Same frame (``dims``, ``origin``, ``voxel_size``) and the same
        voxels (compared brick by brick: cheap even for billions of voxels).
        Colours are not compared."""
        if not isinstance(other, VoxelGrid):
            return NotImplemented
        return self._g.same_as(other._g)

    __hash__ = None  # type: ignore[assignment]  # equal grids need not hash alike

    def __repr__(self) -> str:
        return repr(self._g)

    def indices(self) -> np.ndarray:
        """``(K, 3)`` int32 voxel indices, sorted by (x, y, z): the same rows as
        ``np.argwhere(self.dense())``."""
        return self._g.indices()

    def dense(self, *, max_memory_mib: int = 4096) -> np.ndarray:
        """A ``bool`` array of shape ``dims`` indexed ``[x, y, z]`` (C order).
        ``MemoryError`` if ``nx*ny*nz`` bytes exceed ``max_memory_mib``."""
        return self._g.dense(max_memory_mib)

    def points(self) -> np.ndarray:
        """``(K, 3)`` float64 world positions of the voxel centres, in the order
        of :meth:`indices`: ``origin + (indices + 0.5) * voxel_size``."""
        return self._g.points()

    def save(self, path: PathLike, *, overwrite: bool = True) -> None:
        """Write the grid; the extension picks the format: ``.binvox``,
        ``.vox`` (MagicaVoxel), ``.npy`` (uint8 ``[nx, ny, nz]``), ``.nrrd``,
        or ``.zarr``: an OME-Zarr 0.5 store (a directory; uint8 0/1 array
        ``0`` with axes z, y, x, 64³ chunks in 512³ shards, readable by
        zarr-python 3, ``dask.array.from_zarr`` and OME-Zarr viewers). The
        write is atomic; with ``overwrite=False`` an existing file is a
        ``FileExistsError``. binvox, NRRD and Zarr keep the world frame."""
        path = os.fspath(path)
        if not overwrite and os.path.exists(path):
            raise FileExistsError(errno.EEXIST, "file exists (save(..., overwrite=True) replaces it)", path)
        self._g.save(path, overwrite)

    def tunnels(self, connectivity: int = 6, *, close: int = 1, max_memory_mib: int = 4096) -> dict:
        """Whether an ``connectivity``-connected (6 or 26) path of empty voxels
        leads from outside the surface to its inside, decided from the grid
        alone as ``voxkit check --tunnels N --close K`` does: the inside is
        what the surface encloses once dilated ``close`` times.

        Returns ``{"tunnel": bool, "enclosed": int, "first_inside_reached":
        (x, y, z) | None, ...}``.

        >>> g = voxkit.voxelize(*voxkit.load_mesh("data/meshes/obj/spot.obj"), resolution=48)
        >>> g.tunnels(6)["tunnel"]
        False
        """
        return self._g.tunnels(connectivity, close, max_memory_mib)

    def measure(self, mesh: MeshLike, faces: Any = None, *, max_memory_mib: int = 4096) -> dict:
        """The library's error measures of these voxels against ``mesh`` on this
        grid's lattice: ``missing`` and ``extra`` voxels against the exact
        conservative set of the mesh (vertices at 1/256 voxel),
        ``reference_voxels``, ``max_distance`` / ``mean_distance`` of voxel
        centres to the surface (in voxels), ``far_voxels``, ``closed``,
        ``tunnel6`` / ``tunnel26`` (closed meshes) and ``note``.

        A mesh inside the grid box is measured as ``voxkit voxelize
        --measure`` does: the reference is restricted to the box, which is
        closed at its faces (a vertex on the box's max face belongs to the
        last voxel, the ``resolution=N`` rule), so a fitted grid is not
        charged for the voxels beyond the box that such a face only touches.
        A mesh reaching outside the box is measured on a widened grid, as
        ``voxkit measure`` and :func:`measure` do.

        >>> v, f = voxkit.load_mesh("data/meshes/obj/spot.obj")
        >>> m = voxkit.voxelize(v, f, resolution=32, mode="conservative").measure(v, f)
        >>> m["missing"], m["extra"]
        (0, 0)
        """
        v, f = _mesh_arrays(mesh, faces)
        return self._g.measure(v, f, max_memory_mib)

    def to_trimesh(self):
        """A ``trimesh.voxel.VoxelGrid`` of the same voxels whose transform maps
        indices to world voxel centres (needs trimesh)."""
        try:
            import trimesh
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("VoxelGrid.to_trimesh needs trimesh: pip install trimesh") from e
        h = self.voxel_size
        transform = np.eye(4)
        transform[:3, :3] *= h
        transform[:3, 3] = self.origin + 0.5 * h
        return trimesh.voxel.VoxelGrid(
            trimesh.voxel.encoding.DenseEncoding(self.dense()), transform=transform
        )


def voxelize(
    mesh_or_vertices: MeshLike,
    faces: Any = None,
    *,
    resolution: Optional[int] = None,
    voxel_size: Optional[float] = None,
    origin: Optional[Sequence[float]] = None,
    mode: str = "thin",
    snap: bool = False,
    max_memory_mib: int = 4096,
    threads: Optional[int] = None,
    inside: str = "winding",
) -> VoxelGrid:
    """Voxelize a triangle mesh.

    ``mesh_or_vertices``: an ``(N, 3)`` vertex array with ``faces`` ``(M, 3)``,
    a ``(vertices, faces)`` pair (what :func:`load_mesh` returns), a
    ``trimesh.Trimesh`` or an Open3D ``TriangleMesh``.

    The lattice: ``resolution=N`` (default 256) puts ``N`` voxels along the
    longest side of the mesh's bounding box, whose min corner is the grid's
    origin; or ``voxel_size=h`` makes voxels of edge ``h`` on the lattice
    whose corners include ``origin`` (default: the bounding box's min), the
    grid covering the mesh. A vertex exactly on the grid's max face is kept
    in the last voxel.

    ``mode``: ``"thin"`` (6-tunnel-free surface), ``"thick"``
    (26-tunnel-free), ``"conservative"`` (exactly every voxel whose closed
    cube meets the surface), ``"solid"`` (surface and interior).
    ``inside`` (solid only): ``"winding"`` (generalized winding number
    ≥ ½, robust to holes, flipped faces and overlaps) or ``"parity"``
    (crossing parity; exact for watertight meshes, fastest).
    ``snap=True`` rounds vertices to the voxel lattice (faster on some
    meshes, less exact); otherwise vertices are kept to 1/256 voxel.
    ``threads``: worker threads for this call (default: one per core, a pool
    shared by all calls); with ``threads=n`` each calling Python thread keeps
    a pool of ``n`` workers of its own, so ``threads=1`` lets calls from
    several Python threads run side by side, one core each (the GIL is
    released while voxelizing).

    >>> v, f = voxkit.load_mesh("data/meshes/obj/spot.obj")
    >>> g = voxkit.voxelize(v, f, resolution=64, mode="conservative")
    >>> g.dims
    (36, 63, 64)
    >>> g2 = voxkit.voxelize(v, f, voxel_size=g.voxel_size, mode="conservative")
    >>> bool((g2.indices() == g.indices()).all())
    True
    """
    v, f = _mesh_arrays(mesh_or_vertices, faces)
    if resolution is not None and voxel_size is not None:
        raise ValueError("give resolution or voxel_size, not both")
    if origin is not None and voxel_size is None:
        raise ValueError("origin applies only with voxel_size")
    if resolution is not None and not isinstance(resolution, (int, np.integer)):
        raise ValueError(f"resolution must be an integer, got {resolution!r}")
    native = _voxkit.voxelize(
        v,
        f,
        None if resolution is None else int(resolution),
        None if voxel_size is None else float(voxel_size),
        _vec3(origin, "origin"),
        mode,
        bool(snap),
        int(max_memory_mib),
        None if threads is None else int(threads),
        inside,
    )
    return VoxelGrid(native)


def load_grid(path: PathLike, *, max_memory_mib: int = 4096, level: int = 0) -> VoxelGrid:
    """Read a voxel file written by :meth:`VoxelGrid.save`, ``voxkit voxelize``
    or another tool: ``.binvox``, ``.vox``, ``.npy`` (3D, nonzero = set),
    ``.nrrd``, or a Zarr v3 / OME-Zarr store ``.zarr`` (array ``0``, z, y, x,
    uint8 or bool, nonzero = set; only the chunks present are read).
    ``level`` > 0 reads that level of a store's pyramid (``--pyramid``:
    occupancy max-pooled by ``2**level``, in the level's own frame)."""
    return VoxelGrid(_voxkit.load_grid(os.fspath(path), int(max_memory_mib), int(level)))


class VoxelStore:
    """A ``.zarr`` store that voxkit wrote, opened for :func:`render`: its
    chunks are decoded as rays reach them and kept for later renders, so a
    store bigger than memory renders in the memory its visible part takes.
    From :func:`open_store`."""

    def __init__(self, store: Any) -> None:
        self._s = store

    @property
    def dims(self) -> Tuple[int, int, int]:
        """Grid extents ``(nx, ny, nz)``."""
        return tuple(self._s.dims)

    @property
    def stored_chunks(self) -> int:
        """64³ chunks the store holds."""
        return self._s.stored_chunks

    @property
    def chunks_decoded(self) -> int:
        """Chunks the renders so far have decoded."""
        return self._s.chunks_decoded

    @property
    def pages_built(self) -> int:
        """Render pages (one per 64³ chunk a ray reached) built so far."""
        return self._s.pages_built

    @property
    def memory_bytes(self) -> int:
        """Bytes held: chunk tables, decoded chunks and pages."""
        return self._s.memory_bytes

    def __repr__(self) -> str:
        return (
            f"VoxelStore(dims={self.dims}, stored_chunks={self.stored_chunks}, "
            f"chunks_decoded={self.chunks_decoded}, pages_built={self.pages_built})"
        )


def open_store(path: PathLike, *, level: int = 0, max_memory_mib: int = 4096) -> Optional[VoxelStore]:
    """Open level ``level`` of a ``.zarr`` store for :func:`render` without
    loading it: renders read only the chunks their rays reach, and draw what
    rendering :func:`load_grid`'s grid draws, pixel for pixel. ``None`` for a
    store another tool wrote (other chunking or codecs: use
    :func:`load_grid`). ``max_memory_mib`` caps everything the store will
    hold, the chunks later renders decode included: a render that would
    need more raises ``MemoryError`` and returns no image."""
    s = _voxkit.open_store(os.fspath(path), int(level), int(max_memory_mib))
    return None if s is None else VoxelStore(s)


def write_png(path: PathLike, image: Any, *, overwrite: bool = False) -> None:
    """Write an ``(H, W, 3)`` or ``(H, W, 4)`` uint8 image (e.g. the ``rgb``
    of :func:`render`) as a PNG file, atomically; an existing file is
    replaced only if ``overwrite``."""
    _voxkit.write_png(os.fspath(path), np.ascontiguousarray(image, dtype=np.uint8), bool(overwrite))


def measure(
    mesh: MeshLike,
    indices: Any,
    origin: Sequence[float],
    voxel_size: float,
    *,
    faces: Any = None,
    max_memory_mib: int = 4096,
) -> dict:
    """The library's error measures (as :meth:`VoxelGrid.measure`) of any
    tool's voxels: ``indices`` ``(K, 3)`` integers on the lattice where voxel
    ``(i, j, k)`` covers ``origin + [i, i+1] * voxel_size`` per axis
    (indices may be negative). This is how trimesh's and Open3D's voxels are
    scored in the README."""
    v, f = _mesh_arrays(mesh, faces)
    idx = np.asarray(indices)
    if idx.dtype not in (np.dtype(np.int64), np.dtype(np.int32)):
        if idx.dtype.kind not in "iu":
            raise ValueError(f"indices must be integers, got dtype {idx.dtype}")
        idx = idx.astype(np.int64)
    return _voxkit.measure_indices(
        v, f, idx, _vec3(origin, "origin"), float(voxel_size), int(max_memory_mib)
    )


def line(p0: Sequence[float], p1: Sequence[float], kind: str = "26", *, flag_box: Optional[Sequence[int]] = None) -> np.ndarray:
    """The voxels of the segment ``p0``–``p1`` (grid space: voxel centres at
    integer points; endpoints may be fractional) as a ``(K, 3)`` int64 array,
    in order from ``p0``.

    ``kind``: ``"26"`` (26-connected, the fewest voxels), ``"18"``,
    ``"tripod"`` (6-connected, covers the segment), ``"aw"``
    (Amanatides–Woo in floating point), ``"adaptive"`` (26-connected, 6 in
    voxels of ``flag_box`` ``(x0, y0, z0, x1, y1, z1)``; without it, the
    26-line).

    >>> voxkit.line((0, 0, 0), (3, 1, 0)).tolist()
    [[0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 1, 0]]
    """
    fb = None if flag_box is None else tuple(int(x) for x in flag_box)
    return _voxkit.line(_vec3(p0, "p0"), _vec3(p1, "p1"), kind, fb)


def lines(
    segments: Any, kind: str = "26", *, flag_box: Optional[Sequence[int]] = None, threads: Optional[int] = None
) -> Tuple[np.ndarray, np.ndarray]:
    """Many segments at once, in parallel: ``segments`` ``(N, 6)`` rows
    ``x0 y0 z0 x1 y1 z1``. Returns ``(voxels (T, 3) int64, offsets (N+1,)
    int64)``; segment ``i``'s voxels are ``voxels[offsets[i]:offsets[i+1]]``.
    ``threads`` as in :func:`voxelize`.

    >>> vox, off = voxkit.lines(np.array([[0, 0, 0, 2, 0, 0], [0, 0, 0, 0, 1, 1.0]]))
    >>> off.tolist(), vox[off[1]:off[2]].tolist()
    ([0, 3, 5], [[0, 0, 0], [0, 1, 1]])
    """
    s = np.asarray(segments, dtype=np.float64)
    if s.ndim != 2 or s.shape[1] != 6:
        raise ValueError(f"segments must have shape (N, 6), got {s.shape}")
    fb = None if flag_box is None else tuple(int(x) for x in flag_box)
    return _voxkit.lines(s, kind, fb, None if threads is None else int(threads))


class Volume(tuple):
    """A scalar volume read by :func:`read_volume`: the tuple ``(array,
    spacing, origin)`` (unpack it as before), with the file's full frame
    beside it.

    ``array``: the samples indexed ``[x, y, z]``; ``spacing`` (3,): the
    lengths of the voxel axes; ``origin`` (3,): the world position of voxel
    ``(0, 0, 0)``'s *centre*; ``axes`` (3, 3): the frame, ``world = origin
    + axes @ (i, j, k)`` (its columns are the grid axes' world steps, so
    flipped, rotated and sheared axes keep their directions, as a NIfTI
    affine's upper 3×3 does); ``space``: ``"RAS"``, ``"LAS"``, ``"LPS"``
    or ``None``, the anatomical world the file places the volume in.
    :func:`render` uses ``axes`` and ``space`` (a head stands upright, a
    mirrored axis stays mirrored), as ``voxkit render`` does."""

    def __new__(cls, array: np.ndarray, spacing: np.ndarray, origin: np.ndarray, axes: np.ndarray, space: Optional[str]):
        self = super().__new__(cls, (array, spacing, origin))
        self.axes = axes
        self.space = space
        return self

    @property
    def array(self) -> np.ndarray:
        """The samples, indexed ``[x, y, z]``."""
        return self[0]

    @property
    def spacing(self) -> np.ndarray:
        """The lengths of the voxel axes (3,)."""
        return self[1]

    @property
    def origin(self) -> np.ndarray:
        """The world position of voxel ``(0, 0, 0)``'s centre (3,)."""
        return self[2]

    def __repr__(self) -> str:
        a = self[0]
        return f"Volume(shape={a.shape}, dtype={a.dtype}, spacing={self[1].tolist()}, space={self.space!r})"


def read_volume(path: PathLike, *, max_memory_mib: int = 4096) -> Volume:
    """Read a scalar volume: NRRD (``.nrrd``, ``.nhdr`` + raw/gzip data),
    MetaImage (``.mhd``/``.mha``), NIfTI-1/2 (``.nii``, ``.nii.gz``,
    ``.hdr`` + ``.img``) or ``.npy``.

    Returns a :class:`Volume`: the tuple ``(array, spacing, origin)`` (the
    samples indexed ``[x, y, z]`` in the file's own dtype, a
    Fortran-ordered view of the library's buffer, no copy; the voxel
    spacing (3,); the world position of voxel ``(0, 0, 0)``'s *centre*
    (3,), as NRRD and MetaImage define it), with the frame's ``axes`` and
    anatomical ``space`` as attributes. Pass it to :func:`render`.

    >>> vol = read_volume("data/volumes/HeadMRVolume/HeadMRVolume.mhd")
    >>> vol.array.shape, vol.array.dtype.name, vol.space
    ((48, 62, 42), 'uint8', None)
    """
    return Volume(*_voxkit.read_volume(os.fspath(path), int(max_memory_mib)))


def render(
    grid_or_volume: Any,
    *,
    size: Tuple[int, int] = (1024, 1024),
    eye: Optional[Sequence[float]] = None,
    target: Optional[Sequence[float]] = None,
    up: Optional[Sequence[float]] = None,
    fov: float = 35.0,
    ortho: bool = False,
    view: str = "iso",
    ray: str = "adaptive",
    skip: bool = True,
    normals: str = "smooth",
    background: Sequence[float] = (0.07, 0.08, 0.1),
    volume: Optional[str] = None,
    iso: Optional[float] = None,
    window: Optional[Tuple[float, float]] = None,
    tf: Optional[str] = None,
    sampling: str = "nearest",
    method: str = "rays",
    spacing: Sequence[float] = (1.0, 1.0, 1.0),
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    axes: Optional[Any] = None,
    space: Optional[str] = None,
    max_memory_mib: int = 4096,
    pixels: Optional[Tuple[int, int, int, int]] = None,
) -> Tuple[np.ndarray, np.ndarray]:
    """Render with the library's discrete ray caster, with ``voxkit render``'s
    defaults: a 1024×1024 three-quarter view (``view="iso"``) framed to the
    data, adaptive rays (first hits identical to the 6-connected ray's),
    empty-space skipping, smooth normals.

    ``grid_or_volume``: a :class:`VoxelGrid` (world frame, Y up); a
    :class:`VoxelStore` (:func:`open_store`: only the chunks the rays reach
    are read); a 3D array
    indexed ``[x, y, z]`` (bool or 0/1 → voxels; other numbers → a scalar
    volume, Z up, shown by ``volume="mip"`` (default), ``"composite"`` or
    ``"iso"``), placed by ``spacing`` and ``origin`` (voxel 0's centre), or
    by ``axes`` (3, 3) and ``origin`` (``world = origin + axes @ (i, j,
    k)``: rotated or flipped axes) in place of ``spacing``, in the
    anatomical ``space`` (``"RAS"``, ``"LAS"``, ``"LPS"``: the default
    views stand the patient upright) where given; or the :class:`Volume`
    of :func:`read_volume` (its ``axes`` and ``space`` unless given here),
    or any ``(array, spacing, origin)`` tuple.

    Camera: ``eye``/``target``/``up``/``fov`` (degrees) or a ``view`` preset
    (``front back left right top bottom iso``), ``ortho``. ``ray``: ``"6"``,
    ``"26"``, ``"adaptive"``, ``"aw"``. Volumes: ``window=(lo, hi)``,
    ``iso``, ``tf`` (``"v:opacity[:#rrggbb],..."``), ``sampling``
    (``"nearest"``, ``"trilinear"``), ``method`` (``"rays"``: one exact
    discrete ray per pixel; ``"shear-warp"``: object order, faster, not
    exact; ``voxkit render --method shear-warp --measure`` reports its
    difference from the 6-ray image; iso-surfaces cast rays).

    Returns ``(rgb (H, W, 3) uint8, depth (H, W) float32)``; depth is the
    world distance along the ray to the hit, ``inf`` where nothing was hit.
    64-bit integer arrays (NumPy's default) are held in the narrowest
    integer type that holds every sample exactly (beyond 32 bits: float64).
    A float64 volume is rendered in float32: samples beyond float32's range
    (a ``-1e300`` "no data" value) become ``±inf``, and a ``UserWarning``
    says how many.

    ``pixels=(x, y, w, h)`` (voxels only) renders just that
    rectangle of the ``size`` frame (row 0 at the top), pixel for pixel the
    frame's: how :func:`voxkit.distributed.render_tiled` splits a frame
    across workers. The arrays are then ``(h, w, …)``.
    """
    w, h = (int(size[0]), int(size[1]))
    if w <= 0 or h <= 0:
        raise ValueError(f"size must be two positive integers, got {size!r}")
    common = (
        (w, h),
        _vec3(eye, "eye"),
        _vec3(target, "target"),
        _vec3(up, "up"),
        float(fov),
        bool(ortho),
        view,
        ray,
        bool(skip),
        normals,
        _vec3(background, "background"),
        int(max_memory_mib),
    )
    if isinstance(grid_or_volume, (VoxelGrid, VoxelStore)):
        if volume is not None or iso is not None or window is not None or tf is not None:
            raise ValueError("volume, iso, window and tf apply to scalar volumes, not to voxels")
        px = None if pixels is None else tuple(int(c) for c in pixels)
        if px is not None and len(px) != 4:
            raise ValueError(f"pixels must be (x, y, width, height), got {pixels!r}")
        native = grid_or_volume._s if isinstance(grid_or_volume, VoxelStore) else grid_or_volume._g
        return _voxkit.render_grid(native, *common, px)
    if pixels is not None:
        raise ValueError("pixels applies to a VoxelGrid (render_tiled), not to a scalar volume")
    arr = grid_or_volume
    if isinstance(arr, Volume):
        axes = arr.axes if axes is None else axes
        space = arr.space if space is None else space
    if isinstance(arr, tuple) and len(arr) == 3:
        arr, spacing, origin = arr
    if axes is not None:
        axes = np.asarray(axes, dtype=np.float64)
        if axes.shape != (3, 3):
            raise ValueError(f"axes must be a 3x3 matrix, got shape {axes.shape}")
        axes = [tuple(float(x) for x in row) for row in axes]
    if space is not None and not isinstance(space, str):
        raise ValueError(f"space must be \"RAS\", \"LAS\", \"LPS\" or None, got {space!r}")
    arr = np.asarray(arr)
    if arr.ndim != 3:
        raise ValueError(f"expected a VoxelGrid or a 3D array, got an array of shape {arr.shape}")
    if arr.dtype == np.float16:
        arr = arr.astype(np.float32)  # exact: every float16 is a float32
    win = None if window is None else (float(window[0]), float(window[1]))
    return _voxkit.render_volume(
        arr,
        _vec3(spacing, "spacing"),
        _vec3(origin, "origin"),
        axes,
        space,
        *common,
        volume,
        None if iso is None else float(iso),
        win,
        tf,
        sampling,
        method,
    )
