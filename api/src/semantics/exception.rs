//! Exception codes (OptiX 7 `OptixExceptionCodes`): user codes are 0..2³⁰; built-in codes
//! are negative.

/// A continuation-call stack overflowed.
pub const STACK_OVERFLOW: i32 = -1;
/// `rt_trace` was called beyond the pipeline's `max_trace_depth`.
pub const TRACE_DEPTH_EXCEEDED: i32 = -2;
/// A traversable handle was null-but-nonzero, destroyed or of another device.
pub const INVALID_TRAVERSABLE: i32 = -5;
/// The miss index selected no miss record.
pub const INVALID_MISS_SBT: i32 = -6;
/// The hit SBT index selected no hit group record.
pub const INVALID_HIT_SBT: i32 = -7;
/// The pipeline was not compiled for a primitive type the ray met.
pub const UNSUPPORTED_PRIMITIVE_TYPE: i32 = -8;
/// The ray had a NaN or infinite origin or direction, a negative or NaN tmin, a NaN tmax,
/// or tmin > tmax.
pub const INVALID_RAY: i32 = -9;
/// A callable index selected no callable record, or a record without that kind of callable.
pub const CALLABLE_INVALID_SBT: i32 = -12;

/// Largest user exception code plus one (OptiX: codes 0 to 2³⁰ − 1).
pub const USER_CODE_LIMIT: u32 = 1 << 30;

/// A readable name for an exception code.
pub fn name(code: i32) -> String {
    match code {
        STACK_OVERFLOW => "STACK_OVERFLOW".into(),
        TRACE_DEPTH_EXCEEDED => "TRACE_DEPTH_EXCEEDED".into(),
        INVALID_TRAVERSABLE => "INVALID_TRAVERSABLE".into(),
        INVALID_MISS_SBT => "INVALID_MISS_SBT".into(),
        INVALID_HIT_SBT => "INVALID_HIT_SBT".into(),
        UNSUPPORTED_PRIMITIVE_TYPE => "UNSUPPORTED_PRIMITIVE_TYPE".into(),
        INVALID_RAY => "INVALID_RAY".into(),
        CALLABLE_INVALID_SBT => "CALLABLE_INVALID_SBT".into(),
        c if c >= 0 => format!("user exception {c}"),
        c => format!("exception {c}"),
    }
}

/// The code a user throw raises: `code` masked to the user range (OptiX keeps 30 bits).
pub fn user_code(code: u32) -> i32 {
    (code & (USER_CODE_LIMIT - 1)) as i32
}
