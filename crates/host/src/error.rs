//! Errors of the host tool, split by exit status: bad input (2) or anything else (1).

use std::fmt;

/// Whether the user's input was at fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorKind {
    /// A file, key, column or argument is wrong: exit status 2.
    BadInput,
    /// Anything else (I/O on output, numerical failure): exit status 1.
    Other,
}

/// A one-line error for the user. The message names the file, line, column or key.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostError {
    /// Which exit status it maps to.
    pub kind: ErrorKind,
    /// The one-line reason.
    pub message: String,
}

/// User text as an error message may quote it: control characters escaped (so the message
/// stays on one line) and at most 60 characters, with `…` when cut.
pub fn shown(text: &str) -> String {
    let mut out = String::new();
    for (n, c) in text.chars().enumerate() {
        if n == 60 {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

/// The message with any control character escaped: every error is one line, whatever text
/// from the input it quotes.
fn one_line(message: String) -> String {
    if !message.chars().any(char::is_control) {
        return message;
    }
    let mut out = String::with_capacity(message.len() + 8);
    for c in message.chars() {
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

impl HostError {
    /// Bad input (exit status 2).
    pub fn input(message: impl Into<String>) -> HostError {
        HostError {
            kind: ErrorKind::BadInput,
            message: one_line(message.into()),
        }
    }

    /// Any other failure (exit status 1).
    pub fn other(message: impl Into<String>) -> HostError {
        HostError {
            kind: ErrorKind::Other,
            message: one_line(message.into()),
        }
    }

    /// The same error said of `place` (a file, a record, an argument): `place: message`.
    pub fn at(self, place: &str) -> HostError {
        HostError {
            kind: self.kind,
            message: one_line(format!("{place}: {}", self.message)),
        }
    }

    /// Process exit status for this error.
    pub fn exit_code(&self) -> i32 {
        match self.kind {
            ErrorKind::BadInput => 2,
            ErrorKind::Other => 1,
        }
    }
}

impl fmt::Display for HostError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for HostError {}

/// A rejected parameter is bad input; the message names its key in the parameter file.
impl From<geared_servo::ParamError> for HostError {
    fn from(e: geared_servo::ParamError) -> HostError {
        HostError::input(format!("key `{}` {}", e.field(), e.reason()))
    }
}

/// A rejected analyser configuration is bad input (a frequency or block length the sample
/// period cannot carry).
impl From<geared_servo::analyser::ConfigError> for HostError {
    fn from(e: geared_servo::analyser::ConfigError) -> HostError {
        HostError::input(e.to_string())
    }
}
