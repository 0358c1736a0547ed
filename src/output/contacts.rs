//! Contact forces of a crowd, read from a step's active rows ([`StepReport::contacts`]).
//!
//! The step is `q_{k+1} = q_k + h f + Σᵢ λᵢ ∇gᵢ`: constraint `i` adds `λᵢ/h · ∇gᵢ` to the
//! velocity of the step. A crowd's constraints are distances (`|qᵢ − qⱼ| − rᵢ − rⱼ`, or a
//! person's distance to a wall minus their radius), whose gradient has length 1 on each person
//! it involves: the force of a contact on each of its people is `λ/h`, in metres per second
//! (a velocity: the model is first order). A person's **pressure** is the sum of the magnitudes
//! of the forces on them.

use crate::constraint::FamilyKind;
use crate::problem::Problem;
use crate::stepper::{Contact, StepReport};

/// What a person is in contact with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactWith {
    /// Another person.
    Person,
    /// A wall of the room.
    Wall,
    /// An obstacle.
    Obstacle,
    /// A constraint of another kind.
    Other,
}

impl ContactWith {
    /// As written in the outputs: `person`, `wall`, `obstacle`, `other`.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Person => "person",
            Self::Wall => "wall",
            Self::Obstacle => "obstacle",
            Self::Other => "other",
        }
    }
}

/// One contact of a step: person `a` and what keeps them apart, and the force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactForce {
    /// The person (the smaller index of a pair).
    pub a: usize,
    /// The other person of a pair, `None` for a wall or obstacle.
    pub b: Option<usize>,
    /// What `a` touches.
    pub with: ContactWith,
    /// `λ/h · |∇_{q_a} g|`: the magnitude of the force on `a` (and on `b`, for a pair), m/s.
    pub force: f64,
}

/// The people a contact involves: the distinct `coordinate / 2` of its gradient, in order.
fn people_of(contact: &Contact) -> impl Iterator<Item = usize> + '_ {
    let mut last = None;
    contact.gradient.iter().filter_map(move |&(c, _)| {
        let person = c / 2;
        (last != Some(person)).then(|| {
            last = Some(person);
            person
        })
    })
}

/// Each person's pressure at the step of `report`: the sum of the magnitudes of the contact
/// forces on them, m/s; written into `out` (resized to `people`, zeros without contacts).
pub fn pressures(report: &StepReport, people: usize, out: &mut Vec<f64>) {
    out.clear();
    out.resize(people, 0.0);
    for contact in &report.contacts {
        for p in people_of(contact) {
            if let Some(slot) = out.get_mut(p) {
                *slot += contact.force_on(2 * p..2 * p + 2, report.h);
            }
        }
    }
}

/// What each constraint family of a crowd's problem keeps apart, to say what a contact is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ContactKinds(Vec<ContactWith>);

impl ContactKinds {
    /// The kinds of `problem`'s families: pairs of people, walls (a family of person–shape
    /// constraints named `walls`), obstacles (the other person–shape families).
    pub fn of(problem: &Problem) -> Self {
        Self(
            problem
                .families()
                .iter()
                .map(|f| match f.kind() {
                    FamilyKind::Pairs => ContactWith::Person,
                    FamilyKind::PersonShapes if f.name() == "walls" => ContactWith::Wall,
                    FamilyKind::PersonShapes => ContactWith::Obstacle,
                    FamilyKind::Other => ContactWith::Other,
                })
                .collect(),
        )
    }

    /// The contacts of the step of `report`, in the order of its rows.
    pub fn forces<'a>(&'a self, report: &'a StepReport) -> impl Iterator<Item = ContactForce> + 'a {
        report.contacts.iter().filter_map(move |c| {
            let mut people = people_of(c);
            let a = people.next()?;
            let b = people.next();
            let with = self
                .0
                .get(c.constraint.family)
                .copied()
                .unwrap_or(ContactWith::Other);
            Some(ContactForce {
                a,
                b: if with == ContactWith::Person { b } else { None },
                with,
                force: c.force_on(2 * a..2 * a + 2, report.h),
            })
        })
    }
}

/// `v` as a CSV field: empty for `None` (no step has been made at a run's first frame).
pub(crate) fn optional_field(v: Option<f64>) -> String {
    v.map(|v| v.to_string()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraint::ConstraintId;

    #[test]
    fn a_pair_pushes_both_people_and_a_wall_one() {
        let contact = |family, gradient: Vec<(usize, f64)>, multiplier| Contact {
            constraint: ConstraintId { family, member: 0 },
            multiplier,
            gradient,
        };
        let mut report: StepReport = serde_json::from_str(
            r#"{"step":0,"t":0.1,"h":0.1,"rows":2,"active":2,"solves":1,"iterations":0,
            "times":{"effects":0,"broad_phase":0,"assembly":0,"projection":0,"check":0},
            "max_violation":0,"worst_constraint":null,"max_displacement":0,
            "solve":{"backend":"x","status":"Trivial","iterations":0,"solve_seconds":0,
            "setup_seconds":0,"warm_started":false}}"#,
        )
        .unwrap();
        // People 0 and 2 along x (unit normal), person 2 against a wall (0.6, 0.8).
        report.contacts = vec![
            contact(0, vec![(0, -1.0), (1, 0.0), (4, 1.0), (5, 0.0)], 0.03),
            contact(1, vec![(4, 0.6), (5, 0.8)], 0.05),
        ];
        let mut p = Vec::new();
        pressures(&report, 3, &mut p);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(p[0], 0.3) && p[1] == 0.0 && close(p[2], 0.8), "{p:?}");
        let kinds = ContactKinds(vec![ContactWith::Person, ContactWith::Wall]);
        let forces: Vec<ContactForce> = kinds.forces(&report).collect();
        assert_eq!((forces[0].a, forces[0].b), (0, Some(2)));
        assert_eq!(
            (forces[1].a, forces[1].b, forces[1].with),
            (2, None, ContactWith::Wall)
        );
        assert!(close(forces[0].force, 0.3) && close(forces[1].force, 0.5));
    }
}
