//! What a built scene switched on, one value per effect, printed by `sweep check`.

/// One active effect of a built scene (a constraint family, a velocity term, exits).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Effect {
    /// A desired-velocity term for some people.
    DesiredVelocity {
        /// The field, described by itself.
        field: String,
        /// People it drives.
        people: usize,
    },
    /// People without a desired velocity.
    StandingStill {
        /// How many.
        people: usize,
    },
    /// The non-overlap constraints of the pairs of people, near pairs found by a grid.
    Pairs {
        /// People.
        people: usize,
    },
    /// Static wall segments.
    Walls {
        /// Segments.
        segments: usize,
    },
    /// Obstacles.
    Obstacles {
        /// Obstacles.
        count: usize,
        /// How many of them move (then `Q` depends on `t`).
        moving: usize,
    },
    /// Exits.
    Exits {
        /// Exits.
        count: usize,
    },
    /// A round arena: everybody kept inside its circle.
    Arena {
        /// Its radius.
        radius: f64,
    },
    /// People arriving during the run.
    Sources {
        /// `[[sources]]` entries.
        sources: usize,
        /// People they bring.
        people: usize,
    },
    /// People keeping a least distance from everybody (`gap`).
    Gaps {
        /// People with a gap.
        people: usize,
        /// The largest gap.
        largest: f64,
    },
}

impl std::fmt::Display for Effect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::DesiredVelocity { field, people } => {
                write!(f, "desired velocity: {field} for {people} people")
            }
            Self::StandingStill { people } => write!(
                f,
                "{people} people without a desired velocity (they stand still)"
            ),
            Self::Pairs { people } => write!(
                f,
                "pairs of people: {people} people, near pairs found by a uniform grid"
            ),
            Self::Walls { segments } => write!(f, "walls: {segments} exact segments (static)"),
            Self::Obstacles { count, moving: 0 } => write!(f, "obstacles: {count} (static)"),
            Self::Obstacles { count, moving } => {
                write!(f, "obstacles: {count} ({moving} moving: Q depends on t)")
            }
            Self::Arena { radius } => write!(
                f,
                "arena: a round wall of radius {radius} (convex set: each step projects onto it exactly)"
            ),
            Self::Exits { count } => write!(
                f,
                "exits: {count} (people whose disk is wholly outside the room have left)"
            ),
            Self::Sources { sources, people } => write!(
                f,
                "sources: {sources} bringing {people} people during the run (absent from every \
                 constraint until they arrive; who finds their place taken waits)"
            ),
            Self::Gaps { people, largest } => write!(
                f,
                "gaps: {people} people keep a least distance (up to {largest}): their disks \
                 in the constraints and the outputs have radius + gap/2"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Effect;

    #[test]
    fn effects_print_the_lines_sweep_check_shows() {
        let pairs = Effect::Pairs { people: 40 };
        assert_eq!(
            pairs.to_string(),
            "pairs of people: 40 people, near pairs found by a uniform grid"
        );
        let still = Effect::Obstacles {
            count: 3,
            moving: 0,
        };
        assert_eq!(still.to_string(), "obstacles: 3 (static)");
        let moving = Effect::Obstacles {
            count: 3,
            moving: 1,
        };
        assert_eq!(
            moving.to_string(),
            "obstacles: 3 (1 moving: Q depends on t)"
        );
    }
}
