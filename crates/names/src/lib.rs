//! Named enums written once. Every enum a config key, a flag or a file header names by a word
//! (`sphere_combine = "union"`, `--stale refuse`, a PLY `float32`) declares its names in one
//! [`names!`] table beside the type; the table gives
//!
//! - `NAMES`: the names, one per variant, in declaration order (for messages and tests),
//! - `name(self)`: a variant's name (its first one where it has aliases),
//! - `from_name(s)`: the variant a name (or alias) stands for, `None` for any other text.
//!
//! Each type keeps its own error message, written once with [`one_of`] or in its own words, so
//! no message changes with the mechanism. No name table is written by hand anywhere else.
//!
//! ```
//! #[derive(Clone, Copy, Debug, PartialEq, Eq)]
//! pub enum Spacing { Uniform, Exp }
//! shscale_names::names!(Spacing { Uniform = "uniform", Exp = "exp" | "exponential" });
//! assert_eq!(Spacing::NAMES, ["uniform", "exp"]);
//! assert_eq!(Spacing::from_name("exponential"), Some(Spacing::Exp));
//! assert_eq!(Spacing::Exp.name(), "exp");
//! assert_eq!(Spacing::from_name("Exp"), None);
//! ```

/// Implement `NAMES`, `name` and `from_name` for an existing enum from one table of
/// `Variant = "name" | "alias" …` (unit variants; names are matched exactly, case included).
#[macro_export]
macro_rules! names {
    ($ty:ident { $( $variant:ident = $name:literal $(| $alias:literal)* ),+ $(,)? }) => {
        impl $ty {
            /// The names, one per variant, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($name),+];

            /// The variant's name (its first, where it has aliases).
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $name,)+
                }
            }

            /// The variant a name or alias stands for (exactly), `None` for any other text.
            pub fn from_name(s: &str) -> Option<Self> {
                match s {
                    $($name $(| $alias)* => Some(Self::$variant),)+
                    _ => None,
                }
            }
        }
    };
}

/// The message of a name that is none of `names`: `"x" is not one of "a", "b"`.
pub fn one_of(s: &str, names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("{n:?}")).collect();
    format!("{s:?} is not one of {}", quoted.join(", "))
}

#[cfg(test)]
mod tests {
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    enum Three {
        A,
        B,
        C,
    }
    crate::names!(Three {
        A = "a",
        B = "bee" | "b",
        C = "c-c",
    });

    /// Every name parses back to its variant and every variant's name is in `NAMES`, in order;
    /// aliases parse but are never a variant's name; near misses do not parse.
    #[test]
    fn names_round_trip_and_nothing_else_parses() {
        assert_eq!(Three::NAMES, ["a", "bee", "c-c"]);
        for (v, n) in [(Three::A, "a"), (Three::B, "bee"), (Three::C, "c-c")] {
            assert_eq!(v.name(), n);
            assert_eq!(Three::from_name(n), Some(v));
        }
        assert_eq!(Three::from_name("b"), Some(Three::B));
        for bad in ["", "A", " a", "a ", "be", "c_c", "bee\0", "ä"] {
            assert_eq!(Three::from_name(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn the_message_quotes_the_text_and_every_name() {
        assert_eq!(
            crate::one_of("x\"y", Three::NAMES),
            r#""x\"y" is not one of "a", "bee", "c-c""#
        );
        assert_eq!(crate::one_of("", &[]), r#""" is not one of "#);
    }
}
