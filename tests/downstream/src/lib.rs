//! A crate depending on `sweeping` and nothing else, as a newcomer's would. Its tests
//! (`tests/newcomer_problems.rs`) are the three problems of a first hour — a point inside a moving
//! region, three disks on a line against a wall, assumption checks with a wrong bound — and a
//! custom backend, written with the paths a downstream crate can name (`sweeping::prelude`,
//! `sweeping::assumptions`, `sweeping::study`, `sweeping::api`). If the library's public
//! surface stops being enough for them, this crate stops compiling.
#![forbid(unsafe_code)]
