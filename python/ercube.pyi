"""ercube: the ER-Perspective volume renderer and its bit-accurate chip model.

Volumes and images are numpy arrays. Every frame is rendered by the code
`ercube render` runs, with its defaults, so images, raw words and statistics
are the command line's bit for bit. The GIL is released while a volume loads
or a frame renders. Points and spacing are (x, y, z); voxel arrays are
indexed (z, y, x); sizes are (width, height). See docs/verify.md.
"""

from os import PathLike
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

# Three numbers (x, y, z): a tuple or a list.
Vec3 = Union[Tuple[float, float, float], Sequence[float]]

class Error(ValueError):
    """An ercube failure, carrying the command line's one-line message."""

def load(
    path: Union[str, PathLike[str]], **options: Any
) -> Tuple[npt.NDArray[Union[np.uint8, np.uint16]], Vec3]:
    """Loads a volume file in any format `ercube render --volume` reads.

    Returns (voxels, spacing): voxels a (z, y, x) array in the file's type
    (uint8 or uint16), spacing (x, y, z). Options are the command line's
    source flags with underscores: raw_dims=(x, y, z), raw_type="u16le",
    raw_offset, spacing, window, max_memory.
    """

def scene(spec: str) -> npt.NDArray[Union[np.uint8, np.uint16]]:
    """Builds a synthetic scene as `--scene SPEC` does ("ml:40", "checker:32")."""

def render(
    voxels: npt.NDArray[Union[np.uint8, np.uint16]],
    *,
    spacing: Vec3 = (1.0, 1.0, 1.0),
    eye: Optional[Vec3] = None,
    look_at: Optional[Vec3] = None,
    up: Vec3 = (0.0, 1.0, 0.0),
    fov: float = 60.0,
    size: Union[Tuple[int, int], Sequence[int]] = (256, 256),
    method: str = "er",
    tf: Optional[str] = "grey-ramp",
    config: Optional[str] = None,
    **options: Any,
) -> Tuple[npt.NDArray[np.float32], dict[str, Any]]:
    """Renders voxels as `ercube render` does; returns (image, stats).

    image is the float32 H x W x 4 premultiplied RGBA array `--npy` writes;
    stats the dict `--stats` writes. eye defaults to 1.5 volume depths in
    front of the z = 0 face, look_at to the volume's centre. method is any
    of reference, er, er-ftb, under, over, box, mipmap, shear-warp,
    pipeline, pipeline-ftb. config is a pipeline configuration as TOML
    text. Further options are `ercube render` flags with underscores
    (shade=True, terminate=0.95, pes=8); True is a bare flag, False and
    None leave it out. Pass tf=None to use tf_file=PATH.

    The module keeps the last call's volume and its preparation (the slice
    stack, the empty-space blocks and occupancy map): a call on the same
    voxels and spacing, by any camera or method, reuses them and prepares
    only what the camera changes. Images are the same either way;
    clear_cache() gives the memory back.
    """

def clear_cache() -> None:
    """Drops the volume and preparation kept from the last render or
    Chip.run_frame call."""

class Chip:
    """The bit-accurate PE array with one configuration.

    Frames are whole frames: the model has no per-cycle stepping API, so
    there is no step() or ports().
    """

    def __init__(self, config: Optional[str] = None) -> None:
        """A chip with the pipeline configuration config (TOML text)."""

    def load(
        self,
        voxels: npt.NDArray[Union[np.uint8, np.uint16]],
        spacing: Vec3 = (1.0, 1.0, 1.0),
    ) -> None:
        """Loads voxels ((z, y, x), uint8 or uint16) for the next frames."""

    def run_frame(
        self,
        *,
        eye: Optional[Vec3] = None,
        look_at: Optional[Vec3] = None,
        up: Vec3 = (0.0, 1.0, 0.0),
        fov: float = 60.0,
        size: Union[Tuple[int, int], Sequence[int]] = (256, 256),
        method: str = "pipeline",
        tf: Optional[str] = "grey-ramp",
        **options: Any,
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.int64], dict[str, Any]]:
        """Runs one frame; returns (image, raw, stats).

        raw is the int64 H x W x 4 baseplane of accumulator words
        `--raw-npy` writes (formats in stats["raw_format"]). method is
        pipeline or pipeline-ftb.
        """
