//! Reading and writing the C data both sides of the boundary exchange: strings, arrays and parameter
//! values read through raw pointers (checked for NULL, alignment and UTF-8 before a reference is
//! made), and [`Keep`], the owner of the C views a side builds from SDK types.
//!
//! The plugin side reads the host's parameter lists with these, the host reads a plugin's parameter
//! table with them (`obscura_plugins::decode`), and both build C tables and lists with [`Keep`].

use std::ffi::{CStr, CString, c_char};

use super::AbiError;
use crate::param::{ParamType, ParamValue};

/// Reads a NUL-terminated UTF-8 string; `what` names it in the error.
///
/// # Errors
/// [`AbiError::NullPointer`] or [`AbiError::NotUtf8`].
///
/// # Safety
/// `p` is null or points to a NUL-terminated string.
pub unsafe fn read_str(p: *const c_char, what: &str) -> Result<String, AbiError> {
    if p.is_null() {
        return Err(AbiError::NullPointer { what: what.into() });
    }
    // SAFETY: non-null and NUL-terminated by the caller's promise.
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map(str::to_string)
        .map_err(|_| AbiError::NotUtf8 { what: what.into() })
}

/// A slice from a C array of `n` elements; `n == 0` needs no pointer.
///
/// # Errors
/// As [`check_array`].
///
/// # Safety
/// When `n > 0`, `p` is null or points to `n` readable, initialised `T`s alive for `'a`.
pub unsafe fn read_slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], AbiError> {
    check_array(p, n, what)?;
    if n == 0 {
        return Ok(&[]);
    }
    // SAFETY: non-null, aligned, `n` elements by the caller's promise.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// The checks a C array passes before it becomes a slice: non-null and aligned when not empty.
///
/// # Errors
/// [`AbiError::NullArray`] or [`AbiError::Misaligned`].
pub fn check_array<T>(p: *const T, n: usize, what: &str) -> Result<(), AbiError> {
    if n > 0 && p.is_null() {
        return Err(AbiError::NullArray {
            what: what.into(),
            count: n,
        });
    }
    if n > 0 && !p.is_aligned() {
        return Err(AbiError::Misaligned { what: what.into() });
    }
    Ok(())
}

/// Reads `n` strings of a C array; the `i`-th is named `what[i]` in the error.
///
/// # Errors
/// As [`read_slice`] for the array, as [`read_str`] for each string.
///
/// # Safety
/// Pointers as for [`read_slice`], each string NUL-terminated.
pub unsafe fn read_strs(p: *const *const c_char, n: usize, what: &str) -> Result<Vec<String>, AbiError> {
    // SAFETY: forwarded promise.
    let ptrs = unsafe { read_slice(p, n, what)? };
    ptrs.iter()
        .enumerate()
        // SAFETY: forwarded promise.
        .map(|(i, s)| unsafe { read_str(*s, &format!("{what}[{i}]")) })
        .collect()
}

/// Reads a parameter value of type `ty` from the one of its three arrays that stores that type
/// (`ints` for int, `strings` for string, `floats` for every other type).
///
/// # Errors
/// As [`read_slice`] and [`read_strs`].
///
/// # Safety
/// The pointer of `ty`'s storage is as for [`read_slice`] with `count` elements; the other two are
/// not read.
pub unsafe fn read_value(
    ty: ParamType,
    floats: *const f32,
    ints: *const i32,
    strings: *const *const c_char,
    count: usize,
    what: &str,
) -> Result<ParamValue, AbiError> {
    // SAFETY: forwarded promise.
    unsafe {
        Ok(match ty {
            ParamType::Int => ParamValue::Ints(read_slice(ints, count, what)?.to_vec()),
            ParamType::String => ParamValue::Strings(read_strs(strings, count, what)?),
            _ => ParamValue::Floats(read_slice(floats, count, what)?.to_vec()),
        })
    }
}

/// A parameter value's C view: the array of its storage (the other two NULL) and its scalar count.
#[derive(Debug, Clone, Copy)]
pub struct ValuePtrs {
    /// The floats of a float-stored value, else NULL.
    pub floats: *const f32,
    /// The ints of an int value, else NULL.
    pub ints: *const i32,
    /// The strings of a string value, else NULL.
    pub strings: *const *const c_char,
    /// Scalars held.
    pub count: usize,
}

/// Heap storage that C views point into. Moving a `Keep` moves no heap buffer, so the pointers it
/// handed out stay valid for as long as it lives.
#[derive(Debug, Default)]
pub struct Keep {
    strings: Vec<CString>,
    floats: Vec<Vec<f32>>,
    ints: Vec<Vec<i32>>,
    ptrs: Vec<Vec<*const c_char>>,
}

impl Keep {
    /// A C copy of `s`, kept; `what` names whose string it is in the error.
    ///
    /// # Errors
    /// [`AbiError::NulByte`] when `s` holds a NUL byte.
    pub fn cstr(&mut self, s: &str, what: &str) -> Result<*const c_char, AbiError> {
        let c = CString::new(s).map_err(|_| AbiError::NulByte {
            what: what.into(),
            text: s.into(),
        })?;
        let p = c.as_ptr();
        self.strings.push(c);
        Ok(p)
    }

    /// A C array of C copies of `v`, kept; NULL when `v` is empty.
    ///
    /// # Errors
    /// As [`Keep::cstr`].
    pub fn strs<S: AsRef<str>>(&mut self, v: &[S], what: &str) -> Result<*const *const c_char, AbiError> {
        if v.is_empty() {
            return Ok(std::ptr::null());
        }
        let ptrs = v
            .iter()
            .map(|s| self.cstr(s.as_ref(), what))
            .collect::<Result<Vec<_>, _>>()?;
        let p = ptrs.as_ptr();
        self.ptrs.push(ptrs);
        Ok(p)
    }

    /// The C view of `v`, its scalars copied and kept; an empty value has only NULL arrays.
    ///
    /// # Errors
    /// As [`Keep::cstr`], for a string value.
    pub fn value(&mut self, v: &ParamValue, what: &str) -> Result<ValuePtrs, AbiError> {
        let mut out = ValuePtrs {
            floats: std::ptr::null(),
            ints: std::ptr::null(),
            strings: std::ptr::null(),
            count: v.len(),
        };
        match v {
            ParamValue::Floats(x) if !x.is_empty() => {
                self.floats.push(x.clone());
                out.floats = self.floats.last().map_or(out.floats, |b| b.as_ptr());
            }
            ParamValue::Ints(x) if !x.is_empty() => {
                self.ints.push(x.clone());
                out.ints = self.ints.last().map_or(out.ints, |b| b.as_ptr());
            }
            ParamValue::Strings(x) => out.strings = self.strs(x, what)?,
            _ => {}
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn null_misaligned_and_non_utf8_data_is_refused_by_name() {
        // SAFETY: a NULL pointer is what the function checks for.
        let e = unsafe { read_str(std::ptr::null(), "name") }.unwrap_err();
        assert_eq!(e.to_string(), "name is NULL");
        // SAFETY: a NUL-terminated byte string.
        let e = unsafe { read_str(c"caf\xe9".as_ptr(), "doc") }.unwrap_err();
        assert_eq!(e, AbiError::NotUtf8 { what: "doc".into() });
        // SAFETY: NULL with a count: refused before any read.
        let e = unsafe { read_slice::<f32>(std::ptr::null(), 2, "default") }.unwrap_err();
        assert_eq!(e.to_string(), "default is NULL but 2 element(s) were promised");
        let words = [0u32; 2];
        let odd = words.as_ptr().cast::<u8>().wrapping_add(1).cast::<u32>();
        assert_eq!(
            check_array(odd, 1, "ints").unwrap_err().to_string(),
            "ints is misaligned"
        );
        // SAFETY: an empty array needs no pointer.
        let empty = unsafe { read_slice::<f32>(std::ptr::null(), 0, "none") };
        assert!(empty.unwrap().is_empty());
    }

    #[test]
    fn kept_values_read_back_and_nul_bytes_are_refused() {
        let mut keep = Keep::default();
        let v = ParamValue::Strings(vec!["a".into(), "bc".into()]);
        let p = keep.value(&v, "choices").unwrap();
        assert!(p.floats.is_null() && p.ints.is_null());
        // SAFETY: `keep` owns the two strings `p` points to.
        let back = unsafe { read_value(ParamType::String, p.floats, p.ints, p.strings, p.count, "v") };
        assert_eq!(back.unwrap(), v);
        let v = ParamValue::Ints(vec![3, 4]);
        let p = keep.value(&v, "steps").unwrap();
        // SAFETY: as above.
        let back = unsafe { read_value(ParamType::Int, p.floats, p.ints, p.strings, p.count, "v") };
        assert_eq!(back.unwrap(), v);
        let e = keep.cstr("a\0b", "parameter \"x\"").unwrap_err();
        assert_eq!(e.to_string(), "parameter \"x\" \"a\0b\" contains a NUL byte");
    }
}
