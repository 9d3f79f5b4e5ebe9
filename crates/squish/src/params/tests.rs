use super::*;

fn levels() -> [(&'static str, &'static [ParamInfo]); 3] {
    [("object", ObjectParams::schema()), ("pair", PairParams::schema()), ("articulation", ArticulationParams::schema())]
}

#[test]
fn keys_are_unique_identifiers_with_a_meaning_and_old_names_are_not_keys() {
    for (level, schema) in levels() {
        let mut keys: Vec<&str> = schema.iter().map(|i| i.key).collect();
        keys.sort_unstable();
        let count = keys.len();
        keys.dedup();
        assert_eq!(keys.len(), count, "{level}: duplicate keys");
        for info in schema {
            assert!(
                info.key.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'),
                "{level}.{}: a key is a Python identifier",
                info.key
            );
            assert!(!info.summary.is_empty() && !info.summary.contains('\n'), "{level}.{}", info.key);
            for old in info.renamed_from {
                assert!(!keys.contains(old), "{level}: former name {old} is a key again");
            }
            assert!(!(info.keyframable && matches!(info.kind, ParamKind::PerVertex | ParamKind::Text)));
            assert_eq!(info.optional, !info.word.is_empty() && info.optional);
        }
    }
}

#[test]
fn defaults_are_valid_and_every_key_round_trips_through_get_and_set() {
    fn check<P: Params + PartialEq>() {
        let defaults = P::default();
        defaults.validate().expect("defaults are valid");
        for info in P::schema() {
            let value = defaults.get(info.key).expect("every schema key has a value");
            info.check(&value).expect("the default is in range");
            let mut p = P::default();
            p.set(info.key, &value).expect("setting the default back works");
            assert_eq!(p, defaults, "{}", info.key);
        }
        assert!(defaults.get("no_such_key").is_none());
    }
    check::<ObjectParams>();
    check::<PairParams>();
    check::<ArticulationParams>();
}

#[test]
fn the_thesis_defaults() {
    let o = ObjectParams::default();
    assert_eq!((o.stiffness, o.bulge, o.extent), (1.0, 1.0, None));
    assert_eq!(o.profile(), [1.0 / 3.0, 5.0 / 6.0, 11.0 / 12.0]);
    assert_eq!((o.anisotropy_exponent, o.anisotropy_offset, o.heat_time_factor), (2.0, 0.0, 10.0));
    let p = PairParams::default();
    assert_eq!((p.contact_tau, p.direction, p.safeguard_angle), (0.0, None, 80.0));
    assert_eq!((p.contact_method, p.mapping), (ContactMethod::Geometric, MappingMethod::UniqueDirection));
    let a = ArticulationParams::default();
    // τ = −1 at articulations: the thesis' skinning figures (7.7, 7.8, 7.13).
    assert_eq!((a.contact_tau, a.stiffness, a.safeguard_angle), (-1.0, [1.0, 1.0], 80.0));
}

#[test]
fn set_checks_kind_and_range_and_names_the_key_the_value_and_the_default() {
    let mut p = ObjectParams::default();
    let err = p.set("stiffness", &ParamValue::Number(-1.0)).unwrap_err();
    assert_eq!(err.to_string(), "stiffness = -1: must be > 0 (k, default 1)");
    let err = p.set("stiffness", &ParamValue::Number(f64::NAN)).unwrap_err().with_prefix("a");
    assert!(err.to_string().starts_with("a.stiffness = NaN: must be > 0"), "{err}");
    let err = p.set("rigid", &ParamValue::Word("maybe".into())).unwrap_err();
    assert!(err.to_string().contains("expected true or false"), "{err}");
    let err = p.set("direction_field", &ParamValue::Word("parallel_transprot".into())).unwrap_err();
    assert!(err.to_string().contains("did you mean \"parallel_transport\""), "{err}");
    let err = p.set("stifness", &ParamValue::Number(2.0)).unwrap_err();
    assert!(err.to_string().contains("did you mean \"stiffness\""), "{err}");
    let err = p.set("anisotropic_bulge", &ParamValue::Bool(true)).unwrap_err();
    assert!(err.to_string().contains("renamed (did you mean \"anisotropy\""), "{err}");
    let err = p.set("domain_factor", &ParamValue::Number(0.5)).unwrap_err();
    assert!(err.to_string().contains("≥ 1 (inf allowed)"), "{err}");
    p.set("domain_factor", &ParamValue::Number(f64::INFINITY)).expect("inf is allowed");
    p.set("extent", &ParamValue::Word("auto".into())).expect("auto");
    assert_eq!(p.extent, None);
    p.set("extent", &ParamValue::Number(0.4)).expect("a number");
    assert_eq!(p.extent, Some(0.4));
    // The struct is unchanged by a failed set.
    let before = p.clone();
    assert!(p.set("bulge", &ParamValue::Number(-2.0)).is_err());
    assert_eq!(p, before);
}

#[test]
fn text_is_parsed_by_kind() {
    let mut pair = PairParams::default();
    pair.set_text("direction", "0,0,2").expect("vector");
    assert_eq!(pair.direction, Some(glam::DVec3::new(0.0, 0.0, 2.0)));
    assert!(pair.set_text("direction", "0,0,0").unwrap_err().to_string().contains("non-zero"));
    pair.set_text("contact_method", "ball").expect("word");
    assert!(pair.validate().unwrap_err().to_string().contains("needs ball_radius"));
    pair.set_text("ball_radius", "0.3").expect("number");
    assert_eq!(pair.ball(), Some(0.3));
    pair.validate().expect("method A with its radius");
    let mut a = ArticulationParams::default();
    a.set_text("stiffness", "2").expect("one number for both");
    assert_eq!(a.stiffness, [2.0, 2.0]);
    a.set_text("stiffness", "1,3").expect("two numbers");
    assert_eq!(a.stiffness, [1.0, 3.0]);
    a.set_text("direction", "joints").expect("the word");
    assert!(a.set_text("stiffness", "soft").unwrap_err().to_string().starts_with("stiffness: cannot read \"soft\""));
    let mut o = ObjectParams::default();
    o.set_text("preserve_volume", "auto").expect("auto");
    o.set_text("preserve_volume", "off").expect("off");
    assert_eq!(o.preserve_volume, Some(false));
}

#[test]
fn serde_writes_and_reads_the_schema_keys() {
    let mut o = ObjectParams::default().with_extent(0.4).with_bulge(1.5);
    o.domain_factor = f64::INFINITY;
    o.direction_field = DirectionFieldMethod::ParallelTransport;
    let json = serde_json::to_value(&o).expect("serializes");
    assert_eq!(json["extent"], serde_json::json!(0.4));
    assert_eq!(json["preserve_volume"], serde_json::json!("auto"));
    assert_eq!(json["domain_factor"], serde_json::json!("inf"));
    assert_eq!(json["direction_field"], serde_json::json!("parallel_transport"));
    assert!(json.get("uvs").is_none(), "data fields are not parameters");
    let back: ObjectParams = serde_json::from_value(json).expect("reads back");
    assert_eq!(back, o);
    let err = serde_json::from_str::<ObjectParams>(r#"{"stiffness": 0}"#).unwrap_err().to_string();
    assert!(err.contains("stiffness = 0: must be > 0"), "{err}");
}

#[test]
fn ranges_describe_themselves() {
    let r = |text: &str| {
        ObjectParams::schema()
            .iter()
            .chain(PairParams::schema())
            .chain(ArticulationParams::schema())
            .find(|i| i.range.notation() == text)
            .map(|i| i.range.describe())
    };
    assert_eq!(r("(0, inf)").as_deref(), Some("> 0"));
    assert_eq!(r("[0, inf)").as_deref(), Some("≥ 0"));
    assert_eq!(r("(0, 90]").as_deref(), Some("in (0, 90]"));
    assert_eq!(Range::FINITE.describe(), "finite");
    assert!(!Range::FINITE.contains(f64::INFINITY) && !Range::FINITE.contains(f64::NAN));
}
