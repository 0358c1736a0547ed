use super::*;

/// `trajectory` and `people` written as a run's files in a fresh directory `name`.
fn write(name: &str, trajectory: &str, people: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sweep-saved-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(TrajectoryFormat::Csv.file_name()), trajectory).unwrap();
    std::fs::write(dir.join(PEOPLE_FILE), people).unwrap();
    dir
}

fn error(dir: &Path) -> String {
    SavedRun::read(dir).unwrap_err().to_string()
}

const TWO: &str = "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.25,0.4,-0.25,4\n";
const TWO_STAYING: &str = "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.2,,,\n";

#[test]
fn the_last_frame_is_read_with_who_had_left_where_they_left() {
    let dir = write("ok", "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.5,0,1.5,2.5\n", TWO);
    let saved = SavedRun::read(&dir).unwrap();
    let state = saved.state.clone();
    assert_eq!(state.t, 0.5);
    assert_eq!(state.q, vec![1.5, 2.5, -0.25, 4.0]);
    assert_eq!(state.departed, vec![false, true]);
    assert_eq!(saved.people[1].radius, 0.25);
    assert_eq!(saved.passed_over, None);
    assert!(saved.absent.is_empty());
    assert_eq!(
        saved.place_of(1),
        format!("{}:3", saved.people_file.display())
    );
    assert_eq!(
        saved.place_of(0),
        format!("{}:4", saved.trajectory.display())
    );
    // With the pressure column.
    let dir = write(
        "pressure",
        "t,id,x,y,pressure\n0,0,1,2,\n0,1,3,4,\n0.5,0,1.5,2.5,0.3\n",
        TWO,
    );
    assert_eq!(SavedRun::read(&dir).unwrap().state, state);
}

#[test]
fn with_everybody_gone_the_state_is_at_the_last_departure() {
    let dir = write(
        "gone",
        "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.3,0,1.5,2.5\n",
        "id,radius,t_left,x_left,y_left\n0,0.2,0.35,4.3,2\n1,0.25,0.2,-0.25,4\n",
    );
    let saved = SavedRun::read(&dir).unwrap();
    assert_eq!(saved.state.t, 0.35);
    assert_eq!(saved.state.q, vec![4.3, 2.0, -0.25, 4.0]);
    assert_eq!(saved.state.departed, vec![true, true]);
    assert_eq!(saved.departures().iter().flatten().count(), 2);
}

#[test]
fn a_bad_line_is_named_by_its_number() {
    let e = error(&write("bad", "t,id,x,y\n0,0,1,2\n0,1,x,4\n", TWO));
    assert!(
        e.contains("trajectory.csv:3") && e.contains("x = \"x\""),
        "{e}"
    );
    let e = error(&write("nan", "t,id,x,y\n0,0,1,NaN\n", TWO));
    assert!(e.contains(":2") && e.contains("not finite"), "{e}");
    let e = error(&write(
        "bad-people",
        "t,id,x,y\n0,0,1,2\n",
        "id,radius,t_left,x_left,y_left\n0,0.2,,,\n1,0.2,1,,\n",
    ));
    assert!(e.contains("people.csv:3") && e.contains("x_left"), "{e}");
    let e = error(&write("stranger", "t,id,x,y\n0,0,1,2\n0,2,1,2\n", TWO));
    assert!(
        e.contains(":3") && e.contains("person 2, the people table has 2"),
        "{e}"
    );
}

#[test]
fn frames_out_of_order_listed_after_leaving_or_none_are_refused() {
    let e = error(&write(
        "listed",
        "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.5,0,1,2\n0.5,1,3,4\n",
        TWO,
    ));
    assert!(
        e.contains("trajectory.csv:5") && e.contains("says they left"),
        "{e}"
    );
    let e = error(&write("order", "t,id,x,y\n0.1,0,1,2\n0,0,1,2\n", TWO));
    assert!(e.contains(":3") && e.contains("time order"), "{e}");
    let e = error(&write("ids", "t,id,x,y\n0,1,1,2\n0,0,1,2\n", TWO));
    assert!(e.contains(":3") && e.contains("increasing id order"), "{e}");
    assert!(error(&write("empty", "t,id,x,y\n", TWO)).contains("no frame"));
    assert!(error(&write("header", "time,x\n", TWO)).contains(":1"));
}

#[test]
fn a_run_killed_between_writes_resumes_at_the_last_frame_its_people_table_accounts_for() {
    // Person 1 left between t = 0.1 and 0.2, after the people table was last written: the
    // frames from 0.2 on are passed over, as is the last line, cut short.
    let dir = write(
        "killed",
        "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.1,0,1.1,2\n0.1,1,3.5,4\n0.2,0,1.2,2\n0.3,0,1.3,2\n0.4,0,1.",
        TWO_STAYING,
    );
    let saved = SavedRun::read(&dir).unwrap();
    assert_eq!(saved.state.t, 0.1);
    assert_eq!(saved.state.q, vec![1.1, 2.0, 3.5, 4.0]);
    assert_eq!(saved.last.line, 4);
    assert_eq!(
        saved.passed_over,
        Some(PassedOver {
            last_t: 0.3,
            cut_line: true
        })
    );
    // A last line cut short alone: the frames before it are whole.
    let dir = write(
        "cut-line",
        "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.1,0,1.1",
        TWO_STAYING,
    );
    let saved = SavedRun::read(&dir).unwrap();
    assert_eq!((saved.state.t, saved.last.line), (0.0, 2));
    assert!(saved
        .passed_over
        .is_some_and(|p| p.cut_line && p.last_t == 0.0));
}

#[test]
fn who_was_never_written_has_not_arrived_and_is_absent_not_gone() {
    // Person 0 comes in at t = 0.5 (a scene's source).
    let dir = write(
        "later",
        "t,id,x,y\n0,1,3,4\n0.5,0,1,2\n0.5,1,3,4\n",
        TWO_STAYING,
    );
    let early = write("early", "t,id,x,y\n0,1,3,4\n0.2,1,3,4.1\n", TWO_STAYING);
    let saved = SavedRun::read(&early).unwrap();
    assert_eq!((saved.state.t, saved.absent.clone()), (0.2, vec![0]));
    assert_eq!(saved.state.departed, vec![false, false]);
    let saved = SavedRun::read(&dir).unwrap();
    assert!(saved.absent.is_empty());
    // Who arrives later is not in the start's frame; anyone else must be.
    let q0 = [1.0, 2.0, 3.0, 4.0];
    saved
        .check_start(0.0, &q0, &[0.2, 0.2], |i| i == 0)
        .unwrap();
    let e = saved
        .check_start(0.0, &q0, &[0.2, 0.2], |_| false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lists 1 people, the scene has 2 there"), "{e}");
}

#[test]
fn the_first_frame_and_the_radii_are_checked_against_the_scene() {
    let dir = write("start", "t,id,x,y\n0,0,1,2\n0,1,3,4\n0.5,0,1.5,2.5\n", TWO);
    let saved = SavedRun::read(&dir).unwrap();
    assert_eq!(
        (saved.first.t, saved.first.line, saved.last.line),
        (0.0, 2, 4)
    );
    let radii = [0.2, 0.25];
    let q0 = [1.0, 2.0, 3.0, 4.0];
    let no_sources = |_| false;
    saved.check_start(0.0, &q0, &radii, no_sources).unwrap();
    // A trajectory that starts later (of a resumed run) has no start to compare.
    saved
        .check_start(-1.0, &[9.0; 4], &radii, no_sources)
        .unwrap();
    let e = saved
        .check_start(0.0, &[1.0, 2.0, 3.0, 4.5], &radii, no_sources)
        .unwrap_err()
        .to_string();
    assert!(e.contains(":3") && e.contains("another scene"), "{e}");
    let e = saved
        .check_start(0.1, &q0, &radii, no_sources)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(":2") && e.contains("before the scene's start"),
        "{e}"
    );
    let e = saved
        .check_start(0.0, &q0, &[0.2, 0.2], no_sources)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("people.csv:3") && e.contains("radius 0.25"),
        "{e}"
    );
    let e = saved
        .check_start(0.0, &[1.0, 2.0], &[0.2], no_sources)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lists 2 people, the scene has 1"), "{e}");
}

#[test]
fn a_run_written_as_sqlite_only_is_told_to_write_csv() {
    let dir = std::env::temp_dir().join(format!("sweep-saved-{}-sqlite", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(TrajectoryFormat::Sqlite.file_name()), b"").unwrap();
    let e = error(&dir);
    assert!(e.contains("--format csv"), "{e}");
}
