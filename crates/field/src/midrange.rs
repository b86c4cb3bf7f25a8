//! Mid-range environment lighting (SHS §3.2, Eq. 7; docs/conventions.md §3.2): the environment is a sphere
//! of radius R around `c` whose radiance `L_c(u)` is captured once, at the centre. At a point
//! `q = c + d·v` inside it, the ray in direction ω hits the sphere at the direction `u = τ_k(ω)`
//! from the centre (polar angles measured from v), `k = d/R`, so in the frame with z along v,
//! `L_q = M_k · L_c` with the mid-range τ. Radiance is constant along rays, so the plain η is
//! the right one (no solid-angle factor: the energy variant would describe a source whose
//! intensity is spread over the scaled solid angle, which an environment is not).
//! The "distant lighting" assumption uses `L_c` unchanged at every point.

use crate::error::FieldError;
use crate::frame::LocalFrame;
use crate::shading::EnvLight;
use glam::DVec3;
use shscale_scaling::{Eta, MidRange, ScalingMatrix};
use shscale_sh::ShRotation;

/// The light at `c + offset` inside an environment sphere of radius `radius` (|offset| < radius).
pub fn light_at(env: &EnvLight, offset: DVec3, radius: f64) -> Result<EnvLight, FieldError> {
    let d = offset.length();
    if !(radius > 0.0 && d < radius) {
        return Err(FieldError::Spec(format!("mid-range: point at distance {d} is not inside the environment sphere of radius {radius}")));
    }
    if d == 0.0 {
        return Ok(env.clone());
    }
    let order = env.order();
    let m = ScalingMatrix::compute(&MidRange::new(d / radius)?, Eta::Plain, order)?;
    let f = LocalFrame::from_z(offset / d);
    let rot = ShRotation::new(order, &f.matrix())?;
    let nn = order * order;
    let mut out = [vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]];
    let (mut local, mut scaled) = (vec![0.0; nn], vec![0.0; nn]);
    for c in 0..3 {
        rot.apply_inverse(&env.rgb[c], &mut local)?;
        m.apply(&local, &mut scaled)?;
        rot.apply(&scaled, &mut out[c])?;
    }
    Ok(EnvLight {
        rgb: out,
        source: None,
    })
}

/// The reference for [`light_at`]: irradiance at `q` (|q − c| < `radius`, c the origin here) with
/// normal `n`, `E = ∫ L_c(u(ω)) max(0, n·ω) dω`, where u(ω) is the direction from the centre to
/// the point where the ray from q in direction ω leaves the environment sphere (radiance is
/// constant along rays). Quadrature over `quad` (a full-sphere rule, e.g.
/// `DirectionSet::gauss_sphere(96, 192)`); `basis` evaluates channel `ch` of `env`. Independent of
/// the scaling matrices, so it tests them.
pub fn irradiance_by_ray_exit(
    env: &EnvLight,
    ch: usize,
    q: DVec3,
    radius: f64,
    n: DVec3,
    quad: &shscale_sh::DirectionSet,
    basis: &shscale_sh::ShBasis<f64>,
) -> f64 {
    let mut y = vec![0.0; basis.len()];
    let mut e = 0.0;
    for (d, w) in quad.dirs.iter().zip(&quad.weights) {
        let dir = DVec3::from_array(*d);
        let c = dir.dot(n);
        if c <= 0.0 {
            continue;
        }
        // Exit of q + t·dir from the sphere |x| = radius (t > 0: q is inside).
        let b = q.dot(dir);
        let t = -b + (b * b - (q.length_squared() - radius * radius)).sqrt();
        let exit = (q + t * dir) / radius;
        basis.eval(exit.to_array(), &mut y);
        let l: f64 = env.rgb[ch].iter().zip(&y).map(|(a, b)| a * b).sum();
        e += w * l * c;
    }
    e
}
