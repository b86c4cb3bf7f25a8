//! Key paths (`light.sun`, `parts[2].alpha_deg`): their segments, names and parsing, with the
//! bounds on their depth and length.

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Seg {
    Key(String),
    Index(usize),
}

/// A key path, e.g. `[Key("occluder"), Index(1), Key("radius")]`.
pub type KeyPath = Vec<Seg>;

/// `occluder[1].radius`.
pub(crate) fn path_name(path: &[Seg]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Seg::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// The most segments (names and indices) of a key given on the command line.
pub const MAX_KEY_DEPTH: usize = 16;
/// The most bytes of a key given on the command line.
pub const MAX_KEY_LEN: usize = 256;

/// A key written on the command line (`--set`, `--sweep`): dotted names, each a letter or `_`
/// then letters, digits, `_` or `-`, each optionally followed by list indices `[N]`; at most
/// [`MAX_KEY_DEPTH`] segments and [`MAX_KEY_LEN`] bytes. Anything else is refused, saying why
/// (never read loosely: `order[abc]` or `.order` are not `order`).
pub fn parse_flag_key(s: &str) -> Result<KeyPath, String> {
    if s.len() > MAX_KEY_LEN {
        return Err(format!(
            "the key is {} bytes long, more than the limit {MAX_KEY_LEN}",
            s.len()
        ));
    }
    let mut out = Vec::new();
    for part in s.split('.') {
        let (name, rest) = part
            .split_once('[')
            .map_or((part, None), |(n, r)| (n, Some(r)));
        let ok_name = name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !ok_name {
            return Err(format!(
                "{s:?} is not a key: {name:?} is not a name (a key is dotted names — a letter or '_', then letters, digits, '_' or '-' — each with optional [N] indices, e.g. occluder[1].radius)"
            ));
        }
        out.push(Seg::Key(name.to_string()));
        if let Some(rest) = rest {
            let Some(inner) = rest.strip_suffix(']') else {
                return Err(format!(
                    "{s:?} is not a key: {part:?} does not end with ']'"
                ));
            };
            for idx in inner.split("][") {
                let i: usize = (idx.len() <= 9 && idx.bytes().all(|b| b.is_ascii_digit()))
                    .then(|| idx.parse().ok())
                    .flatten()
                    .ok_or_else(|| {
                        format!("{s:?} is not a key: [{idx}] is not a list index (a whole number, e.g. [0])")
                    })?;
                out.push(Seg::Index(i));
            }
        }
        if out.len() > MAX_KEY_DEPTH {
            return Err(format!(
                "{s:?} has more than {MAX_KEY_DEPTH} segments, the limit of a key"
            ));
        }
    }
    Ok(out)
}

/// Parse `a.b[2].c` into a path (keys the code or a config wrote; see [`parse_flag_key`] for
/// keys from the command line).
pub(crate) fn parse_path(s: &str) -> KeyPath {
    let mut out = Vec::new();
    for part in s.split('.') {
        let (name, rest) = part.split_once('[').unwrap_or((part, ""));
        if !name.is_empty() {
            out.push(Seg::Key(name.to_string()));
        }
        for idx in rest.split('[') {
            if let Ok(i) = idx.trim_end_matches(']').parse() {
                out.push(Seg::Index(i));
            }
        }
    }
    out
}

/// A serde_path_to_error path as ours.
pub(crate) fn serde_path(p: &serde_path_to_error::Path) -> KeyPath {
    p.iter()
        .filter_map(|s| match s {
            serde_path_to_error::Segment::Map { key } => Some(Seg::Key(key.clone())),
            serde_path_to_error::Segment::Seq { index } => Some(Seg::Index(*index)),
            _ => None,
        })
        .collect()
}
