use super::*;

#[test]
fn sweep_list_error_names_the_element_line() {
    let text =
        "experiment = \"probe\"\norder = 4\n[sweep]\nalpha_deg = [\n  10,\n  20,\n  10,\n]\n";
    let e = expand("c.toml", text, &Overrides::default())
        .err()
        .expect("duplicate must be refused");
    assert_eq!(
        e.place,
        Place::Line {
            file: "c.toml".into(),
            line: 7
        },
        "{e}"
    );
    assert!(e.to_string().contains("sweep.alpha_deg"), "{e}");
}

#[test]
fn zip_and_product() {
    let text = "experiment = \"x\"\n[sweep]\na = [1, 2]\n[sweep.zip]\nb = [1, 2, 3]\nc = [\"x\", \"y\", \"z\"]\n";
    let ex = expand("c.toml", text, &Overrides::default()).unwrap();
    assert_eq!(ex.len(), 6);
    assert_eq!(ex.axes, vec!["a", "b", "c"]);
    let pairs: Vec<(i64, String)> = ex
        .combinations()
        .map(Result::unwrap)
        .map(|c| {
            (
                c.table["b"].as_integer().unwrap(),
                c.table["c"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert!(pairs.contains(&(3, "z".into())) && !pairs.contains(&(1, "y".into())));
    let bad = "experiment = \"x\"\n[sweep.zip]\nb = [1, 2, 3]\nc = [1, 2]\n";
    let e = expand("c.toml", bad, &Overrides::default()).err().unwrap();
    assert!(e.message.contains("equal length"), "{e}");
}

#[test]
fn sweep_blocks_unite_their_products() {
    let text = "experiment = \"x\"\nk = 1\n[[sweep]]\ntau = [\"cone\"]\nk = [0.5, 2.0]\nalpha_deg = [20, 45]\n[[sweep]]\ntau = [\"midrange\"]\nk = [\n  -0.5,\n  0.5,\n]\n";
    let ex = expand("c.toml", text, &Overrides::default()).unwrap();
    assert_eq!(ex.len(), 4 + 2);
    let taus: Vec<String> = ex
        .combinations()
        .map(Result::unwrap)
        .map(|c| c.table["tau"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(
        taus,
        ["cone", "cone", "cone", "cone", "midrange", "midrange"]
    );
    assert!(ex.combination(5).unwrap().table.get("alpha_deg").is_none());
    // The second block's second k sits on line 11 of the file.
    assert_eq!(
        ex.place_of(&ex.combination(5).unwrap(), &parse_path("k")),
        Place::Line {
            file: "c.toml".into(),
            line: 11
        }
    );
    assert_eq!(ex.axes, ["alpha_deg", "k", "tau"]);
    // --sweep adds the axis to every block.
    let ov = Overrides {
        sweep: vec!["order=2,4".into()],
        ..Overrides::default()
    };
    assert_eq!(expand("c.toml", text, &ov).unwrap().len(), 12);
    // A duplicate inside a block is named at its element.
    let dup = "experiment = \"x\"\n[[sweep]]\nk = [1]\n[[sweep]]\nk = [2,\n 2]\n";
    let Err(e) = expand("c.toml", dup, &Overrides::default()) else {
        panic!("a duplicate in a block must be refused")
    };
    assert!(e.to_string().contains("c.toml:6"), "{e}");
    assert!(e.to_string().contains("sweep[1].k"), "{e}");
}

#[test]
fn flag_keys_are_dotted_names_with_indices_and_nothing_else() {
    let ok = |k: &str| parse_flag_key(k).unwrap_or_else(|e| panic!("{k}: {e}"));
    assert_eq!(ok("order"), vec![Seg::Key("order".into())]);
    assert_eq!(
        ok("occluder[1].radius"),
        vec![
            Seg::Key("occluder".into()),
            Seg::Index(1),
            Seg::Key("radius".into())
        ]
    );
    assert_eq!(ok("a[0][2]").len(), 3);
    assert_eq!(ok("k_count"), parse_path("k_count"));
    for (bad, why) in [
        ("order[abc]", "[abc] is not a list index"),
        (".order", "\"\" is not a name"),
        ("order.", "\"\" is not a name"),
        ("a..b", "\"\" is not a name"),
        ("", "\"\" is not a name"),
        ("1st", "\"1st\" is not a name"),
        ("a b", "\"a b\" is not a name"),
        ("a/../b", "is not a name"),
        ("order[1", "does not end with ']'"),
        ("a[", "does not end with ']'"),
        ("a[1]b", "does not end with ']'"),
        ("order[-1]", "[-1] is not a list index"),
        ("order[]", "[] is not a list index"),
        ("order[99999999999]", "is not a list index"),
        ("radii[0]x", "does not end with ']'"),
    ] {
        let e = parse_flag_key(bad).expect_err(bad);
        assert!(e.contains(why), "{bad}: {e}");
    }
    // Depth and length are bounded before any table is built (30,000 levels once
    // overflowed the stack).
    let deep = vec!["a"; 17].join(".");
    assert!(parse_flag_key(&deep)
        .unwrap_err()
        .contains("more than 16 segments"));
    assert_eq!(ok(&vec!["a"; 16].join(".")).len(), 16);
    let huge = vec!["a"; 30_000].join(".");
    assert!(parse_flag_key(&huge)
        .unwrap_err()
        .contains("more than the limit 256"));
    let ov = Overrides {
        set: vec![format!("{huge}=1")],
        ..Overrides::default()
    };
    let e = expand("c.toml", "experiment = \"x\"\n", &ov).err().unwrap();
    assert!(e.to_string().starts_with("--set a.a.a"), "{e}");
    assert!(
        e.to_string().len() < 400,
        "the message holds the whole key: {e}"
    );
    let ov = Overrides {
        sweep: vec!["order[abc]=1,2".into()],
        ..Overrides::default()
    };
    let e = expand("c.toml", "experiment = \"x\"\n", &ov).err().unwrap();
    assert!(e.to_string().contains("--sweep order[abc]=1,2"), "{e}");
}

#[test]
fn overrides_set_and_sweep() {
    let text = "experiment = \"x\"\norder = 4\n";
    let ov = Overrides {
        set: vec![
            "order=6".into(),
            "light.sun=2.5".into(),
            "mesh=bunny".into(),
        ],
        sweep: vec!["radii=[1,2],[3]".into()],
        name: Some("n1".into()),
    };
    let ex = expand("c.toml", text, &ov).unwrap();
    assert_eq!(ex.runner.name.as_deref(), Some("n1"));
    assert_eq!(ex.len(), 2);
    let t = &ex.combination(0).unwrap().table;
    assert_eq!(t["order"].as_integer(), Some(6));
    assert_eq!(t["mesh"].as_str(), Some("bunny"));
    assert_eq!(t["light"]["sun"].as_float(), Some(2.5));
    assert_eq!(t["radii"].as_array().unwrap().len(), 2);
    // `--set key=v1,v2` is the list [v1, v2], as --sweep writes values.
    let ov = Overrides {
        set: vec!["radii=1.3,2".into(), "label=a b".into()],
        ..Overrides::default()
    };
    let listed = expand("c.toml", text, &ov).unwrap();
    let t = &listed.combination(0).unwrap().table;
    assert_eq!(t["radii"].as_array().unwrap().len(), 2);
    assert_eq!(t["radii"][0].as_float(), Some(1.3));
    assert_eq!(t["label"].as_str(), Some("a b"));
    assert_eq!(
        ex.place_of(&ex.combination(1).unwrap(), &parse_path("radii")),
        Place::Flag("--sweep radii=[1,2],[3]".into())
    );
    assert_eq!(
        ex.place_of(&ex.combination(1).unwrap(), &parse_path("order")),
        Place::Flag("--set order=6".into())
    );
}

#[test]
fn an_error_about_a_key_a_flag_set_part_of_names_the_flag() {
    let text = "experiment = \"x\"\nradii = [1.0, 2.0]\norder = 2\n";
    let ov = Overrides {
        set: vec!["radii[0]=nan".into()],
        ..Overrides::default()
    };
    let ex = expand("c.toml", text, &ov).unwrap();
    let c = ex.combination(0).unwrap();
    assert_eq!(
        ex.place_of(&c, &parse_path("radii")),
        Place::Flag("--set radii[0]=nan".into())
    );
    assert_eq!(
        ex.place_of(&c, &parse_path("order")),
        Place::Line {
            file: "c.toml".into(),
            line: 3
        }
    );
}

#[test]
fn array_of_tables_line() {
    let text =
        "experiment = \"x\"\n[[occluder]]\nmesh = \"a\"\n[[occluder]]\nmesh = \"b\"\nradius = -1\n";
    let ex = expand("s.toml", text, &Overrides::default()).unwrap();
    let p = parse_path("occluder[1].radius");
    assert_eq!(
        ex.place_of(&ex.combination(0).unwrap(), &p),
        Place::Line {
            file: "s.toml".into(),
            line: 6
        }
    );
    assert_eq!(path_name(&p), "occluder[1].radius");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]
    /// Any string as a `--set` key: refused with a reason, or a path that writes back as the
    /// same key; never a panic.
    #[test]
    fn flag_keys_accept_exactly_what_they_write_back(key in "[a-z_.\\[\\]0-9 -]{0,40}") {
        if let Ok(path) = parse_flag_key(&key) {
            proptest::prop_assert_eq!(path_name(&path), key);
            proptest::prop_assert!(path.len() <= MAX_KEY_DEPTH);
        }
    }

    /// Arbitrary override strings through the whole expansion: a plan or an error naming the
    /// flag, never a panic.
    #[test]
    fn overrides_never_panic(set in "\\PC{0,30}", sweep in "\\PC{0,30}") {
        let ov = Overrides {
            set: vec![set.clone()],
            sweep: vec![sweep],
            name: None,
        };
        if let Err(e) = expand("c.toml", "experiment = \"x\"\norder = 2\n[sweep]\nk = [1, 2]\n", &ov) {
            proptest::prop_assert!(!e.to_string().is_empty());
        }
    }

    /// Sweep tables of arbitrary small lists: the combination count is the product (or the
    /// duplicate/empty list is refused), never a panic.
    #[test]
    fn sweep_tables_expand_to_their_product(
        a in proptest::collection::vec(0i64..5, 0..5),
        b in proptest::collection::vec(0i64..5, 0..5),
    ) {
        let list = |v: &[i64]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ");
        let text = format!("experiment = \"x\"\n[sweep]\na = [{}]\nb = [{}]\n", list(&a), list(&b));
        let distinct = |v: &[i64]| v.iter().collect::<std::collections::BTreeSet<_>>().len() == v.len();
        let valid = distinct(&a) && distinct(&b) && !a.is_empty() && !b.is_empty();
        match expand("c.toml", &text, &Overrides::default()) {
            Ok(ex) => {
                proptest::prop_assert!(valid);
                proptest::prop_assert_eq!(ex.len(), a.len() * b.len());
            }
            Err(e) => {
                proptest::prop_assert!(!valid, "{}", e);
            }
        }
    }
}
