//! A particle's landmark map: persistent (structurally shared) storage with a spatial
//! index, so resampled copies share everything and a write copies only the path to the
//! landmark it changes (docs/ALGORITHMS.md §1 step 6, DESIGN.md "Fast").
//!
//! Storage is two persistent B+ trees from `imbl` (16 entries per node):
//! - `by_cell`: key [`Slot`] `(cell_x, cell_y, id)` → [`Landmark`]. Cells are squares of side
//!   `cell_size` (m); landmarks of one cell column form contiguous key ranges, so a
//!   window query is one range scan per column. This *is* the spatial index — there is
//!   no second copy of the landmarks to keep in step.
//! - `cell_of`: `id` → cell, for lookups by id (known association) and removal.
//!
//! Beside them, the sorted ids of the *tentative* landmarks (`hits` below a threshold,
//! see [`LandmarkMap::track_tentative`]), kept up to date by every write: negative
//! evidence visits only those, by id, instead of scanning the sensor's footprint.
//!
//! Cloning a map is O(1) (two reference-count increments); an update, insertion or
//! removal costs O(log M) and copies O(log M) nodes of the writing particle only.

use crate::observation;
use crate::pose::Pose2;
use imbl::OrdMap;
use nalgebra::{Matrix2, Vector2};
use std::sync::Arc;

/// One landmark's Gaussian and its detection counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    /// Stable identity: the observation's id under known association, otherwise a
    /// per-particle counter.
    pub id: u64,
    /// Position estimate `μ` (m), world frame.
    pub mean: Vector2<f64>,
    /// Position covariance `Σ` (m²), symmetric positive definite.
    pub covariance: Matrix2<f64>,
    /// Scans in which an observation was assigned to this landmark (including the one
    /// that created it).
    pub hits: u32,
    /// Scans in which the landmark was inside the sensor footprint while still tentative
    /// (`hits < min_hits`); counting stops once it is confirmed, since a confirmed
    /// landmark is never removed (see `evidence`).
    pub chances: u32,
}

/// Grid cell coordinates (cell_x, cell_y).
type Cell = (i64, i64);

/// Where a landmark is stored in a map: its cell and id, the key the map keeps it under. A read
/// ([`LandmarkMap::locate`], [`LandmarkMap::within`]) hands it out so that a later write
/// of the same map ([`LandmarkMap::update_at`]) need not look the id up again. It stays
/// valid until that landmark moves to another cell or is removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Slot {
    cell_x: i64,
    cell_y: i64,
    id: u64,
}

impl Slot {
    /// The landmark's id.
    pub fn id(&self) -> u64 {
        self.id
    }

    fn new((cell_x, cell_y): Cell, id: u64) -> Self {
        Self { cell_x, cell_y, id }
    }

    fn cell(&self) -> Cell {
        (self.cell_x, self.cell_y)
    }
}

/// The id of the landmark that observation `index` of the scan at filter step `step`
/// creates under unknown association: `step · 2¹⁶ + index`, `None` past 2¹⁶ observations
/// (or at the end of the ids). Every particle that maps that observation as new gives it
/// this id, and no other landmark ever has it: an id names one object across the cloud,
/// which is what the smoothing back-end needs when the best particle changes lineage (a
/// per-particle counter would let two copies of one ancestor give one id to two
/// different landmarks). Ids grow with the step, so the smaller id is the older one.
pub fn new_landmark_id(step: u64, index: usize) -> Option<u64> {
    const PER_SCAN: u64 = 1 << 16;
    let index = u64::try_from(index).ok().filter(|&i| i < PER_SCAN)?;
    step.checked_mul(PER_SCAN)?.checked_add(index)
}

/// A particle's landmark map; see the module documentation for the layout and costs.
#[derive(Debug, Clone)]
pub struct LandmarkMap {
    by_cell: OrdMap<Slot, Landmark>,
    cell_of: OrdMap<u64, Cell>,
    /// Ids of the landmarks with `hits < tentative_below`, sorted; shared between copies
    /// until one of them changes the set.
    tentative: Arc<Vec<u64>>,
    /// Hits that confirm a landmark; 0 tracks nothing.
    tentative_below: u32,
    cell_size: f64,
}

impl LandmarkMap {
    /// An empty map whose spatial index uses square cells of `cell_size` metres
    /// (finite, > 0; the filter's config checks it).
    pub fn new(cell_size: f64) -> Self {
        Self {
            by_cell: OrdMap::new(),
            cell_of: OrdMap::new(),
            tentative: Arc::default(),
            tentative_below: 0,
            cell_size,
        }
    }

    /// The same map, keeping from now on the ids of its landmarks with fewer than
    /// `min_hits` hits (none for 0): negative evidence's `min_hits`.
    ///
    /// # Performance
    /// O(M) once; afterwards each write keeps the set in step in O(1), or O(T) for T
    /// tentative landmarks when a landmark joins or leaves it.
    pub fn track_tentative(mut self, min_hits: u32) -> Self {
        self.tentative_below = min_hits;
        let mut ids: Vec<u64> = self
            .by_cell
            .values()
            .filter(|l| l.hits < min_hits)
            .map(|l| l.id)
            .collect();
        ids.sort_unstable();
        self.tentative = Arc::new(ids);
        self
    }

    /// The hits below which a landmark counts as tentative (0: none is tracked).
    pub fn tentative_below(&self) -> u32 {
        self.tentative_below
    }

    /// Ids of the tentative landmarks, sorted (a shared handle: the map may be written
    /// while it is read).
    pub fn tentative(&self) -> Arc<Vec<u64>> {
        Arc::clone(&self.tentative)
    }

    /// Puts `id` in or out of the tentative set as its `hits` say.
    fn classify(&mut self, id: u64, hits: u32) {
        let tentative = hits < self.tentative_below;
        match (self.tentative.binary_search(&id), tentative) {
            (Err(at), true) => Arc::make_mut(&mut self.tentative).insert(at, id),
            (Ok(at), false) => {
                Arc::make_mut(&mut self.tentative).remove(at);
            }
            _ => {}
        }
    }

    /// Number of landmarks.
    pub fn len(&self) -> usize {
        self.cell_of.len()
    }

    /// True when the map holds no landmark.
    pub fn is_empty(&self) -> bool {
        self.cell_of.is_empty()
    }

    /// True when both maps are the very same storage (a resampled copy nobody has
    /// written to yet): sharing costs no memory.
    pub fn shares_storage_with(&self, other: &Self) -> bool {
        self.by_cell.ptr_eq(&other.by_cell)
            && self.cell_of.ptr_eq(&other.cell_of)
            && Arc::ptr_eq(&self.tentative, &other.tentative)
    }

    fn cell(&self, p: &Vector2<f64>) -> Cell {
        // Float-to-int `as` saturates, so far-away points land in the border cells.
        (
            (p[0] / self.cell_size).floor() as i64,
            (p[1] / self.cell_size).floor() as i64,
        )
    }

    /// The landmark with `id`.
    ///
    /// # Performance
    /// O(log M), two tree lookups.
    pub fn get(&self, id: u64) -> Option<&Landmark> {
        self.locate(id).map(|(_, landmark)| landmark)
    }

    /// The landmark with `id` and where it is stored, for a later
    /// [`update_at`](Self::update_at).
    ///
    /// # Performance
    /// O(log M), two tree lookups.
    pub fn locate(&self, id: u64) -> Option<(Slot, &Landmark)> {
        let slot = Slot::new(*self.cell_of.get(&id)?, id);
        self.by_cell.get(&slot).map(|landmark| (slot, landmark))
    }

    /// The landmark stored at `slot`, if it is still there.
    ///
    /// # Performance
    /// O(log M), one tree lookup.
    pub fn at(&self, slot: Slot) -> Option<&Landmark> {
        self.by_cell.get(&slot)
    }

    /// Every landmark, in spatial-index order (cell column, cell row, id).
    pub fn iter(&self) -> impl Iterator<Item = &Landmark> + '_ {
        self.by_cell.values()
    }

    /// Landmarks whose mean lies within `radius` metres of `centre`, with where they are
    /// stored.
    ///
    /// # Performance
    /// One range scan per cell column crossed by the disc's bounding box (columns are
    /// clipped to the map's extent): O(columns · log M + k) for k landmarks in the box,
    /// independent of M for a fixed landmark density.
    pub fn within(
        &self,
        centre: Vector2<f64>,
        radius: f64,
    ) -> impl Iterator<Item = (Slot, &Landmark)> + '_ {
        let (lo_x, lo_y) = self.cell(&(centre - Vector2::repeat(radius)));
        let (hi_x, hi_y) = self.cell(&(centre + Vector2::repeat(radius)));
        let first_column = self.by_cell.get_min().map_or(0, |(slot, _)| slot.cell_x);
        let last_column = self.by_cell.get_max().map_or(-1, |(slot, _)| slot.cell_x);
        let radius_squared = radius * radius;
        (lo_x.max(first_column)..=hi_x.min(last_column))
            .flat_map(move |cx| {
                self.by_cell
                    .range(Slot::new((cx, lo_y), 0)..=Slot::new((cx, hi_y), u64::MAX))
            })
            .filter(move |(_, landmark)| (landmark.mean - centre).norm_squared() <= radius_squared)
            .map(|(slot, landmark)| (*slot, landmark))
    }

    /// Inserts `landmark`, replacing any landmark with the same id.
    ///
    /// # Performance
    /// O(log M); copies the touched tree paths if they are shared.
    pub fn insert(&mut self, landmark: Landmark) {
        self.remove(landmark.id);
        let cell = self.cell(&landmark.mean);
        self.cell_of.insert(landmark.id, cell);
        self.classify(landmark.id, landmark.hits);
        self.by_cell.insert(Slot::new(cell, landmark.id), landmark);
    }

    /// Applies `change` to the landmark with `id`, moving it in the spatial index if its
    /// mean left its cell. Returns false (and does nothing) when there is no such id.
    ///
    /// # Performance
    /// O(log M); copies only the tree path to this landmark if it is shared.
    pub fn update(&mut self, id: u64, change: impl FnOnce(&mut Landmark)) -> bool {
        match self.cell_of.get(&id) {
            Some(&cell) => self.update_at(Slot::new(cell, id), change),
            None => false,
        }
    }

    /// [`update`](Self::update) of the landmark stored at `slot` (from a read of this
    /// map since it last moved or removed that landmark); false, doing nothing, when it is
    /// not there.
    ///
    /// # Performance
    /// O(log M), one tree walk fewer than [`update`](Self::update).
    pub fn update_at(&mut self, slot: Slot, change: impl FnOnce(&mut Landmark)) -> bool {
        let Some(landmark) = self.by_cell.get_mut(&slot) else {
            return false;
        };
        let hits_before = landmark.hits;
        change(landmark);
        let (mean, hits) = (landmark.mean, landmark.hits);
        if hits != hits_before {
            self.classify(slot.id, hits);
        }
        let moved_to = self.cell(&mean);
        if moved_to != slot.cell()
            && let Some(landmark) = self.by_cell.remove(&slot)
        {
            self.by_cell.insert(Slot::new(moved_to, slot.id), landmark);
            self.cell_of.insert(slot.id, moved_to);
        }
        true
    }

    /// Removes and returns the landmark with `id`.
    pub fn remove(&mut self, id: u64) -> Option<Landmark> {
        let cell = self.cell_of.remove(&id)?;
        self.classify(id, u32::MAX);
        self.by_cell.remove(&Slot::new(cell, id))
    }

    /// A landmark built from one observation `z` seen from `pose` ([`observation::initialise`]).
    pub fn landmark_from(
        id: u64,
        pose: &Pose2,
        z: &Vector2<f64>,
        noise: &Matrix2<f64>,
    ) -> Landmark {
        let (mean, covariance) = observation::initialise(pose, z, noise);
        Landmark {
            id,
            mean,
            covariance,
            hits: 1,
            chances: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn landmark(id: u64, x: f64, y: f64) -> Landmark {
        Landmark {
            id,
            mean: Vector2::new(x, y),
            covariance: Matrix2::identity(),
            hits: 1,
            chances: 0,
        }
    }

    #[test]
    fn window_query_finds_exactly_the_landmarks_in_the_disc() {
        let mut map = LandmarkMap::new(5.0);
        let mut id = 0;
        for i in -20..20 {
            for j in -20..20 {
                map.insert(landmark(id, i as f64 * 2.5 + 0.3, j as f64 * 2.5 - 0.7));
                id += 1;
            }
        }
        let centre = Vector2::new(3.3, -4.1);
        let mut found: Vec<u64> = map.within(centre, 7.0).map(|(slot, _)| slot.id()).collect();
        found.sort_unstable();
        let mut expected: Vec<u64> = map
            .iter()
            .filter(|l| (l.mean - centre).norm() <= 7.0)
            .map(|l| l.id)
            .collect();
        expected.sort_unstable();
        assert!(!expected.is_empty());
        assert_eq!(found, expected);
        assert_eq!(map.within(Vector2::new(1e6, 1e6), 10.0).count(), 0);
        assert_eq!(map.within(Vector2::zeros(), 1e300).count(), map.len());
    }

    #[test]
    fn update_moves_a_landmark_between_cells() {
        let mut map = LandmarkMap::new(5.0);
        map.insert(landmark(7, 1.0, 1.0));
        assert!(map.update(7, |l| l.mean = Vector2::new(12.0, -3.0)));
        assert_eq!(map.get(7).unwrap().mean, Vector2::new(12.0, -3.0));
        assert_eq!(map.within(Vector2::new(12.0, -3.0), 0.5).count(), 1);
        assert_eq!(map.within(Vector2::new(1.0, 1.0), 0.5).count(), 0);
        assert_eq!(map.len(), 1);
        assert!(!map.update(8, |_| ()));
        assert_eq!(map.remove(7).map(|l| l.id), Some(7));
        assert!(map.is_empty());
    }

    #[test]
    fn copies_share_storage_until_one_writes() {
        let mut parent = LandmarkMap::new(5.0);
        (0..1000).for_each(|i| parent.insert(landmark(i, i as f64, 0.0)));
        let mut child = parent.clone();
        assert!(child.shares_storage_with(&parent));
        child.update(3, |l| l.hits += 1);
        assert!(!child.shares_storage_with(&parent));
        assert_eq!(
            parent.get(3).unwrap().hits,
            1,
            "the parent never sees the child's write"
        );
        assert_eq!(child.get(3).unwrap().hits, 2);
        assert_eq!(child.get(4), parent.get(4));
    }

    #[test]
    fn the_tentative_set_follows_every_write() {
        let tentative = |m: &LandmarkMap| m.tentative().as_ref().clone();
        let mut map = LandmarkMap::new(5.0);
        map.insert(Landmark {
            hits: 3,
            ..landmark(9, 0.0, 0.0)
        });
        let mut map = map.track_tentative(2);
        assert_eq!(
            tentative(&map),
            Vec::<u64>::new(),
            "built from the contents"
        );
        (0..4).for_each(|i| map.insert(landmark(i, i as f64, 0.0)));
        assert_eq!(tentative(&map), vec![0, 1, 2, 3]);
        let before = map.clone();
        map.update(2, |l| l.hits += 1); // confirmed
        map.update(1, |l| l.mean.x += 20.0); // moved, still tentative
        map.remove(3);
        map.update(9, |l| l.hits = 1); // back below the threshold
        assert_eq!(tentative(&map), vec![0, 1, 9]);
        assert_eq!(
            tentative(&before),
            vec![0, 1, 2, 3],
            "the copy keeps its own"
        );
        let rebuilt = map.clone().track_tentative(2);
        assert_eq!(tentative(&rebuilt), tentative(&map));
        assert!(LandmarkMap::new(5.0).tentative().is_empty());
    }

    #[test]
    fn a_new_landmark_id_names_its_scan_and_observation() {
        assert_eq!(new_landmark_id(0, 0), Some(0));
        assert_eq!(new_landmark_id(3, 7), Some(3 * 65_536 + 7));
        assert_ne!(new_landmark_id(3, 65_535), new_landmark_id(4, 0));
        assert_eq!(new_landmark_id(3, 65_536), None);
    }
}
