"""Obscura in Python: RenderMan-style camera projections, calibrated camera models and projection
plugins, with numpy arrays in and out.

>>> import numpy as np, obscura
>>> cam = obscura.Camera("PxrPerspective", format=(640, 480), fov=60)
>>> rays = cam.rays()                      # every pixel's chief ray, H×W×3 directions
>>> cam = obscura.Camera.from_calibration("cameras.txt", camera=1)
>>> d, ok = cam.pixel_to_ray(np.array([[100.5, 200.5]]))   # f64, COLMAP's pixel convention

Camera space is Obscura's (RenderMan's): +X right, +Y up, looking down +Z; pass
``camera_space="opencv"`` for OpenCV/COLMAP's +Y down. Raster positions have y down, from the top-left
image corner. See ``help(obscura.Camera)`` for every method.
"""

from ._obscura import (
    Camera,
    __version__,
    add_plugin_path,
    calibration_models,
    check,
    frame_chunks,
    get_num_threads,
    load_plugin,
    parse_frames,
    projections,
    render,
    render_dataset,
    set_num_threads,
    stmap,
)

__all__ = [
    "Camera",
    "__version__",
    "add_plugin_path",
    "calibration_models",
    "check",
    "frame_chunks",
    "get_num_threads",
    "load_plugin",
    "parse_frames",
    "projections",
    "render",
    "render_dataset",
    "set_num_threads",
    "stmap",
]
