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

impl From<ConfigError> for crate::error::Error {
    fn from(e: ConfigError) -> Self {
        crate::error::Error::Config(e.to_string())
    }
}

/// One step of a key path.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Seg {
    Key(String),
    Index(usize),
}

/// A key path, e.g. `[Key("occluder"), Index(1), Key("radius")]`.
pub type KeyPath = Vec<Seg>;

/// `occluder[1].radius`.
pub fn path_name(path: &[Seg]) -> String {
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
pub fn parse_path(s: &str) -> KeyPath {
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

    fn line_at(&self, byte: usize) -> usize {
        self.newlines
            .partition_point(|&i| i < byte.min(self.text.len()))
            + 1
    }

    /// The line of the item at `path` in the file (or of its nearest written ancestor, with
    /// `exact = false`); `None` when not even the first key is written.
    pub fn line_of(&self, path: &[Seg]) -> Option<(usize, bool)> {
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

fn item_span(item: &toml_edit::Item) -> Option<std::ops::Range<usize>> {
    match item {
        toml_edit::Item::Value(v) => v.span(),
        toml_edit::Item::Table(t) => t.span(),
        toml_edit::Item::ArrayOfTables(a) => a.get(0).and_then(|t| t.span()),
        toml_edit::Item::None => None,
    }
}

/// A `--set` or `--sweep` given on the command line.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// `key=value` (dotted keys), applied in order.
    pub set: Vec<String>,
    /// `key=v1,v2,…`: adds or replaces the sweep axis `key`.
    pub sweep: Vec<String>,
    /// `--name NAME`.
    pub name: Option<String>,
}

impl Overrides {
    /// Every override as its flag, for the manifest.
    pub fn flags(&self) -> Vec<String> {
        let mut v: Vec<String> = self.set.iter().map(|s| format!("--set {s}")).collect();
        v.extend(self.sweep.iter().map(|s| format!("--sweep {s}")));
        if let Some(n) = &self.name {
            v.push(format!("--name {n}"));
        }
        v
    }
}

/// A value written on the command line: TOML when it parses as a TOML value; a bare comma list
/// (`1.3,2`, as `--sweep` takes it) as the list `[1.3, 2]`; else a string.
fn cli_value(text: &str) -> toml::Value {
    let t = text.trim();
    let parse = |t: &str| {
        toml::from_str::<toml::Table>(&format!("v = {t}"))
            .ok()
            .and_then(|mut tab| tab.remove("v"))
    };
    parse(t)
        .or_else(|| {
            (split_top(t).len() > 1)
                .then(|| parse(&format!("[{t}]")))
                .flatten()
        })
        .unwrap_or_else(|| toml::Value::String(t.to_string()))
}

/// Split `a,b,[c,d],"e,f"` at top-level commas.
fn split_top(s: &str) -> Vec<String> {
    let (mut out, mut cur, mut depth, mut quote) = (Vec::new(), String::new(), 0i32, None);
    for c in s.chars() {
        match (c, quote) {
            ('"' | '\'', None) => quote = Some(c),
            (q, Some(open)) if q == open => quote = None,
            ('[' | '{', None) => depth += 1,
            (']' | '}', None) => depth -= 1,
            (',', None) if depth == 0 => {
                out.push(std::mem::take(&mut cur));
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    out.push(cur);
    out
}

fn set_path(table: &mut toml::Table, path: &[Seg], value: toml::Value) -> Result<(), String> {
    let Some((Seg::Key(first), rest)) = path.split_first() else {
        return Err("the key must start with a name".into());
    };
    if rest.is_empty() {
        table.insert(first.clone(), value);
        return Ok(());
    }
    let entry = table
        .entry(first.clone())
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    match (entry, &rest[0]) {
        (toml::Value::Table(t), Seg::Key(_)) => set_path(t, rest, value),
        (toml::Value::Array(a), Seg::Index(i)) => {
            let slot = a
                .get_mut(*i)
                .ok_or_else(|| format!("index {i} is past the end of the list"))?;
            match (slot, rest.get(1)) {
                (slot, None) => {
                    *slot = value;
                    Ok(())
                }
                (toml::Value::Table(t), Some(_)) => set_path(t, &rest[1..], value),
                _ => Err("not a table".into()),
            }
        }
        _ => Err(format!("{first} is not a table")),
    }
}

/// The runner's own keys of a config.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunnerKeys {
    pub experiment: String,
    pub name: Option<String>,
    pub gpu: Option<String>,
    pub parallel_runs: Option<bool>,
    pub timing_warmup: Option<usize>,
    pub timing_repeats: Option<usize>,
    /// The results' title and the claim (a paper's, or the question) they test, in words: the
    /// heading of `summary.md` and of a figure's section in `paper-figs/README.md`.
    pub title: Option<String>,
    pub claim: Option<String>,
}

/// The runner's keys (everything else belongs to the kind).
pub const RUNNER_KEYS: &[&str] = &[
    "experiment",
    "name",
    "gpu",
    "parallel_runs",
    "timing_warmup",
    "timing_repeats",
    "title",
    "claim",
    "sweep",
];

/// One combination of the sweep axes: the kind's table and where each swept value came from.
#[derive(Clone, Debug)]
pub struct Combination {
    pub table: toml::Table,
    /// Swept key path → the place of its value.
    pub swept: Vec<(KeyPath, Place)>,
}

/// A config with overrides applied, split into runner keys and the kind's combinations —
/// which are made one at a time, on demand ([`Expanded::combination`]): a sweep of 10⁶
/// combinations holds its axes, not 10⁶ tables.
pub struct Expanded {
    pub source: Source,
    pub runner: RunnerKeys,
    /// Key paths set by `--set`, with their flag.
    pub set_places: Vec<(KeyPath, Place)>,
    /// Sweep axes in expansion order (dotted names).
    pub axes: Vec<String>,
    /// The kind's table before any sweep value is set.
    doc: toml::Table,
    /// The `[sweep]` blocks, and how many combinations each makes.
    blocks: Vec<(Vec<Axis>, usize)>,
}

/// The most combinations a config may expand to at all (`--dry-run` surveys plans up to this
/// size; a plan that runs holds at most [`crate::plan::MAX_RUNS`]).
pub const MAX_COMBINATIONS: usize = 10_000_000;

impl Expanded {
    /// The number of combinations (every block's product, added).
    pub fn len(&self) -> usize {
        self.blocks.iter().map(|(_, n)| n).sum()
    }

    /// Combination `i` in words: its number (1-based) and, with several `[[sweep]]` blocks, the
    /// block (1-based) and its place there — for errors that name two combinations.
    pub fn describe_combination(&self, i: usize) -> String {
        if self.blocks.len() < 2 {
            return format!("{}", i + 1);
        }
        let mut rest = i;
        for (b, (_, n)) in self.blocks.iter().enumerate() {
            if rest < *n {
                return format!(
                    "{} ([[sweep]] block {}, its run {})",
                    i + 1,
                    b + 1,
                    rest + 1
                );
            }
            rest -= n;
        }
        format!("{}", i + 1)
    }

    /// Whether the sweep makes no combination (never: an empty axis is refused).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Combination `i` (`i < len()`), in expansion order: the blocks in turn, within a block
    /// the cartesian product of its axes with the first axis varying slowest.
    pub fn combination(&self, i: usize) -> Result<Combination, ConfigError> {
        let mut rest = i;
        let (axes, _) = (self.blocks.iter())
            .find(|(_, n)| {
                let here = rest < *n;
                if !here {
                    rest -= n;
                }
                here
            })
            .ok_or_else(|| ConfigError {
                place: Place::File(self.source.file.clone()),
                key: "sweep".into(),
                message: format!("combination {i} is beyond the {} of the sweep", self.len()),
            })?;
        let mut steps = vec![0; axes.len()];
        for (a, step) in axes.iter().zip(steps.iter_mut()).rev() {
            *step = rest % a.values.len();
            rest /= a.values.len();
        }
        let mut c = Combination {
            table: self.doc.clone(),
            swept: Vec::new(),
        };
        for (a, &step) in axes.iter().zip(&steps) {
            for (((rel, full), v), place) in a.keys.iter().zip(&a.values[step]).zip(&a.places[step])
            {
                set_path(&mut c.table, rel, v.clone()).map_err(|message| ConfigError {
                    place: place.clone(),
                    key: path_name(full),
                    message,
                })?;
                c.swept.push((rel.clone(), place.clone()));
            }
        }
        Ok(c)
    }

    /// Every combination, in order ([`Expanded::combination`]).
    pub fn combinations(&self) -> impl Iterator<Item = Result<Combination, ConfigError>> + '_ {
        (0..self.len()).map(|i| self.combination(i))
    }

    /// Where the value at `path` (of one combination) came from: its sweep list element, the
    /// `--set` flag, its line in the file, or the file (a default).
    pub fn place_of(&self, combo: &Combination, path: &[Seg]) -> Place {
        for (p, place) in &combo.swept {
            if path.starts_with(p) {
                return place.clone();
            }
        }
        // A flag that set the key or a part of it (`--set radii[0]=nan` and an error about
        // `radii`): the flag is the place, not the file's line.
        for (p, place) in self.set_places.iter().rev() {
            if path.starts_with(p) || (!path.is_empty() && p.starts_with(path)) {
                return place.clone();
            }
        }
        match self.source.line_of(path) {
            Some((line, _)) => Place::Line {
                file: self.source.file.clone(),
                line,
            },
            None => Place::File(self.source.file.clone()),
        }
    }

    /// An error about `path` of a combination.
    pub fn error(&self, combo: &Combination, path: &[Seg], message: String) -> ConfigError {
        ConfigError {
            place: self.place_of(combo, path),
            key: path_name(path),
            message,
        }
    }
}

/// `key=value` of a `--set` or `--sweep` flag, or an error at that flag saying what it expected.
fn key_value<'a>(
    s: &'a str,
    flag: &Place,
    expected: &str,
) -> Result<(&'a str, &'a str), ConfigError> {
    s.split_once('=').ok_or_else(|| ConfigError {
        place: flag.clone(),
        key: s.to_string(),
        message: format!("expected {expected}"),
    })
}

/// Read the config `text` of `file`, apply `ov`, split the runner's keys and expand the sweep.
pub fn expand(file: &str, text: &str, ov: &Overrides) -> Result<Expanded, ConfigError> {
    let source = Source::new(file, text);
    let mut doc = parse_table(file, text)?;
    let (set_places, sweep_flags) = apply_overrides(&mut doc, ov)?;
    // `--set sweep…` flags place sweep errors too (after the `--sweep` flags, which win).
    let mut sweep_flags = sweep_flags;
    sweep_flags.extend(
        (set_places.iter())
            .filter(|(p, _)| p.first() == Some(&Seg::Key("sweep".into())))
            .cloned(),
    );
    let places = Places {
        file,
        source: &source,
        sweep_flags,
    };
    let (runner, sweep) = runner_keys(&mut doc, &set_places, &places)?;
    let mut blocks = places.blocks(sweep)?;
    let counts = check_total(file, &blocks)?;
    let mut axis_names: Vec<String> = Vec::new();
    for a in blocks.iter_mut().flatten() {
        a.places = places.step_places(a);
        for (k, _) in &a.keys {
            let n = path_name(k);
            if !axis_names.contains(&n) {
                axis_names.push(n);
            }
        }
    }
    let ex = Expanded {
        runner,
        set_places,
        axes: axis_names,
        doc,
        blocks: blocks.into_iter().zip(counts).collect(),
        source,
    };
    // A swept key that cannot be set (its parent is not a table) is an error of the config,
    // found now: the first combination of every block sets every key of its axes.
    let mut first = 0;
    for (_, n) in &ex.blocks {
        ex.combination(first)?;
        first += n;
    }
    Ok(ex)
}

/// The config text as a TOML table; a syntax error at its line, naming the key written there.
fn parse_table(file: &str, text: &str) -> Result<toml::Table, ConfigError> {
    toml::from_str(text).map_err(|e| toml_error(file, text, &e))
}

/// A flag as errors name it: the flag and its value, cut after 120 characters (a value can be
/// arbitrarily long; the message should not be).
fn flag_text(flag: &str, value: &str) -> String {
    match value.char_indices().nth(120) {
        Some((i, _)) => format!("{flag} {}… ({} bytes)", &value[..i], value.len()),
        None => format!("{flag} {value}"),
    }
}

/// Apply `--set`, `--sweep` and `--name` to `doc`; the places of the values they set (`--set`,
/// `--name`) and of the axes they add (`--sweep`).
#[allow(clippy::type_complexity)]
fn apply_overrides(
    doc: &mut toml::Table,
    ov: &Overrides,
) -> Result<(Vec<(KeyPath, Place)>, Vec<(KeyPath, Place)>), ConfigError> {
    let at_flag = |flag: &Place, k: &str| {
        let flag = flag.clone();
        let key = match k.trim().char_indices().nth(60) {
            Some((i, _)) => format!("{}…", &k.trim()[..i]),
            None => k.trim().to_string(),
        };
        move |message: String| ConfigError {
            place: flag,
            key,
            message,
        }
    };
    let mut set_places = Vec::new();
    for s in &ov.set {
        let flag = Place::Flag(flag_text("--set", s));
        let (k, v) = key_value(s, &flag, "key=value")?;
        let path = parse_flag_key(k.trim()).map_err(at_flag(&flag, k))?;
        set_path(doc, &path, cli_value(v)).map_err(at_flag(&flag, k))?;
        // A sweep block that sweeps the key would override the set value: the value replaces
        // that axis there too (every entry of a zipped one), so `--set` reaches every block.
        if path.first() != Some(&Seg::Key("sweep".into())) {
            for (p, value) in sweep_axes_of(doc, &path, &cli_value(v)) {
                set_path(doc, &p, value).map_err(at_flag(&flag, k))?;
                set_places.push((p, flag.clone()));
            }
        }
        set_places.push((path, flag));
    }
    let mut sweep_flags = Vec::new();
    for s in &ov.sweep {
        let flag = Place::Flag(flag_text("--sweep", s));
        let (k, v) = key_value(s, &flag, "key=v1,v2,…")?;
        let values: Vec<toml::Value> = split_top(v).iter().map(|x| cli_value(x)).collect();
        // With `[[sweep]]` blocks the axis is added to (or replaced in) every block.
        let roots: Vec<KeyPath> = match doc.get("sweep") {
            Some(toml::Value::Array(list)) => (0..list.len())
                .map(|i| vec![Seg::Key("sweep".into()), Seg::Index(i)])
                .collect(),
            _ => vec![vec![Seg::Key("sweep".into())]],
        };
        for root in roots {
            let mut path = root;
            path.extend(parse_flag_key(k.trim()).map_err(at_flag(&flag, k))?);
            set_path(doc, &path, toml::Value::Array(values.clone())).map_err(at_flag(&flag, k))?;
            sweep_flags.push((path, flag.clone()));
        }
    }
    if let Some(n) = &ov.name {
        doc.insert("name".into(), toml::Value::String(n.clone()));
        set_places.push((
            vec![Seg::Key("name".into())],
            Place::Flag(format!("--name {n}")),
        ));
    }
    Ok((set_places, sweep_flags))
}

/// The sweep axes of `doc` that sweep `path` — in the `[sweep]` table or any `[[sweep]]` block,
/// directly or in its `zip` — each with the list that sets them all to `value`.
fn sweep_axes_of(
    doc: &toml::Table,
    path: &[Seg],
    value: &toml::Value,
) -> Vec<(KeyPath, toml::Value)> {
    let blocks: Vec<(KeyPath, &toml::Table)> = match doc.get("sweep") {
        Some(toml::Value::Table(t)) => vec![(vec![Seg::Key("sweep".into())], t)],
        Some(toml::Value::Array(list)) => (list.iter().enumerate())
            .filter_map(|(i, b)| {
                let root = vec![Seg::Key("sweep".into()), Seg::Index(i)];
                b.as_table().map(|t| (root, t))
            })
            .collect(),
        _ => Vec::new(),
    };
    let get = |t: &toml::Table, p: &[Seg]| -> Option<toml::Value> {
        let mut v = toml::Value::Table(t.clone());
        for seg in p {
            v = match (seg, v) {
                (Seg::Key(k), toml::Value::Table(t)) => t.get(k)?.clone(),
                (Seg::Index(i), toml::Value::Array(a)) => a.get(*i)?.clone(),
                _ => return None,
            };
        }
        Some(v)
    };
    let mut out = Vec::new();
    for (root, block) in blocks {
        if let Some(toml::Value::Array(_)) = get(block, path) {
            let mut p = root.clone();
            p.extend(path.iter().cloned());
            out.push((p, toml::Value::Array(vec![value.clone()])));
        }
        let mut zip = vec![Seg::Key("zip".into())];
        zip.extend(path.iter().cloned());
        if let Some(toml::Value::Array(list)) = get(block, &zip) {
            let mut p = root.clone();
            p.extend(zip);
            out.push((p, toml::Value::Array(vec![value.clone(); list.len()])));
        }
    }
    out
}

/// Take the runner's keys out of `doc`: them deserialised, and the `sweep` value.
fn runner_keys(
    doc: &mut toml::Table,
    set_places: &[(KeyPath, Place)],
    places: &Places,
) -> Result<(RunnerKeys, Option<toml::Value>), ConfigError> {
    let mut runner_table = toml::Table::new();
    for k in RUNNER_KEYS {
        if let Some(v) = doc.remove(*k) {
            runner_table.insert(k.to_string(), v);
        }
    }
    let sweep = runner_table.remove("sweep");
    let runner =
        serde_path_to_error::deserialize(toml::Value::Table(runner_table)).map_err(|e| {
            let path = serde_path(e.path());
            let place = set_places
                .iter()
                .find(|(p, _)| path.starts_with(p))
                .map(|(_, pl)| pl.clone())
                .unwrap_or_else(|| places.at(&path));
            ConfigError {
                place,
                key: if path.is_empty() {
                    "experiment".into()
                } else {
                    path_name(&path)
                },
                message: e.into_inner().to_string().trim().to_string(),
            }
        })?;
    Ok((runner, sweep))
}

/// The number of runs of each block (its product) when all of them add up to at most
/// [`MAX_COMBINATIONS`].
fn check_total(file: &str, blocks: &[Vec<Axis>]) -> Result<Vec<usize>, ConfigError> {
    let counts: Option<Vec<usize>> = (blocks.iter())
        .map(|axes| {
            axes.iter()
                .try_fold(1usize, |acc, a| acc.checked_mul(a.values.len()))
        })
        .collect();
    let total = counts
        .as_ref()
        .and_then(|c| c.iter().try_fold(0usize, |s, &n| s.checked_add(n)));
    if total.is_none_or(|t| t > MAX_COMBINATIONS) {
        return Err(ConfigError {
            place: Place::File(file.into()),
            key: "sweep".into(),
            message: format!(
                "the sweep expands to {} runs, more than the limit {MAX_COMBINATIONS}",
                total.map_or("too many".into(), |t| t.to_string())
            ),
        });
    }
    Ok(counts.unwrap_or_default())
}

/// One sweep axis: key paths relative to the kind's table with the path of their list in the
/// config, and the values (one per key) of each step.
struct Axis {
    keys: Vec<(KeyPath, KeyPath)>,
    values: Vec<Vec<toml::Value>>,
    /// Where each step's value of each key came from (its list element or `--sweep` flag),
    /// found once per step, not once per combination.
    places: Vec<Vec<Place>>,
}

/// Lists under a sweep table, by path: `out` gets the plain lists, `zip` (at the block's top
/// only) those of `[sweep.zip]`.
fn walk_lists(
    t: &toml::Table,
    prefix: &KeyPath,
    root_len: usize,
    out: &mut Vec<(KeyPath, Vec<toml::Value>)>,
    mut zip: Option<&mut Vec<(KeyPath, Vec<toml::Value>)>>,
) -> Result<(), (KeyPath, String)> {
    for (k, v) in t {
        let mut p = prefix.clone();
        p.push(Seg::Key(k.clone()));
        match v {
            toml::Value::Array(a) => out.push((p, a.clone())),
            toml::Value::Table(sub) if k == "zip" && prefix.len() == root_len => {
                // A zip block holds lists of equal length, nothing nested (`[sweep.zip.zip]`
                // once read as a parameter `zip`).
                if let Some((name, _)) = sub.iter().find(|(_, v)| v.is_table()) {
                    let mut q = p.clone();
                    q.push(Seg::Key(name.clone()));
                    return Err((
                        q,
                        "a [sweep.zip] block holds lists of equal length; a table inside it is not allowed".into(),
                    ));
                }
                if let Some(z) = zip.as_deref_mut() {
                    walk_lists(sub, &p, root_len, z, None)?;
                }
            }
            toml::Value::Table(sub) => walk_lists(sub, &p, root_len, out, None)?,
            other => {
                return Err((
                    p,
                    format!("a sweep axis must be a list of values, not {other}"),
                ))
            }
        }
    }
    Ok(())
}

/// Where the values of one config came from, for errors: its lines, and the `--sweep` flags.
struct Places<'a> {
    file: &'a str,
    source: &'a Source,
    sweep_flags: Vec<(KeyPath, Place)>,
}

impl Places<'_> {
    /// The line of `path` in the file, or the file.
    fn at(&self, path: &[Seg]) -> Place {
        match self.source.line_of(path) {
            Some((line, _)) => Place::Line {
                file: self.file.into(),
                line,
            },
            None => Place::File(self.file.into()),
        }
    }

    /// The `--sweep` flag that set `path`, or its line.
    fn in_sweep(&self, path: &[Seg]) -> Place {
        (self.sweep_flags.iter().find(|(p, _)| path.starts_with(p)))
            .map_or_else(|| self.at(path), |(_, pl)| pl.clone())
    }

    fn error(&self, path: &[Seg], message: String) -> ConfigError {
        ConfigError {
            place: self.in_sweep(path),
            key: path_name(path),
            message,
        }
    }

    /// The blocks: `[sweep]` is one; `[[sweep]]` tables are several, whose runs are united.
    fn blocks(&self, sweep: Option<toml::Value>) -> Result<Vec<Vec<Axis>>, ConfigError> {
        let sweep_root = vec![Seg::Key("sweep".into())];
        match sweep {
            None => Ok(vec![Vec::new()]),
            Some(toml::Value::Table(t)) => Ok(vec![self.block_axes(&t, &sweep_root)?]),
            Some(toml::Value::Array(list)) if !list.is_empty() => {
                let mut v = Vec::new();
                for (i, b) in list.iter().enumerate() {
                    let mut root = sweep_root.clone();
                    root.push(Seg::Index(i));
                    let toml::Value::Table(t) = b else {
                        let m = "each [[sweep]] block must be a table of lists";
                        return Err(self.error(&root, m.into()));
                    };
                    v.push(self.block_axes(t, &root)?);
                }
                Ok(v)
            }
            Some(_) => Err(ConfigError {
                place: self.in_sweep(&sweep_root),
                key: "sweep".into(),
                message: "must be a table of lists ([sweep]) or blocks of them ([[sweep]])".into(),
            }),
        }
    }

    /// One block (the `[sweep]` table, or one `[[sweep]]` table of several): its axes, every
    /// list (nested keys too) one axis and `[sweep.zip]` one axis.
    fn block_axes(&self, sweep: &toml::Table, root: &KeyPath) -> Result<Vec<Axis>, ConfigError> {
        let mut leaves: Vec<(KeyPath, Vec<toml::Value>)> = Vec::new();
        let mut zip: Vec<(KeyPath, Vec<toml::Value>)> = Vec::new();
        walk_lists(sweep, root, root.len(), &mut leaves, Some(&mut zip))
            .map_err(|(p, m)| self.error(&p, m))?;
        self.check_lists(&leaves, &zip)?;
        let rel = |p: &KeyPath| -> KeyPath {
            let skip =
                if p.get(root.len()) == Some(&Seg::Key("zip".into())) && p.len() > root.len() + 1 {
                    root.len() + 1
                } else {
                    root.len()
                };
            p[skip..].to_vec()
        };
        let mut axes: Vec<Axis> = (leaves.iter())
            .map(|(p, vals)| Axis {
                keys: vec![(rel(p), p.clone())],
                values: vals.iter().map(|v| vec![v.clone()]).collect(),
                places: Vec::new(),
            })
            .collect();
        if !zip.is_empty() {
            let n = zip[0].1.len();
            if let Some((p, v)) = zip.iter().find(|(_, v)| v.len() != n) {
                let m = format!(
                    "zipped axes vary together and need lists of equal length: {} has {}, {} has {n}",
                    path_name(p),
                    v.len(),
                    path_name(&zip[0].0)
                );
                return Err(self.error(p, m));
            }
            axes.push(Axis {
                keys: zip.iter().map(|(p, _)| (rel(p), p.clone())).collect(),
                values: (0..n)
                    .map(|i| zip.iter().map(|(_, v)| v[i].clone()).collect())
                    .collect(),
                places: Vec::new(),
            });
        }
        self.check_swept_once(&axes)?;
        Ok(axes)
    }

    /// Every list: not empty; no duplicate values (zipped lists: no duplicate tuples).
    fn check_lists(
        &self,
        leaves: &[(KeyPath, Vec<toml::Value>)],
        zip: &[(KeyPath, Vec<toml::Value>)],
    ) -> Result<(), ConfigError> {
        if let Some((p, _)) = leaves.iter().chain(zip).find(|(_, v)| v.is_empty()) {
            return Err(self.error(p, "a sweep axis must not be empty".into()));
        }
        let item = |p: &KeyPath, i: usize| {
            let mut ep = p.clone();
            ep.push(Seg::Index(i));
            ep
        };
        if let Some((p, _)) = zip.first() {
            let n = zip.iter().map(|(_, v)| v.len()).min().unwrap_or(0);
            let mut first = HashMap::with_capacity(n);
            for i in 0..n {
                let tuple: Vec<String> = zip.iter().map(|(_, v)| value_key(&v[i])).collect();
                if let Some(&j) = first.get(&tuple) {
                    return Err(ConfigError {
                        key: path_name(p),
                        ..self.error(&item(p, i), format!(
                            "the zipped values of items {} and {} are the same: each run would be done twice",
                            j + 1,
                            i + 1
                        ))
                    });
                }
                first.insert(tuple, i);
            }
        }
        for (p, vals) in leaves {
            let mut first = HashMap::with_capacity(vals.len());
            for (i, v) in vals.iter().enumerate() {
                if let Some(&j) = first.get(&value_key(v)) {
                    return Err(ConfigError {
                        key: path_name(p),
                        ..self.error(&item(p, i), format!(
                            "value {v} appears twice (items {} and {}): each run would be done twice",
                            j + 1,
                            i + 1
                        ))
                    });
                }
                first.insert(value_key(v), i);
            }
        }
        Ok(())
    }

    /// A key swept twice (in [sweep] and [sweep.zip]) is ambiguous.
    fn check_swept_once(&self, axes: &[Axis]) -> Result<(), ConfigError> {
        let mut seen: BTreeMap<KeyPath, KeyPath> = BTreeMap::new();
        for (k, full) in axes.iter().flat_map(|a| &a.keys) {
            if let Some(prev) = seen.insert(k.clone(), full.clone()) {
                let m = format!("{} is already swept by {}", path_name(k), path_name(&prev));
                return Err(self.error(full, m));
            }
        }
        Ok(())
    }

    /// Where each step's value of each key of `a` came from: its list element, or the
    /// `--sweep` flag that set the axis.
    fn step_places(&self, a: &Axis) -> Vec<Vec<Place>> {
        (0..a.values.len())
            .map(|i| {
                (a.keys.iter())
                    .map(|(_, full)| {
                        let mut ep = full.clone();
                        ep.push(Seg::Index(i));
                        self.in_sweep(&ep)
                    })
                    .collect()
            })
            .collect()
    }
}

/// A key equal for two values exactly when they are the same sweep value: numbers by value
/// (`1` and `1.0` are one value, so are `-0` and `0`), everything else as written. The
/// duplicate checks of sweep lists hash it, so a list of n values is checked in O(n).
fn value_key(v: &toml::Value) -> String {
    match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
        // -0 and 0 are the same value.
        Some(x) => format!("n{}", if x == 0.0 { 0.0 } else { x }),
        None => format!("v{v}"),
    }
}

/// A serde_path_to_error path as ours.
pub fn serde_path(p: &serde_path_to_error::Path) -> KeyPath {
    p.iter()
        .filter_map(|s| match s {
            serde_path_to_error::Segment::Map { key } => Some(Seg::Key(key.clone())),
            serde_path_to_error::Segment::Seq { index } => Some(Seg::Index(*index)),
            _ => None,
        })
        .collect()
}

/// Deserialise one combination's table into `T`; errors name the place of the culprit value.
pub fn deserialize<T: serde::de::DeserializeOwned>(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_list_error_names_the_element_line() {
        let text =
            "experiment = \"probe\"\norder = 4\n[sweep]\nalpha_deg = [\n  10,\n  20,\n  10,\n]\n";
        let e = expand("c.toml", text, &Overrides::default())
            .err()
            .expect("duplicate must be refused");
        assert_eq!(
            e.place,
            Place::Line {
                file: "c.toml".into(),
                line: 7
            },
            "{e}"
        );
        assert!(e.to_string().contains("sweep.alpha_deg"), "{e}");
    }

    #[test]
    fn zip_and_product() {
        let text = "experiment = \"x\"\n[sweep]\na = [1, 2]\n[sweep.zip]\nb = [1, 2, 3]\nc = [\"x\", \"y\", \"z\"]\n";
        let ex = expand("c.toml", text, &Overrides::default()).unwrap();
        assert_eq!(ex.len(), 6);
        assert_eq!(ex.axes, vec!["a", "b", "c"]);
        let pairs: Vec<(i64, String)> = ex
            .combinations()
            .map(Result::unwrap)
            .map(|c| {
                (
                    c.table["b"].as_integer().unwrap(),
                    c.table["c"].as_str().unwrap().to_string(),
                )
            })
            .collect();
        assert!(pairs.contains(&(3, "z".into())) && !pairs.contains(&(1, "y".into())));
        let bad = "experiment = \"x\"\n[sweep.zip]\nb = [1, 2, 3]\nc = [1, 2]\n";
        let e = expand("c.toml", bad, &Overrides::default()).err().unwrap();
        assert!(e.message.contains("equal length"), "{e}");
    }

    #[test]
    fn sweep_blocks_unite_their_products() {
        let text = "experiment = \"x\"\nk = 1\n[[sweep]]\ntau = [\"cone\"]\nk = [0.5, 2.0]\nalpha_deg = [20, 45]\n[[sweep]]\ntau = [\"midrange\"]\nk = [\n  -0.5,\n  0.5,\n]\n";
        let ex = expand("c.toml", text, &Overrides::default()).unwrap();
        assert_eq!(ex.len(), 4 + 2);
        let taus: Vec<String> = ex
            .combinations()
            .map(Result::unwrap)
            .map(|c| c.table["tau"].as_str().unwrap().to_string())
            .collect();
        assert_eq!(
            taus,
            ["cone", "cone", "cone", "cone", "midrange", "midrange"]
        );
        assert!(ex.combination(5).unwrap().table.get("alpha_deg").is_none());
        // The second block's second k sits on line 11 of the file.
        assert_eq!(
            ex.place_of(&ex.combination(5).unwrap(), &parse_path("k")),
            Place::Line {
                file: "c.toml".into(),
                line: 11
            }
        );
        assert_eq!(ex.axes, ["alpha_deg", "k", "tau"]);
        // --sweep adds the axis to every block.
        let ov = Overrides {
            sweep: vec!["order=2,4".into()],
            ..Overrides::default()
        };
        assert_eq!(expand("c.toml", text, &ov).unwrap().len(), 12);
        // A duplicate inside a block is named at its element.
        let dup = "experiment = \"x\"\n[[sweep]]\nk = [1]\n[[sweep]]\nk = [2,\n 2]\n";
        let Err(e) = expand("c.toml", dup, &Overrides::default()) else {
            panic!("a duplicate in a block must be refused")
        };
        assert!(e.to_string().contains("c.toml:6"), "{e}");
        assert!(e.to_string().contains("sweep[1].k"), "{e}");
    }

    #[test]
    fn flag_keys_are_dotted_names_with_indices_and_nothing_else() {
        let ok = |k: &str| parse_flag_key(k).unwrap_or_else(|e| panic!("{k}: {e}"));
        assert_eq!(ok("order"), vec![Seg::Key("order".into())]);
        assert_eq!(
            ok("occluder[1].radius"),
            vec![
                Seg::Key("occluder".into()),
                Seg::Index(1),
                Seg::Key("radius".into())
            ]
        );
        assert_eq!(ok("a[0][2]").len(), 3);
        assert_eq!(ok("k_count"), parse_path("k_count"));
        for (bad, why) in [
            ("order[abc]", "[abc] is not a list index"),
            (".order", "\"\" is not a name"),
            ("order.", "\"\" is not a name"),
            ("a..b", "\"\" is not a name"),
            ("", "\"\" is not a name"),
            ("1st", "\"1st\" is not a name"),
            ("a b", "\"a b\" is not a name"),
            ("a/../b", "is not a name"),
            ("order[1", "does not end with ']'"),
            ("a[", "does not end with ']'"),
            ("a[1]b", "does not end with ']'"),
            ("order[-1]", "[-1] is not a list index"),
            ("order[]", "[] is not a list index"),
            ("order[99999999999]", "is not a list index"),
            ("radii[0]x", "does not end with ']'"),
        ] {
            let e = parse_flag_key(bad).expect_err(bad);
            assert!(e.contains(why), "{bad}: {e}");
        }
        // Depth and length are bounded before any table is built (30,000 levels once
        // overflowed the stack).
        let deep = vec!["a"; 17].join(".");
        assert!(parse_flag_key(&deep)
            .unwrap_err()
            .contains("more than 16 segments"));
        assert_eq!(ok(&vec!["a"; 16].join(".")).len(), 16);
        let huge = vec!["a"; 30_000].join(".");
        assert!(parse_flag_key(&huge)
            .unwrap_err()
            .contains("more than the limit 256"));
        let ov = Overrides {
            set: vec![format!("{huge}=1")],
            ..Overrides::default()
        };
        let e = expand("c.toml", "experiment = \"x\"\n", &ov).err().unwrap();
        assert!(e.to_string().starts_with("--set a.a.a"), "{e}");
        assert!(
            e.to_string().len() < 400,
            "the message holds the whole key: {e}"
        );
        let ov = Overrides {
            sweep: vec!["order[abc]=1,2".into()],
            ..Overrides::default()
        };
        let e = expand("c.toml", "experiment = \"x\"\n", &ov).err().unwrap();
        assert!(e.to_string().contains("--sweep order[abc]=1,2"), "{e}");
    }

    #[test]
    fn overrides_set_and_sweep() {
        let text = "experiment = \"x\"\norder = 4\n";
        let ov = Overrides {
            set: vec![
                "order=6".into(),
                "light.sun=2.5".into(),
                "mesh=bunny".into(),
            ],
            sweep: vec!["radii=[1,2],[3]".into()],
            name: Some("n1".into()),
        };
        let ex = expand("c.toml", text, &ov).unwrap();
        assert_eq!(ex.runner.name.as_deref(), Some("n1"));
        assert_eq!(ex.len(), 2);
        let t = &ex.combination(0).unwrap().table;
        assert_eq!(t["order"].as_integer(), Some(6));
        assert_eq!(t["mesh"].as_str(), Some("bunny"));
        assert_eq!(t["light"]["sun"].as_float(), Some(2.5));
        assert_eq!(t["radii"].as_array().unwrap().len(), 2);
        // `--set key=v1,v2` is the list [v1, v2], as --sweep writes values.
        let ov = Overrides {
            set: vec!["radii=1.3,2".into(), "label=a b".into()],
            ..Overrides::default()
        };
        let listed = expand("c.toml", text, &ov).unwrap();
        let t = &listed.combination(0).unwrap().table;
        assert_eq!(t["radii"].as_array().unwrap().len(), 2);
        assert_eq!(t["radii"][0].as_float(), Some(1.3));
        assert_eq!(t["label"].as_str(), Some("a b"));
        assert_eq!(
            ex.place_of(&ex.combination(1).unwrap(), &parse_path("radii")),
            Place::Flag("--sweep radii=[1,2],[3]".into())
        );
        assert_eq!(
            ex.place_of(&ex.combination(1).unwrap(), &parse_path("order")),
            Place::Flag("--set order=6".into())
        );
    }

    #[test]
    fn an_error_about_a_key_a_flag_set_part_of_names_the_flag() {
        let text = "experiment = \"x\"\nradii = [1.0, 2.0]\norder = 2\n";
        let ov = Overrides {
            set: vec!["radii[0]=nan".into()],
            ..Overrides::default()
        };
        let ex = expand("c.toml", text, &ov).unwrap();
        let c = ex.combination(0).unwrap();
        assert_eq!(
            ex.place_of(&c, &parse_path("radii")),
            Place::Flag("--set radii[0]=nan".into())
        );
        assert_eq!(
            ex.place_of(&c, &parse_path("order")),
            Place::Line {
                file: "c.toml".into(),
                line: 3
            }
        );
    }

    #[test]
    fn array_of_tables_line() {
        let text = "experiment = \"x\"\n[[occluder]]\nmesh = \"a\"\n[[occluder]]\nmesh = \"b\"\nradius = -1\n";
        let ex = expand("s.toml", text, &Overrides::default()).unwrap();
        let p = parse_path("occluder[1].radius");
        assert_eq!(
            ex.place_of(&ex.combination(0).unwrap(), &p),
            Place::Line {
                file: "s.toml".into(),
                line: 6
            }
        );
        assert_eq!(path_name(&p), "occluder[1].radius");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Any string as a `--set` key: refused with a reason, or a path that writes back as the
        /// same key; never a panic.
        #[test]
        fn flag_keys_accept_exactly_what_they_write_back(key in "[a-z_.\\[\\]0-9 -]{0,40}") {
            if let Ok(path) = parse_flag_key(&key) {
                proptest::prop_assert_eq!(path_name(&path), key);
                proptest::prop_assert!(path.len() <= MAX_KEY_DEPTH);
            }
        }

        /// Arbitrary override strings through the whole expansion: a plan or an error naming the
        /// flag, never a panic.
        #[test]
        fn overrides_never_panic(set in "\\PC{0,30}", sweep in "\\PC{0,30}") {
            let ov = Overrides {
                set: vec![set.clone()],
                sweep: vec![sweep],
                name: None,
            };
            if let Err(e) = expand("c.toml", "experiment = \"x\"\norder = 2\n[sweep]\nk = [1, 2]\n", &ov) {
                proptest::prop_assert!(!e.to_string().is_empty());
            }
        }

        /// Sweep tables of arbitrary small lists: the combination count is the product (or the
        /// duplicate/empty list is refused), never a panic.
        #[test]
        fn sweep_tables_expand_to_their_product(
            a in proptest::collection::vec(0i64..5, 0..5),
            b in proptest::collection::vec(0i64..5, 0..5),
        ) {
            let list = |v: &[i64]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ");
            let text = format!("experiment = \"x\"\n[sweep]\na = [{}]\nb = [{}]\n", list(&a), list(&b));
            let distinct = |v: &[i64]| v.iter().collect::<std::collections::BTreeSet<_>>().len() == v.len();
            let valid = distinct(&a) && distinct(&b) && !a.is_empty() && !b.is_empty();
            match expand("c.toml", &text, &Overrides::default()) {
                Ok(ex) => {
                    proptest::prop_assert!(valid);
                    proptest::prop_assert_eq!(ex.len(), a.len() * b.len());
                }
                Err(e) => {
                    proptest::prop_assert!(!valid, "{}", e);
                }
            }
        }
    }
}
