//! What is allowed but rarely meant is pointed out before a run (`BuiltScene::output.notes`,
//! printed by `sweep run` and `sweep check` as `note:` lines): nobody moving, people cut off
//! from every exit, a run of very many steps, a trajectory of hundreds of megabytes.

use sweeping::scene::{Overrides, Scene};

fn notes_of(text: &str) -> Vec<String> {
    Scene::from_toml_str(text, "scene.toml")
        .and_then(|s| s.build(&Overrides::default()))
        .unwrap_or_else(|e| panic!("{e}"))
        .output
        .notes
}

const TWO_ROOMS: &str = r#"
[room]
rectangle = [0.0, 0.0, 10.0, 10.0]
[[exits]]
from = [10.0, 4.5]
to = [10.0, 5.5]
[[obstacles]]
segment = { from = [5.0, 0.0], to = [5.0, 10.0] }
[[people]]
position = [2.0, 5.0]
radius = 0.25
[[people]]
position = [7.0, 5.0]
radius = 0.25
[run]
t_end = 3.0
"#;

#[test]
fn a_person_cut_off_from_every_exit_is_named() {
    let notes = notes_of(&format!("{TWO_ROOMS}[desired]\nkind = \"exit\"\n"));
    let cut_off: Vec<_> = notes
        .iter()
        .filter(|n| n.contains("cannot reach any exit"))
        .collect();
    assert_eq!(cut_off.len(), 1, "{notes:?}");
    assert!(cut_off[0].contains("1 of the 2 people"), "{}", cut_off[0]);
    assert!(cut_off[0].contains("person 0 at (2, 5)"), "{}", cut_off[0]);
    assert!(!cut_off[0].contains("person 1"), "{}", cut_off[0]);
}

#[test]
fn an_opening_in_the_wall_gives_everybody_a_route() {
    let open = TWO_ROOMS.replace("to = [5.0, 10.0]", "to = [5.0, 7.0]");
    let notes = notes_of(&format!("{open}[desired]\nkind = \"exit\"\n"));
    assert!(
        notes.iter().all(|n| !n.contains("cannot reach")),
        "{notes:?}"
    );
}

#[test]
fn nobody_with_a_desired_velocity_is_pointed_out() {
    let notes = notes_of(TWO_ROOMS);
    assert!(
        notes.iter().any(|n| n.contains("nobody will move")),
        "{notes:?}"
    );
    // One person heading out, the other without a desire of their own.
    let one = TWO_ROOMS.replacen(
        "radius = 0.25\n",
        "radius = 0.25\ndesired = { kind = \"point\", point = [3.0, 3.0] }\n",
        1,
    );
    let notes = notes_of(&one);
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("1 of 2 people have no desired velocity")),
        "{notes:?}"
    );
    assert!(notes.iter().all(|n| !n.contains("nobody will move")));
}

#[test]
fn a_run_of_many_steps_and_a_huge_trajectory_are_pointed_out() {
    let long = TWO_ROOMS.replace("t_end = 3.0", "t_end = 1e6\nh = 0.01");
    let notes = notes_of(&format!("{long}[desired]\nkind = \"exit\"\n"));
    assert!(
        notes
            .iter()
            .any(|n| n.contains("the run takes 1.0e8 steps")),
        "{notes:?}"
    );
    // 2 people written every 0.1 s for 10⁶ s: 2·10⁷ rows.
    assert!(
        notes
            .iter()
            .any(|n| n.contains("about 2.0e7 rows") && n.contains("MB of CSV")),
        "{notes:?}"
    );
}

#[test]
fn the_shipped_evacuation_needs_no_note() {
    let text = include_str!("../examples/scenes/paper-evacuation.toml");
    let notes = notes_of(text);
    assert!(notes.is_empty(), "{notes:?}");
}
