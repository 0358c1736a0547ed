//! A built scene's geometry as the independent trajectory checker sees it.

use sweeping::crowd::Motion;
use sweeping::scene::{BuiltScene, ObstacleShape};
use sweeping_testkit::checker::{still, Geometry, Obstacle};

/// The scene's geometry as the independent checker sees it: a polygon obstacle is its edges.
pub fn checker_geometry(built: &BuiltScene) -> Geometry {
    let offset = |m: &Motion| -> Box<dyn Fn(f64) -> [f64; 2]> {
        match m {
            Motion::Static => still(),
            m => {
                let m = m.clone();
                Box::new(move |t| m.offset(t))
            }
        }
    };
    let mut obstacles = Vec::new();
    for o in &built.geometry.obstacles {
        match &o.shape {
            ObstacleShape::Disk { center, radius } => {
                obstacles.push(Obstacle::Disk(*center, *radius, offset(&o.motion)))
            }
            ObstacleShape::Segment { a, b } => {
                obstacles.push(Obstacle::Segment(*a, *b, offset(&o.motion)))
            }
            ObstacleShape::Polygon(p) => {
                for k in 0..p.len() {
                    let b = p[(k + 1) % p.len()];
                    obstacles.push(Obstacle::Segment(p[k], b, offset(&o.motion)));
                }
            }
        }
    }
    Geometry {
        room: built.geometry.room.clone(),
        exits: built.geometry.exits.iter().map(|e| (e.a, e.b)).collect(),
        obstacles,
        radii: built.population.radii().to_vec(),
    }
}
