//! The output directory of `sweep run`: one run at a time writes in it (two runs into one
//! directory both exited 0 with their files mixed), files the run did not write are never
//! deleted (a user's own `trajectory.sqlite` or snapshots were), and a full disk reports the
//! first file it could not write and leaves no empty file (the only message was about
//! `summary.json`, beside empty `summary.json`, `animation.html` and `final.svg`).

#![cfg(unix)]

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use support::{long_scene, sweep_run, sweep_run_command};

/// `sweep run` of the scene beside `out` (as `sweep_run_command` wrote it) into `out`.
fn rerun(out: &Path, name: &str, args: &[&str]) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(out.with_file_name(format!("{name}.toml")))
        .arg("--out")
        .arg(out)
        .args(["--threads", "1"])
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

fn wait_for_rows(csv: &Path) {
    let start = Instant::now();
    while std::fs::metadata(csv).map_or(0, |m| m.len()) < 20_000 {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no trajectory written"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_second_run_into_a_folder_in_use_is_refused_and_a_killed_runs_lock_is_not_left() {
    let (mut command, out) = sweep_run_command("out-lock", &long_scene(30), &["--threads", "1"]);
    let mut first = command
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_for_rows(&out.join("trajectory.csv"));
    let (ok, said) = rerun(&out, "out-lock", &["--t-end", "0.1", "--seed", "5"]);
    let first_still_runs = first.try_wait().unwrap().is_none();
    // Killed outright: its lock goes with it.
    first.kill().unwrap();
    first.wait().unwrap();
    assert!(first_still_runs, "the first run ended before the test");
    assert!(!ok, "{said}");
    assert!(
        said.contains(&format!("--out {}", out.display()))
            && said.contains("another `sweep run`")
            && said.contains("is using this folder"),
        "{said}"
    );
    let (ok, said) = rerun(&out, "out-lock", &["--t-end", "0.1"]);
    assert!(ok, "{said}");
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let relative = path.strip_prefix(dir).unwrap();
                found.push(relative.to_string_lossy().into_owned());
            }
        }
    }
    found.sort();
    found
}

#[test]
fn a_folder_holding_other_files_is_refused_and_left_as_it_was() {
    let (_, out) = sweep_run_command("out-theirs", &long_scene(30), &[]);
    std::fs::create_dir_all(out.join("snapshots")).unwrap();
    for name in [
        "trajectory.sqlite",
        "disagreement.json",
        "snapshots/t0001.00.svg",
    ] {
        std::fs::write(out.join(name), "mine").unwrap();
    }
    let before = files(&out);
    let (ok, said) = rerun(&out, "out-theirs", &["--t-end", "0.1"]);
    assert!(!ok, "{said}");
    assert!(
        said.contains(&format!("--out {}", out.display()))
            && said.contains("disagreement.json, snapshots, trajectory.sqlite")
            && said.contains("did not write"),
        "{said}"
    );
    assert_eq!(files(&out), before);
    for name in &before {
        assert_eq!(std::fs::read_to_string(out.join(name)).unwrap(), "mine");
    }
}

#[test]
fn a_run_into_an_earlier_runs_folder_leaves_the_files_it_did_not_write() {
    let first = sweep_run(
        "out-ours",
        &long_scene(30),
        &["--threads", "1", "--t-end", "0.2"],
    );
    assert!(first.success, "{}", first.output);
    std::fs::write(first.out.join("notes.txt"), "mine").unwrap();
    let (ok, said) = rerun(&first.out, "out-ours", &["--t-end", "0.1"]);
    assert!(ok, "{said}");
    assert_eq!(
        std::fs::read_to_string(first.out.join("notes.txt")).unwrap(),
        "mine"
    );
}

/// A small file system of its own, unmounted when dropped.
struct Tmpfs(PathBuf);

impl Tmpfs {
    /// `None` where mounting is not allowed (not root, or no `mount`).
    fn mount(dir: PathBuf, size: &str) -> Option<Self> {
        std::fs::create_dir_all(&dir).unwrap();
        let mounted = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(&dir)
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        mounted.then_some(Self(dir))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_disk_reports_the_first_file_it_could_not_write_and_leaves_no_empty_file() {
    let (_, out) = sweep_run_command("out-full", &long_scene(30), &[]);
    let Some(disk) = Tmpfs::mount(out.with_file_name("disk"), "64k") else {
        eprintln!("skipped: a tmpfs cannot be mounted here (not root?)");
        return;
    };
    let out = disk.0.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_sweep"))
        .arg("run")
        .arg(disk.0.with_file_name("out-full.toml"))
        .arg("--out")
        .arg(&out)
        .args(["--threads", "1", "--t-end", "3"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    let error = stderr
        .lines()
        .find_map(|l| l.strip_prefix("error: "))
        .unwrap_or_else(|| panic!("no error line: {stderr}"));
    let trajectory = error.find("trajectory.csv: No space left on device");
    assert!(
        trajectory.is_some_and(|at| error.find("summary.json").is_none_or(|s| s > at)),
        "{error}"
    );
    let empty: Vec<String> = files(&out)
        .into_iter()
        .filter(|name| !name.starts_with('.'))
        .filter(|name| std::fs::metadata(out.join(name)).unwrap().len() == 0)
        .collect();
    assert!(empty.is_empty(), "empty files left: {empty:?}");
}
