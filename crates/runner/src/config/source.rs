//! A config file's text with the byte spans of its values, and TOML and serde errors turned
//! into errors at the value's place.

use super::*;

/// The config text with the spans of every item, for error lines.
pub struct Source {
    pub file: String,
    pub text: String,
    doc: Option<toml_edit::ImDocument<String>>,
    /// The byte offset of every `\n`, for line numbers in O(log n) (counting them from the
    /// start per value made a 10⁶-value sweep list quadratic).
    newlines: Vec<usize>,
}

impl Source {
    pub fn new(file: &str, text: &str) -> Self {
        Self {
            file: file.to_string(),
            text: text.to_string(),
            doc: toml_edit::ImDocument::parse(text.to_string()).ok(),
            newlines: text.match_indices('\n').map(|(i, _)| i).collect(),
        }
    }

    /// Where the key `key` (a dotted path, `occluder[1].radius`) is written: its own line, else
    /// the first line that writes its last segment (`radius = …`, `[camera]`), else the file.
    pub fn place_of_key(&self, key: &str) -> Place {
        let last = key.split('.').next_back().unwrap_or(key);
        let line = self.line_of(&parse_path(key)).map(|(l, _)| l).or_else(|| {
            self.text
                .lines()
                .position(|l| {
                    let t = l.trim_start();
                    t.starts_with(&format!("{last} "))
                        || t.starts_with(&format!("{last}="))
                        || t.starts_with(&format!("[{last}]"))
                        || t.starts_with(&format!("[[{last}]]"))
                })
                .map(|i| i + 1)
        });
        match line {
            Some(line) => Place::Line {
                file: self.file.clone(),
                line,
            },
            None => Place::File(self.file.clone()),
        }
    }

    pub(super) fn line_at(&self, byte: usize) -> usize {
        self.newlines
            .partition_point(|&i| i < byte.min(self.text.len()))
            + 1
    }

    /// The line of the item at `path` in the file (or of its nearest written ancestor, with
    /// `exact = false`); `None` when not even the first key is written.
    pub(crate) fn line_of(&self, path: &[Seg]) -> Option<(usize, bool)> {
        let doc = self.doc.as_ref()?;
        let mut item: &toml_edit::Item = doc.as_item();
        let mut best: Option<usize> = None;
        for (depth, seg) in path.iter().enumerate() {
            let (next, key_span) = match seg {
                Seg::Key(k) => {
                    let key_span = item
                        .as_table_like()
                        .and_then(|t| t.get_key_value(k))
                        .and_then(|(key, _)| key.span());
                    (item.get(k.as_str()), key_span)
                }
                Seg::Index(i) => (item.get(*i), None),
            };
            let Some(next) = next else {
                return best.map(|b| (b, false));
            };
            item = next;
            let span = item_span(item).or(key_span);
            if let Some(s) = span {
                best = Some(self.line_at(s.start));
            }
            if depth + 1 == path.len() {
                return best.map(|b| (b, true));
            }
        }
        best.map(|b| (b, true))
    }
}

pub(super) fn item_span(item: &toml_edit::Item) -> Option<std::ops::Range<usize>> {
    match item {
        toml_edit::Item::Value(v) => v.span(),
        toml_edit::Item::Table(t) => t.span(),
        toml_edit::Item::ArrayOfTables(a) => a.get(0).and_then(|t| t.span()),
        toml_edit::Item::None => None,
    }
}

/// Deserialise one combination's table into `T`; errors name the place of the culprit value.
pub(crate) fn deserialize<T: serde::de::DeserializeOwned>(
    ex: &Expanded,
    combo: &Combination,
) -> Result<T, ConfigError> {
    serde_path_to_error::deserialize(toml::Value::Table(combo.table.clone())).map_err(|e| {
        let mut path = serde_path(e.path());
        let message = e.into_inner().to_string().trim().to_string();
        // An unknown field is reported at its own key.
        if let Some(name) = message
            .strip_prefix("unknown field `")
            .and_then(|m| m.split('`').next())
        {
            if path.last() != Some(&Seg::Key(name.to_string())) {
                path.push(Seg::Key(name.to_string()));
            }
        }
        ex.error(combo, &path, message)
    })
}

/// A TOML parse error of `file` (whose text is `text`) at its place: the line, and — when the
/// message does not already name it — the key written on that line.
pub fn toml_error(file: &str, text: &str, e: &toml::de::Error) -> ConfigError {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    let message = e.message().trim().to_string();
    let key = line
        .and_then(|l| text.lines().nth(l - 1))
        .and_then(|l| l.split_once('='))
        .map(|(k, _)| k.trim().to_string())
        .filter(|k| !k.is_empty() && !message.contains(k.as_str()))
        .unwrap_or_default();
    ConfigError {
        place: line.map_or(Place::File(file.into()), |line| Place::Line {
            file: file.into(),
            line,
        }),
        key,
        message,
    }
}
