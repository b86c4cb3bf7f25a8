//! Property tests of the mesh readers: arbitrary bytes, and valid files with random damage
//! (bytes overwritten, truncated, lines duplicated), never panic; whatever they accept is a valid
//! mesh inside the documented domain. Bounded: 256 cases per property (a few seconds).

use proptest::prelude::*;
use shscale_geometry::ply::parse_ply;
use shscale_geometry::Mesh;

const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n";
const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";

/// A binary little-endian PLY of the same tetrahedron.
fn binary_ply() -> Vec<u8> {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for p in [
        [0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ] {
        for v in p {
            b.extend(v.to_le_bytes());
        }
    }
    for f in [[0i32, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
        b.push(3);
        for v in f {
            b.extend(v.to_le_bytes());
        }
    }
    b
}

fn accepted_is_valid(m: &Mesh) {
    assert!(!m.triangles.is_empty());
    let n = m.positions.len() as u32;
    assert!(m.triangles.iter().flatten().all(|&v| v < n));
    assert!(m
        .positions
        .iter()
        .all(|p| p.is_finite() && p.abs().max_element() <= Mesh::MAX_COORDINATE));
}

/// `base` with damage: (position, byte) overwrites, then a truncation.
fn damage(base: &[u8], edits: &[(usize, u8)], cut: usize) -> Vec<u8> {
    let mut b = base.to_vec();
    for &(at, v) in edits {
        let i = at % b.len();
        b[i] = v;
    }
    b.truncate(b.len() - cut % (b.len() / 2));
    b
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        if let Ok(m) = parse_ply("x.ply", &bytes) { accepted_is_valid(&m); }
        if let Ok(m) = Mesh::from_obj_bytes("x.obj", &bytes) { accepted_is_valid(&m); }
        let mut ply = b"ply\nformat ascii 1.0\n".to_vec();
        ply.extend(&bytes);
        if let Ok(m) = parse_ply("x.ply", &ply) { accepted_is_valid(&m); }
    }

    #[test]
    fn damaged_files_never_panic(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        cut in any::<usize>(),
        text_edits in proptest::collection::vec((any::<usize>(), prop::sample::select(vec![b'-', b'9', b'e', b' ', b'\n', b'/', b'.', b'x', b'0'])), 0..6),
    ) {
        for base in [PLY.as_bytes().to_vec(), binary_ply()] {
            if let Ok(m) = parse_ply("x.ply", &damage(&base, &edits, cut)) { accepted_is_valid(&m); }
            if let Ok(m) = parse_ply("x.ply", &damage(&base, &text_edits, cut)) { accepted_is_valid(&m); }
        }
        for e in [&edits, &text_edits] {
            if let Ok(m) = Mesh::from_obj_bytes("x.obj", &damage(OBJ.as_bytes(), e, cut)) { accepted_is_valid(&m); }
        }
    }

    #[test]
    fn lying_counts_never_allocate_or_panic(nv in any::<u32>(), nf in any::<u32>()) {
        let text = PLY.replace("element vertex 4", &format!("element vertex {nv}")).replace("element face 4", &format!("element face {nf}"));
        if let Ok(m) = parse_ply("x.ply", text.as_bytes()) { accepted_is_valid(&m); }
        let mut b = binary_ply();
        let at = b.windows(16).position(|w| w == b"element vertex 4").unwrap();
        let patched = format!("element vertex {nv}");
        b.splice(at..at + 16, patched.bytes());
        if let Ok(m) = parse_ply("x.ply", &b) { accepted_is_valid(&m); }
    }
}
