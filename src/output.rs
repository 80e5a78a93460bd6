//! Writing outputs: whole files or nothing, names that stay inside the folder the user named.
//!
//! - [`write_atomic`] writes through a temporary file in the same folder and a rename, so a path
//!   holds its previous content or the complete new one, never half a file; an interrupt
//!   ([`install_interrupt_handler`]) removes the temporary files being written and reports it
//!   to the caller, which owns the exit.
//! - [`check_file_name`] is the rule for names that become file names (a scenario's `name`, a
//!   vehicle's `name`): a scenario from someone else must not write outside `--out`.

use std::io::Write;
use std::path::PathBuf;

/// Temporary files being written right now: an interrupt removes them, so a killed run leaves
/// each output either as it was or complete (the rename is atomic), and no debris.
static IN_FLIGHT: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// What an interrupt (SIGINT or SIGTERM) found: the unfinished outputs it removed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Interrupted {
    /// Temporary files of outputs being written, removed (the outputs keep their old content).
    pub removed: usize,
}

/// Installs the SIGINT/SIGTERM handler (once per process; later calls are no-ops): it removes
/// the temporary files of the outputs being written, then hands `then` what it did. The caller
/// decides what an interrupt means (the command line prints a line and exits 130); the library
/// never ends the process.
pub fn install_interrupt_handler(then: impl Fn(Interrupted) + Send + 'static) {
    let _ = ctrlc::set_handler(move || {
        let mut removed = 0;
        if let Ok(files) = IN_FLIGHT.lock() {
            removed = files.iter().filter(|f| std::fs::remove_file(f).is_ok()).count();
        }
        then(Interrupted { removed });
    });
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so the
/// path holds either its previous content or the complete new one, never half a file.
pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    if let Ok(mut f) = IN_FLIGHT.lock() {
        f.push(tmp.clone());
    }
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    if let Ok(mut f) = IN_FLIGHT.lock() {
        f.retain(|p| *p != tmp);
    }
    result
}

/// The characters a name that becomes a file name may hold.
pub const FILE_NAME_CHARS: &str = "letters A–Z a–z, digits 0–9, `-`, `_` and `.`";
/// The longest such name (bytes; file systems allow 255 for the whole file name, and outputs add
/// suffixes such as `.sweep.shard-12-of-64.journal.jsonl`).
pub const FILE_NAME_MAX: usize = 100;

/// What is wrong with a name that becomes part of a file name (the message completes "name
/// `x` ...").
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BadFileName {
    /// No character.
    #[error("is empty; use {FILE_NAME_CHARS}")]
    Empty,
    /// Longer than [`FILE_NAME_MAX`] (its length).
    #[error("is {0} characters long; at most {FILE_NAME_MAX}")]
    TooLong(usize),
    /// A character outside [`FILE_NAME_CHARS`].
    #[error("holds {0:?}, which cannot be in a file name here; use {FILE_NAME_CHARS}")]
    Character(char),
    /// A leading dot.
    #[error("starts with `.` (a hidden file, or a way out of the output folder)")]
    Dot,
    /// A device name on Windows (`CON`, `COM1`, ...).
    #[error("is `{0}`, a device name on Windows")]
    Device(String),
}

/// Checks a name that becomes part of a file name: 1 to [`FILE_NAME_MAX`] characters from
/// [`FILE_NAME_CHARS`], not starting with `.` (no hidden files, no `..`), and not a name Windows
/// reserves for a device (`CON`, `NUL`, `COM1`, …, with any extension). Returns what is wrong.
pub fn check_file_name(name: &str) -> Result<(), BadFileName> {
    if name.is_empty() {
        return Err(BadFileName::Empty);
    }
    if name.len() > FILE_NAME_MAX {
        return Err(BadFileName::TooLong(name.len()));
    }
    if let Some(c) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))) {
        return Err(BadFileName::Character(c));
    }
    if name.starts_with('.') {
        return Err(BadFileName::Dot);
    }
    let stem = name.split('.').next().unwrap_or("").to_ascii_uppercase();
    let reserved = ["CON", "PRN", "AUX", "NUL"].contains(&stem.as_str())
        || ((stem.starts_with("COM") || stem.starts_with("LPT"))
            && stem.len() == 4
            && stem.as_bytes()[3].is_ascii_digit());
    if reserved {
        return Err(BadFileName::Device(stem));
    }
    Ok(())
}
