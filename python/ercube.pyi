"""ercube: the ER-Perspective volume renderer and its bit-accurate chip model.

Volumes and images are numpy arrays. Every frame is rendered by the code
`ercube render` runs, with its defaults, so images, raw words and statistics
are the command line's bit for bit. The GIL is released while a volume loads
or a frame renders. Points and spacing are (x, y, z); voxel arrays are
indexed (z, y, x); sizes are (width, height). See docs/verify.md.
"""

from os import PathLike
from typing import Any, List, Optional, Sequence, Tuple, TypedDict, Union

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

    Returns (voxels, spacing): voxels a read-only (z, y, x) array in the
    file's type (uint8 or uint16) over the loaded volume's own buffer (a
    render of it, or of a view into it, is known to be of the kept voxels
    without comparing them; `voxels.copy()` gives an array to change),
    spacing (x, y, z). Options are the command line's
    source flags with underscores: raw_dims=(x, y, z), raw_type="u16le",
    raw_offset, spacing, window, max_memory.
    """

def scene(spec: str) -> npt.NDArray[Union[np.uint8, np.uint16]]:
    """Builds a synthetic scene as `--scene SPEC` does ("ml:40", "checker:32"):
    a read-only (z, y, x) array, as `load`'s voxels."""

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
    None leave it out. Pass tf=None to use tf_file=PATH. A pipeline
    method also renders its golden twin for the stats' error_vs_golden and
    bound; no_golden_twin=True skips it (the image and cycles are the same).

    The module keeps the last call's volume and its preparation (the slice
    stack, the empty-space blocks and occupancy map). A call compares the
    array's voxels with the kept ones, value for value: the same voxels and
    spacing, by any camera or method, render from the kept volume without
    copying and prepare only what the camera changes; an array changed in
    place since is copied once and prepared again, so a frame is never
    stale. Images are the same either way; clear_cache() gives the memory
    back. The array is read with the GIL released: another thread must not
    change it while the call runs.
    """

class PeVectors(TypedDict):
    """One PE's sample stage over a frame (`ercube.pe_vectors`): the words
    of the files `ercube vectors --stage pe` writes, as arrays."""

    pe: int
    pes: int
    rows: int
    """Clocks (rows of every port's array), clock 0 the first after reset
    and the tables."""
    depth: int
    """The datapath's depth: a sample issued in clock c is written back in
    clock c + depth."""
    tap_stage: int
    """Clocks from an issue to its taps."""
    samples: int
    """Samples this PE issued."""
    samples_all_pes: int
    frame_cycles: int
    mapping: str
    """The column mapping: "blocks", "interleave" or "cyclic"."""
    inputs: dict[str, npt.NDArray[np.uint64]]
    """Stimulus by port: the word at the rising edge that starts each clock
    (two's complement over the port's width)."""
    outputs: dict[str, npt.NDArray[np.uint64]]
    """Expected responses by port: the word during each clock."""
    ports: dict[str, dict[str, Any]]
    """Per port: bits, signed, direction ("in", "out") and checked
    ("stimulus", "every cycle", "where iss_valid is 1", ...)."""
    constants: dict[str, int]
    """col_lo, col_end, nx_last: inputs that hold one word over the frame."""
    writes: dict[str, npt.NDArray[Any]]
    """The memory writes the model makes without a clock, in order: cycle
    (uint64; applied before the rising edge that ends it), mem (uint8, an
    index into memories), addr, data (uint64; for term, slot << 1 | bit;
    for cm_mx, the ray index as two's complement over its width). Under
    the interleave and cyclic mappings they include the column map's
    entries (cm_mx, cm_sl: addr the entry) and the column decoder (loc:
    addr the volume column, data its local index)."""
    memories: List[str]
    """The memories by code: sb0, sb1, ec0, ec1, bank0, bank1, term,
    cm_mx, cm_sl, loc."""
    tables: dict[str, npt.NDArray[np.int64]]
    """The datapath's tables, raw words by name (Datapath.load_table takes
    them; the module's host port their low bits)."""
    verilog: dict[str, str]
    """The two modules' Verilog by name: ercube_pe_sample, ercube_sample."""

def pe_vectors(
    voxels: npt.NDArray[Union[np.uint8, np.uint16]],
    *,
    pe: int = 0,
    spacing: Vec3 = (1.0, 1.0, 1.0),
    eye: Optional[Vec3] = None,
    look_at: Optional[Vec3] = None,
    up: Vec3 = (0.0, 1.0, 0.0),
    fov: float = 60.0,
    size: Union[Tuple[int, int], Sequence[int]] = (256, 256),
    tf: Optional[str] = "grey-ramp",
    order: Optional[str] = None,
    config: Optional[str] = None,
    **options: Any,
) -> PeVectors:
    """PE `pe`'s sample stage (ercube_pe_sample) over the frame `ercube
    vectors --stage pe` captures of voxels: every port's stimulus and
    expected response a clock, the memory writes and the tables, equal to
    the command's files word for word, with no file written.

    Defaults are the command line's; order is "btf" or "ftb" (default the
    configuration's); further options are its flags with underscores
    (pes=3, terminate=0.95); every column mapping. Shading and the volume
    of interest raise ercube.Error as the command refuses them. The GIL is
    released while the frame runs.
    """

STAGES: List[str]
"""The controller's stages by code: STAGES[Chip.broadcast()["stage"]]."""

def clear_cache() -> None:
    """Drops the volume and preparation kept from the last render or
    Chip.run_frame call."""

class Chip:
    """The bit-accurate PE array with one configuration.

    Runs whole frames (run_frame) or steps one clock at a time: begin(),
    then step(), ports(), broadcast() and commands() after each step, or
    run(cycles, signals) for a trace of many cycles as arrays, and
    finish(). A
    stepped frame runs on a worker thread that hands over after every
    cycle: the same cycles, and every PE's values, as the frame
    `ercube render --vcd` traces.
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

    def begin(
        self,
        voxels: Optional[npt.NDArray[Union[np.uint8, np.uint16]]] = None,
        *,
        spacing: Vec3 = (1.0, 1.0, 1.0),
        eye: Optional[Vec3] = None,
        look_at: Optional[Vec3] = None,
        up: Vec3 = (0.0, 1.0, 0.0),
        fov: float = 60.0,
        size: Union[Tuple[int, int], Sequence[int]] = (256, 256),
        method: str = "pipeline",
        tf: Optional[str] = "grey-ramp",
        **options: Any,
    ) -> None:
        """Begins a frame to step one clock at a time.

        Of voxels ((z, y, x) with spacing) or, when None, of the loaded
        volume, with run_frame's options. A frame in progress stops. No
        cycle runs before step().
        """

    def step(self, n: int = 1) -> int:
        """Clocks up to n cycles (the GIL released).

        Returns the number of the last cycle clocked (the frame's cycles
        count from 1); once the frame has ended (done), its cycle count,
        stats["cycles"]. A frame that fails raises its error here.
        """

    @property
    def done(self) -> bool:
        """Whether the frame has no cycle left."""

    @property
    def cycle(self) -> int:
        """The number of the last cycle clocked (0 before the first)."""

    def ports(self) -> npt.NDArray[np.void]:
        """Every PE in the last cycle clocked: a numpy structured array, one
        record per PE in PE order.

        A field per signal, named as the waveform names it below top.pe_K
        ("busy", "ray_mx", "sample", "acc_r", ..., "left.ray_valid",
        "left.ray_r", "right.edge_0", "host.valid", "host.r", ...), then the
        report lines to the controller ("report.drained_at",
        "report.lands_by", "report.settled", "report.readout_done",
        "report.active", "report.pass_width", "report.slot_work",
        "report.merge_outputs", "report.split_outputs"). Each field is the
        smallest numpy integer holding the signal's width (uint8 to uint64;
        int8 to int64 where the word is two's complement: ray indices,
        words of signed formats); dtype.metadata["bits"][name] is the
        width. ports()["acc_r"] is every PE's acc_r; ports()[k] PE k's
        record. One copy per call.
        """

    def broadcast(self) -> np.void:
        """The controller in the last cycle clocked: a numpy record.

        Fields "cycle", then its signals as the waveform names them below
        top.ctrl ("stage", "slice", "row", "pass_x_valid", "pass_x",
        "pass_y_valid", "pass_y", "pass_col", "drive_valid", "drive_row"),
        each the smallest numpy integer holding its width.
        STAGES[record["stage"]] names the stage.
        """

    def commands(self) -> List[Tuple[str, int, int]]:
        """The commands the controller broadcast to every PE before the
        last cycle clocked (since the previous cycle), each (name, a, b),
        e.g. ("begin_slice", first ray, last ray), ("plan_rows", first row,
        rows), ("begin_row", row, 0)."""

    def run(
        self, cycles: int, signals: Optional[Sequence[str]] = None
    ) -> dict[str, npt.NDArray[Any]]:
        """Clocks up to cycles cycles (the GIL released) and returns the
        chosen signals of every cycle clocked, as arrays by name.

        A PE's signal or report line (a ports() field name) is a 2-D array
        (cycle, PE); the controller's, named "ctrl.stage", "ctrl.row", ...,
        a 1-D array; "cycle" (the cycles' numbers) is always there. The
        dtypes are ports()'s and broadcast()'s fields'. signals=None takes
        every signal. Fewer rows than cycles when the frame ends. An
        unknown name raises Error listing the frame's signals.
        """

    def finish(
        self,
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.int64], dict[str, Any]]:
        """Runs the rest of the frame; returns (image, raw, stats).

        The same as run_frame returns for the frame (apart from the
        wall-clock times in stats).
        """

class Port(TypedDict):
    name: str
    bits: int
    frac: int
    signed: bool

class Datapath:
    """One sample of the datapath, bit for bit the model's.

    unit is "sample" (the whole plain sample: ports slot_m, a, t, b, k,
    row_wy, sy, sz, acc_r..acc_a and the voxel taps v00..v11), "bilinear"
    or "composite" (the emitted units of `ercube synth --unit`). Words are
    raw two's-complement integers: the value is word * 2**-frac.
    """

    def __init__(
        self, config: Optional[str] = None, order: Optional[str] = "btf", unit: str = "sample"
    ) -> None:
        """config is pipeline TOML text (None: defaults); order "btf" or
        "ftb" (None: the configuration's)."""

    @property
    def unit(self) -> str: ...
    @property
    def inputs(self) -> List[Port]:
        """Input ports in order: name, bits, frac, signed."""
    @property
    def outputs(self) -> List[Port]:
        """Outputs in order: name, bits, frac, signed."""
    @property
    def latency(self) -> int:
        """Clocks from inputs to outputs in the unit's Verilog."""
    @property
    def tables(self) -> List[dict[str, Any]]:
        """Tables the unit reads: name, depth, format."""
    def table(self, name: str) -> List[int]:
        """A table's raw words."""
    def load_table(self, name: str, words: Sequence[int]) -> None:
        """Loads a table with exactly its depth of raw words."""
    def fill_tables(self, tf: str) -> None:
        """Fills every table from a transfer-function preset (grey-ramp, ml, brain, ...)."""
    def eval(self, **words: int) -> dict[str, int]:
        """One sample: every input's raw word by name -> every output's by name."""
    def pipelined(self, module: str = "ercube_sample") -> dict[str, Any]:
        """The whole sample's pipelined module as `ercube rtl` emits it: name,
        verilog, depth, ports (name, input, bits, frac, signed, stage) and
        tables (name, sel, depth, bits). A cut is refused."""
    def verilog(self, module: str = "ercube_unit") -> str:
        """The unit as a Verilog module (the cuts; the whole sample's is `pipelined`)."""
