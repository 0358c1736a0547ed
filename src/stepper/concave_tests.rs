//! The keys of a step's rows when concave members are cut: assembled rows keyed by their
//! constraint, cuts by keys of their own that no other row of the run takes.

use crate::prelude::*;
use crate::stepper::Stepper;
use sweeping_api::RowKey;

/// `x ≥ −100`: far away, a family before the concave one.
struct FarFloor;
impl Constraint<1> for FarFloor {
    fn value<D: Scalar>(&self, _t: D, z: [D; 1]) -> D {
        z[0] + 100.0
    }
}

/// `g = 1 − ((x − t/4)/2)² − y²`: concave, `{g ≥ 0}` a moving ellipse.
struct InsideEllipse;
impl Constraint<2> for InsideEllipse {
    fn value<D: Scalar>(&self, t: D, z: [D; 2]) -> D {
        let u = (z[0] - t * 0.25) * 0.5;
        -(u * u + z[1] * z[1]) + 1.0
    }
    fn curvature(&self) -> Curvature {
        Curvature::Concave
    }
}

fn pushed_out(_t: f64, _q: &[f64], f: &mut [f64]) {
    f[0] = 1.0;
    f[1] = 1.0;
}

/// Every row's key after a step, checked against where the row came from; the cuts' serials.
fn keys_after_step(stepper: &mut Stepper<'_>, families: usize) -> Vec<u64> {
    stepper
        .step(&mut ReferenceProjector::default())
        .expect("the step succeeds");
    let cuts = &stepper.cuts;
    assert!(
        !cuts.kept.is_empty(),
        "a step from the boundary outward cuts"
    );
    assert_eq!(stepper.b.len(), cuts.base_rows + cuts.kept.len());
    let keys: Vec<RowKey> = (0..stepper.b.len()).map(|r| stepper.row_key(r)).collect();
    for (r, key) in keys.iter().enumerate() {
        let (family, member) = stepper.row_origin[r];
        let expected = match r.checked_sub(cuts.base_rows) {
            None => RowKey {
                family: family as u32,
                member: member as u64,
            },
            Some(c) => RowKey {
                family: (families + family) as u32,
                member: cuts.kept[c].serial,
            },
        };
        assert_eq!(*key, expected, "row {r} of {}", keys.len());
    }
    cuts.kept.iter().map(|c| c.serial).collect()
}

#[test]
fn cuts_are_keyed_beyond_the_problems_families_by_serials_never_reused() {
    let problem = Problem::new(vec![0.5, 0.9], pushed_out)
        .with_constraint("far floor", FarFloor, [0])
        .with_constraint("inside ellipse", InsideEllipse, [0, 1]);
    let settings = StepperSettings {
        h: 0.5,
        t_end: 2.0,
        ..Default::default()
    };
    let mut stepper = Stepper::new(&problem, settings).unwrap();
    let first = keys_after_step(&mut stepper, 2);
    let second = keys_after_step(&mut stepper, 2);
    let all: Vec<u64> = first.iter().chain(&second).copied().collect();
    let mut distinct = all.clone();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(distinct.len(), all.len(), "serials {all:?}");
    let last_of_first = first.iter().max().unwrap();
    assert!(
        second.iter().all(|s| s > last_of_first),
        "{first:?} then {second:?}"
    );
}
