//! Who is in the crowd: who has arrived (people may arrive during a run) and who has left.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// A closed polygonal room (counter-clockwise or clockwise), used to tell who has left.
#[derive(Debug, Clone, PartialEq)]
pub struct Room {
    /// Vertices of the boundary, in order (the last connects back to the first).
    pub vertices: Vec<[f64; 2]>,
}

impl Room {
    /// An axis-aligned rectangle `[x0, x1] × [y0, y1]`.
    pub fn rectangle(x0: f64, y0: f64, x1: f64, y1: f64) -> Self {
        Self {
            vertices: vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]],
        }
    }

    /// Whether `p` lies inside the polygon (even–odd rule).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        point_in_polygon(&self.vertices, p)
    }

    /// `[x0, y0, x1, y1]` when the polygon is an axis-aligned rectangle of positive area
    /// (four vertices, every edge horizontal or vertical), `None` otherwise.
    pub fn as_axis_aligned_box(&self) -> Option<[f64; 4]> {
        let v = &self.vertices;
        if v.len() != 4 {
            return None;
        }
        let axis_aligned =
            (0..4).all(|i| v[i][0] == v[(i + 1) % 4][0] || v[i][1] == v[(i + 1) % 4][1]);
        let (x0, x1) = (
            v.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
            v.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
        );
        let (y0, y1) = (
            v.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
            v.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
        );
        // All four corners of the bounding box among the four vertices (so every vertex is a
        // corner), in an order whose edges are all axis-aligned: the boundary of the box.
        let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        (axis_aligned && x0 < x1 && y0 < y1 && corners.iter().all(|c| v.contains(c)))
            .then_some([x0, y0, x1, y1])
    }

    /// Distance from `p` to the polygon's boundary.
    pub fn boundary_distance(&self, p: [f64; 2]) -> f64 {
        let v = &self.vertices;
        (0..v.len())
            .map(|i| segment_distance(p, v[i], v[(i + 1) % v.len()]))
            .fold(f64::INFINITY, f64::min)
    }
}

/// Whether `p` lies inside the polygon with vertices `v` (even–odd rule).
pub fn point_in_polygon(v: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut inside = false;
    let mut j = v.len().wrapping_sub(1);
    for i in 0..v.len() {
        let (a, b) = (v[i], v[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Distance from `p` to the segment `[a, b]`.
pub fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let s = if len2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let c = [a[0] + s * ab[0], a[1] + s * ab[1]];
    ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt()
}

/// One flag per person, latched: once set, it stays set until reset (who has left, who has
/// arrived).
#[derive(Debug, Default)]
struct Latches(Vec<AtomicBool>);

impl Latches {
    fn new(n: usize) -> Self {
        Self((0..n).map(|_| AtomicBool::new(false)).collect())
    }
    fn get(&self, i: usize) -> bool {
        self.0[i].load(Ordering::Relaxed)
    }
    fn set(&self, i: usize) {
        self.0[i].store(true, Ordering::Relaxed);
    }
    fn snapshot(&self) -> Vec<bool> {
        self.0.iter().map(|b| b.load(Ordering::Relaxed)).collect()
    }
}

impl Clone for Latches {
    fn clone(&self) -> Self {
        Self(self.snapshot().into_iter().map(AtomicBool::new).collect())
    }
}

impl PartialEq for Latches {
    fn eq(&self, other: &Self) -> bool {
        self.snapshot() == other.snapshot()
    }
}

/// The people of a crowd: their radii, and the rule that says who has left.
///
/// Shared (behind an `Arc`) by the constraint families and the velocity field, so that all
/// agree on who is present. Person `i` leaves when a room is set and its centre is outside the
/// room by at least `rᵢ` (the disk is wholly out); walls are enforced, so that can only happen
/// through an exit. **Once left, always left**: the departure is latched the first time
/// [`is_present`](Self::is_present) sees it, so a person walking on past the door can never
/// re-enter the room, be counted, or touch anyone, even if their straight path crosses
/// another part of a non-convex room. A run starts by clearing the latches
/// ([`reset_departures`](Self::reset_departures); [`crate::scene::BuiltScene::run`] does it).
#[derive(Debug, Clone, PartialEq)]
pub struct Population {
    radii: Vec<f64>,
    max_radius: f64,
    room: Option<Room>,
    /// The room itself when it is an axis-aligned rectangle `[x0, y0, x1, y1]`: a point
    /// strictly inside is in the room without walking the polygon (presence is asked for every
    /// person several times a step).
    room_box: Option<[f64; 4]>,
    departed: Latches,
    /// When people arrive during the run (a scene's sources); `None`: everybody is there
    /// from the start, and presence costs no arrival check.
    arrivals: Option<Arrivals>,
}

impl Population {
    /// `radii.len()` people; nobody ever leaves unless [`Population::with_room`] is set.
    pub fn new(radii: Vec<f64>) -> Self {
        let max_radius = radii.iter().copied().fold(0.0, f64::max);
        let departed = Latches::new(radii.len());
        Self {
            radii,
            max_radius,
            room: None,
            room_box: None,
            departed,
            arrivals: None,
        }
    }

    /// People arrive during the run: person `i` is due at `due[i]` (`None`: there from the
    /// start) and is absent, in no constraint and standing still, until
    /// [`admit`](Self::admit) lets them in.
    ///
    /// # Panics
    /// When `due` has not one entry per person.
    pub fn with_arrivals(mut self, due: Vec<Option<f64>>) -> Self {
        assert_eq!(due.len(), self.len(), "one arrival time per person");
        self.arrivals = Some(Arrivals::new(due));
        self
    }

    /// People whose disk is wholly outside `room` have left.
    pub fn with_room(mut self, room: Room) -> Self {
        self.room_box = room.as_axis_aligned_box();
        self.room = Some(room);
        self
    }

    /// Shares it.
    pub fn shared(self) -> Arc<Self> {
        Arc::new(self)
    }

    /// Number of people (present or not).
    pub fn len(&self) -> usize {
        self.radii.len()
    }

    /// Whether there is nobody.
    pub fn is_empty(&self) -> bool {
        self.radii.is_empty()
    }

    /// Radius of person `i`.
    pub fn radius(&self, i: usize) -> f64 {
        self.radii[i]
    }

    /// All radii.
    pub fn radii(&self) -> &[f64] {
        &self.radii
    }

    /// The largest radius.
    pub fn max_radius(&self) -> f64 {
        self.max_radius
    }

    /// The room, if set.
    pub fn room(&self) -> Option<&Room> {
        self.room.as_ref()
    }

    /// Position of person `i` in `q`.
    pub fn position(q: &[f64], i: usize) -> [f64; 2] {
        [q[2 * i], q[2 * i + 1]]
    }

    /// Whether person `i` is still in the room at configuration `q`: not yet departed, and
    /// with a disk not wholly outside the room. A departure seen here is latched (the type's
    /// documentation), so `q` should be a configuration of the run (not a trial point).
    #[inline]
    pub fn is_present(&self, q: &[f64], i: usize) -> bool {
        if !self.has_arrived(i) {
            return false;
        }
        match &self.room {
            None => true,
            Some(room) => {
                if self.departed.get(i) {
                    return false;
                }
                let p = Self::position(q, i);
                let inside = self.strictly_in_box(p)
                    || room.contains(p)
                    || room.boundary_distance(p) < self.radii[i];
                if !inside {
                    self.departed.set(i);
                }
                inside
            }
        }
    }

    /// Whether `p` lies strictly inside the room when it is an axis-aligned rectangle (a
    /// shortcut of [`Room::contains`], asked for every person several times a step).
    #[inline]
    fn strictly_in_box(&self, p: [f64; 2]) -> bool {
        self.room_box
            .is_some_and(|[x0, y0, x1, y1]| x0 < p[0] && p[0] < x1 && y0 < p[1] && p[1] < y1)
    }

    /// Whether a room is set and `p` is not inside it ([`Room::contains`], with the
    /// rectangle's shortcut).
    pub fn outside_room(&self, p: [f64; 2]) -> bool {
        self.room
            .as_ref()
            .is_some_and(|room| !(self.strictly_in_box(p) || room.contains(p)))
    }

    /// Whether person `i` has been seen leaving (latched).
    #[inline]
    pub fn has_departed(&self, i: usize) -> bool {
        self.departed.get(i)
    }

    /// The largest displacement `|xᵢ − qᵢ|` of anyone not seen leaving (the present people
    /// and perhaps a few more: a bound on how far a person's linearization has drifted).
    pub fn largest_displacement(&self, q: &[f64], x: &[f64]) -> f64 {
        // The largest squared displacement, then one square root (monotone and correctly
        // rounded, so the same number as the largest root).
        (0..self.len())
            .filter(|&i| !self.has_departed(i))
            .map(|i| (x[2 * i] - q[2 * i]).powi(2) + (x[2 * i + 1] - q[2 * i + 1]).powi(2))
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// Clears every departure: the start of a new run from `q₀`.
    pub fn reset_departures(&self) {
        for b in &self.departed.0 {
            b.store(false, Ordering::Relaxed);
        }
    }

    /// Latches person `i` as departed: a run resumed from a state in which they had left
    /// (see [`crate::scene::BuiltScene::resume_at`]) starts with them gone, as the run that
    /// reached that state had them.
    pub fn set_departed(&self, i: usize) {
        self.departed.set(i);
    }

    /// How many people are still in the room.
    pub fn present_count(&self, q: &[f64]) -> usize {
        (0..self.len()).filter(|&i| self.is_present(q, i)).count()
    }

    /// Whether person `i` has arrived (always, for a population without arrivals).
    #[inline]
    pub fn has_arrived(&self, i: usize) -> bool {
        self.arrivals.as_ref().is_none_or(|a| a.arrived.get(i))
    }

    /// Whether people arrive during the run ([`with_arrivals`](Self::with_arrivals)).
    pub fn has_arrivals(&self) -> bool {
        self.arrivals.is_some()
    }

    /// When person `i` is due (`None`: there from the start).
    pub fn due(&self, i: usize) -> Option<f64> {
        self.arrivals.as_ref().and_then(|a| a.due[i])
    }

    /// How many people have not arrived yet.
    pub fn pending_count(&self) -> usize {
        self.arrivals.as_ref().map_or(0, |a| {
            (0..self.len()).filter(|&i| !a.arrived.get(i)).count()
        })
    }

    /// Nobody in the room and nobody still to come: a run may stop.
    pub fn is_done(&self, q: &[f64]) -> bool {
        self.pending_count() == 0 && self.present_count(q) == 0
    }

    /// Clears every arrival but those of the people there from the start: the start of a new
    /// run.
    pub fn reset_arrivals(&self) {
        if let Some(a) = &self.arrivals {
            a.reset();
        }
    }

    /// Latches person `i` as arrived by `t`, whatever their place: a run resumed from a state
    /// in which they were in the room or had left (see
    /// [`crate::scene::BuiltScene::resume_at`]) starts with them in, as the run that reached
    /// that state had them. Nothing for someone there from the start.
    pub fn set_arrived(&self, i: usize, t: f64) {
        let Some(a) = &self.arrivals else {
            return;
        };
        if a.due[i].is_some() && !a.arrived.get(i) {
            a.arrived.set(i);
            a.log.lock().unwrap_or_else(|e| e.into_inner()).arrived_at[i] = Some(t);
        }
    }

    /// Lets in, at time `t`, everybody due by `t` whose disk at their place in `q` overlaps
    /// nobody present (people due earlier first, then by index); who is due but finds their
    /// place taken waits, and the wait is recorded. Returns how many came in. A run calls it
    /// at its start and after every step ([`crate::scene::BuiltScene::run`] does).
    pub fn admit(&self, t: f64, q: &[f64]) -> usize {
        let Some(a) = &self.arrivals else {
            return 0;
        };
        let due: Vec<usize> = a
            .order
            .iter()
            .copied()
            .filter(|&i| !a.arrived.get(i) && a.due[i].is_some_and(|d| d <= t))
            .collect();
        if due.is_empty() {
            return 0;
        }
        // The present people by cell: a place is taken only by someone within 2 r_max.
        let cell = (2.0 * self.max_radius).max(1e-9);
        let key = |p: [f64; 2]| ((p[0] / cell).floor() as i64, (p[1] / cell).floor() as i64);
        let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> = Default::default();
        for j in (0..self.len()).filter(|&j| self.is_present(q, j)) {
            grid.entry(key(Self::position(q, j))).or_default().push(j);
        }
        let mut log = a.log.lock().unwrap_or_else(|e| e.into_inner());
        let mut admitted = 0;
        for i in due {
            let p = Self::position(q, i);
            let (kx, ky) = key(p);
            let taken = (-1..=1)
                .flat_map(|dx| (-1..=1).map(move |dy| (kx + dx, ky + dy)))
                .flat_map(|k| grid.get(&k).into_iter().flatten())
                .any(|&j| {
                    let pj = Self::position(q, j);
                    (p[0] - pj[0]).hypot(p[1] - pj[1]) < self.radii[i] + self.radii[j]
                });
            if taken {
                log.blocked_since[i].get_or_insert(t);
                continue;
            }
            a.arrived.set(i);
            log.arrived_at[i] = Some(t);
            grid.entry((kx, ky)).or_default().push(i);
            admitted += 1;
        }
        admitted
    }

    /// Who has arrived and who waited, at time `t` (`None` without arrivals).
    pub fn arrival_report(&self, t: f64) -> Option<ArrivalReport> {
        let a = self.arrivals.as_ref()?;
        let log = a.log.lock().unwrap_or_else(|e| e.into_inner());
        let mut r = ArrivalReport::default();
        for i in (0..self.len()).filter(|&i| a.due[i].is_some()) {
            r.scheduled += 1;
            let arrived = log.arrived_at[i];
            if arrived.is_some() {
                r.arrived += 1;
            }
            if let Some(since) = log.blocked_since[i] {
                let wait = arrived.unwrap_or(t) - since;
                r.waited += 1;
                r.total_wait += wait;
                r.longest_wait = r.longest_wait.max(wait);
                if arrived.is_none() {
                    r.still_waiting += 1;
                }
            }
        }
        Some(r)
    }
}

/// People arriving during a run: who is due when, who has arrived, who had to wait.
#[derive(Debug)]
struct Arrivals {
    due: Vec<Option<f64>>,
    /// The people due during the run, by due time (then index): the order of admission.
    order: Vec<usize>,
    arrived: Latches,
    log: Mutex<ArrivalLog>,
}

/// When each person arrived, and since when they waited for their place.
#[derive(Debug, Clone, PartialEq, Default)]
struct ArrivalLog {
    arrived_at: Vec<Option<f64>>,
    blocked_since: Vec<Option<f64>>,
}

impl Arrivals {
    fn new(due: Vec<Option<f64>>) -> Self {
        let mut order: Vec<usize> = (0..due.len()).filter(|&i| due[i].is_some()).collect();
        order.sort_by(|&i, &j| due[i].unwrap_or(0.0).total_cmp(&due[j].unwrap_or(0.0)));
        let a = Arrivals {
            arrived: Latches::new(due.len()),
            log: Mutex::new(ArrivalLog::default()),
            due,
            order,
        };
        a.reset();
        a
    }

    fn reset(&self) {
        for (i, d) in self.due.iter().enumerate() {
            self.arrived.0[i].store(d.is_none(), Ordering::Relaxed);
        }
        let n = self.due.len();
        *self.log.lock().unwrap_or_else(|e| e.into_inner()) = ArrivalLog {
            arrived_at: vec![None; n],
            blocked_since: vec![None; n],
        };
    }
}

impl Clone for Arrivals {
    fn clone(&self) -> Self {
        Arrivals {
            due: self.due.clone(),
            order: self.order.clone(),
            arrived: self.arrived.clone(),
            log: Mutex::new(self.log.lock().unwrap_or_else(|e| e.into_inner()).clone()),
        }
    }
}

impl PartialEq for Arrivals {
    fn eq(&self, other: &Self) -> bool {
        self.due == other.due && self.arrived == other.arrived
    }
}

/// Who arrived during a run, and who had to wait because their place was taken.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ArrivalReport {
    /// People due to arrive during the run.
    pub scheduled: usize,
    /// People who arrived.
    pub arrived: usize,
    /// People who found their place taken when due, and waited.
    pub waited: usize,
    /// People still waiting (due, place taken).
    pub still_waiting: usize,
    /// The longest wait, in seconds (up to now for who still waits).
    pub longest_wait: f64,
    /// The waits summed, in seconds.
    pub total_wait: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rectangle's shortcut says what the polygon test says: inside, outside, on an edge
    /// and at a corner, for a rectangle and for an L-shaped room; never outside without a room.
    #[test]
    fn outside_room_agrees_with_the_polygon_test() {
        let rectangle = Room::rectangle(0.0, 0.0, 4.0, 2.0);
        let l_shape = Room {
            vertices: vec![
                [0.0, 0.0],
                [4.0, 0.0],
                [4.0, 1.0],
                [1.0, 1.0],
                [1.0, 3.0],
                [0.0, 3.0],
            ],
        };
        let points = [
            [1.0, 1.0],
            [3.9, 0.1],
            [5.0, 1.0],
            [-1.0, 1.0],
            [0.0, 1.0],
            [4.0, 1.0],
            [2.0, 2.0],
            [2.0, 0.0],
            [0.0, 0.0],
            [4.0, 2.0],
            [0.5, 2.5],
            [2.0, 2.5],
        ];
        for room in [rectangle, l_shape] {
            let pop = Population::new(vec![0.2]).with_room(room.clone());
            for p in points {
                assert_eq!(pop.outside_room(p), !room.contains(p), "{p:?} in {room:?}");
            }
        }
        assert!(!Population::new(vec![0.2]).outside_room([1e9, 1e9]));
    }

    #[test]
    fn presence_needs_the_whole_disk_out() {
        let pop = Population::new(vec![0.2]).with_room(Room::rectangle(0.0, 0.0, 10.0, 10.0));
        assert!(pop.is_present(&[5.0, 5.0], 0));
        assert!(pop.is_present(&[10.1, 5.0], 0)); // half out
        assert!(!pop.is_present(&[10.25, 5.0], 0));
        assert_eq!(pop.present_count(&[10.25, 5.0]), 0);
    }

    #[test]
    fn once_left_always_left_until_reset() {
        let pop = Population::new(vec![0.2]).with_room(Room::rectangle(0.0, 0.0, 10.0, 10.0));
        assert!(!pop.is_present(&[10.25, 5.0], 0));
        // Back inside (a non-convex room's other arm): still gone.
        assert!(!pop.is_present(&[5.0, 5.0], 0));
        assert!(pop.has_departed(0));
        pop.reset_departures();
        assert!(pop.is_present(&[5.0, 5.0], 0));
    }

    /// An L-shaped hexagon: the unit squares at (0, 0), (1, 0) and (0, 1).
    const L_SHAPED: [[f64; 2]; 6] = [
        [0.0, 0.0],
        [2.0, 0.0],
        [2.0, 1.0],
        [1.0, 1.0],
        [1.0, 2.0],
        [0.0, 2.0],
    ];

    #[test]
    fn only_axis_aligned_rectangles_are_boxes() {
        let r = Room::rectangle(1.0, 2.0, 4.0, 3.0);
        assert_eq!(r.as_axis_aligned_box(), Some([1.0, 2.0, 4.0, 3.0]));
        // The same rectangle listed clockwise from another corner.
        let mut v = r.vertices.clone();
        v.reverse();
        v.rotate_left(1);
        assert_eq!(
            Room { vertices: v }.as_axis_aligned_box(),
            Some([1.0, 2.0, 4.0, 3.0])
        );
        for vertices in [
            // A rotated square, a trapezoid, a bow tie of the box's corners, a triangle,
            // two flat rectangles, an L-shaped hexagon.
            vec![[1.0, 0.0], [2.0, 1.0], [1.0, 2.0], [0.0, 1.0]],
            vec![[0.0, 0.0], [4.0, 0.0], [3.0, 1.0], [1.0, 1.0]],
            vec![[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]],
            vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 0.0]],
            vec![[0.0, 0.0], [0.0, 1.0], [0.0, 1.0], [0.0, 0.0]],
            L_SHAPED.to_vec(),
        ] {
            assert_eq!(
                Room {
                    vertices: vertices.clone()
                }
                .as_axis_aligned_box(),
                None,
                "{vertices:?}"
            );
        }
    }

    #[test]
    fn a_disk_exactly_its_radius_outside_has_left() {
        // 10.25 − 10 = 0.25 exactly: the disk touches the wall from outside.
        let pop = Population::new(vec![0.25]).with_room(Room::rectangle(0.0, 0.0, 10.0, 10.0));
        assert!(!pop.is_present(&[10.25, 5.0], 0));
        let pop = Population::new(vec![0.25]).with_room(Room::rectangle(0.0, 0.0, 10.0, 10.0));
        assert!(pop.is_present(&[10.2499, 5.0], 0));
    }

    #[test]
    fn presence_in_a_room_that_is_no_rectangle_walks_the_polygon() {
        // An L-shaped room: its corner (1.5, 1.5) is outside, (0.5, 1.5) deep inside.
        let room = Room {
            vertices: L_SHAPED.to_vec(),
        };
        let pop = Population::new(vec![0.1, 0.1]).with_room(room);
        assert!(pop.is_present(&[0.5, 1.5, 1.5, 1.5], 0));
        assert!(!pop.is_present(&[0.5, 1.5, 1.5, 1.5], 1));
    }

    proptest::proptest! {
        /// The box shortcut answers exactly as the polygon walk does, near and on the walls.
        #[test]
        fn the_box_shortcut_agrees_with_the_polygon(
            x in -1.0..11.0f64, y in -1.0..11.0f64, snap in 0usize..5, radius in 0usize..2,
        ) {
            // Points snapped onto a wall's line, where the even–odd rule is delicate, and
            // radius 0, where only that rule decides.
            let (x, y) = match snap {
                1 => (10.0, y),
                2 => (x, 0.0),
                3 => (0.0, y),
                4 => (x, 10.0),
                _ => (x, y),
            };
            let r = [0.2, 0.0][radius];
            let room = Room::rectangle(0.0, 0.0, 10.0, 10.0);
            let walked = room.contains([x, y]) || room.boundary_distance([x, y]) < r;
            let pop = Population::new(vec![r]).with_room(room);
            proptest::prop_assert_eq!(pop.is_present(&[x, y], 0), walked);
        }
    }
}
