//! Command-line overrides (`--set key=value`): their values and where they go in the table.

use super::*;

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
pub(super) fn cli_value(text: &str) -> toml::Value {
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
pub(super) fn split_top(s: &str) -> Vec<String> {
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

pub(super) fn set_path(
    table: &mut toml::Table,
    path: &[Seg],
    value: toml::Value,
) -> Result<(), String> {
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
