//! The continuous verdict ([`super::surface`]) on tables whose answers are known, built from the
//! `budget` kind's own parameters ([`super::spheres::Params`]).

use super::spheres::Params;
use super::surface;
use super::verdict::{Config, Split};
use shscale_runner::records::Results;
use shscale_scene::method::Spec;

/// The continuous verdict on a table whose answer is known: a cheap ray tracer beats the
/// papers' extrapolation under its rays by a gap far outside the seeds' spread, a full field
/// ties the winner (paired gaps averaging 0.01 with a spread of 0.03), a fine ray tracer
/// beyond the cap wins at any budget; the intervals are the t ones computed by hand.
#[test]
fn the_continuous_verdict_finds_the_winner_its_interval_and_the_tie() {
    let spec = |f: &dyn Fn(&mut Params)| {
        let mut p = Params::default();
        f(&mut p);
        p.spec().unwrap()
    };
    let papers = spec(&|p| p.hemisphere_res = 16);
    let rt2 = spec(&|p| {
        p.method = "ray_traced".into();
        p.rt_res = 2;
        p.layout = "latlong:12x20".into();
        p.hemisphere_res = 32;
    });
    let rt16 = spec(&|p| {
        p.method = "ray_traced".into();
        p.rt_res = 16;
    });
    let ff = spec(&|p| p.method = "full_field".into());
    let columns: Vec<String> = [
        "probe_seed",
        "truth_seed",
        "orientation_seed",
        "rays",
        "frame_seconds",
        "memory_bytes",
        "occ_rel_l2_mean",
        "frame_seconds_hi",
    ]
    .map(String::from)
    .to_vec();
    let mut rows = Vec::new();
    let mut configs = Vec::new();
    let table: [(Spec, [f64; 3], [f64; 5]); 4] = [
        (papers, [61440.0, 1.0, 1e3], [0.30, 0.31, 0.29, 0.30, 0.30]),
        (rt2, [1e3, 0.5, 0.0], [0.20, 0.21, 0.19, 0.20, 0.20]),
        (rt16, [1e6, 9.0, 0.0], [0.05, 0.05, 0.05, 0.05, 0.05]),
        (ff, [5e4, 0.9, 5e2], [0.21, 0.26, 0.16, 0.23, 0.19]),
    ];
    for (spec, [rays, secs, bytes], errs) in table {
        let mut mine = Vec::new();
        for (s, e) in errs.iter().enumerate() {
            mine.push(rows.len());
            let cells = [
                s as f64,
                10.0 + s as f64,
                20.0 + s as f64,
                rays,
                secs,
                bytes,
                *e,
                secs * 1.01,
            ];
            rows.push(cells.map(|x| x.to_string()).to_vec());
        }
        configs.push(Config { rows: mine, spec });
    }
    let t = Results::new(columns, rows);
    let splits = vec![Split {
        label: "N = 4".into(),
        groups: vec![("duck".into(), configs)],
    }];
    let regimes = vec![("occ_rel_l2_mean".to_string(), "all receivers".to_string())];
    let v = surface::verdict(&t, &splits, &regimes, "test");
    println!("{v}");
    let line = v.lines().find(|l| l.contains("all receivers")).unwrap();
    let cells: Vec<&str> = line.split(" | ").collect();
    // Rays, time, bytes (the ray tracer holds no bytes: T = 16 fits), any.
    assert_eq!(cells[2], "ray_traced: duck~ — 0.200", "{line}");
    assert_eq!(cells[3], "ray_traced: duck~ — 0.200", "{line}");
    assert_eq!(
        cells[4].trim_end_matches(" |"),
        "ray_traced: duck — 0.050",
        "{line}"
    );
    assert!(cells[5].starts_with("ray_traced: duck — 0.050"), "{line}");
    // Two orders: one row per regime, each cell both orders' answers, labelled.
    let two: Vec<Split> = ["N = 4", "N = 6"]
        .map(|label| Split {
            label: label.into(),
            groups: splits[0].groups.clone(),
        })
        .into();
    let v2 = surface::verdict(&t, &two, &regimes, "test");
    let rows2: Vec<&str> = v2.lines().filter(|l| l.contains("all receivers")).collect();
    assert_eq!(rows2.len(), 1, "{v2}");
    let want2 = "| N = 4, N = 6 | all receivers | **N = 4** ray_traced: duck~ — 0.200 **N = 6** ray_traced: duck~ — 0.200 |";
    assert!(rows2[0].starts_with(want2), "{v2}");
    let full = surface::tables(&t, &splits, &regimes, "test");
    println!("{full}");
    // s = √(5e-5), t_{0.975,4} = 2.776: ± 2.776·s/√5 = 0.009; the gap 0.010 ± 0.039.
    let h = 2.776 * 5e-5f64.sqrt() / 5f64.sqrt();
    let want = format!("ray tracing, T = 2 0.200 ± {h:.3}; full_field +0.010 ± 0.039 **tie**");
    let fine = "ray tracing, T = 16 0.050 ± 0.000; full_field +0.160 ± 0.047";
    assert!(full.contains(&want), "{full}\nwant {want}");
    assert!(full.contains(fine), "{full}\nwant {fine}");
}

/// The `budget` kind's discussion of a table holding the papers' extrapolation and the papers'
/// 16-shell full field at the same sampling (the claim as stated) reads only columns its rows
/// have: the plane's cached-frame columns are looked up only where the table has them (before,
/// `shscale run configs/experiments/budget_surface.toml` ended with "the report of kind budget
/// read column(s) \"cached_frame_seconds\" that the file does not have").
#[test]
fn the_budget_discussion_of_the_speed_claim_reads_only_the_budget_rows_columns() {
    use shscale_runner::records::to_cells;
    use shscale_runner::Kind;
    let row = |method: &str, rays: f64, seconds: f64| {
        let p = Params {
            method: method.into(),
            ..Params::default()
        };
        let r = super::spheres::Row {
            rays,
            frame_seconds: seconds,
            frame_seconds_lo: 0.9 * seconds,
            frame_seconds_hi: 1.1 * seconds,
            occ_rel_l2_mean: Some(0.1),
            ..Default::default()
        };
        let (mut h, mut c) = to_cells(&p).unwrap();
        let (rh, rc) = to_cells(&r).unwrap();
        h.extend(rh);
        c.extend(rc);
        (h, c)
    };
    let (h, a) = row("extrapolated", 1e5, 1e-3);
    let (_, b) = row("full_field", 1.6e6, 2e-2);
    let t = Results::new(h, vec![a, b]);
    let text = super::spheres::Budget::discussion(&t).unwrap();
    println!("{text}");
    assert!(text.contains("*The claim as stated*"), "{text}");
    assert!(text.contains("16× the rays"), "{text}");
    t.check_read("the test's discussion").unwrap();
}
