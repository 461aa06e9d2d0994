//! Standard output of the commands. A reader that closed the pipe (`skeletrace info s.ron |
//! head -1`) ends the command quietly with status 0, as `cat` does; any other write error (a
//! full device) is one line on standard error and a failure status. `--json` outputs are
//! written from typed records by `serde_json` (non-finite numbers become `null`).

use std::io::{ErrorKind, Write};

/// Writes `text` to standard output.
///
/// # Errors
/// A write error other than a closed pipe, in words.
pub fn print(text: &str) -> Result<(), String> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(format!("writing to standard output: {e}")),
    }
}

/// Writes `record` to standard output as indented JSON and a newline.
///
/// # Errors
/// As [`print`].
pub fn print_json(record: &impl serde::Serialize) -> Result<(), String> {
    let mut text = serde_json::to_string_pretty(record)
        .map_err(|e| format!("writing JSON to standard output: {e}"))?;
    text.push('\n');
    print(&text)
}

/// A method left out of a command's `all` (or of the GPU), with the reason.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Skipped {
    /// The method's name.
    pub name: &'static str,
    /// Why it was left out.
    pub reason: String,
}
