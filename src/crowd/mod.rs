//! The Maury–Venel crowd-motion model: people are disks that may not overlap.
//!
//! The configuration is `q = (x₁, y₁, …, x_N, y_N) ∈ R^{2N}`; person `i` has radius `rᵢ` and
//! the constraints are
//!
//! * pairs: `D_ij(q) = |qᵢ − qⱼ| − (rᵢ + rⱼ) ≥ 0` ([`DiskPairs`], culled by a uniform grid);
//! * walls and obstacles: `|qᵢ − P_S(t)(qᵢ)| − rᵢ ≥ 0` for segments and disks that may move
//!   ([`PersonShapes`]); walls are exact segments, never rasterized;
//! * a round arena, when the scene has one: `(R − rᵢ) − |qᵢ − c| ≥ 0` ([`ArenaWall`]), a
//!   concave constraint (a convex set, projected onto exactly each step).
//!
//! People who have left through an exit (their centre outside the room by more than their
//! radius, see [`Population`]) drop out of every constraint and keep walking straight on.

mod arena;
pub mod fast_marching;
pub mod journey;
mod pairs;
mod population;
mod shapes;
pub mod velocity;
mod verlet;

pub use arena::{ArenaWall, InsideCircleKernel};
pub use pairs::{DiskPairKernel, DiskPairs};
pub use population::{segment_distance, ArrivalReport, Population, Room};
pub use shapes::{rectangle_walls, Motion, PersonShapeKernel, PersonShapes, Shape, ShapeParams};
