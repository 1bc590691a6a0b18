//! The host reading what a plugin sends it: the rows of its parameter table ([`decl_from_raw`], at
//! load) and its answers to property queries ([`value_from_raw`]).
//!
//! Everything is checked before it is trusted: a row's counts before anything is read through its
//! pointers, every enumeration on arrival. A failure is an [`AbiError`] naming the parameter and the
//! field; the loader adds the plugin and the file.

use std::borrow::Cow;

use obscura_sdk::abi::c_data::{read_str, read_strs, read_value};
use obscura_sdk::abi::{
    ARRAY_SINGLE, ARRAY_VARIABLE, AbiError, RANGE_LIMITED, RANGE_MAX_INCLUSIVE, RANGE_MIN_INCLUSIVE,
    RawParamDecl, RawPropertyValue, VALUE_DEEP_METRIC, VALUE_DICING_HINT, VALUE_FLOAT, deep_metric_from_raw,
    param_type_from_raw,
};
use obscura_sdk::{DicingHint, ParamDecl, ParamType, ParamValue, PropertyValue, ValueRange};

/// Every `range_flags` bit the ABI defines; a row with any other bit set is refused at load.
const RANGE_KNOWN_BITS: u32 = RANGE_LIMITED | RANGE_MIN_INCLUSIVE | RANGE_MAX_INCLUSIVE;

/// Most scalars a `float[]` parameter's default may hold: more is taken for a corrupt count.
const MAX_LIST_DEFAULT: usize = 1 << 16;

/// Most choices a string parameter may offer: more is taken for a corrupt count.
const MAX_CHOICES: usize = 1024;

/// The dicing hint numbered `v` (`OBSCURA_DICING_*`), if any.
fn dicing_hint_from_raw(v: i32) -> Option<DicingHint> {
    [
        DicingHint::Orthographic,
        DicingHint::Perspective,
        DicingHint::Spherical,
    ]
    .into_iter()
    .find(|h| *h as i32 == v)
}

/// Reads a property answer.
///
/// # Errors
/// [`AbiError::UnknownEnum`] naming the unknown kind or enum value.
pub fn value_from_raw(v: RawPropertyValue) -> Result<PropertyValue, AbiError> {
    let unknown = |what, value, expected| AbiError::UnknownEnum {
        what,
        value,
        expected: Some(expected),
    };
    match v.kind {
        VALUE_DICING_HINT => dicing_hint_from_raw(v.enum_value)
            .map(PropertyValue::DicingHint)
            .ok_or_else(|| unknown("dicing hint", v.enum_value, "0, 1 or 2")),
        VALUE_DEEP_METRIC => deep_metric_from_raw(v.enum_value)
            .map(PropertyValue::DeepMetric)
            .ok_or_else(|| unknown("deep metric", v.enum_value, "0 or 1")),
        VALUE_FLOAT => Ok(PropertyValue::Float(v.float_value)),
        k => Err(unknown("property value kind", k, "0, 1 or 2")),
    }
}

/// Reads one row of a plugin's parameter table, checking it: a name, a known type, a consistent
/// array length and default, known range flags and a well-formed range that holds the default,
/// choices only on strings.
///
/// # Errors
/// An [`AbiError`]: a bad name, or [`AbiError::Param`] naming the parameter and what is wrong.
///
/// # Safety
/// Every pointer in `d` is null or valid for the counts it gives, strings NUL-terminated.
pub unsafe fn decl_from_raw(d: &RawParamDecl) -> Result<ParamDecl, AbiError> {
    // SAFETY: the caller's promise covers every pointer read.
    let name = unsafe { read_str(d.name, "name")? };
    if name.is_empty() || name.chars().any(char::is_whitespace) {
        return Err(AbiError::BadName { name });
    }
    // SAFETY: as above.
    unsafe { named_decl_from_raw(d, &name) }.map_err(|e| e.in_param(&name))
}

/// [`decl_from_raw`] once the row's name is read.
///
/// # Safety
/// As [`decl_from_raw`].
unsafe fn named_decl_from_raw(d: &RawParamDecl, name: &str) -> Result<ParamDecl, AbiError> {
    let shape = Shape::from_raw(d)?;
    // The counts are checked before anything is read through them: a C author's slip (a sizeof
    // where a length belongs) must be an error naming the parameter, not a read past the array.
    shape.check_default_count(d.default_count)?;
    if d.num_choices > MAX_CHOICES {
        return Err(AbiError::TooMany {
            what: "num_choices",
            count: d.num_choices,
            max: MAX_CHOICES,
            hint: "; a sizeof where a count belongs?",
        });
    }
    let ty = shape.ty;
    // SAFETY: the caller's promise; the counts are checked above.
    let default = unsafe {
        read_value(
            ty,
            d.default_floats,
            d.default_ints,
            d.default_strings,
            d.default_count,
            "default",
        )?
    };
    let doc = if d.doc.is_null() {
        String::new()
    } else {
        // SAFETY: as above.
        unsafe { read_str(d.doc, "doc")? }
    };
    let choices = if d.num_choices == 0 {
        Vec::new()
    } else if ty != ParamType::String {
        return Err(AbiError::ChoicesOnNonString { ty });
    } else {
        // SAFETY: as above.
        unsafe { read_strs(d.choices, d.num_choices, "choices")? }
    };
    let decl = ParamDecl {
        name: Cow::Owned(name.to_string()),
        ty,
        array_len: shape.array_len,
        variable_len: shape.variable_len,
        default,
        range: range_from_raw(d)?,
        choices: choices.into_iter().map(Cow::Owned).collect(),
        doc: Cow::Owned(doc),
    };
    check_default(&decl)?;
    Ok(decl)
}

/// A row's type and array length, checked.
struct Shape {
    ty: ParamType,
    array_len: Option<usize>,
    variable_len: bool,
}

impl Shape {
    fn from_raw(d: &RawParamDecl) -> Result<Self, AbiError> {
        let ty = param_type_from_raw(d.ty).ok_or(AbiError::UnknownEnum {
            what: "type",
            value: d.ty,
            expected: Some("0..7"),
        })?;
        let (array_len, variable_len) = match d.array_len {
            ARRAY_SINGLE => (None, false),
            ARRAY_VARIABLE if ty == ParamType::Float => (None, true),
            ARRAY_VARIABLE => return Err(AbiError::VariableLength { ty }),
            n if n > 0 && n as usize <= MAX_LIST_DEFAULT => (Some(n as usize), false),
            n if n > 0 => {
                return Err(AbiError::TooMany {
                    what: "array length",
                    count: n as usize,
                    max: MAX_LIST_DEFAULT,
                    hint: "",
                });
            }
            n => return Err(AbiError::BadArrayLength { len: n }),
        };
        Ok(Shape {
            ty,
            array_len,
            variable_len,
        })
    }

    /// `default_count` must be whole values of a list (within the cap), or exactly a fixed size.
    fn check_default_count(&self, count: usize) -> Result<(), AbiError> {
        let comps = self.ty.components();
        if self.variable_len {
            if count > MAX_LIST_DEFAULT || !count.is_multiple_of(comps) {
                return Err(AbiError::ListDefaultCount {
                    count,
                    components: comps,
                    max: MAX_LIST_DEFAULT,
                });
            }
        } else {
            let need = comps * self.array_len.unwrap_or(1);
            if count != need {
                let ty = self.ty;
                return Err(AbiError::DefaultCount {
                    count,
                    decl: self
                        .array_len
                        .map_or_else(|| ty.to_string(), |n| format!("{ty}[{n}]")),
                    need,
                });
            }
        }
        Ok(())
    }
}

/// The row's range: none without [`RANGE_LIMITED`] (the `INCLUSIVE` bits alone mean nothing, as the
/// header says), refused with bits the ABI does not define or with an empty or NaN interval.
fn range_from_raw(d: &RawParamDecl) -> Result<Option<ValueRange>, AbiError> {
    let unknown = d.range_flags & !RANGE_KNOWN_BITS;
    if unknown != 0 {
        return Err(AbiError::UnknownRangeFlags {
            flags: d.range_flags,
            unknown,
        });
    }
    if d.range_flags & RANGE_LIMITED == 0 {
        return Ok(None);
    }
    if d.range_min.is_nan() || d.range_max.is_nan() || d.range_min > d.range_max {
        return Err(AbiError::BadRange {
            min: d.range_min,
            max: d.range_max,
        });
    }
    Ok(Some(ValueRange {
        min: d.range_min,
        max: d.range_max,
        min_inclusive: d.range_flags & RANGE_MIN_INCLUSIVE != 0,
        max_inclusive: d.range_flags & RANGE_MAX_INCLUSIVE != 0,
    }))
}

/// The default fits its own declaration: its length, its range, its choices.
fn check_default(decl: &ParamDecl) -> Result<(), AbiError> {
    let comps = decl.ty.components();
    let count_ok = if decl.variable_len {
        decl.default.len().is_multiple_of(comps)
    } else {
        decl.default.len() == decl.scalar_count()
    };
    if !count_ok {
        return Err(AbiError::DefaultLength {
            has: decl.default.len(),
            decl: decl.rib_declaration(),
            needs: decl.scalar_count(),
        });
    }
    if let Some(range) = decl.range {
        let outside = match &decl.default {
            ParamValue::Floats(v) => v.iter().map(|x| f64::from(*x)).find(|x| !range.contains(*x)),
            ParamValue::Ints(v) => v.iter().map(|x| f64::from(*x)).find(|x| !range.contains(*x)),
            ParamValue::Strings(_) => None,
        };
        if let Some(value) = outside {
            return Err(AbiError::DefaultOutOfRange { value, range });
        }
    }
    if let ParamValue::Strings(v) = &decl.default
        && !decl.choices.is_empty()
        && let Some(s) = v.iter().find(|s| !decl.choices.iter().any(|c| c == s.as_str()))
    {
        return Err(AbiError::DefaultNotAChoice { value: s.clone() });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::abi::{param_type_to_raw, property_from_raw, value_to_raw};
    use obscura_sdk::{DeepMetric, DicingHint, ProjectionProperty};

    #[test]
    fn enum_numbers_round_trip_and_unknown_ones_are_refused() {
        for t in ParamType::ALL {
            assert_eq!(param_type_from_raw(param_type_to_raw(t)), Some(t));
        }
        assert_eq!(param_type_from_raw(8), None);
        for p in ProjectionProperty::ALL {
            assert_eq!(property_from_raw(p as i32), Some(p));
        }
        assert_eq!(property_from_raw(-1), None);
        for v in [
            PropertyValue::DicingHint(DicingHint::Spherical),
            PropertyValue::DeepMetric(DeepMetric::RayLength),
            PropertyValue::Float(37.5),
        ] {
            assert_eq!(value_from_raw(value_to_raw(v)), Ok(v));
        }
        let bad = RawPropertyValue {
            kind: VALUE_DICING_HINT,
            enum_value: 7,
            float_value: 0.0,
        };
        assert!(
            value_from_raw(bad)
                .unwrap_err()
                .to_string()
                .contains("unknown dicing hint 7")
        );
    }

    /// A `float scale = 1` row in [0, 10], its strings and default static.
    fn scale_row() -> RawParamDecl {
        static DEFAULT: [f32; 1] = [1.0];
        RawParamDecl {
            name: c"scale".as_ptr(),
            doc: std::ptr::null(),
            default_floats: DEFAULT.as_ptr(),
            default_ints: std::ptr::null(),
            default_strings: std::ptr::null(),
            default_count: 1,
            choices: std::ptr::null(),
            num_choices: 0,
            range_min: 0.0,
            range_max: 10.0,
            ty: param_type_to_raw(ParamType::Float),
            array_len: ARRAY_SINGLE,
            range_flags: RANGE_LIMITED | RANGE_MIN_INCLUSIVE | RANGE_MAX_INCLUSIVE,
        }
    }

    fn decode(row: &RawParamDecl) -> Result<ParamDecl, AbiError> {
        // SAFETY: `scale_row`'s pointers are static, NUL-terminated, and valid for its counts.
        unsafe { decl_from_raw(row) }
    }

    /// Regression: `range_flags` bits beyond the three the header defines were ignored, so a row
    /// meaning something this host does not know loaded as if it meant something else.
    #[test]
    fn range_flags_with_unknown_bits_are_refused_and_inclusive_bits_without_limited_mean_no_range() {
        let good = decode(&scale_row()).unwrap();
        assert_eq!(good.range, Some(ValueRange::closed(0.0, 10.0)));
        let mut row = scale_row();
        row.range_flags |= 8;
        let e = decode(&row).unwrap_err();
        assert_eq!(
            e,
            AbiError::UnknownRangeFlags {
                flags: RANGE_KNOWN_BITS | 8,
                unknown: 8
            }
            .in_param("scale")
        );
        let text = e.to_string();
        assert!(
            text.starts_with("parameter \"scale\": range_flags 0xf has unknown bits 0x8"),
            "{text}"
        );
        // The header: without LIMITED the INCLUSIVE bits mean nothing (and the bounds are not read).
        let mut row = scale_row();
        row.range_flags = RANGE_MIN_INCLUSIVE | RANGE_MAX_INCLUSIVE;
        row.range_min = f64::NAN;
        assert_eq!(decode(&row).unwrap().range, None);
    }
}
