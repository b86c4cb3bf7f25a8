//! CSV records through the `csv` crate: header and cells derived from a row or parameter struct
//! (no hand-kept column list), reading and validating results files, run ids.

use crate::error::Error;
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Header and cells of one flat struct, as the `csv` crate writes them.
pub fn to_cells<T: Serialize>(v: &T) -> Result<(Vec<String>, Vec<String>), String> {
    // Small buffers: one flat record, written once per call (per run and per row validated, so
    // the default 8 KiB buffers would dominate its cost). The two lines are read back by
    // `split_line`, not a `csv::Reader`, whose construction (a DFA per reader) cost 20 µs a call,
    // four fifths of resolving a run.
    let mut w = csv::WriterBuilder::new()
        .has_headers(true)
        .buffer_capacity(512)
        .from_writer(Vec::new());
    w.serialize(v).map_err(|e| e.to_string())?;
    let bytes = w.into_inner().map_err(|e| e.to_string())?;
    let text = std::str::from_utf8(&bytes).map_err(|e| e.to_string())?;
    let (headers, rest) = split_line(text).ok_or("no header")?;
    let (cells, rest) = split_line(rest).ok_or("no record")?;
    if !rest.is_empty() || cells.len() != headers.len() {
        return Err(format!(
            "{} header cells and {} record cells",
            headers.len(),
            cells.len()
        ));
    }
    Ok((headers, cells))
}

/// The fields of the first line of `text` as the `csv` crate's writer writes a record (fields
/// separated by `,`, ended by `\n`; a field holding `,`, `"`, `\r` or `\n` in quotes, with `"`
/// doubled), and the text after it; `None` when `text` is empty or the line is not such a
/// record.
fn split_line(text: &str) -> Option<(Vec<String>, &str)> {
    if text.is_empty() {
        return None;
    }
    let b = text.as_bytes();
    let mut fields = Vec::new();
    let mut i = 0;
    loop {
        let mut f = String::new();
        if b.get(i) == Some(&b'"') {
            i += 1;
            loop {
                let j = i + text[i..].find('"')?;
                f.push_str(&text[i..j]);
                if b.get(j + 1) == Some(&b'"') {
                    f.push('"');
                    i = j + 2;
                } else {
                    i = j + 1;
                    break;
                }
            }
        } else {
            let j = i + text[i..].find([',', '\n']).unwrap_or(text.len() - i);
            f.push_str(&text[i..j]);
            i = j;
        }
        fields.push(f);
        match b.get(i) {
            Some(b',') => i += 1,
            Some(b'\n') => return Some((fields, &text[i + 1..])),
            None => return Some((fields, "")),
            Some(_) => return None,
        }
    }
}

/// A flat struct from named cells (types checked by serde).
pub fn from_cells<T: DeserializeOwned>(headers: &[String], cells: &[String]) -> Result<T, String> {
    let h: csv::StringRecord = headers.iter().collect();
    let c: csv::StringRecord = cells.iter().collect();
    c.deserialize(Some(&h)).map_err(|e| {
        let msg = e.to_string();
        // csv's messages carry a byte position of our in-memory record; keep the reason.
        msg.split_once(": ")
            .filter(|(pre, _)| pre.starts_with("CSV deserialize error"))
            .map_or(msg.clone(), |(_, rest)| rest.to_string())
    })
}

/// The canonical serialisation of parameters: `name=cell;…` in field order.
pub fn canonical<T: Serialize>(p: &T) -> Result<String, String> {
    let (h, c) = to_cells(p)?;
    Ok(canonical_of(&h, &c))
}

/// [`canonical`] of parameters already in cells.
pub(crate) fn canonical_of(headers: &[String], cells: &[String]) -> String {
    let mut s = String::new();
    for (i, (k, v)) in headers.iter().zip(cells).enumerate() {
        if i > 0 {
            s.push(';');
        }
        s.push_str(k);
        s.push('=');
        s.push_str(v);
    }
    s
}

/// FNV-1a (64 bit) of `kind` and the canonical parameters, hex.
pub fn run_id(kind: &str, canonical: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in kind.bytes().chain([b'\n']).chain(canonical.bytes()) {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// A list parameter in one CSV cell (`0.5;0.7;2`), read from a TOML list or that cell:
/// `#[serde(with = "crate::records::list")]`.
pub mod list {
    use serde::de::{self, SeqAccess, Visitor};
    use serde::{Deserializer, Serializer};
    use std::fmt;
    use std::str::FromStr;

    pub fn serialize<S: Serializer, T: fmt::Display>(v: &[T], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(
            &v.iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(";"),
        )
    }

    pub fn deserialize<'de, D, T>(d: D) -> Result<Vec<T>, D::Error>
    where
        D: Deserializer<'de>,
        T: FromStr + serde::Deserialize<'de>,
    {
        struct V<T>(std::marker::PhantomData<T>);
        impl<'de, T: FromStr + serde::Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = Vec<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a list of numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut a: A) -> Result<Vec<T>, A::Error> {
                let mut out = Vec::new();
                while let Some(x) = a.next_element()? {
                    out.push(x);
                }
                Ok(out)
            }
            // A one-element list in a CSV cell reads as a number.
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Vec<T>, E> {
                self.visit_str(&v.to_string())
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Vec<T>, E> {
                self.visit_str(&v.to_string())
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Vec<T>, E> {
                self.visit_str(&v.to_string())
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<Vec<T>, E> {
                if s.trim().is_empty() {
                    return Ok(Vec::new());
                }
                s.split(';')
                    .map(|x| {
                        x.trim()
                            .parse()
                            .map_err(|_| E::custom(format!("{x:?} in list {s:?} is not a number")))
                    })
                    .collect()
            }
        }
        d.deserialize_any(V(std::marker::PhantomData))
    }
}

/// The results table and its reading (the ground floor's, `shscale_files::table`): the runner
/// and the kinds call it `Results`.
pub use shscale_files::table::{cmp_cells, read_raw, read_raw_header, CsvLine, Table as Results};

/// CSV text of a header and rows.
pub fn write_text(columns: &[String], rows: &[Vec<String>]) -> Result<String, Error> {
    String::from_utf8(csv_bytes(Some(columns), rows)?)
        .map_err(|e| Error::Config(format!("writing CSV: {e}")))
}

/// CSV bytes of rows, after the header when one is given.
pub fn csv_bytes(columns: Option<&[String]>, rows: &[Vec<String>]) -> Result<Vec<u8>, Error> {
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    let e = |e: csv::Error| Error::Config(format!("writing CSV: {e}"));
    if let Some(c) = columns {
        w.write_record(c).map_err(e)?;
    }
    for r in rows {
        w.write_record(r).map_err(e)?;
    }
    w.into_inner()
        .map_err(|e| Error::Config(format!("writing CSV: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize, serde::Deserialize, Default, PartialEq, Debug)]
    struct P {
        a: usize,
        b: f64,
        c: Option<f64>,
        s: String,
        #[serde(with = "list")]
        l: Vec<f64>,
    }

    #[test]
    fn cells_round_trip_and_run_id_is_stable() {
        let p = P {
            a: 3,
            b: 0.1,
            c: None,
            s: "x,\"y\"".into(),
            l: vec![0.5, 1e-7, 2.0],
        };
        // A one-element list is a plain number in its cell.
        let one = P {
            l: vec![2.0],
            ..Default::default()
        };
        let (h1, c1) = to_cells(&one).unwrap();
        assert_eq!(from_cells::<P>(&h1, &c1).unwrap(), one);
        let (h, c) = to_cells(&p).unwrap();
        assert_eq!(h, ["a", "b", "c", "s", "l"]);
        assert_eq!(c[2], "");
        let back: P = from_cells(&h, &c).unwrap();
        assert_eq!(back, p);
        assert_eq!(canonical(&back).unwrap(), canonical(&p).unwrap());
        let bad = from_cells::<P>(
            &h,
            &["x".into(), "1".into(), "".into(), "".into(), "".into()],
        );
        assert!(bad.is_err());
        let text = write_text(&h, &[c]).unwrap();
        assert!(text.contains("\"x,\"\"y\"\"\""), "{text}");
    }

    #[test]
    fn split_line_reads_what_the_csv_writer_wrote_as_the_csv_reader_does() {
        // Oracle: the csv crate's own reader, on records of awkward cells.
        let cells = [
            "",
            "plain",
            "a,b",
            "say \"hi\"",
            "\"",
            "\"\"",
            "two\nlines",
            "cr\rlf\r\n",
            " lead",
            "trail ",
            "ünï,cödé",
            ",",
            "\n",
            "x\"y,z\"\n",
        ];
        for n in 1..=3 {
            for w in cells.windows(n) {
                let mut wr = csv::Writer::from_writer(Vec::new());
                wr.write_record(w).unwrap();
                wr.write_record(w.iter().rev()).unwrap();
                let bytes = wr.into_inner().unwrap();
                let text = std::str::from_utf8(&bytes).unwrap();
                let want: Vec<Vec<String>> = csv::ReaderBuilder::new()
                    .has_headers(false)
                    .from_reader(bytes.as_slice())
                    .records()
                    .map(|r| r.unwrap().iter().map(String::from).collect())
                    .collect();
                let (first, rest) = split_line(text).unwrap();
                let (second, end) = split_line(rest).unwrap();
                assert_eq!(vec![first, second], want, "{text:?}");
                assert_eq!(end, "");
            }
        }
        // Not a record: an unclosed quote, text after a closing quote, nothing.
        assert!(split_line("\"open").is_none());
        assert!(split_line("\"a\"b,c\n").is_none());
        assert!(split_line("").is_none());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
        /// Any record of any cells reads back as the csv crate's reader reads it.
        #[test]
        fn split_line_agrees_with_the_csv_reader(
            cells in proptest::collection::vec(".{0,12}", 1..6)
        ) {
            // The oracle drops a byte-order mark at the start of its input (a header of field
            // names never starts with one).
            proptest::prop_assume!(!cells[0].starts_with('\u{feff}'));
            let mut wr = csv::Writer::from_writer(Vec::new());
            wr.write_record(&cells).unwrap();
            let bytes = wr.into_inner().unwrap();
            let text = std::str::from_utf8(&bytes).unwrap();
            let want: Vec<String> = csv::ReaderBuilder::new()
                .has_headers(false)
                .from_reader(bytes.as_slice())
                .records()
                .next()
                .unwrap()
                .unwrap()
                .iter()
                .map(String::from)
                .collect();
            let (got, rest) = split_line(text).unwrap();
            proptest::prop_assert_eq!(got, want);
            proptest::prop_assert_eq!(rest, "");
        }

        /// Arbitrary text is never a panic: a record or `None`.
        #[test]
        fn split_line_never_panics(text in "\\PC{0,40}") {
            let _ = split_line(&text);
        }
    }
}

/// The type of every field of a flat struct as the CSV cells hold it — `integer`, `float`,
/// `bool`, `string` or `list` (of numbers, `;`-separated, [`list`]), with `?` after it when the
/// cell may be empty (an `Option`) — read off the struct's `Deserialize` by a deserializer that
/// records what each field asks for. `None` for a struct it cannot walk.
pub fn column_types<T: DeserializeOwned>() -> Option<Vec<(String, String)>> {
    let mut out = Vec::new();
    T::deserialize(probe::Struct { out: &mut out }).ok()?;
    Some(out)
}

mod probe {
    use serde::de::{self, DeserializeSeed, IntoDeserializer, MapAccess, Visitor};
    use serde::forward_to_deserialize_any;

    #[derive(Debug)]
    pub struct E(String);
    impl std::fmt::Display for E {
        fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str(&self.0)
        }
    }
    impl std::error::Error for E {}
    impl de::Error for E {
        fn custom<T: std::fmt::Display>(m: T) -> Self {
            E(m.to_string())
        }
    }

    pub struct Struct<'a> {
        pub out: &'a mut Vec<(String, String)>,
    }

    impl<'de> de::Deserializer<'de> for Struct<'_> {
        type Error = E;
        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, E> {
            Err(E("not a struct".into()))
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            v: V,
        ) -> Result<V::Value, E> {
            v.visit_map(Fields {
                fields,
                i: 0,
                out: self.out,
            })
        }
        forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
            option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
            ignored_any
        }
    }

    struct Fields<'a> {
        fields: &'static [&'static str],
        i: usize,
        out: &'a mut Vec<(String, String)>,
    }

    impl<'de> MapAccess<'de> for Fields<'_> {
        type Error = E;
        fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, k: K) -> Result<Option<K::Value>, E> {
            let Some(f) = self.fields.get(self.i) else {
                return Ok(None);
            };
            self.out.push((f.to_string(), String::new()));
            k.deserialize((*f).into_deserializer()).map(Some)
        }
        fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, v: V) -> Result<V::Value, E> {
            self.i += 1;
            let slot = &mut self.out.last_mut().expect("a key before its value").1;
            v.deserialize(Field { ty: slot })
        }
    }

    struct Field<'a> {
        ty: &'a mut String,
    }

    impl Field<'_> {
        fn set(&mut self, t: &str) {
            self.ty.push_str(t);
        }
    }

    struct NoItems;
    impl<'de> de::SeqAccess<'de> for NoItems {
        type Error = E;
        fn next_element_seed<T: DeserializeSeed<'de>>(
            &mut self,
            _: T,
        ) -> Result<Option<T::Value>, E> {
            Ok(None)
        }
    }

    impl<'de> de::Deserializer<'de> for Field<'_> {
        type Error = E;
        fn deserialize_any<V: Visitor<'de>>(mut self, v: V) -> Result<V::Value, E> {
            // The list cells' deserializer (`records::list`) asks for any and takes a sequence.
            self.set("list");
            v.visit_seq(NoItems)
        }
        fn deserialize_bool<V: Visitor<'de>>(mut self, v: V) -> Result<V::Value, E> {
            self.set("bool");
            v.visit_bool(false)
        }
        fn deserialize_u64<V: Visitor<'de>>(mut self, v: V) -> Result<V::Value, E> {
            self.set("integer");
            v.visit_u64(0)
        }
        fn deserialize_u32<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_u64(v)
        }
        fn deserialize_u16<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_u64(v)
        }
        fn deserialize_u8<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_u64(v)
        }
        fn deserialize_i64<V: Visitor<'de>>(mut self, v: V) -> Result<V::Value, E> {
            self.set("integer");
            v.visit_i64(0)
        }
        fn deserialize_i32<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_i64(v)
        }
        fn deserialize_i16<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_i64(v)
        }
        fn deserialize_i8<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_i64(v)
        }
        fn deserialize_f64<V: Visitor<'de>>(mut self, v: V) -> Result<V::Value, E> {
            self.set("float");
            v.visit_f64(0.0)
        }
        fn deserialize_f32<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_f64(v)
        }
        fn deserialize_str<V: Visitor<'de>>(mut self, v: V) -> Result<V::Value, E> {
            self.set("string");
            v.visit_str("")
        }
        fn deserialize_string<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_str(v)
        }
        fn deserialize_char<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            self.deserialize_str(v)
        }
        fn deserialize_option<V: Visitor<'de>>(self, v: V) -> Result<V::Value, E> {
            let ty = self.ty;
            let r = v.visit_some(Field { ty: &mut *ty });
            ty.push('?');
            r
        }
        forward_to_deserialize_any! {
            i128 u128 bytes byte_buf unit unit_struct newtype_struct seq tuple tuple_struct map
            struct enum identifier ignored_any
        }
    }
}

#[cfg(test)]
mod read_tests {
    /// A lookup of a column the table lacks is recorded and then an error naming the column and
    /// the file — never a NaN in a verdict.
    #[test]
    fn a_missing_column_is_an_error_naming_it_and_the_file() {
        let mut t = super::Results::new(
            vec!["run_id".into(), "frame_ms".into()],
            vec![vec!["a".into(), "1.5".into()]],
        );
        t.source = "results/x/runs.csv".into();
        assert_eq!(t.num(0, "frame_ms"), 1.5);
        assert!(t.check_read("the verdict").is_ok());
        assert!(
            t.col("frame_seconds").is_none(),
            "a presence test is not recorded"
        );
        assert!(t.check_read("the verdict").is_ok());
        assert!(t.num(0, "frame_seconds").is_nan());
        let e = t
            .check_read("the verdict of kind budget")
            .unwrap_err()
            .to_string();
        println!("{e}");
        assert!(
            e.contains("results/x/runs.csv")
                && e.contains("\"frame_seconds\"")
                && e.contains("verdict of kind budget"),
            "{e}"
        );
    }
}
