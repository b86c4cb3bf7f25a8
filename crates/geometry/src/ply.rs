//! A PLY reader (ASCII, binary little- and big-endian) for `vertex` x/y/z and `face`
//! vertex-index lists; other elements and properties are skipped. Polygons are fan-triangulated.
//! Errors name the file and the header line, the ASCII line, or the binary element.

use crate::{GeometryError, Mesh};
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

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }
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
    let perr = |line: usize, reason: String| GeometryError::Parse {
        file: file.into(),
        line,
        reason,
    };
    // Header: lines up to "end_header".
    let mut pos = 0;
    let mut lines = Vec::new();
    loop {
        let end = bytes[pos..]
            .iter()
            .position(|&c| c == b'\n')
            .ok_or_else(|| perr(lines.len() + 1, "missing end_header".into()))?;
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
            1,
            format!("not a PLY file (first line {:?})", lines[0]),
        ));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (i, l) in lines.iter().enumerate().skip(1) {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first().copied() {
            Some("format") => {
                format = w.get(1).map(|s| s.to_string());
                if w.get(2) != Some(&"1.0") {
                    return Err(perr(
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
                    .ok_or_else(|| perr(i + 1, format!("bad element line {l:?}")))?;
                elements.push(Element {
                    name: w.get(1).unwrap_or(&"").to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| perr(i + 1, "property before any element".into()))?;
                let p = if w.get(1) == Some(&"list") {
                    match (
                        w.get(2).and_then(|s| Scalar::parse(s)),
                        w.get(3).and_then(|s| Scalar::parse(s)),
                        w.get(4),
                    ) {
                        (Some(c), Some(v), Some(n)) => Prop::List(n.to_string(), c, v),
                        _ => return Err(perr(i + 1, format!("bad list property {l:?}"))),
                    }
                } else {
                    match (w.get(1).and_then(|s| Scalar::parse(s)), w.get(2)) {
                        (Some(t), Some(n)) => Prop::Scalar(n.to_string(), t),
                        _ => return Err(perr(i + 1, format!("bad property {l:?}"))),
                    }
                };
                el.props.push(p);
            }
            _ => {}
        }
    }
    let le = match format.as_deref() {
        Some("ascii") => None,
        Some("binary_little_endian") => Some(true),
        Some("binary_big_endian") => Some(false),
        other => return Err(perr(2, format!("unsupported format {other:?}"))),
    };
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let header_lines = lines.len();
    let body = &bytes[pos..];
    let text = if le.is_none() {
        Some(String::from_utf8_lossy(body).to_string())
    } else {
        None
    };
    let mut ascii_lines = text
        .as_deref()
        .map(|t| t.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()));
    let mut off = 0usize;
    for el in &elements {
        for idx in 0..el.count {
            // Read one element's values: scalars, and lists as vectors.
            let mut scalars: Vec<(String, f64)> = Vec::new();
            let mut lists: Vec<(String, Vec<f64>)> = Vec::new();
            if let Some(lines) = ascii_lines.as_mut() {
                let (ln, line) = lines.next().ok_or_else(|| {
                    perr(
                        header_lines,
                        format!("file ends inside element {} {idx}", el.name),
                    )
                })?;
                let line_no = header_lines + ln + 1;
                let mut toks = line.split_whitespace().map(|t| t.parse::<f64>());
                let mut next = || -> Result<f64, GeometryError> {
                    toks.next()
                        .ok_or_else(|| perr(line_no, format!("{} {idx}: too few values", el.name)))?
                        .map_err(|_| perr(line_no, format!("{} {idx}: not a number", el.name)))
                };
                for p in &el.props {
                    match p {
                        Prop::Scalar(n, _) => scalars.push((n.clone(), next()?)),
                        Prop::List(n, _, _) => {
                            let c = next()?;
                            if !(c >= 0.0 && c.fract() == 0.0) {
                                return Err(perr(
                                    line_no,
                                    format!("{} {idx}: bad list length {c}", el.name),
                                ));
                            }
                            let v = (0..c as usize)
                                .map(|_| next())
                                .collect::<Result<Vec<_>, _>>()?;
                            lists.push((n.clone(), v));
                        }
                    }
                }
            } else {
                let le = le.unwrap();
                let short = || GeometryError::Invalid {
                    file: file.into(),
                    element: "element",
                    index: idx,
                    reason: format!("file ends inside {} {idx}", el.name),
                };
                let mut take = |t: Scalar| -> Result<f64, GeometryError> {
                    let s = t.size();
                    let b = body.get(off..off + s).ok_or_else(short)?;
                    off += s;
                    Ok(t.read(b, le))
                };
                for p in &el.props {
                    match p {
                        Prop::Scalar(n, t) => scalars.push((n.clone(), take(*t)?)),
                        Prop::List(n, c, t) => {
                            let count = take(*c)? as usize;
                            let v = (0..count)
                                .map(|_| take(*t))
                                .collect::<Result<Vec<_>, _>>()?;
                            lists.push((n.clone(), v));
                        }
                    }
                }
            }
            match el.name.as_str() {
                "vertex" => {
                    let get = |k: &str| scalars.iter().find(|(n, _)| n == k).map(|(_, v)| *v);
                    match (get("x"), get("y"), get("z")) {
                        (Some(x), Some(y), Some(z)) => positions.push(DVec3::new(x, y, z)),
                        _ => {
                            return Err(GeometryError::Invalid {
                                file: file.into(),
                                element: "vertex",
                                index: idx,
                                reason: "missing x, y or z property".into(),
                            })
                        }
                    }
                }
                "face" => {
                    let Some((_, v)) = lists
                        .iter()
                        .find(|(n, _)| n == "vertex_indices" || n == "vertex_index")
                    else {
                        return Err(GeometryError::Invalid {
                            file: file.into(),
                            element: "face",
                            index: idx,
                            reason: "no vertex_indices list".into(),
                        });
                    };
                    if v.len() < 3 {
                        return Err(GeometryError::Invalid {
                            file: file.into(),
                            element: "face",
                            index: idx,
                            reason: format!("{} vertices", v.len()),
                        });
                    }
                    let known = if positions.is_empty() {
                        u32::MAX as f64
                    } else {
                        positions.len() as f64 - 1.0
                    };
                    if let Some(bad) = v
                        .iter()
                        .find(|x| **x < 0.0 || x.fract() != 0.0 || **x > known)
                    {
                        return Err(GeometryError::Invalid {
                            file: file.into(),
                            element: "face",
                            index: idx,
                            reason: format!("bad vertex index {bad}"),
                        });
                    }
                    for k in 1..v.len() - 1 {
                        triangles.push([v[0] as u32, v[k] as u32, v[k + 1] as u32]);
                    }
                }
                _ => {}
            }
        }
    }
    Mesh::new(file, positions, triangles, false)
}
