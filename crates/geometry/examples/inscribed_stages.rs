//! The inscribed fit's cost on one mesh: its work (cells × triangles) and the seconds of the
//! check and the fit. `cargo run --release -p shscale-geometry --example inscribed_stages --
//! NAME` for a bundled mesh, or a number of rings for a UV sphere of 2·rings² triangles (the
//! worst case of the greedy cover: one solid ball).
use shscale_geometry::{bundled, inscribed, shapes};

fn main() {
    let arg = std::env::args().nth(1).unwrap_or_else(|| "40".into());
    let m = match arg.parse::<usize>() {
        Ok(rings) => shapes::uv_sphere(1.0, rings, 2 * rings),
        Err(_) => bundled::load(&arg).expect("a bundled mesh"),
    };
    let t = std::time::Instant::now();
    let work = inscribed::inscribable(&m).expect("a mesh with an inside");
    let check = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let balls = inscribed::inscribed_spheres(&m, 64, inscribed::INSCRIBED_RES).expect("a fit");
    println!(
        "{arg}: {} triangles, {work:.3e} solid angles; check {check:.3} s; fit {} balls in {:.2} s",
        m.triangles.len(),
        balls.len(),
        t.elapsed().as_secs_f64()
    );
}
