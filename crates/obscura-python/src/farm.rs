//! Frame lists as farms write them, read by the same parser as `obscura render --frames`
//! ([`obscura_render::sequence::FrameSpec`]).

use obscura_render::sequence::FrameSpec;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Reads a selection into a [`FrameSpec`], or a `ValueError` with the parser's message.
fn spec(frames: &str) -> PyResult<FrameSpec> {
    FrameSpec::parse(frames).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The frames of a frame list as farms write it (`"1-24"`, `"1-24:6"`, `"1-24x6"`,
/// `"1-3,5,7-20:2"`, negative numbers), sorted and without repeats; the same parser as
/// `obscura render --frames`. Raises ValueError naming the bad item.
#[pyfunction]
pub fn parse_frames(frames: &str) -> PyResult<Vec<i32>> {
    Ok(spec(frames)?.frames().collect())
}

/// The frame list cut into runs of at most `size` frames, each as a canonical frame list
/// (`"1-6"`, `"7-13:2"`): what each task of a farm job chunked `size` frames at a time renders.
/// Raises ValueError for a bad list or a size of 0.
#[pyfunction]
pub fn frame_chunks(frames: &str, size: u32) -> PyResult<Vec<String>> {
    if size == 0 {
        return Err(PyValueError::new_err(
            "size: a chunk holds at least one frame, got 0",
        ));
    }
    Ok(spec(frames)?
        .chunks(size)
        .iter()
        .map(ToString::to_string)
        .collect())
}
