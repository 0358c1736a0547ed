//! Contact forces against their closed form, read back from the files a run writes.
//!
//! A column of `n` people of radius `r`, touching each other in a line along `x`, the first
//! touching the wall `x = 0`, all wanting the constant velocity `(−v, 0)`. Nobody can move, so
//! every step's projection is `u = 0`, and its stationarity `u − h f = Σᵢ λᵢ ∇gᵢ` reads, on
//! the `x` coordinate of each person (the rows' gradients are the unit vectors of distance
//! constraints, `∓1` on the two people of a pair, `+1` on a person at the wall):
//!
//! * the last person (`k = n`, counted from the wall): `h v = λ_{n−1,n}`;
//! * person `k`: `h v = λ_{k−1,k} − λ_{k,k+1}`, so `λ_{k−1,k} = (n − k + 1) h v`;
//! * the wall: `λ_wall = n h v`.
//!
//! The `n` rows in `n` unknowns are independent, so the multipliers are unique, and the forces
//! `λ/h` do not depend on the step: the contact in front of the `k`-th person carries the
//! `n − k + 1` people from it to the back, `(n − k + 1) v`, and a person's pressure (the sum of
//! their two contacts) is `(2(n − k) + 1) v`.
// The run writes the SQLite trajectory too, and its tables are checked.
#![cfg(feature = "sqlite")]

use rusqlite::Connection;
use std::path::{Path, PathBuf};
use sweeping::output::{run_scene, RunOptions, CONTACTS_FILE};
use sweeping::scene::{Overrides, Scene};

const N: usize = 5;
const R: f64 = 0.25;
const V: f64 = 1.3;

/// The column, with the contact forces written or not, at step `h`.
fn column(h: f64, forces: bool) -> String {
    let mut s = format!(
        "name = \"column\"\n[room]\nrectangle = [0.0, 0.0, 10.0, 2.0]\n\
         [run]\nh = {h}\nt_end = 0.5\n\
         [output]\ntrajectory_every = 0.1\nformats = [\"csv\", \"sqlite\"]\n\
         contact_forces = {forces}\n"
    );
    for k in 0..N {
        s += &format!(
            "[[people]]\nposition = [{}, 1.0]\nradius = {R}\n\
             desired = {{ kind = \"constant\", velocity = [-{V}, 0.0] }}\n",
            R + 2.0 * R * k as f64
        );
    }
    s
}

fn run(name: &str, h: f64, forces: bool) -> PathBuf {
    let out = std::env::temp_dir().join(format!("sweeping-forces-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let scene = Scene::from_toml_str(&column(h, forces), name)
        .unwrap()
        .build(&Overrides::default())
        .unwrap();
    let options = RunOptions {
        out: Some(out.clone()),
        ..RunOptions::default()
    };
    let done = run_scene(&scene, &options, &mut ()).unwrap();
    assert!(done.result.is_ok(), "{:?}", done.result.err());
    out
}

/// `(2(n − k) + 1) v`, person `i = k − 1` counted from the wall.
fn pressure(i: usize) -> f64 {
    (2 * (N - i - 1) + 1) as f64 * V
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1.0)
}

/// Every file's forces against the closed form.
fn check(out: &Path) {
    // trajectory.csv: the pressure of each person, empty at the first frame (no step yet).
    let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,id,x,y,pressure"));
    let mut frames = 0;
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let (t, i): (f64, usize) = (f[0].parse().unwrap(), f[1].parse().unwrap());
        if t == 0.0 {
            assert_eq!(f[4], "", "{line}");
            continue;
        }
        let p: f64 = f[4].parse().unwrap();
        assert!(close(p, pressure(i)), "{line}: expected {}", pressure(i));
        frames += usize::from(i == 0);
    }
    assert_eq!(frames, 5);
    // contacts.csv: the wall carries everybody, the pair (i, i + 1) those from i + 1 back.
    let text = std::fs::read_to_string(out.join(CONTACTS_FILE)).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,a,b,kind,force"));
    let mut rows = 0;
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let a: usize = f[1].parse().unwrap();
        let force: f64 = f[4].parse().unwrap();
        let expected = match (f[2], f[3]) {
            ("", "wall") => {
                assert_eq!(a, 0, "{line}");
                N as f64 * V
            }
            (b, "person") => {
                assert_eq!(b.parse::<usize>().unwrap(), a + 1, "{line}");
                (N - a - 1) as f64 * V
            }
            _ => panic!("{line}"),
        };
        assert!(close(force, expected), "{line}: expected {expected}");
        rows += 1;
    }
    assert_eq!(
        rows,
        5 * N,
        "N contacts in each of the 5 frames after the first"
    );
    // trajectory.sqlite: the same in its tables.
    let db = Connection::open(out.join("trajectory.sqlite")).unwrap();
    let mut q = db
        .prepare("SELECT frame, id, pressure FROM pressure")
        .unwrap();
    let pressures: Vec<(i64, i64, f64)> = q
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(pressures.len(), 5 * N);
    for (frame, id, p) in pressures {
        assert!(
            frame >= 1 && close(p, pressure(id as usize)),
            "{frame} {id} {p}"
        );
    }
    let wall: f64 = db
        .query_row(
            "SELECT force FROM contacts WHERE kind = 'wall' AND frame = 3 AND b IS NULL",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert!(close(wall, N as f64 * V), "{wall}");
}

#[test]
fn a_column_pushed_against_a_wall_carries_the_people_behind_at_every_step_size() {
    for (name, h) in [("coarse", 0.05), ("fine", 0.01)] {
        check(&run(name, h, true));
    }
}

#[test]
fn without_the_option_no_force_is_written() {
    let out = run("off", 0.05, false);
    let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(text.starts_with("t,id,x,y\n"), "{}", &text[..40]);
    assert!(!out.join(CONTACTS_FILE).exists());
    let db = Connection::open(out.join("trajectory.sqlite")).unwrap();
    let tables: i64 = db
        .query_row(
            "SELECT count(*) FROM sqlite_master WHERE name IN ('pressure', 'contacts')",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(tables, 0);
}
