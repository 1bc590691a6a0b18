//! NumPy `.npz` files: a zip archive of `.npy` arrays, one per name, as `numpy.load` reads them.
//!
//! Each member `<name>.npy` is NPY format version 1.0: the magic `\x93NUMPY`, the version bytes
//! `1 0`, a little-endian `u16` header length, and an ASCII header
//! `{'descr': '<f4', 'fortran_order': False, 'shape': (N, T, 2), }` padded with spaces and ended by
//! `\n` so that the data starts at a multiple of 64 bytes; then the data, C order (last index
//! fastest), little-endian. Members are deflate-compressed (as `numpy.savez_compressed` writes them).
//! The file is written atomically.

use std::io::{self, Write};
use std::path::Path;

use obscura_image::atomic::{AtomicWriteError, write_atomically};
use zip::CompressionMethod;
use zip::write::SimpleFileOptions;

/// The element types the annotations use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    /// 32-bit float, `<f4`.
    F32,
    /// Unsigned byte, `|u1`.
    U8,
    /// 32-bit unsigned integer, `<u4`.
    U32,
    /// 32-bit signed integer, `<i4`.
    I32,
}

impl Dtype {
    /// NumPy's type string.
    #[must_use]
    pub fn descr(self) -> &'static str {
        match self {
            Dtype::F32 => "<f4",
            Dtype::U8 => "|u1",
            Dtype::U32 => "<u4",
            Dtype::I32 => "<i4",
        }
    }

    /// Bytes per element.
    #[must_use]
    pub fn size(self) -> usize {
        match self {
            Dtype::U8 => 1,
            Dtype::F32 | Dtype::U32 | Dtype::I32 => 4,
        }
    }
}

/// One array: its name in the archive (without `.npy`), type, shape and little-endian data.
#[derive(Debug, Clone, PartialEq)]
pub struct Array {
    /// Member name, without `.npy`.
    pub name: String,
    /// Element type.
    pub dtype: Dtype,
    /// Shape, C order.
    pub shape: Vec<usize>,
    /// The elements' little-endian bytes, C order.
    pub data: Vec<u8>,
}

impl Array {
    /// An `f32` array.
    #[must_use]
    pub fn f32(name: &str, shape: &[usize], values: &[f32]) -> Array {
        Array::new(
            name,
            Dtype::F32,
            shape,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )
    }

    /// A `u8` array.
    #[must_use]
    pub fn u8(name: &str, shape: &[usize], values: &[u8]) -> Array {
        Array::new(name, Dtype::U8, shape, values.to_vec())
    }

    /// A `u32` array.
    #[must_use]
    pub fn u32(name: &str, shape: &[usize], values: &[u32]) -> Array {
        Array::new(
            name,
            Dtype::U32,
            shape,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )
    }

    /// An `i32` array.
    #[must_use]
    pub fn i32(name: &str, shape: &[usize], values: &[i32]) -> Array {
        Array::new(
            name,
            Dtype::I32,
            shape,
            values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        )
    }

    fn new(name: &str, dtype: Dtype, shape: &[usize], data: Vec<u8>) -> Array {
        Array {
            name: name.to_string(),
            dtype,
            shape: shape.to_vec(),
            data,
        }
    }

    /// The array as a `.npy` file.
    ///
    /// # Errors
    /// When the data's length is not the shape's element count times the element size, or the header
    /// would not fit NPY 1.0's 16-bit length.
    pub fn to_npy(&self) -> io::Result<Vec<u8>> {
        let count: usize = self.shape.iter().product();
        if count * self.dtype.size() != self.data.len() {
            return Err(io::Error::other(format!(
                "array `{}`: shape {:?} of {} needs {} bytes, the data has {}",
                self.name,
                self.shape,
                self.dtype.descr(),
                count * self.dtype.size(),
                self.data.len()
            )));
        }
        let shape = match self.shape.as_slice() {
            [n] => format!("({n},)"),
            s => format!(
                "({})",
                s.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
            ),
        };
        let mut header = format!(
            "{{'descr': '{}', 'fortran_order': False, 'shape': {shape}, }}",
            self.dtype.descr()
        );
        // magic (6) + version (2) + length (2) + header + '\n', padded to 64.
        let unpadded = 10 + header.len() + 1;
        header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
        header.push('\n');
        let length = u16::try_from(header.len())
            .map_err(|_| io::Error::other(format!("array `{}`: NPY header too long", self.name)))?;
        let mut out = Vec::with_capacity(10 + header.len() + self.data.len());
        out.extend_from_slice(b"\x93NUMPY\x01\x00");
        out.extend_from_slice(&length.to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(&self.data);
        Ok(out)
    }
}

/// Writes `arrays` to `path` as a `.npz` archive, atomically (see the module documentation).
///
/// # Errors
/// [`AtomicWriteError`] naming `path` when it cannot be written or an array's data does not fit its
/// shape.
pub fn write_npz(path: &Path, arrays: &[Array]) -> Result<(), AtomicWriteError> {
    write_atomically(path, |file| {
        let mut zip = zip::ZipWriter::new(file);
        let options = SimpleFileOptions::default()
            .compression_method(CompressionMethod::Deflated)
            .large_file(arrays.iter().any(|a| a.data.len() > u32::MAX as usize / 2));
        for a in arrays {
            zip.start_file(format!("{}.npy", a.name), options)
                .map_err(io::Error::other)?;
            zip.write_all(&a.to_npy()?)?;
        }
        zip.finish().map_err(io::Error::other)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_headers_align_the_data_to_64_bytes_and_state_the_shape() {
        for shape in [vec![3usize], vec![2, 5, 2], vec![0, 4]] {
            let n: usize = shape.iter().product();
            let a = Array::f32("x", &shape, &vec![1.5; n]);
            let npy = a.to_npy().unwrap();
            let hlen = u16::from_le_bytes([npy[8], npy[9]]) as usize;
            assert_eq!((10 + hlen) % 64, 0);
            assert_eq!(npy[10 + hlen - 1], b'\n');
            assert_eq!(npy.len(), 10 + hlen + 4 * n);
            let header = std::str::from_utf8(&npy[10..10 + hlen]).unwrap();
            assert!(header.contains("'descr': '<f4'"), "{header}");
            if shape.len() == 1 {
                assert!(header.contains("'shape': (3,)"), "{header}");
            }
        }
    }

    #[test]
    fn a_shape_that_does_not_fit_the_data_is_an_error_naming_the_array() {
        let a = Array::u8("status", &[2, 3], &[0; 5]);
        let e = a.to_npy().unwrap_err().to_string();
        assert!(e.contains("status") && e.contains("[2, 3]"), "{e}");
    }
}
