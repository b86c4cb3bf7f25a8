//! A PLY reader (ASCII, binary little- and big-endian) for `vertex` x/y/z and `face`
//! vertex-index lists; other elements and properties are skipped. Polygons are fan-triangulated.
//! Errors name the file and the header line, the ASCII line, or the binary element.

use crate::error::GeometryError;

use crate::mesh::Mesh;
use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

shscale_names::names!(Scalar {
    I8 = "char" | "int8",
    U8 = "uchar" | "uint8",
    I16 = "short" | "int16",
    U16 = "ushort" | "uint16",
    I32 = "int" | "int32",
    U32 = "uint" | "uint32",
    F32 = "float" | "float32",
    F64 = "double" | "float64",
});

impl Scalar {
    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }
    fn read(self, b: &[u8], le: bool) -> f64 {
        macro_rules! rd {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().unwrap();
                (if le {
                    <$t>::from_le_bytes(a)
                } else {
                    <$t>::from_be_bytes(a)
                }) as f64
            }};
        }
        match self {
            Self::I8 => b[0] as i8 as f64,
            Self::U8 => b[0] as f64,
            Self::I16 => rd!(i16, 2),
            Self::U16 => rd!(u16, 2),
            Self::I32 => rd!(i32, 4),
            Self::U32 => rd!(u32, 4),
            Self::F32 => rd!(f32, 4),
            Self::F64 => rd!(f64, 8),
        }
    }
}

#[derive(Debug)]
enum Prop {
    Scalar(String, Scalar),
    List(String, Scalar, Scalar),
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

/// Parse PLY bytes into a validated mesh.
pub fn parse_ply(file: &str, bytes: &[u8]) -> Result<Mesh, GeometryError> {
    let (lines, pos) = header_lines(file, bytes)?;
    let (le, elements) = parse_header(file, &lines)?;
    let body = &bytes[pos..];
    let text = le
        .is_none()
        .then(|| String::from_utf8_lossy(body).to_string());
    let mut reader = match (&text, le) {
        (Some(t), _) => Body::Ascii {
            lines: Box::new(t.lines().enumerate().filter(|(_, l)| !l.trim().is_empty())),
            header_lines: lines.len(),
        },
        (None, Some(le)) => Body::Binary { body, off: 0, le },
        (None, None) => unreachable!("a format without text is binary"),
    };
    let mut out = (Vec::new(), Vec::new());
    for el in &elements {
        for idx in 0..el.count {
            let v = reader.element(file, el, idx)?;
            add_element(file, el, idx, &v, &mut out)?;
        }
    }
    Mesh::new(file, out.0, out.1, false)
}

fn perr(file: &str, line: usize, reason: String) -> GeometryError {
    GeometryError::Parse {
        file: file.into(),
        line,
        reason,
    }
}

fn invalid(file: &str, element: &'static str, index: usize, reason: String) -> GeometryError {
    GeometryError::Invalid {
        file: file.into(),
        element,
        index,
        reason,
    }
}

/// The header's lines up to `end_header`, and the byte where the body starts.
fn header_lines(file: &str, bytes: &[u8]) -> Result<(Vec<String>, usize), GeometryError> {
    let mut pos = 0;
    let mut lines = Vec::new();
    loop {
        let end = bytes[pos..]
            .iter()
            .position(|&c| c == b'\n')
            .ok_or_else(|| perr(file, lines.len() + 1, "missing end_header".into()))?;
        let line = String::from_utf8_lossy(&bytes[pos..pos + end])
            .trim_end_matches('\r')
            .to_string();
        pos += end + 1;
        let done = line.trim() == "end_header";
        lines.push(line);
        if done {
            break;
        }
    }
    if lines[0].trim() != "ply" {
        return Err(perr(
            file,
            1,
            format!("not a PLY file (first line {:?})", lines[0]),
        ));
    }
    Ok((lines, pos))
}

/// The format (`None` ASCII, `Some(little_endian)` binary) and the elements of a header.
fn parse_header(
    file: &str,
    lines: &[String],
) -> Result<(Option<bool>, Vec<Element>), GeometryError> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (i, l) in lines.iter().enumerate().skip(1) {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first().copied() {
            Some("format") => {
                format = w.get(1).map(|s| s.to_string());
                if w.get(2) != Some(&"1.0") {
                    return Err(perr(
                        file,
                        i + 1,
                        format!(
                            "unsupported PLY version {:?} (only 1.0 exists)",
                            w.get(2).unwrap_or(&"")
                        ),
                    ));
                }
            }
            Some("element") => {
                let count = w
                    .get(2)
                    .and_then(|s| s.parse().ok())
                    .ok_or_else(|| perr(file, i + 1, format!("bad element line {l:?}")))?;
                elements.push(Element {
                    name: w.get(1).unwrap_or(&"").to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| perr(file, i + 1, "property before any element".into()))?;
                el.props.push(parse_property(&w).ok_or_else(|| {
                    let what = if w.get(1) == Some(&"list") {
                        "list property"
                    } else {
                        "property"
                    };
                    perr(file, i + 1, format!("bad {what} {l:?}"))
                })?);
            }
            _ => {}
        }
    }
    let le = match format.as_deref() {
        Some("ascii") => None,
        Some("binary_little_endian") => Some(true),
        Some("binary_big_endian") => Some(false),
        other => return Err(perr(file, 2, format!("unsupported format {other:?}"))),
    };
    Ok((le, elements))
}

/// `property <type> <name>` or `property list <count type> <value type> <name>`.
fn parse_property(w: &[&str]) -> Option<Prop> {
    if w.get(1) == Some(&"list") {
        let (c, v, n) = (
            Scalar::from_name(w.get(2)?)?,
            Scalar::from_name(w.get(3)?)?,
            w.get(4)?,
        );
        Some(Prop::List(n.to_string(), c, v))
    } else {
        Some(Prop::Scalar(
            w.get(2)?.to_string(),
            Scalar::from_name(w.get(1)?)?,
        ))
    }
}

/// One element's values: scalars by name, and lists as vectors.
#[derive(Default)]
struct Values {
    scalars: Vec<(String, f64)>,
    lists: Vec<(String, Vec<f64>)>,
}

/// The body of a PLY file, read element by element.
enum Body<'a> {
    Ascii {
        lines: Box<dyn Iterator<Item = (usize, &'a str)> + 'a>,
        header_lines: usize,
    },
    Binary {
        body: &'a [u8],
        off: usize,
        le: bool,
    },
}

impl Body<'_> {
    fn element(&mut self, file: &str, el: &Element, idx: usize) -> Result<Values, GeometryError> {
        let mut v = Values::default();
        match self {
            Body::Ascii {
                lines,
                header_lines,
            } => {
                let (ln, line) = lines.next().ok_or_else(|| {
                    let m = format!("file ends inside element {} {idx}", el.name);
                    perr(file, *header_lines, m)
                })?;
                let line_no = *header_lines + ln + 1;
                let mut toks = line.split_whitespace().map(|t| t.parse::<f64>());
                let mut next = || -> Result<f64, GeometryError> {
                    let m = |what: &str| perr(file, line_no, format!("{} {idx}: {what}", el.name));
                    toks.next()
                        .ok_or_else(|| m("too few values"))?
                        .map_err(|_| m("not a number"))
                };
                for p in &el.props {
                    match p {
                        Prop::Scalar(n, _) => v.scalars.push((n.clone(), next()?)),
                        Prop::List(n, _, _) => {
                            let c = next()?;
                            if !(c >= 0.0 && c.fract() == 0.0) {
                                let m = format!("{} {idx}: bad list length {c}", el.name);
                                return Err(perr(file, line_no, m));
                            }
                            let l = (0..c as usize).map(|_| next()).collect::<Result<_, _>>()?;
                            v.lists.push((n.clone(), l));
                        }
                    }
                }
            }
            Body::Binary { body, off, le } => {
                let mut take = |t: Scalar| -> Result<f64, GeometryError> {
                    let s = t.size();
                    let b = body.get(*off..*off + s).ok_or_else(|| {
                        invalid(
                            file,
                            "element",
                            idx,
                            format!("file ends inside {} {idx}", el.name),
                        )
                    })?;
                    *off += s;
                    Ok(t.read(b, *le))
                };
                for p in &el.props {
                    match p {
                        Prop::Scalar(n, t) => v.scalars.push((n.clone(), take(*t)?)),
                        Prop::List(n, c, t) => {
                            let count = take(*c)? as usize;
                            let l = (0..count).map(|_| take(*t)).collect::<Result<_, _>>()?;
                            v.lists.push((n.clone(), l));
                        }
                    }
                }
            }
        }
        Ok(v)
    }
}

/// Add a `vertex` (its x, y, z) or a `face` (fanned into triangles, every index checked) to
/// `(positions, triangles)`; other elements are skipped.
fn add_element(
    file: &str,
    el: &Element,
    idx: usize,
    v: &Values,
    (positions, triangles): &mut (Vec<DVec3>, Vec<[u32; 3]>),
) -> Result<(), GeometryError> {
    match el.name.as_str() {
        "vertex" => {
            let get = |k: &str| v.scalars.iter().find(|(n, _)| n == k).map(|(_, v)| *v);
            let (Some(x), Some(y), Some(z)) = (get("x"), get("y"), get("z")) else {
                return Err(invalid(
                    file,
                    "vertex",
                    idx,
                    "missing x, y or z property".into(),
                ));
            };
            positions.push(DVec3::new(x, y, z));
        }
        "face" => {
            let Some((_, f)) =
                (v.lists.iter()).find(|(n, _)| n == "vertex_indices" || n == "vertex_index")
            else {
                return Err(invalid(file, "face", idx, "no vertex_indices list".into()));
            };
            if f.len() < 3 {
                return Err(invalid(file, "face", idx, format!("{} vertices", f.len())));
            }
            let known = if positions.is_empty() {
                u32::MAX as f64
            } else {
                positions.len() as f64 - 1.0
            };
            if let Some(bad) = f
                .iter()
                .find(|x| **x < 0.0 || x.fract() != 0.0 || **x > known)
            {
                return Err(invalid(
                    file,
                    "face",
                    idx,
                    format!("bad vertex index {bad}"),
                ));
            }
            for k in 1..f.len() - 1 {
                triangles.push([f[0] as u32, f[k] as u32, f[k + 1] as u32]);
            }
        }
        _ => {}
    }
    Ok(())
}
