#[test]
fn tick_labels_keep_three_significant_digits() {
    for (x, want) in [
        (63095.734, "6.31e4"),
        (251.188, "251"),
        (0.0123456, "0.0123"),
        (1.0, "1"),
        (2.5, "2.5"),
        (-2.5, "-2.5"),
        (0.001234, "1.23e-3"),
        (1e-9, "1e-9"),
        (1e6, "1e6"),
        (0.0, "0"),
    ] {
        assert_eq!(super::significant(x, 3), want, "{x}");
    }
}

#[test]
fn plots_cap_their_series_and_say_so() {
    use std::collections::BTreeMap;
    let series: BTreeMap<String, Vec<(f64, f64)>> = (0..100)
        .map(|i| (format!("s{i:03}"), vec![(0.0, i as f64)]))
        .collect();
    let (kept, title) = super::capped(&series, "t");
    assert_eq!(kept.len(), super::MAX_SERIES);
    assert!(kept.contains_key("s000") && kept.contains_key("s099"));
    assert_eq!(title, "t (24 of 100 series shown, evenly spaced)");
    let few: BTreeMap<String, Vec<(f64, f64)>> = series.into_iter().take(24).collect();
    let (kept, title) = super::capped(&few, "t");
    assert_eq!((kept.len(), title.as_str()), (24, "t"));
    // 3 × 5000 points: 1 in 4 drawn per series (x order), first and last kept.
    let many: BTreeMap<String, Vec<(f64, f64)>> = (0..3)
        .map(|s| {
            let pts = (0..5000).rev().map(|i| (i as f64, s as f64)).collect();
            (format!("s{s}"), pts)
        })
        .collect();
    let (kept, title) = super::capped(&many, "t");
    let drawn: usize = kept.values().map(Vec::len).sum();
    assert!(drawn <= super::MAX_POINTS, "{drawn}");
    assert_eq!(title, format!("t (1 point in 4 drawn: {drawn} of 15000)"));
    for pts in kept.values() {
        assert_eq!(
            (pts[0].0, pts[pts.len() - 1].0, pts[1].0),
            (0.0, 4999.0, 4.0)
        );
    }
}

#[test]
fn extreme_values_and_hostile_names_never_hang_or_escape() {
    use std::collections::BTreeMap;
    let d = std::env::temp_dir().join(format!("shscale-plots-extreme-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let labels = super::Labels {
        title: "t",
        x: "x",
        y: "y",
    };
    // ±1e308 once spun plotters' tick search forever: left out, the rest drawn.
    for pts in [
        vec![(0.0, 1e308), (1.0, -1e308), (2.0, 1.0), (3.0, 2.0)],
        vec![(0.0, 1e300), (1.0, -1e300)],
        vec![(1e300, 1.0), (1e300, 1.0)],
        vec![(0.0, 1.0), (1.0, 1.0 + 1e-15)],
        vec![(5.0, 3.0)],
    ] {
        let series: BTreeMap<String, Vec<(f64, f64)>> = [("s".to_string(), pts.clone())].into();
        let files = super::write_both(&d, "p", &labels, &series, false, &pts).unwrap();
        assert_eq!(files.len(), 2, "{pts:?}");
    }
    let only_huge: BTreeMap<String, Vec<(f64, f64)>> =
        [("s".to_string(), vec![(0.0, 1e308), (1.0, f64::MAX)])].into();
    let e = super::write_both(&d, "p", &labels, &only_huge, false, &[]).unwrap_err();
    assert!(e.to_string().contains("no finite data to plot"), "{e}");
    // A stem is a plain name; a column name is made one.
    let ok: BTreeMap<String, Vec<(f64, f64)>> = [("s".to_string(), vec![(0.0, 1.0)])].into();
    for bad in ["../up", "a/b", "", ".hidden", ".."] {
        let e = super::write_both(&d, bad, &labels, &ok, false, &[]).unwrap_err();
        assert!(
            e.to_string().contains("not a plain file name"),
            "{bad}: {e}"
        );
    }
    assert_eq!(super::stem_part("../../x y"), ".._.._x_y");
    assert!(!d.parent().unwrap().join("up.png").exists());
    // No temporary left behind by a refusal.
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&d).ok();
}

use super::y_range;

/// Data spanning two decades or more go on a log axis; negative, zero or narrow data do not.
#[test]
fn log_axis_when_data_span_decades() {
    assert!(super::log_axis(&[1e-6, 3e-4, 1e-2]));
    assert!(super::log_axis(&[1.0, 100.0]));
    assert!(!super::log_axis(&[1.0, 99.0]));
    assert!(!super::log_axis(&[0.0, 1e-6, 1.0]));
    assert!(!super::log_axis(&[-1.0, 1e3]));
    assert!(!super::log_axis(&[]));
    assert!(super::log_axis(&[f64::NAN, 1e-3, 1.0]));
}

/// One value (or values equal to the last digits) gets a drawable range around it: ±10 % on
/// a linear y axis — a single error of 0.068 stays above zero —, ±0.5 otherwise (half a
/// decade on a log axis, a unit around an integer parameter); 0 gets ±0.5; a real span is
/// kept.
#[test]
fn a_single_value_gets_a_range_around_it() {
    for (v, relative, want) in [
        (0.068, true, (0.0612, 0.0748)),
        (-2.0, true, (-2.2, -1.8)),
        (0.0, true, (-0.5, 0.5)),
        (-0.4, false, (-0.9, 0.1)),
        (4.0, false, (3.5, 4.5)),
        (1e12, true, (0.9e12, 1.1e12)),
    ] {
        let (lo, hi) = super::degenerate_span(v, v, relative);
        println!("{v} (relative {relative}) → [{lo}, {hi}]");
        assert!((lo - want.0).abs() <= 1e-12 * want.0.abs().max(1.0), "{lo}");
        assert!((hi - want.1).abs() <= 1e-12 * want.1.abs().max(1.0), "{hi}");
    }
    assert_eq!(super::degenerate_span(0.1, 0.2, true), (0.1, 0.2));
    let (lo, hi) = super::degenerate_span(0.068, 0.068 * (1.0 + 1e-12), true);
    assert!(lo > 0.0 && hi > lo, "{lo} {hi}");
}

/// A series reaching −0.76 (an element of M_k, Fig. 3) stays inside the drawn range; data
/// that are non-negative keep their axis at or above 0.
#[test]
fn negative_values_stay_inside_the_drawn_range() {
    for (y0, y1) in [
        (-0.76, 1.09),
        (-3.0, -1.0),
        (0.0, 2.0),
        (0.2, 0.3),
        (1e-9, 1e-8),
    ] {
        let (lo, hi) = y_range(y0, y1);
        println!("data [{y0}, {y1}] → drawn [{lo}, {hi}]");
        assert!(
            lo < y0 || (lo == 0.0 && y0 == 0.0),
            "{y0} below the drawn {lo}"
        );
        assert!(hi > y1, "{y1} above the drawn {hi}");
        if y0 >= 0.0 {
            assert!(lo >= 0.0, "non-negative data drawn from {lo}");
        }
    }
}
