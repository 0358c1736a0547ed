//! Crowds built in code for benchmarks and tests: `n` people of radius 0.2 in a square room.
//!
//! * [`Start::Spread`]: the paper's density (150 people in 10 m × 10 m, about 19 % of the
//!   floor covered), everybody walking towards the middle of the right wall: few contacts.
//! * [`Start::Jammed`]: twice that density (about 38 %), everybody walking to the centre: the
//!   first steps already have many simultaneous contacts.
//!
//! Walls are the four sides of the room; nobody leaves (there is no exit), so the dimension
//! and the number of people in play stay fixed and steps are comparable across `n`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::spec::DesiredSpec;
use super::{BuiltScene, CrowdBuilder};
use crate::error::SweepError;
use crate::problem::Problem;

/// Radius of every person of a synthetic crowd.
pub const RADIUS: f64 = 0.2;

/// How a synthetic crowd starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Start {
    /// The paper's density, walking to the middle of the right wall.
    Spread,
    /// Twice the paper's density, walking to the centre.
    Jammed,
}

impl std::fmt::Display for Start {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Start::Spread => "spread",
            Start::Jammed => "jammed",
        })
    }
}

impl std::str::FromStr for Start {
    type Err = SweepError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "spread" => Ok(Start::Spread),
            "jammed" => Ok(Start::Jammed),
            other => Err(SweepError::InvalidInput(format!(
                "unknown crowd start `{other}` (expected spread or jammed)"
            ))),
        }
    }
}

/// A synthetic crowd: its size, start and the seed of the placement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyntheticCrowd {
    /// Number of people.
    pub n: usize,
    /// Density and desired velocity.
    pub start: Start,
    /// Seed of the random placement.
    pub seed: u64,
}

impl SyntheticCrowd {
    /// The side of the square room: `n` people at the paper's density (`Jammed`: twice it).
    pub fn side(&self) -> f64 {
        let area = 100.0 * self.n as f64 / 150.0;
        match self.start {
            Start::Spread => area.sqrt(),
            Start::Jammed => (area / 2.0).sqrt(),
        }
    }

    /// Random non-overlapping centres in `[r, L − r]²` (random sequential addition, a grid
    /// of cell `2r` to test neighbours), with a clearance of `1e-3` between people.
    ///
    /// # Errors
    /// [`SweepError::InvalidInput`] when `n` people do not fit after `1000 n + 10⁵` draws.
    pub fn positions(&self) -> Result<Vec<f64>, SweepError> {
        let (n, l) = (self.n, self.side());
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let cell = 2.0 * RADIUS;
        let cells = (l / cell).ceil() as usize + 1;
        let mut grid: Vec<Vec<usize>> = vec![Vec::new(); cells * cells];
        let mut q: Vec<f64> = Vec::with_capacity(2 * n);
        let budget = n.saturating_mul(1000).saturating_add(100_000);
        let (lo, hi) = (RADIUS + 1e-3, l - RADIUS - 1e-3);
        if n > 0 && lo >= hi {
            return Err(SweepError::InvalidInput(format!(
                "a synthetic room of side {l} is too small for a person of radius {RADIUS}"
            )));
        }
        let mut tries = 0usize;
        while q.len() < 2 * n {
            tries += 1;
            if tries > budget {
                return Err(SweepError::InvalidInput(format!(
                    "could place only {} of {n} people in {l} × {l} after {budget} draws",
                    q.len() / 2
                )));
            }
            let x = rng.gen_range(lo..hi);
            let y = rng.gen_range(lo..hi);
            let (cx, cy) = ((x / cell) as usize, (y / cell) as usize);
            let clear = (cx.saturating_sub(1)..=(cx + 1).min(cells - 1)).all(|gx| {
                (cy.saturating_sub(1)..=(cy + 1).min(cells - 1)).all(|gy| {
                    grid[gx * cells + gy].iter().all(|&j| {
                        let (dx, dy) = (q[2 * j] - x, q[2 * j + 1] - y);
                        dx * dx + dy * dy >= (2.0 * RADIUS + 1e-3).powi(2)
                    })
                })
            });
            if clear {
                grid[cx * cells + cy].push(q.len() / 2);
                q.push(x);
                q.push(y);
            }
        }
        Ok(q)
    }

    /// The crowd as a scene, built with [`CrowdBuilder`]: the square room (its four walls),
    /// everybody at [`positions`](Self::positions) walking at unit speed towards the target
    /// (pairs grid-culled), no exit.
    ///
    /// # Errors
    /// As [`positions`](Self::positions); [`SweepError::InvalidInput`] with the scene's error
    /// for `n = 0` (a scene has somebody in it).
    pub fn scene(&self) -> Result<BuiltScene, SweepError> {
        let l = self.side();
        let target = match self.start {
            Start::Spread => [l, l / 2.0],
            Start::Jammed => [l / 2.0, l / 2.0],
        };
        let q0 = self.positions()?;
        let builder = q0.chunks(2).fold(
            CrowdBuilder::new(format!("synthetic-{}-{}", self.start, self.n))
                .rectangle([0.0, 0.0, l, l])
                .desired(DesiredSpec::point(target)),
            |b, p| b.person([p[0], p[1]], RADIUS),
        );
        builder
            .build()
            .map_err(|e| SweepError::InvalidInput(e.to_string()))
    }

    /// The problem of [`scene`](Self::scene): pairs (grid-culled), the four walls, and unit
    /// desired velocities.
    ///
    /// # Errors
    /// As [`scene`](Self::scene).
    pub fn problem(&self) -> Result<Problem, SweepError> {
        Ok(self.scene()?.problem)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placements_do_not_overlap_and_stay_inside() {
        for start in [Start::Spread, Start::Jammed] {
            let crowd = SyntheticCrowd {
                n: 300,
                start,
                seed: 3,
            };
            let q = crowd.positions().unwrap();
            let l = crowd.side();
            for i in 0..crowd.n {
                let (x, y) = (q[2 * i], q[2 * i + 1]);
                assert!(x >= RADIUS && x <= l - RADIUS && y >= RADIUS && y <= l - RADIUS);
                for j in 0..i {
                    let d = ((x - q[2 * j]).powi(2) + (y - q[2 * j + 1]).powi(2)).sqrt();
                    assert!(d >= 2.0 * RADIUS, "people {i} and {j} overlap: {d}");
                }
            }
            crowd.problem().unwrap().validate(0.0).unwrap();
        }
    }

    #[test]
    fn empty_and_single_person_crowds_are_placed() {
        let crowd = SyntheticCrowd {
            n: 0,
            start: Start::Jammed,
            seed: 0,
        };
        assert!(crowd.positions().unwrap().is_empty());
        let tiny = SyntheticCrowd {
            n: 1,
            start: Start::Jammed,
            seed: 0,
        };
        // One person at twice the density still gets a room of side 0.58 > 0.4.
        assert_eq!(tiny.positions().unwrap().len(), 2);
    }

    /// The builder wires what the hand-written problem did: the placed positions as `q₀`, a
    /// grid-culled pair family, the four walls, unit speed towards the target.
    #[test]
    fn the_scene_is_the_placed_crowd_walking_to_its_target() {
        let crowd = SyntheticCrowd {
            n: 50,
            start: Start::Spread,
            seed: 1,
        };
        let built = crowd.scene().unwrap();
        let q0 = crowd.positions().unwrap();
        assert_eq!(built.problem.q0(), &q0[..]);
        let names: Vec<_> = built
            .problem
            .families()
            .iter()
            .map(|f| f.name().to_string())
            .collect();
        assert_eq!(names, ["pairs of people", "walls"]);
        let l = crowd.side();
        let mut f = vec![0.0; q0.len()];
        built.problem.perturbation().eval(0.0, &q0, &mut f);
        for (p, v) in q0.chunks(2).zip(f.chunks(2)) {
            let d = [l - p[0], l / 2.0 - p[1]];
            let n = d[0].hypot(d[1]);
            assert!((v[0] - d[0] / n).abs() < 1e-12 && (v[1] - d[1] / n).abs() < 1e-12);
        }
        assert!(SyntheticCrowd { n: 0, ..crowd }.scene().is_err());
    }
}
