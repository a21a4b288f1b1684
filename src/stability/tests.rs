use super::*;

#[test]
fn every_case_is_valid() {
    for m in sweep_models() {
        let cs = cases(m).unwrap_or_else(|e| panic!("{}: {e:#}", model_label(m)));
        assert!(cs.len() >= 2, "{}", model_label(m));
        for c in cs {
            assert_eq!(c.params.model(), m, "{}", c.label);
        }
    }
}

#[test]
fn regions_are_above_the_horizon() {
    for r in regions() {
        assert!(!r.pairs.is_empty());
        for (wi, wo) in r.pairs {
            assert!(wi.z > 0.0 && wo.z > 0.0, "{}: {wi:?} {wo:?}", r.name);
            assert!((wi.length() - 1.0).abs() < 1e-6 && (wo.length() - 1.0).abs() < 1e-6);
        }
    }
}

#[test]
fn opposite_grazing_has_h_at_n() {
    let r = regions();
    let opp = r.iter().find(|r| r.name == "opposite-grazing").unwrap();
    let (wi, wo) = opp.pairs[0];
    let s = wi + wo;
    assert!(s.x.abs() < 1e-7 && s.y.abs() < 1e-7 && s.z > 0.0, "{s:?}");
}
