//! `--set key=value`: a scene field overridden as if the file said it, its errors the file's
//! errors naming the override, and the file's lines kept in every other error.

use sweeping::scene::{Overrides, Scene, SceneError, SetOverride};

const SCENE: &str = r#"name = "two-crowds"
[room]
rectangle = [0.0, 0.0, 10.0, 10.0]

[[exits]]
from = [10.0, 4.0]
to = [10.0, 6.0]

[[crowds]]
count = 10
region = [0.0, 0.0, 4.0, 10.0]
radius = 0.2

[[crowds]]
count = 5
region = [5.0, 0.0, 9.0, 10.0]
radius = 0.2
desired = { kind = "constant", velocity = [0.5, 0.0] }

[desired]
kind = "exit"
"#;

fn sets(items: &[&str]) -> Vec<SetOverride> {
    items.iter().map(|s| s.parse().unwrap()).collect()
}

/// The error building `scene` gives.
fn build_error(scene: Scene) -> SceneError {
    match scene.build(&Overrides::default()) {
        Ok(_) => panic!("the scene was built"),
        Err(e) => e,
    }
}

fn scene_with(items: &[&str]) -> Result<Scene, SceneError> {
    Scene::from_toml_str_with(SCENE, "s.toml", &sets(items))
}

#[test]
fn overrides_change_the_scene_as_the_file_would() {
    let scene = scene_with(&[
        "crowds.0.count=20",
        "crowds.1.desired.velocity=[0.0, 0.5]",
        "crowds.0.speed=0.7",
        "exits.0.to=[10.0, 6.5]",
        "run.t_end=3",
        "run.backend=reference",
        "name=renamed",
    ])
    .unwrap();
    // The same scene written by hand.
    let by_hand = SCENE
        .replace("count = 10", "count = 20\nspeed = 0.7")
        .replace("velocity = [0.5, 0.0] }", "velocity = [0.0, 0.5] }")
        .replace("to = [10.0, 6.0]", "to = [10.0, 6.5]")
        .replace("two-crowds", "renamed")
        + "[run]\nt_end = 3\nbackend = \"reference\"\n";
    let hand = Scene::from_toml_str(&by_hand, "hand.toml").unwrap();
    assert_eq!(
        format!("{:?}", scene.spec.get_spec_values()),
        format!("{:?}", hand.spec.get_spec_values())
    );
    assert_eq!(scene.name, "renamed");
    let built = scene.build(&Overrides::default()).unwrap();
    assert_eq!(built.population.len(), 25);
    assert_eq!(built.settings.t_end, 3.0);
    assert_eq!(built.backend.to_string(), "reference");
    assert_eq!(built.geometry.exits[0].b, [10.0, 6.5]);
}

/// What the spec holds, without the positions of its tables in the text (which differ).
trait SpecValues {
    fn get_spec_values(&self) -> String;
}

impl SpecValues for sweeping::scene::SceneSpec {
    fn get_spec_values(&self) -> String {
        // `Spanned` prints its span: drop every `span: a..b`.
        let text = format!("{self:?}");
        let mut out = String::new();
        let mut rest = text.as_str();
        while let Some(i) = rest.find("span: ") {
            out.push_str(&rest[..i]);
            let after = &rest[i + 6..];
            let end = after.find([',', ' ', '}']).unwrap_or(after.len());
            rest = &after[end..];
        }
        out.push_str(rest);
        out
    }
}

#[test]
fn an_unknown_key_is_the_files_error_naming_the_override() {
    let from_file = Scene::from_toml_str(
        &SCENE.replace("count = 5", "count = 5\ncuont = 3"),
        "s.toml",
    )
    .unwrap_err();
    let SceneError::Parse { message, line, .. } = &from_file else {
        panic!("{from_file}");
    };
    assert_eq!(*line, 16);
    let e = scene_with(&["crowds.1.cuont=3"]).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!("s.toml: --set crowds.1.cuont=3: {message}")
    );
    assert!(message.contains("unknown field `cuont`"), "{message}");
    // A key nobody has, at the top and in a table the file lacks.
    let e = scene_with(&["nmae=x"]).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("s.toml: --set nmae=x: unknown field `nmae`"),
        "{e}"
    );
    let e = scene_with(&["run.hh=0.1"]).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("s.toml: --set run.hh=0.1: unknown field `hh`"),
        "{e}"
    );
}

#[test]
fn a_wrong_type_names_the_override() {
    let e = scene_with(&["crowds.0.count=many"]).unwrap_err();
    assert!(matches!(e, SceneError::Set { .. }), "{e}");
    assert!(e.to_string().contains("--set crowds.0.count=many"), "{e}");
    assert!(
        e.to_string().contains("invalid type: string \"many\""),
        "{e}"
    );
    let e = scene_with(&["exits.0.from=[1.0]"]).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("s.toml: --set exits.0.from=[1.0]: "),
        "{e}"
    );
}

#[test]
fn errors_of_the_file_keep_its_line_numbers() {
    // A crowd that cannot fit, written on line 14; overrides add lines above it.
    let crowded = SCENE.replace("count = 5", "count = 5000");
    let plain = build_error(Scene::from_toml_str(&crowded, "s.toml").unwrap());
    let with = build_error(
        Scene::from_toml_str_with(
            &crowded,
            "s.toml",
            &sets(&["crowds.0.seed=4", "geodesic.cell=0.1", "crowds.1.seed=9"]),
        )
        .unwrap(),
    );
    assert_eq!(plain.line(), Some(14), "{plain}");
    assert_eq!(with.line(), Some(14), "{with}");
    // A parse error of the file after an added line.
    let broken = SCENE.replace("radius = 0.2\n\n[[crowds]]", "radius = 0.2,\n\n[[crowds]]");
    let plain = Scene::from_toml_str(&broken, "s.toml").unwrap_err();
    let with = Scene::from_toml_str_with(&broken, "s.toml", &sets(&["crowds.0.seed=4"]));
    // The file does not parse: it is reported as it is, the override not applied.
    assert_eq!(with.unwrap_err().to_string(), plain.to_string());
    // A bad value written by an override into a valid key: the scene's own check, at the
    // item's line.
    let e = build_error(scene_with(&["crowds.1.radius=-1"]).unwrap());
    assert_eq!(e.line(), Some(14), "{e}");
}

#[test]
fn an_override_of_a_missing_list_item_is_refused() {
    let e = scene_with(&["crowds.2.count=3"]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "s.toml: --set crowds.2.count=3: `crowds` has 2 items (numbered from 0): there is no item 2; --set changes an item of a list, it does not add one"
    );
    let e = scene_with(&["obstacles.0.disk.radius=1"]).unwrap_err();
    assert!(
        e.to_string().contains("the scene has no `obstacles`"),
        "{e}"
    );
}
