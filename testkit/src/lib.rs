//! What the tests of every crate of `sweeping` share, in one place instead of files included
//! by path: the certified projection ([`certified`]), the corpus of recorded projection
//! problems ([`fixtures`], each with its provenance in `fixtures/README.md`) and the
//! independent checker of a run's trajectory ([`checker`]).
//!
//! A dev-dependency only; it depends on the projection contract alone, so that the backends'
//! own tests can use it.
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod certified;
pub mod checker;
pub mod fixtures;
