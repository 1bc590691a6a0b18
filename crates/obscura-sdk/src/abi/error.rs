//! [`AbiError`]: why data crossing the C boundary could not be read or written, on either side.
//!
//! The host's loader wraps it in its own error naming the file and the plugin; a Rust plugin's
//! trampolines send its text to the host's error sink. Each variant's text is what a C author reads,
//! so it names the field (`default`, `params[2].name`, `range_flags`) as the header spells it.

use crate::context::ContextLengthError;
use crate::param::{DeclarationError, ParamType, ValueRange};
use crate::plugin::PluginError;

/// Why C data could not be read (a null or misaligned pointer, a corrupt count, a malformed
/// parameter row, an unknown enumeration value) or written (a string C cannot carry).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AbiError {
    /// A required pointer is NULL.
    #[error("{what} is NULL")]
    NullPointer {
        /// The field or argument.
        what: String,
    },
    /// An array's pointer is NULL though its count promises elements.
    #[error("{what} is NULL but {count} element(s) were promised")]
    NullArray {
        /// The array.
        what: String,
        /// The count that came with it.
        count: usize,
    },
    /// An array's pointer is not aligned for its element type.
    #[error("{what} is misaligned")]
    Misaligned {
        /// The array.
        what: String,
    },
    /// A string is not UTF-8.
    #[error("{what} is not UTF-8")]
    NotUtf8 {
        /// The string's field.
        what: String,
    },
    /// A string holds a NUL byte, which a C string cannot carry.
    #[error("{what} \"{text}\" contains a NUL byte")]
    NulByte {
        /// Whose string it is.
        what: String,
        /// The string.
        text: String,
    },
    /// A struct's `struct_size` is smaller than the layout this side reads.
    #[error("{what} struct_size {size} is smaller than {min}")]
    TooSmall {
        /// The struct.
        what: &'static str,
        /// The `struct_size` found.
        size: u32,
        /// This side's layout.
        min: usize,
    },
    /// An enumeration crossed as an `int32_t` with a value it does not have.
    #[error("unknown {what} {value}{}", expected.map(|e| format!(" (expected {e})")).unwrap_or_default())]
    UnknownEnum {
        /// The enumeration (`dicing hint`, `type`).
        what: &'static str,
        /// The value found.
        value: i32,
        /// The values it may take, when worth saying.
        expected: Option<&'static str>,
    },
    /// `create_projection` wrote an unknown deep metric into the environment.
    #[error(
        "create_projection set the environment's deep metric to {value} (expected 0 = cameraZ or 1 = rayLength)"
    )]
    DeepMetricWritten {
        /// The value written.
        value: i32,
    },
    /// A parameter row's name is empty or has white space.
    #[error("parameter name \"{name}\" is empty or has spaces")]
    BadName {
        /// The name.
        name: String,
    },
    /// What is wrong with the named parameter.
    #[error("parameter \"{name}\": {error}")]
    Param {
        /// The parameter.
        name: String,
        /// What is wrong (boxed: the enum is recursive).
        error: Box<AbiError>,
    },
    /// A parameter of another type than `float` declared a variable length.
    #[error("only float[] may have variable length, not {ty}[]")]
    VariableLength {
        /// The parameter's type.
        ty: ParamType,
    },
    /// An `array_len` that is none of `OBSCURA_ARRAY_SINGLE`, `OBSCURA_ARRAY_VARIABLE` or a length.
    #[error("array length {len} (expected 0, -1 or a positive length)")]
    BadArrayLength {
        /// The `array_len` found.
        len: i32,
    },
    /// A count over its cap, taken for a corrupt one.
    #[error("{what} {count} (at most {max}{hint})")]
    TooMany {
        /// The count's field (`array length`, `num_choices`).
        what: &'static str,
        /// The count found.
        count: usize,
        /// The cap.
        max: usize,
        /// A likely cause, `; …`, or empty.
        hint: &'static str,
    },
    /// A `float[]` default whose `default_count` is over the cap or not whole values.
    #[error("default_count {count} for float[] (expected a multiple of {components}, at most {max})")]
    ListDefaultCount {
        /// The `default_count` found.
        count: usize,
        /// Scalars per value.
        components: usize,
        /// The cap.
        max: usize,
    },
    /// A fixed-size default whose `default_count` is not the size of the declared type.
    #[error("default_count {count} but a {decl} default has {need} scalar(s)")]
    DefaultCount {
        /// The `default_count` found.
        count: usize,
        /// The declared type, `float` or `int[2]`.
        decl: String,
        /// The scalars that type holds.
        need: usize,
    },
    /// Choices on a parameter that is not a string.
    #[error("choices on a {ty} parameter (only strings take choices)")]
    ChoicesOnNonString {
        /// The parameter's type.
        ty: ParamType,
    },
    /// `range_flags` has bits the ABI does not define.
    #[error(
        "range_flags {flags:#x} has unknown bits {unknown:#x} (only OBSCURA_RANGE_LIMITED, \
         OBSCURA_RANGE_MIN_INCLUSIVE and OBSCURA_RANGE_MAX_INCLUSIVE are defined)"
    )]
    UnknownRangeFlags {
        /// The whole `range_flags`.
        flags: u32,
        /// The bits not defined.
        unknown: u32,
    },
    /// A limited range that is empty or has a NaN bound.
    #[error("range [{min}, {max}] is empty or NaN")]
    BadRange {
        /// `range_min`.
        min: f64,
        /// `range_max`.
        max: f64,
    },
    /// A default whose length does not fit its declaration.
    #[error("the default has {has} scalar(s) but {decl} needs {needs}")]
    DefaultLength {
        /// Scalars in the default.
        has: usize,
        /// The RIB declaration (`float[2] k`).
        decl: String,
        /// Scalars the declaration needs.
        needs: usize,
    },
    /// A default outside its parameter's own range.
    #[error("the default {value} is outside its own range {range}")]
    DefaultOutOfRange {
        /// The first scalar outside.
        value: f64,
        /// The range.
        range: ValueRange,
    },
    /// A string default that is not one of its parameter's own choices.
    #[error("the default \"{value}\" is not one of its own choices")]
    DefaultNotAChoice {
        /// The default.
        value: String,
    },
    /// A parameter value whose scalars do not make whole values of its type.
    #[error("{count} scalar(s) do not make whole {ty}s")]
    PartialValue {
        /// Scalars given.
        count: usize,
        /// The type.
        ty: ParamType,
    },
    /// A parameter list entry that does not make a declaration.
    #[error(transparent)]
    Declaration(#[from] DeclarationError),
    /// The factory's own error (from `init` or `create_projection`).
    #[error(transparent)]
    Plugin(#[from] PluginError),
    /// A batch whose arrays differ in length.
    #[error(transparent)]
    Context(#[from] ContextLengthError),
}

impl AbiError {
    /// This error, said of the parameter `name`.
    #[must_use]
    pub fn in_param(self, name: &str) -> Self {
        AbiError::Param {
            name: name.to_string(),
            error: Box::new(self),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_field_and_what_was_expected() {
        let e = AbiError::UnknownEnum {
            what: "dicing hint",
            value: 7,
            expected: Some("0, 1 or 2"),
        };
        assert_eq!(e.to_string(), "unknown dicing hint 7 (expected 0, 1 or 2)");
        let e = AbiError::UnknownEnum {
            what: "deep metric",
            value: 9,
            expected: None,
        };
        assert_eq!(e.to_string(), "unknown deep metric 9");
        let e = AbiError::UnknownRangeFlags {
            flags: 0x9,
            unknown: 0x8,
        }
        .in_param("scale");
        assert!(
            e.to_string()
                .starts_with("parameter \"scale\": range_flags 0x9 has unknown bits 0x8"),
            "{e}"
        );
    }
}
