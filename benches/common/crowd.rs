//! A crowd built in code for benchmarks: `n` people of radius 0.2 placed at random without
//! overlap in a square room whose side keeps the paper's density (150 people in 10 × 10,
//! about 19 % of the floor covered), all walking towards the middle of the right wall.
//! `dense` packs them twice as tight (about 38 %) and sends them to the centre, so that
//! the first step already has many contacts.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweeping::crowd::{DiskPairs, Motion, PersonShapes, Population, Shape};
use sweeping::problem::Problem;

/// Radius of every person.
pub const RADIUS: f64 = 0.2;

/// The room's side for `n` people at the paper's density (`dense`: twice that density).
pub fn side(n: usize, dense: bool) -> f64 {
    let area = 100.0 * n as f64 / 150.0;
    if dense {
        (area / 2.0).sqrt()
    } else {
        area.sqrt()
    }
}

/// Random non-overlapping centres in `[r, L − r]²` (random sequential addition, a grid of
/// cell `2r` to test neighbours).
pub fn place(n: usize, l: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let cell = 2.0 * RADIUS;
    let cells = (l / cell).ceil() as usize + 1;
    let mut grid: Vec<Vec<usize>> = vec![Vec::new(); cells * cells];
    let mut q: Vec<f64> = Vec::with_capacity(2 * n);
    let mut tries = 0usize;
    while q.len() < 2 * n {
        tries += 1;
        assert!(
            tries < 1000 * n + 100_000,
            "could not place {n} people in {l} × {l}"
        );
        let x = rng.gen_range(RADIUS + 1e-3..l - RADIUS - 1e-3);
        let y = rng.gen_range(RADIUS + 1e-3..l - RADIUS - 1e-3);
        let (cx, cy) = ((x / cell) as usize, (y / cell) as usize);
        let mut free = true;
        'scan: for gx in cx.saturating_sub(1)..=(cx + 1).min(cells - 1) {
            for gy in cy.saturating_sub(1)..=(cy + 1).min(cells - 1) {
                for &j in &grid[gx * cells + gy] {
                    let (dx, dy) = (q[2 * j] - x, q[2 * j + 1] - y);
                    if dx * dx + dy * dy < (2.0 * RADIUS + 1e-3).powi(2) {
                        free = false;
                        break 'scan;
                    }
                }
            }
        }
        if free {
            grid[cx * cells + cy].push(q.len() / 2);
            q.push(x);
            q.push(y);
        }
    }
    q
}

/// The crowd problem: pairs (grid-culled) and the four walls.
pub fn crowd(n: usize, dense: bool, seed: u64) -> Problem {
    let l = side(n, dense);
    let q0 = place(n, l, seed);
    let pop: Arc<Population> = Population::new(vec![RADIUS; n]).shared();
    let target = if dense {
        [l / 2.0, l / 2.0]
    } else {
        [l, l / 2.0]
    };
    let velocity = move |_t: f64, q: &[f64], f: &mut [f64]| {
        for (p, v) in q.chunks(2).zip(f.chunks_mut(2)) {
            let d = [target[0] - p[0], target[1] - p[1]];
            let norm = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-9);
            v[0] = d[0] / norm;
            v[1] = d[1] / norm;
        }
    };
    let walls = [
        ([0.0, 0.0], [l, 0.0]),
        ([l, 0.0], [l, l]),
        ([l, l], [0.0, l]),
        ([0.0, l], [0.0, 0.0]),
    ]
    .iter()
    .map(|&(a, b)| (Shape::Segment { a, b }, Motion::Static))
    .collect();
    Problem::new(q0, velocity)
        .with_family(DiskPairs::new(pop.clone()))
        .with_family(PersonShapes::new("walls", pop, walls))
}
