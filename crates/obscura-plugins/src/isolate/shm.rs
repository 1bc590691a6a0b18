//! The shared memory a host and its worker exchange batches through: one `memfd` per worker, mapped
//! by both, holding one batch's six arrays back to back.
//!
//! For a batch of `n` rays the layout is, in bytes from the start (every offset a multiple of 4, the
//! alignment of each element type, and the mapping page-aligned):
//!
//! | array | type | offset | size |
//! |---|---|---|---|
//! | screen | `Point2` | 0 | 8n |
//! | lens | `Point2` | 8n | 8n |
//! | aperture | `Point2` | 16n | 8n |
//! | time | `f32` | 24n | 4n |
//! | rays | `RayGeometry` | 28n | 40n |
//! | tint | `Rgb` | 68n | 12n |
//!
//! The host writes the inputs (and the pre-filled rays, times and tints), sends `Project`, and reads
//! `time`, `rays` and `tint` back once the worker has replied: while one side works the other does not
//! touch the memory, which is what makes sharing it sound.

use std::fs::File;

use memmap2::MmapMut;
use obscura_sdk::{Point2, RayGeometry, Rgb};

/// Bytes one ray takes in the shared memory.
pub const BYTES_PER_RAY: usize =
    3 * size_of::<Point2>() + size_of::<f32>() + size_of::<RayGeometry>() + size_of::<Rgb>();

/// The six arrays of one batch inside the shared memory.
pub struct Arrays<'a> {
    pub screen: &'a mut [Point2],
    pub lens: &'a mut [Point2],
    pub aperture: &'a mut [Point2],
    pub time: &'a mut [f32],
    pub rays: &'a mut [RayGeometry],
    pub tint: &'a mut [Rgb],
}

/// A memfd and its mapping.
pub struct Shm {
    file: File,
    map: MmapMut,
}

impl Shm {
    /// Maps `file` as it is (the worker's side: the host created and sized it).
    ///
    /// # Errors
    /// The system's reason.
    pub fn map(file: File) -> std::io::Result<Shm> {
        // SAFETY: the memfd is shared only with the host, which by the protocol never writes it while
        // the worker reads or writes it (and the other way round); see the module doc.
        let map = unsafe { MmapMut::map_mut(&file) }?;
        Ok(Shm { file, map })
    }

    /// A new memfd of `len` bytes, mapped (the host's side).
    ///
    /// # Errors
    /// The system's reason.
    pub fn create(len: usize) -> std::io::Result<Shm> {
        let fd = rustix::fs::memfd_create("obscura-plugin-batch", rustix::fs::MemfdFlags::CLOEXEC)?;
        let file = File::from(fd);
        file.set_len(len as u64)?;
        Self::map(file)
    }

    /// The memfd.
    pub fn file(&self) -> &File {
        &self.file
    }

    /// The mapping's length in bytes.
    pub fn len(&self) -> usize {
        self.map.len()
    }

    /// Makes the memory hold at least `n` rays (the host's side): grows the memfd to the next power of
    /// two and maps it again.
    ///
    /// # Errors
    /// The system's reason.
    pub fn reserve(&mut self, n: usize) -> std::io::Result<()> {
        let need = n.saturating_mul(BYTES_PER_RAY);
        if need > self.map.len() {
            let len = need.next_power_of_two();
            self.file.set_len(len as u64)?;
            self.remap(len)?;
        }
        Ok(())
    }

    /// Maps the memfd again if it is no longer `len` bytes long here (the worker's side, after the
    /// host grew it).
    ///
    /// # Errors
    /// The system's reason, or a length the file does not have.
    pub fn remap(&mut self, len: usize) -> std::io::Result<()> {
        if len != self.map.len() {
            let actual = self.file.metadata()?.len();
            if actual != len as u64 {
                return Err(std::io::Error::other(format!(
                    "the shared memory is {actual} bytes, not the {len} announced"
                )));
            }
            // SAFETY: as in `map`.
            self.map = unsafe { MmapMut::map_mut(&self.file) }?;
        }
        Ok(())
    }

    /// The arrays of a batch of `n` rays, or `None` when the memory is too small for them.
    pub fn arrays(&mut self, n: usize) -> Option<Arrays<'_>> {
        if n.checked_mul(BYTES_PER_RAY)? > self.map.len() {
            return None;
        }
        let (screen, rest) = self.map.split_at_mut(8 * n);
        let (lens, rest) = rest.split_at_mut(8 * n);
        let (aperture, rest) = rest.split_at_mut(8 * n);
        let (time, rest) = rest.split_at_mut(4 * n);
        let (rays, rest) = rest.split_at_mut(40 * n);
        let (tint, _) = rest.split_at_mut(12 * n);
        Some(Arrays {
            screen: cast(screen),
            lens: cast(lens),
            aperture: cast(aperture),
            time: cast(time),
            rays: cast(rays),
            tint: cast(tint),
        })
    }
}

/// Plain `#[repr(C)]` types of `f32` fields only: every bit pattern is a valid value.
trait Plain: Copy {}
impl Plain for f32 {}
impl Plain for Point2 {}
impl Plain for RayGeometry {}
impl Plain for Rgb {}

/// `bytes` as a slice of `T`.
///
/// # Panics
/// When `bytes` is not aligned for `T` or not a whole number of `T` (the layout above rules both out).
fn cast<T: Plain>(bytes: &mut [u8]) -> &mut [T] {
    assert!(
        bytes.as_ptr().align_offset(align_of::<T>()) == 0 && bytes.len().is_multiple_of(size_of::<T>()),
        "shared-memory layout broken"
    );
    // SAFETY: aligned and sized for `T` (checked above), borrowed exclusively for the result's
    // lifetime, and any bit pattern is a valid `T` (`Plain`).
    unsafe { std::slice::from_raw_parts_mut(bytes.as_mut_ptr().cast::<T>(), bytes.len() / size_of::<T>()) }
}

const _: () = assert!(
    size_of::<Point2>() == 8
        && size_of::<RayGeometry>() == 40
        && size_of::<Rgb>() == 12
        && BYTES_PER_RAY == 80
);
