//! Errors a user can cause, and the exit code each gives.

/// Exit code for bad input (a style, a path, a flag), like clap's own usage errors.
pub const EXIT_BAD_INPUT: i32 = 2;

/// A user's mistake outside a style or motion file (a flag's value, a missing path): exit 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// The exit code of a failed command: 2 for bad input (a style, a motion, a flag), else 1.
pub fn exit_code(e: &anyhow::Error) -> i32 {
    let bad = e.chain().any(|c| {
        c.downcast_ref::<crate::style::StyleError>().is_some()
            || c.downcast_ref::<crate::motion::MotionError>().is_some()
            || c.downcast_ref::<BadInput>().is_some()
    });
    if bad {
        EXIT_BAD_INPUT
    } else {
        1
    }
}
