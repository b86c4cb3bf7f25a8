//! Property tests of the readers of scenes and configs: scene files and experiment configs with random damage
//! (values replaced by hostile ones, bytes overwritten, truncated), and EXR files of arbitrary
//! bytes or with damaged headers, never panic; what they accept passes the documented bounds.
//! Bounded: 128–256 cases per property (seconds).

use proptest::prelude::*;
use shscale_runner::config::Overrides;
use shscale_runner::Plan;
use shscale_runner::{DynKind, Erased};
use shscale_scene::scene::Scene;
use std::path::Path;

const SCENE: &str = "order = 2\nalpha_deg = 45\nlayout = \"fib:20\"\nhemisphere_res = 4\nk_count = 8\nsampling_radius = 1.0\n[[occluder]]\nmesh = \"sphere\"\ncenter = [0, 0, 1.5]\nradius = 1.0\n[receiver]\ncenter = [0, 0, 0]\nsize = [4, 4]\nresolution = [8, 8]\n[light]\nkind = \"sky\"\nambient = 0.3\nzenith = 1.0\nsun = 20.0\nsun_dir = [0.3, 0.2, 1]\nsun_radius_deg = 5\n[[light_source]]\nkind = \"quad\"\ncenter = [0, 0, 3]\nsize = 1.0\nintensity = 2.0\n";

const CONFIG: &str = "experiment = \"probe\"\nmesh = \"sphere\"\norder = 2\nlayout = \"fib:10\"\nhemisphere_res = 2\nk_count = 4\nradii = [2.0, 3.0]\non_surface_eps = 0.001\n[sweep]\nalpha_deg = [30, 60]\n[sweep.zip]\nsampling_radius = [1.0, 2.0]\nk_spacing = [\"exp\", \"uniform\"]\n";

/// Hostile replacements for a numeric or string value.
fn hostile() -> impl Strategy<Value = String> {
    prop::sample::select(vec![
        "nan",
        "inf",
        "-inf",
        "-1",
        "0",
        "1e308",
        "-1e308",
        "1e-308",
        "18446744073709551616",
        "4294967296",
        "1000000000",
        "\"\"",
        "\"x\"",
        "[]",
        "[1e308, 1e308, 1e308]",
        "[nan, 0, 0]",
        "{}",
        "true",
        "\"fib:1000000000\"",
        "\"cube:5000000000\"",
        "\"latlong:0x0\"",
        "[0, 0]",
        "-0.0",
        "1e-320",
        "99999999999999999999",
    ])
    .prop_map(String::from)
}

/// Replace the value of the `n`-th `key = value` line of `text` with `v`.
fn replace_value(text: &str, n: usize, v: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let values: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].contains(" = "))
        .collect();
    let target = values[n % values.len()];
    lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if i == target {
                format!("{} = {v}", l.split(" = ").next().unwrap())
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn scene_ok((s, rs): &(Scene, shscale_scene::settings::RenderSettings)) {
    assert!((1..=16).contains(&rs.order));
    assert!(rs.alpha > 0.0 && rs.alpha < std::f64::consts::FRAC_PI_2);
    assert!((1..=256).contains(&rs.hemisphere_res));
    assert!(rs.layout.sample_count().is_some_and(|n| n <= 1_000_000));
    assert!(s.resolution.iter().all(|n| (2..=4096).contains(n)));
    assert!(s.occluders.iter().all(|o| o.center.is_finite()
        && o.radius.is_finite()
        && o.radius > 0.0
        && o.center.abs().max_element() <= shscale_scene::scene::MAX_SCENE_COORDINATE));
}

static PROBE: Erased<shscale_experiments::probe::Probe> = Erased::new();

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn scenes_with_hostile_values_never_panic(n in 0usize..64, m in 0usize..64, a in hostile(), b in hostile()) {
        let text = replace_value(&replace_value(SCENE, n, &a), m, &b);
        if let Ok(s) = Scene::parse("s.toml", &text, Path::new(".")) { scene_ok(&s); }
    }

    #[test]
    fn damaged_scene_bytes_never_panic(edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6), cut in 0usize..400) {
        let mut b = SCENE.as_bytes().to_vec();
        for (at, v) in edits { let i = at % b.len(); b[i] = v; }
        b.truncate(b.len().saturating_sub(cut));
        let text = String::from_utf8_lossy(&b);
        if let Ok(s) = Scene::parse("s.toml", &text, Path::new(".")) { scene_ok(&s); }
    }

    #[test]
    fn configs_with_hostile_values_never_panic(n in 0usize..64, a in hostile(), set in hostile(), key in prop::sample::select(vec!["order", "radii", "layout", "k_count", "alpha_deg", "name", "sweep.order", "timing_repeats"])) {
        let text = replace_value(CONFIG, n, &a);
        let registry: [&'static dyn DynKind; 1] = [&PROBE];
        let ov = Overrides { set: vec![format!("{key}={set}")], sweep: vec![format!("hemisphere_res={set},3")], name: None };
        for ov in [Overrides::default(), ov] {
            if let Ok(plan) = Plan::parse("c.toml", "c", &text, &ov, &registry) {
                prop_assert!(!plan.runs.is_empty());
                let _ = plan.describe(None);
                let _ = plan.check_limits(false);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn exr_files_of_damaged_bytes_never_panic(edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..6), cut in any::<usize>(), garbage in proptest::collection::vec(any::<u8>(), 0..600)) {
        let dir = std::env::temp_dir().join(format!("shscale-fuzz-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.exr");
        if !good.exists() {
            shscale_present::image::write_exr(&good, 4, 3, &[[0.5, 1.0, 2.0]; 12]).unwrap();
        }
        let mut b = std::fs::read(&good).unwrap();
        for (at, v) in edits { let i = at % b.len(); b[i] = v; }
        b.truncate(b.len() - cut % b.len());
        let p = dir.join(format!("d{}.exr", std::thread::current().name().map_or(0, |n| n.len())));
        for bytes in [b, garbage] {
            std::fs::write(&p, &bytes).unwrap();
            if let Ok((w, h, px)) = shscale_present::image::read_exr(&p) {
                prop_assert_eq!(px.len(), w * h);
                prop_assert!(w <= shscale_present::image::MAX_IMAGE_SIDE && h <= shscale_present::image::MAX_IMAGE_SIDE);
                prop_assert!(px.iter().flatten().all(|v| v.is_finite()));
            }
            let _ = shscale_present::image::read_radiance_exr(&p);
        }
    }
}
