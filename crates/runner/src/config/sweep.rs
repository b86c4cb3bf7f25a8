//! The runner's own keys and the sweep expansion: `[sweep]`, `[sweep.zip]` and `[[sweep]]`
//! blocks into combinations, bounded by [`MAX_COMBINATIONS`].

use super::*;

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
pub(crate) const RUNNER_KEYS: &[&str] = &[
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
    pub(crate) fn describe_combination(&self, i: usize) -> String {
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
    pub(crate) fn place_of(&self, combo: &Combination, path: &[Seg]) -> Place {
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
pub(super) fn key_value<'a>(
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
pub(super) fn parse_table(file: &str, text: &str) -> Result<toml::Table, ConfigError> {
    toml::from_str(text).map_err(|e| toml_error(file, text, &e))
}

/// A flag as errors name it: the flag and its value, cut after 120 characters (a value can be
/// arbitrarily long; the message should not be).
pub(super) fn flag_text(flag: &str, value: &str) -> String {
    match value.char_indices().nth(120) {
        Some((i, _)) => format!("{flag} {}… ({} bytes)", &value[..i], value.len()),
        None => format!("{flag} {value}"),
    }
}

/// Apply `--set`, `--sweep` and `--name` to `doc`; the places of the values they set (`--set`,
/// `--name`) and of the axes they add (`--sweep`).
#[allow(clippy::type_complexity)]
pub(super) fn apply_overrides(
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
pub(super) fn sweep_axes_of(
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
pub(super) fn runner_keys(
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
pub(super) fn check_total(file: &str, blocks: &[Vec<Axis>]) -> Result<Vec<usize>, ConfigError> {
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
pub(super) struct Axis {
    pub(super) keys: Vec<(KeyPath, KeyPath)>,
    pub(super) values: Vec<Vec<toml::Value>>,
    /// Where each step's value of each key came from (its list element or `--sweep` flag),
    /// found once per step, not once per combination.
    pub(super) places: Vec<Vec<Place>>,
}

/// Lists under a sweep table, by path: `out` gets the plain lists, `zip` (at the block's top
/// only) those of `[sweep.zip]`.
pub(super) fn walk_lists(
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
