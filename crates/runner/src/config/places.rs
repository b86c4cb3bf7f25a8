//! Where each value of a combination came from: its file and line, its sweep element, or the
//! flag that set it.

use super::*;

/// Where the values of one config came from, for errors: its lines, and the `--sweep` flags.
pub(super) struct Places<'a> {
    pub(super) file: &'a str,
    pub(super) source: &'a Source,
    pub(super) sweep_flags: Vec<(KeyPath, Place)>,
}

impl Places<'_> {
    /// The line of `path` in the file, or the file.
    pub(super) fn at(&self, path: &[Seg]) -> Place {
        match self.source.line_of(path) {
            Some((line, _)) => Place::Line {
                file: self.file.into(),
                line,
            },
            None => Place::File(self.file.into()),
        }
    }

    /// The `--sweep` flag that set `path`, or its line.
    pub(super) fn in_sweep(&self, path: &[Seg]) -> Place {
        (self.sweep_flags.iter().find(|(p, _)| path.starts_with(p)))
            .map_or_else(|| self.at(path), |(_, pl)| pl.clone())
    }

    pub(super) fn error(&self, path: &[Seg], message: String) -> ConfigError {
        ConfigError {
            place: self.in_sweep(path),
            key: path_name(path),
            message,
        }
    }

    /// The blocks: `[sweep]` is one; `[[sweep]]` tables are several, whose runs are united.
    pub(super) fn blocks(&self, sweep: Option<toml::Value>) -> Result<Vec<Vec<Axis>>, ConfigError> {
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
    pub(super) fn block_axes(
        &self,
        sweep: &toml::Table,
        root: &KeyPath,
    ) -> Result<Vec<Axis>, ConfigError> {
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
    pub(super) fn check_lists(
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
    pub(super) fn check_swept_once(&self, axes: &[Axis]) -> Result<(), ConfigError> {
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
    pub(super) fn step_places(&self, a: &Axis) -> Vec<Vec<Place>> {
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
pub(super) fn value_key(v: &toml::Value) -> String {
    match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
        // -0 and 0 are the same value.
        Some(x) => format!("n{}", if x == 0.0 { 0.0 } else { x }),
        None => format!("v{v}"),
    }
}
