use super::sphere_set::MAX_SPHERE_ORDER;
use super::*;
use shscale_field::bsv::RadialRule;

fn keys(method: &str) -> Keys<'_> {
    Keys {
        method,
        parts: 4,
        layout: "latlong:12x20",
        hemisphere_res: 32,
        shells: 16,
        shell_max: 8.0,
        shell_spacing: "uniform",
        field_interp: "trilinear",
        rt_res: 8,
        alpha_deg: 45.0,
        alpha_mode: Some("fixed"),
        plausibility: "none",
        sampling_radius: 1.0,
        radial: "uniform",
        radial_delta: 0.1,
        radial_tau: Some(0.5),
        radial_max: Some(2.0),
        sphere_combine: Some("product"),
        sphere_fit: Some("area"),
        sphere_order: Some(0),
        part_combine: Some("product"),
        k_count: Some(40),
    }
}

#[test]
fn every_name_parses_to_its_method_and_back() {
    for m in Method::ALL {
        assert_eq!(Method::parse(m.name()), Ok(m));
        assert_eq!(Method::parse_cli(m.name()), Ok(m));
        assert_eq!(m.to_string(), m.name());
    }
    assert_eq!(
        Method::parse_cli("raytraced-full"),
        Ok(Method::FullFrequency)
    );
    assert_eq!(Method::parse_cli("full-field"), Ok(Method::FullField));
    let e = Method::parse("raytraced").unwrap_err();
    assert!(e.contains("\"ray_traced\""), "{e}");
    let e = Method::parse_among("full_frequency", &Method::BUDGETED).unwrap_err();
    assert!(
        e.contains("full_frequency") && !e.contains("\"full_frequency\","),
        "{e}"
    );
}

#[test]
fn a_key_the_method_does_not_read_is_refused_unless_at_its_default() {
    let d = keys("extrapolated");
    // At their defaults, every method's unread keys pass.
    for m in Method::BUDGETED {
        let k = keys(m.name());
        assert_eq!(Spec::parse(&k, &d, 1024).unwrap().method(), m);
    }
    // sphere_combine under extrapolation, α under ray tracing, δ under uniform radii.
    type Set = fn(&mut Keys);
    let cases: [(&str, Set); 7] = [
        ("sphere_combine", |k| k.sphere_combine = Some("quadrature")),
        ("part_combine", |k| k.part_combine = Some("shexp")),
        ("sphere_order", |k| k.sphere_order = Some(8)),
        // The internal order is read by the products only, not by the quadrature.
        ("sphere_order", |k| {
            k.method = "sphere_set";
            k.sphere_combine = Some("quadrature");
            k.sphere_order = Some(8)
        }),
        ("alpha_deg", |k| {
            k.method = "ray_traced";
            k.alpha_deg = 30.0
        }),
        ("radial_delta", |k| k.radial_delta = 0.2),
        ("shells", |k| {
            k.method = "sub_volumes";
            k.shells = 4
        }),
    ];
    for (key, set) in cases {
        let mut k = keys("extrapolated");
        set(&mut k);
        let e = Spec::parse(&k, &d, 1024).unwrap_err();
        println!("{}: {}", e.key, e.message);
        assert_eq!(e.key, key);
        assert!(
            e.message.contains(&format!("method \"{}\"", k.method)),
            "{}",
            e.message
        );
    }
    // The internal order: read by products, within 1..=MAX_SPHERE_ORDER (0: the run's N).
    let mut k = keys("sphere_set");
    k.sphere_order = Some(12);
    assert!(matches!(
        Spec::parse(&k, &d, 1024).unwrap(),
        Spec::SphereSet(SetSpec {
            internal_order: 12,
            ..
        })
    ));
    k.sphere_order = Some(MAX_SPHERE_ORDER + 1);
    assert_eq!(Spec::parse(&k, &d, 1024).unwrap_err().key, "sphere_order");
    // The fit by name: both names parse, others are refused by key, and another method
    // may not be given one.
    for &name in SphereFit::NAMES {
        let mut k = keys("sphere_set");
        k.sphere_fit = Some(name);
        let Spec::SphereSet(SetSpec { fit, .. }) = Spec::parse(&k, &d, 1024).unwrap() else {
            panic!("a sphere set")
        };
        assert_eq!(fit.name(), name);
    }
    let mut k = keys("sphere_set");
    k.sphere_fit = Some("medial");
    assert_eq!(Spec::parse(&k, &d, 1024).unwrap_err().key, "sphere_fit");
    let mut k = keys("extrapolated");
    k.sphere_fit = Some("inscribed");
    assert_eq!(Spec::parse(&k, &d, 1024).unwrap_err().key, "sphere_fit");
    // The combinations by name: every sphere_combine name parses, part_combine takes two.
    for &name in Combine::NAMES {
        let mut k = keys("sphere_set");
        k.sphere_combine = Some(name);
        let Spec::SphereSet(SetSpec { combine, .. }) = Spec::parse(&k, &d, 1024).unwrap() else {
            panic!("{name}")
        };
        assert_eq!(Combine::from_name(name), Some(combine));
        assert_eq!(combine.name(), name);
    }
    let mut k = keys("sub_volumes");
    k.part_combine = Some("shexp");
    assert!(matches!(
        Spec::parse(&k, &d, 1024).unwrap(),
        Spec::SubVolumes(SubVolumeSpec {
            combine: Combine::Shexp,
            ..
        })
    ));
    k.part_combine = Some("union");
    let e = Spec::parse(&k, &d, 1024).unwrap_err();
    assert!(
        e.key == "part_combine" && e.message.contains("union"),
        "{e:?}"
    );
    // The combinations' domains at the run's order, at their edges.
    let max = shscale_field::shexp_ol::MAX_SHEXP_ORDER;
    let mut k = keys("sphere_set");
    k.sphere_order = Some(6);
    let s6 = Spec::parse(&k, &d, 1024).unwrap();
    assert!(s6.check_order(6).is_ok() && s6.check_order(4).is_ok());
    assert_eq!(s6.check_order(7).unwrap_err().key, "sphere_order");
    k.sphere_order = Some(0);
    k.sphere_combine = Some("shexp");
    let sx = Spec::parse(&k, &d, 1024).unwrap();
    assert!(sx.check_order(max).is_ok());
    assert_eq!(sx.check_order(max + 1).unwrap_err().key, "sphere_combine");
    let mut k = keys("sub_volumes");
    k.part_combine = Some("shexp");
    let sl = Spec::parse(&k, &d, 1024).unwrap();
    assert!(sl.check_order(max).is_ok());
    assert_eq!(sl.check_order(max + 1).unwrap_err().key, "part_combine");
    k.plausibility = "clamp";
    let e = Spec::parse(&k, &d, 1024)
        .unwrap()
        .check_order(4)
        .unwrap_err();
    assert!(
        e.key == "plausibility" && e.message.contains("logs"),
        "{e:?}"
    );
    // Read keys off their defaults are fine: δ with clearance, α with a fixed α.
    let mut k = keys("extrapolated");
    k.radial = "clearance";
    k.radial_delta = 0.2;
    k.alpha_deg = 30.0;
    let s = Spec::parse(&k, &d, 1024).unwrap();
    assert_eq!(
        s.extrapolation().unwrap().radial,
        RadialRule::Clearance { delta: 0.2 }
    );
    // α under α by distance is not read.
    k.alpha_mode = Some("fit");
    assert_eq!(Spec::parse(&k, &d, 1024).unwrap_err().key, "alpha_deg");
}

#[test]
fn domains_are_checked_at_their_edges_and_named() {
    let d = keys("extrapolated");
    let mut k = keys("extrapolated");
    k.radial = "clearance";
    for (delta, ok) in [
        (0.0, true),
        (10.0, true),
        (-1e-9, false),
        (10.0 + 1e-9, false),
    ] {
        k.radial_delta = delta;
        let r = Spec::parse(&k, &d, 1024);
        assert_eq!(r.is_ok(), ok, "δ = {delta}");
        if let Err(e) = r {
            assert_eq!(e.key, "radial_delta");
        }
    }
    // Not a number, or infinite: refused under the rule that reads it, and under any other
    // (not its default).
    for v in [f64::NAN, f64::INFINITY, -5.0] {
        let mut k = keys("extrapolated");
        k.radial_delta = v;
        assert_eq!(
            Spec::parse(&k, &d, 1024).unwrap_err().key,
            "radial_delta",
            "{v}"
        );
        k.radial = "clearance";
        assert_eq!(
            Spec::parse(&k, &d, 1024).unwrap_err().key,
            "radial_delta",
            "{v}"
        );
    }
    let mut k = keys("extrapolated");
    k.radial = "occlusion";
    for (tau, max, bad) in [
        (0.0, 1.0, None),
        (1.0, 2.0, Some("radial_tau")),
        (0.5, 10.5, Some("radial_max")),
    ] {
        k.radial_tau = Some(tau);
        k.radial_max = Some(max);
        assert_eq!(
            Spec::parse(&k, &d, 1024).err().map(|e| e.key),
            bad.map(String::from)
        );
    }
    // A kind without τ and the ceiling has no occlusion rule.
    k.radial_tau = None;
    k.radial_max = None;
    assert_eq!(Spec::parse(&k, &d, 1024).unwrap_err().key, "radial");
    let mut k = keys("ray_traced");
    k.rt_res = 256;
    assert_eq!(Spec::parse(&k, &d, 255).unwrap_err().key, "rt_res");
    assert!(Spec::parse(&k, &d, 256).is_ok());
    let mut k = keys("sphere_set");
    k.parts = 0;
    assert_eq!(Spec::parse(&k, &d, 255).unwrap_err().key, "parts");
    let k = keys("full_frequency");
    assert_eq!(Spec::parse(&k, &d, 255).unwrap_err().key, "method");
}

#[test]
fn rays_and_bytes_follow_the_formulas() {
    use super::sub_volumes::LOG_SAMPLE_SECONDS;
    use super::SHEXP_SECONDS;
    let d = keys("extrapolated");
    let spec = |k: &Keys| Spec::parse(k, &d, 1024).unwrap();
    // 12 × 20 samples × 32² rays; 16 shells of them; 4T² per receiver.
    let ex = spec(&keys("extrapolated"));
    assert_eq!(ex.rays(1.0, 100.0), 240.0 * 1024.0);
    assert_eq!(
        spec(&keys("full_field")).rays(2.0, 100.0),
        2.0 * 16.0 * 240.0 * 1024.0
    );
    assert_eq!(
        spec(&keys("ray_traced")).rays(1.0, 100.0),
        100.0 * 4.0 * 64.0
    );
    assert_eq!(spec(&keys("sphere_set")).rays(1.0, 100.0), 0.0);
    let mut q = keys("sphere_set");
    q.sphere_combine = Some("quadrature");
    assert_eq!(spec(&q).rays(1.0, 10.0), 10.0 * 2.0 * 64.0 * 64.0);
    let mut o = keys("extrapolated");
    o.radial = "occlusion";
    assert_eq!(spec(&o).rays(1.0, 1.0), 8.0 * 240.0 * 1024.0);
    // N = 3: 9 doubles per sample, 40 tables of 81 doubles.
    assert_eq!(ex.memory_bytes(3, 1.0, 0), 240.0 * 72.0 + 40.0 * 648.0);
    assert_eq!(
        spec(&keys("sub_volumes")).memory_bytes(3, 1.0, 0),
        4.0 * (240.0 * 72.0 + 40.0 * 648.0)
    );
    assert_eq!(spec(&keys("ray_traced")).memory_bytes(3, 5.0, 40), 0.0);
    assert_eq!(
        spec(&keys("sphere_set")).memory_bytes(3, 2.0, 40),
        2.0 * 4.0 * 32.0
    );
    // Time: rays at the rate; sphere sets by products add SPHERE_SECONDS per receiver and
    // sphere, by quadrature their rays are priced per direction and sphere test instead.
    let rate = 1e7;
    assert_eq!(ex.seconds(4, 1e7, 100.0, rate), 1.0);
    assert_eq!(ex.seconds(4, 0.0, 100.0, rate), 0.0);
    let prod = spec(&keys("sphere_set"));
    let want = 100.0 * 4.0 * SPHERE_SECONDS;
    assert!((prod.seconds(4, 0.0, 100.0, rate) - want).abs() < 1e-18);
    // At an internal order M the product's work scales as (M/4)⁵; at M ≤ 4 as the plain
    // chain; the run's own order counts the same way (the chain at N = 8 is 32× N = 4's).
    let mut k8 = keys("sphere_set");
    k8.sphere_order = Some(8);
    let m8 = spec(&k8).seconds(4, 0.0, 100.0, rate);
    assert!((m8 - 32.0 * want).abs() < 1e-15, "{m8}");
    k8.sphere_order = Some(3);
    assert!((spec(&k8).seconds(3, 0.0, 100.0, rate) - want).abs() < 1e-18);
    let n8 = prod.seconds(8, 0.0, 100.0, rate);
    assert!((n8 - 32.0 * want).abs() < 1e-15, "{n8}");
    let quad = spec(&q);
    let rays = quad.rays(1.0, 10.0);
    let want = rays * (SPHERE_DIRECTION_SECONDS + 4.0 * SPHERE_TEST_SECONDS);
    assert!((quad.seconds(4, rays, 10.0, rate) - want).abs() < 1e-15);
    // Sub-volumes in log space add each sample's log, (N/4)⁶, and the exponential.
    let mut kl = keys("sub_volumes");
    kl.part_combine = Some("shexp");
    let logs = spec(&kl).seconds(8, 0.0, 100.0, rate);
    let want = 4.0 * 240.0 * LOG_SAMPLE_SECONDS * 64.0 + 100.0 * SHEXP_SECONDS * 32.0;
    assert!((logs - want).abs() < 1e-12 * want, "{logs} vs {want}");
}

/// The unread-key rule compares values, not their cells: a number equal to its default by value
/// (`-0` against `0`, which print differently) passes under a method that does not read it; one
/// differing in the last bit is refused naming the key; an integer is never equal to a real.
#[test]
fn the_unread_key_rule_compares_values_by_value() {
    assert_eq!(KeyValue::Real(0.0), KeyValue::Real(-0.0));
    assert_ne!(
        KeyValue::Real(0.0).to_string(),
        KeyValue::Real(-0.0).to_string()
    );
    assert_ne!(KeyValue::Int(8), KeyValue::Real(8.0));
    assert_ne!(KeyValue::Text("product"), KeyValue::Text("Product"));
    let mut d = keys("ray_traced");
    d.radial_delta = 0.0;
    let mut k = keys("ray_traced");
    k.radial_delta = -0.0;
    assert!(Spec::parse(&k, &d, 1024).is_ok());
    k.radial_delta = f64::from_bits(1);
    let e = Spec::parse(&k, &d, 1024).unwrap_err();
    assert_eq!(e.key, "radial_delta", "{}", e.message);
    println!("{}", e.message);
}
