"""Type stubs of Obscura's native module (re-exported by ``obscura``)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike
FloatArray = npt.NDArray[np.floating[Any]]
BoolArray = npt.NDArray[np.bool_]
PixelConvention = Literal["colmap", "opencv", "matlab"]
CameraSpace = Literal["obscura", "opencv"]
Matrix4 = Union[Sequence[Sequence[float]], Sequence[float], npt.ArrayLike]

class Rays(TypedDict):
    """What ``Camera.project`` and ``Camera.rays`` return (N or H×W leading dimensions)."""

    origin: FloatArray
    direction: FloatArray
    origin_radius: FloatArray
    ray_spread: FloatArray
    min_dist: FloatArray
    max_dist: FloatArray
    tint: FloatArray
    time: FloatArray
    valid: BoolArray

class Camera:
    """A camera: a projection (built-in, plugin or calibration) with its parameters and the camera
    options of RIB.

    ``Camera(projection, format=(w, h), **params)``: ``projection`` is a built-in's name
    (``"PxrPerspective"``, ``"Fisheye"``, ``"CalibratedCamera"``, …), a plugin found as
    ``<Name>.so`` along ``add_plugin_path`` directories and ``OBSCURA_PLUGIN_PATH``, or a plugin
    file's path. Projection parameters are keyword arguments with the names, types and ranges of
    ``obscura plugins NAME`` (``fov=60``, ``fStop=2.8``, ``mapping="equisolid"``); a bad one raises
    ``ValueError`` (unknown name, out of range) or ``TypeError`` (wrong type) naming it and what was
    expected, exactly as the CLI's ``--param`` does.

    Camera options (keyword-only): ``format`` (width, height; default 640×480, or a calibration's
    size), ``pixel_aspect``, ``screen_window`` (left, right, bottom, top), ``crop`` (xmin, xmax,
    ymin, ymax in NDC), ``clipping`` (near, far), ``shutter`` (open, close),
    ``aperture_sides``, ``aperture_angle``, ``aperture_roundness``, ``aperture_density``,
    ``dof_aspect``, ``shutter_open_time``, ``shutter_close_time``, ``shutter_opening`` (8 values),
    ``world_to_camera`` (a 4×4 matrix in RenderMan's row-vector convention ``[p 1]·M``, or a list of
    ``(time, matrix)`` motion samples).

    A calibrated camera can be built from its model directly:
    ``Camera("CalibratedCamera", model="OPENCV_OMNIDIR", params=[...], resolution=(w, h))``
    (see ``calibration_models()`` for every model and its parameter order).
    """

    def __init__(self, projection: str = "PxrPerspective", **kwargs: Any) -> None: ...
    @classmethod
    def from_calibration(
        cls,
        path: Union[str, PathLike[str]],
        camera: Optional[Union[str, int]] = None,
        frame: Optional[float] = None,
        **kwargs: Any,
    ) -> "Camera":
        """A camera from a calibration file the CLI reads: COLMAP ``cameras.txt``, OpenCV YAML/JSON,
        Kalibr ``camchain.yaml``, OCamCalib ``calib_results.txt``, a Nuke script with 3DEqualizer's
        ``LD_3DE*`` nodes, a 3DE lens export. ``camera`` picks one of several (a COLMAP CAMERA_ID,
        Kalibr's ``cam0``, an LD node's name; default the first); ``frame`` evaluates a Nuke
        script's animated knobs at that frame (default: the script's current frame). The format defaults to the
        calibration's size; keyword arguments are camera options or ``CalibratedCamera`` parameters
        replacing the file's. Errors name the file, the line and the field."""
    @property
    def projection(self) -> str:
        """The projection's name."""
    @property
    def format(self) -> Tuple[int, int]:
        """(width, height) in pixels."""
    @property
    def screen_window(self) -> Tuple[float, float, float, float]:
        """(left, right, bottom, top) of the screen window in force."""
    @property
    def pixels(self) -> Tuple[int, int, int, int]:
        """The pixels ``rays()`` covers (the crop): (x0, x1, y0, y1), end exclusive."""
    @property
    def fov(self) -> Optional[float]:
        """The field of view in degrees (``FieldOfView``), or None when not answered."""
    @property
    def dicing_hint(self) -> Literal["perspective", "orthographic", "spherical"]:
        """The ``DicingHint`` property."""
    @property
    def deep_metric(self) -> Literal["CameraZ", "RayLength"]:
        """The ``DeepMetric`` property: how depth is measured."""
    @property
    def fstop(self) -> Optional[float]:
        """The ``FStop`` property, or None."""
    @property
    def focal_length(self) -> Optional[float]:
        """The ``FocalLength`` property, or None."""
    @property
    def focal_distance(self) -> Optional[float]:
        """The ``FocalDistance`` property, or None."""
    @property
    def clipping(self) -> Tuple[float, float]:
        """(near, far) clipping."""
    @property
    def shutter(self) -> Tuple[float, float]:
        """(open, close) shutter times."""
    @property
    def model(self) -> Optional[str]:
        """The calibrated model's name (``"OPENCV"``, …), or None for other projections."""
    @property
    def pixel_convention(self) -> PixelConvention:
        """The default pixel convention of ``pixel_to_ray``/``ray_to_pixel``: the calibration's own,
        ``"colmap"`` (Obscura's raster) for other cameras."""
    @property
    def calibration(self) -> Optional[str]:
        """Where the camera came from (the calibration file and line), or None."""
    @property
    def params(self) -> Dict[str, Any]:
        """The projection's parameters as given."""
    @property
    def warnings(self) -> List[str]:
        """Warnings from setting the camera up."""
    def project(
        self,
        screen: ArrayLike,
        lens: Optional[ArrayLike] = None,
        time: Optional[ArrayLike] = None,
        out: Optional[Rays] = None,
    ) -> Rays:
        """Rays of N screen samples through the projection and the host's contract.

        ``screen``: N×2 screen-space positions (y up). ``lens``: N×2 canonical lens samples in
        [0, 1)², warped by the aperture options (default the lens centre); ``time``: N canonical
        shutter samples in [0, 1), warped by the shutter opening (default 0). With neither, the chief
        rays ``rays()`` computes. Returns ``origin``, ``direction`` (N×3), ``origin_radius``,
        ``ray_spread``, ``min_dist``, ``max_dist`` (N), ``tint`` (N×3), ``time`` (N) and ``valid``
        (N bool); culled rays have a zero direction. float32 in gives float32 out, float64 gives
        float64 (the projection's f32 values). Every component is contiguous (the N×3 arrays are
        transposed views of 3×N arrays); ``out``, an earlier call's dict of as many samples in the
        same float type, is written in place and returned. Integer arrays raise TypeError, wrong shapes and NaN
        ValueError, naming the argument."""
    def rays(self) -> Rays:
        """Every pixel centre's chief ray over the crop window (H×W leading dimensions, float32),
        bit-identical to ``obscura rays``."""
    def pixel_to_ray(
        self,
        px: ArrayLike,
        pixel_convention: Optional[PixelConvention] = None,
        camera_space: CameraSpace = "obscura",
    ) -> Tuple[FloatArray, BoolArray]:
        """Unit ray directions (N×3) of N raster positions (N×2, y down) and ``valid`` (N).

        ``pixel_convention``: ``"colmap"`` (top-left pixel centre at (0.5, 0.5)), ``"opencv"`` (at
        (0, 0)), ``"matlab"`` (at (1, 1)); default the calibration's own. A calibrated camera runs
        its model in f64 (converged to 1e-9 in normalised coordinates); other cameras give their
        chief ray's direction (f32). Invalid pixels have a zero direction; NaN raises ValueError."""
    def ray_to_pixel(
        self,
        points: ArrayLike,
        pixel_convention: Optional[PixelConvention] = None,
        camera_space: CameraSpace = "obscura",
    ) -> Tuple[FloatArray, BoolArray]:
        """Raster positions (N×2) where N camera-space points (N×3) are seen, and ``valid`` (N).

        A calibrated camera runs its model in f64; other cameras invert their projection
        (``unproject``, f32). Points not seen give ``valid = False`` and NaN pixels; NaN input
        raises ValueError."""
    def world_to_pixel(
        self,
        points_world: ArrayLike,
        time: float = 0.0,
        pixel_convention: Optional[PixelConvention] = None,
    ) -> Tuple[FloatArray, BoolArray]:
        """Raster positions (N×2) of world-space points (N×3) through the world-to-camera transform
        at scene time ``time`` (motion interpolated as the renderer does), and ``valid`` (N)."""
    def world_to_camera(self, time: float = 0.0) -> List[List[float]]:
        """World-to-camera at scene time ``time`` (4×4, RenderMan's row-vector convention)."""

class ProjectionParam(TypedDict):
    name: str
    type: str
    default: Any
    range: Optional[Tuple[float, float]]
    choices: List[str]
    doc: str

class ProjectionInfo(TypedDict):
    name: str
    summary: str
    path: Optional[str]
    params: List[ProjectionParam]

def projections() -> List[ProjectionInfo]:
    """Every projection: built-ins, loaded plugins and the plugins on the plugin path, with their
    parameter tables."""

def load_plugin(path: Union[str, PathLike[str]]) -> str:
    """Loads a projection plugin library (C or Rust, Obscura's C ABI) and returns its name."""

def add_plugin_path(directory: Union[str, PathLike[str]]) -> None:
    """Adds a directory searched for ``<Name>.so`` (before ``OBSCURA_PLUGIN_PATH``)."""

def calibration_models() -> List[Dict[str, Any]]:
    """The calibrated camera models: ``name``, ``params`` (names in order), ``counts``,
    ``pixel_convention``."""

def set_num_threads(n: int) -> None:
    """Threads of obscura's batched calls (0: one per core, the default)."""

def get_num_threads() -> int:
    """Threads of obscura's batched calls."""

def stmap(a: Camera, b: Camera, distance: float = 1.0e4) -> Dict[str, Any]:
    """The ST-map turning images of camera ``a`` into images of camera ``b`` (Nuke's STMap
    convention): ``s``, ``t``, ``alpha`` (H×W float32 over b's format) and counts."""

def check(
    camera: Camera, format: Optional[Tuple[int, int]] = None, samples_per_pixel: int = 4, seed: int = 0
) -> Dict[str, Any]:
    """The contract report of ``obscura check --json`` as a dict; ``clean`` is True when every
    check passed."""

def render_dataset(
    scene: Optional[Union[str, PathLike[str]]],
    output: Union[str, PathLike[str]],
    frames: Optional[str] = None,
    rig: Optional[Union[str, PathLike[str]]] = None,
    exports: Optional[Union[str, Sequence[str]]] = None,
    annotations: Optional[Union[str, Sequence[str]]] = None,
    tracks: int = 256,
    finalize: bool = False,
    projection: Optional[str] = None,
    params: Optional[Dict[str, Any]] = None,
    calibration: Optional[Union[str, PathLike[str]]] = None,
    camera: Optional[str] = None,
    format: Optional[Tuple[int, int]] = None,
    spp: Optional[int] = None,
    seed: int = 0,
    max_depth: int = 6,
    fps: float = 24.0,
) -> Dict[str, Any]:
    """Renders a dataset through the same driver as `obscura dataset` (layout: docs/datasets.md):
    images of every camera of `rig` with ground truth, `exports` (colmap, nerfstudio, gsplat),
    `annotations` (boxes, tracks, correspondences) and `dataset.json`. Resumable; `frames` renders a
    farm task's frames, `finalize=True` assembles the files spanning frames. Returns `rendered`,
    `skipped`, `render_seconds`, `annotation_seconds`, `finalized`, `warnings`."""

def render(
    scene: Optional[Union[str, PathLike[str]]] = None,
    camera: Optional[Camera] = None,
    spp: Optional[int] = None,
    aovs: Optional[Sequence[str]] = None,
    seed: int = 0,
    max_depth: int = 6,
    progress: Optional[Callable[[int, int], Any]] = None,
    output: Optional[Union[str, PathLike[str]]] = None,
    write: bool = False,
    sensor: Optional[Union[Dict[str, Any], str, PathLike[str]]] = None,
    raw_output: Optional[Union[str, PathLike[str]]] = None,
) -> Dict[str, Any]:
    """Renders a scene (RIB, glTF, OBJ; None for the built-in one) through ``camera`` (default the
    scene's), with the same frame pipeline as ``obscura render``, and returns ``beauty`` (H×W×3),
    ``alpha``, ``z``, ``N``, ``P``, ``cameraDirection``, ``albedo`` (H×W×3), ``uv`` (H×W×2) and
    ``stats``; ``aovs`` picks among these and the ground truth (``cameraZ``, ``distance``,
    ``Pcamera``, ``Ncamera``, ``objectId``/``instanceId``/``materialId`` as uint32, ``flowForward``,
    ``flowBackward``, ``flowValid``). ``output`` writes the files ``obscura render -o output --aov
    …`` writes (EXR, PNG preview, ID and camera sidecars with ground truth); ``write=True`` writes
    the scene's own displays (else ``render.exr``). ``stats["written"]`` lists the files and
    ``stats["warnings"]`` the messages. ``progress(done, total)`` is called with tile counts; Ctrl-C
    raises KeyboardInterrupt. ``sensor`` (a dict of the sensor keys of docs/sensor.md, or a JSON
    file's path) puts an image sensor after the lens: ``beauty`` is then the ISP's noisy processed
    image, ``clean`` the same ISP on the noise-free exposure, ``film`` the renderer's noiseless
    linear image, ``raw`` the mosaic in DN and ``electrons`` the expected photoelectrons (H×W);
    ``raw_output`` writes the mosaic as a DNG file."""


def parse_frames(frames: str) -> List[int]:
    """The frames of a frame list as farms write it ("1-24", "1-24:6", "1-24x6", "1-3,5,7-20:2",
    negative numbers), sorted and without repeats; the same parser as ``obscura render --frames``.
    Raises ValueError naming the bad item."""

def frame_chunks(frames: str, size: int) -> List[str]:
    """The frame list cut into runs of at most ``size`` frames, each as a canonical frame list
    ("1-6", "7-13:2"): what each task of a farm job chunked ``size`` frames at a time renders."""
