//! Experiment config files: the runner's own keys, command-line overrides, sweep expansion and
//! errors that point at the exact place — the file and line of the value (inside a `[sweep]`
//! list, an array of tables, a nested table) or the command-line flag that set it.
//!
//! A config is one TOML table. The runner's keys (`experiment`, `name`, `gpu`, `parallel_runs`,
//! `timing_warmup`, `timing_repeats`, `title`, `claim`, `sweep`) are taken out; everything else is the kind's, and
//! is deserialised into the kind's parameter struct once per combination of the sweep axes, so
//! serde checks every value's type and no axis needs code of its own.
//!
//! ```toml
//! [sweep]                       # cartesian product of every list below
//! alpha_deg = [15, 30, 45]
//! light.sun = [1.0, 8.0]        # a nested key (dotted) is an axis too
//! [sweep.zip]                   # lists of equal length, varied together (one axis)
//! order = [2, 4, 8]
//! hemisphere_res = [8, 16, 32]
//! ```
//!
//! Several products are united with `[[sweep]]` blocks (each one a `[sweep]` table as above, its
//! runs added to the others'; a run in two blocks is an error), e.g. cone τ over k × α and the
//! mid-range τ over its own k:
//!
//! ```toml
//! [[sweep]]
//! tau = ["cone"]
//! k = [0.5, 2.0]
//! alpha_deg = [20, 45]
//! [[sweep]]
//! tau = ["midrange"]
//! k = [-0.5, 0.5]
//! ```
//!
//! [`keys`]: key paths and their names; [`source`]: a config's text and the spans of its values;
//! [`overrides`]: `--set` flags; [`sweep`]: the runner's keys and sweep expansion; [`places`]:
//! where each value of a combination came from.

mod keys;
mod overrides;
mod places;
mod source;
mod sweep;
#[cfg(test)]
mod tests;

pub use keys::*;
pub use overrides::*;
use places::*;
pub use source::*;
pub use sweep::*;

use std::collections::{BTreeMap, HashMap};
use std::fmt;

/// Where a config value came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Place {
    /// A line of a config file (1-based).
    Line { file: String, line: usize },
    /// A config file, when the key is not written in it (its default applies).
    File(String),
    /// A command-line flag, as given (`--set order=x`).
    Flag(String),
}

/// A config error: where, which key, what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    pub place: Place,
    /// The key as a dotted path (`sweep.alpha_deg`, `occluder[1].radius`).
    pub key: String,
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            return write!(f, "{}: {}", self.place, self.message);
        }
        match &self.place {
            Place::Line { file, line } => {
                write!(f, "{file}:{line}: {}: {}", self.key, self.message)
            }
            Place::File(file) => write!(f, "{file}: {}: {}", self.key, self.message),
            Place::Flag(flag) => write!(f, "{flag}: {}: {}", self.key, self.message),
        }
    }
}

impl std::error::Error for ConfigError {}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Place::Line { file, line } => write!(f, "{file}:{line}"),
            Place::File(file) => write!(f, "{file}"),
            Place::Flag(flag) => write!(f, "{flag}"),
        }
    }
}
