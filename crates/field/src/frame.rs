//! Local frames (docs/conventions.md §2): for a point p ≠ c the local z axis points from p toward c. The
//! x/y axes complete it by the branchless construction of Duff et al. 2017 ("Building an
//! orthonormal basis, revisited", JCGT 6(1)); rotations about z commute with scaling, so this
//! choice does not change scaled results, only the stored coefficients.

use glam::DVec3;

/// An orthonormal frame: `to_world(v) = x·v.x + y·v.y + z·v.z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    pub x: DVec3,
    pub y: DVec3,
    pub z: DVec3,
}

impl LocalFrame {
    /// Frame with the given unit z axis.
    pub(crate) fn from_z(z: DVec3) -> Self {
        let sign = 1f64.copysign(z.z);
        let a = -1.0 / (sign + z.z);
        let b = z.x * z.y * a;
        let x = DVec3::new(1.0 + sign * z.x * z.x * a, sign * b, -sign * z.x);
        let y = DVec3::new(b, sign + z.y * z.y * a, -z.y);
        Self { x, y, z }
    }

    /// The local frame at `p` for an entity centred at `c` (z toward c). `p ≠ c`.
    pub fn toward(p: DVec3, c: DVec3) -> Self {
        Self::from_z((c - p).normalize())
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(self.x.dot(v), self.y.dot(v), self.z.dot(v))
    }

    /// The rotation matrix local → world, row-major `R[row][col]` (columns are x, y, z).
    pub fn matrix(&self) -> [[f64; 3]; 3] {
        [
            [self.x.x, self.y.x, self.z.x],
            [self.x.y, self.y.y, self.z.y],
            [self.x.z, self.y.z, self.z.z],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_right_handed() {
        for z in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::new(0.3, -0.4, 0.1).normalize(),
            DVec3::new(1e-9, 0.0, -1.0).normalize(),
        ] {
            let f = LocalFrame::from_z(z);
            assert!((f.x.length() - 1.0).abs() < 1e-14 && (f.y.length() - 1.0).abs() < 1e-14);
            assert!(
                f.x.dot(f.y).abs() < 1e-14
                    && f.x.dot(f.z).abs() < 1e-14
                    && f.y.dot(f.z).abs() < 1e-14
            );
            assert!((f.x.cross(f.y) - f.z).length() < 1e-14);
            let v = DVec3::new(0.2, 0.7, -0.1);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-14);
        }
    }
}
