# Type stubs of the native module `voxkit._voxkit` (python/src/*.rs).
# The public, documented API is in `voxkit/__init__.py`, which wraps these.

from typing import Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

Vec3 = Tuple[float, float, float]
Image = Tuple[npt.NDArray[np.uint8], npt.NDArray[np.float32]]

class Grid:
    @property
    def dims(self) -> Tuple[int, int, int]: ...
    @property
    def origin(self) -> Vec3: ...
    @property
    def voxel_size(self) -> float: ...
    def __len__(self) -> int: ...
    def same_as(self, other: "Grid") -> bool: ...
    def stats(self) -> Optional[dict]: ...
    def indices(self) -> npt.NDArray[np.int32]: ...
    def points(self) -> npt.NDArray[np.float64]: ...
    def dense(self, max_memory_mib: int = 4096) -> npt.NDArray[np.bool_]: ...
    def save(self, path: str, overwrite: bool = True) -> None: ...
    def tunnels(self, connectivity: int = 6, close: int = 1, max_memory_mib: int = 4096) -> dict: ...
    def measure(self, vertices: np.ndarray, faces: np.ndarray, max_memory_mib: int = 4096) -> dict: ...

def load_mesh(path: str) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]: ...
def voxelize(
    vertices: np.ndarray,
    faces: np.ndarray,
    resolution: Optional[int] = None,
    voxel_size: Optional[float] = None,
    origin: Optional[Vec3] = None,
    mode: str = "thin",
    snap: bool = False,
    max_memory_mib: int = 4096,
    threads: Optional[int] = None,
    inside: str = "winding",
) -> Grid: ...
def load_grid(path: str, max_memory_mib: int = 4096, level: int = 0) -> Grid: ...
def plan_tiles(
    mesh_path: str,
    store: str,
    voxel_size: float,
    origin: Optional[Vec3],
    tile_size: int,
    mode: str = "thin",
    inside: str = "winding",
    force: bool = False,
    max_memory_mib: int = 4096,
    pyramid: bool = False,
) -> str: ...
def finish_tiles(store: str, max_memory_mib: int = 4096) -> str: ...
def voxelize_tile(
    mesh_path: str,
    store: str,
    voxel_size: float,
    origin: Optional[Vec3],
    tile_size: int,
    tile: Tuple[int, int, int],
    mode: str = "thin",
    inside: str = "winding",
    max_memory_mib: int = 4096,
    threads: Optional[int] = None,
) -> str: ...
def measure_indices(
    vertices: np.ndarray,
    faces: np.ndarray,
    indices: np.ndarray,
    origin: Vec3,
    voxel_size: float,
    max_memory_mib: int = 4096,
) -> dict: ...
def line(
    p0: Vec3, p1: Vec3, kind: str = "26", flag_box: Optional[Tuple[int, int, int, int, int, int]] = None
) -> npt.NDArray[np.int64]: ...
def lines(
    segments: npt.NDArray[np.float64],
    kind: str = "26",
    flag_box: Optional[Tuple[int, int, int, int, int, int]] = None,
    threads: Optional[int] = None,
) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def render_grid(
    grid: Grid,
    size: Tuple[int, int],
    eye: Optional[Vec3],
    target: Optional[Vec3],
    up: Optional[Vec3],
    fov: float,
    ortho: bool,
    view: str,
    ray: str,
    skip: bool,
    normals: str,
    background: Vec3,
    max_memory_mib: int,
    pixels: Optional[Tuple[int, int, int, int]] = None,
) -> Image: ...
def write_png(path: str, image: np.ndarray, overwrite: bool = False) -> None: ...
def render_volume(
    array: np.ndarray,
    spacing: Vec3,
    origin: Vec3,
    axes: Optional[Sequence[Vec3]],
    space: Optional[str],
    size: Tuple[int, int],
    eye: Optional[Vec3],
    target: Optional[Vec3],
    up: Optional[Vec3],
    fov: float,
    ortho: bool,
    view: str,
    ray: str,
    skip: bool,
    normals: str,
    background: Vec3,
    max_memory_mib: int,
    volume: Optional[str],
    iso: Optional[float],
    window: Optional[Tuple[float, float]],
    tf: Optional[str],
    sampling: str,
    method: str,
) -> Image: ...
def read_volume(
    path: str, max_memory_mib: int
) -> Tuple[
    np.ndarray,
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    Optional[str],
]: ...
def _panic_for_test() -> None: ...
