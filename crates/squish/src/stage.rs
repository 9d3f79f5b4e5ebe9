//! The stages of a frame (thesis ch. 3, Fig. 3.1) and their wall-clock times: the one list of
//! stages that the pipeline, the contact and deformation stages, reports and benchmarks share.
//!
//! [`Stage::ALL`] is in pipeline order. The stages that are not [nested](Stage::is_nested) are
//! disjoint spans of a frame's time (summed over region pairs and regions); the nested ones are
//! shares of others (the factorizations of §5.1–5.3 and, within them, the analyses of coupled-row
//! submatrices). The columns of the thesis' tables 7.1–7.2 are the stages
//! [`in_thesis_tables`](Stage::in_thesis_tables).
//!
//! [`PerStage`] holds one value per stage, indexed by [`Stage`]; [`StageTimes`] is its durations
//! and [`StageWork`] its [`Work`]: a deterministic count of what each stage did (queries,
//! triangle tests, rounds, rows, factorization flops), the same on every machine and thread count,
//! which lets tests guard a stage's cost without a clock.
//! Serde writes it as a map from [`Stage::name`] to the value, in the order of [`Stage::ALL`]
//! (missing names read as the default value, unknown ones are an error).

use std::cell::Cell;
use std::fmt;
use std::marker::PhantomData;
use std::ops::{AddAssign, Index, IndexMut};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// One stage of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stage {
    /// Topology checks, normals, triangle trees of the objects; self-contact's caches of the rest
    /// pose (its own crossings, the articulations' shared regions), at its first frame.
    Setup,
    /// Choosing the working regions and updating their caches, a new region's symbolic analysis
    /// included (run when chapter 5 first factorizes the region, or an articulation's sides
    /// first touch).
    Regions,
    /// Self-contact of skinned articulations: the crease cut of each shared region (§6.1.3) and
    /// the truncated regions chapter 4 runs between (their sub-meshes, trees and normals).
    CreaseCut,
    /// Intersection regions.
    Intersection,
    /// Mapping direction and mapping regions.
    Mapping,
    /// Potential contact surface and contact zones.
    ContactZone,
    /// Radial parametrization: contact set, cut weights, heat step and Poisson solve.
    Parametrization,
    /// Direction field: normals, mapping-field diffusion and blend (or parallel transport).
    Directions,
    /// Amplitude and slope fields: estimation at ∂𝒞 and diffusion.
    Guide,
    /// Bulge map, profiles, volume cubic and final positions.
    Deformation,
    /// Self-contact of skinned articulations: the blend over each shared region and the bulge
    /// heights of the object's volume (§6, App. C).
    Blend,
    /// Self-contact between the parts of a skinned mesh: the touching pairs and their contacts.
    PartContacts,
    /// Self-contact: what the contacts leave crossing, smoothed out.
    Untangle,
    /// The separation pass: region pairs with a contact gap pushed apart, volumes solved again.
    Separation,
    /// The quality and warnings pass: penetrations and intersecting faces before and after,
    /// what the frame did not do.
    Quality,
    /// Of parametrization, directions and guide: assembling and numerically factorizing systems.
    Factorization,
    /// Of the factorizations: symbolic analyses of coupled-row submatrices.
    Analysis,
}

impl Stage {
    /// Number of stages.
    pub const COUNT: usize = 17;

    /// Every stage, in pipeline order.
    pub const ALL: [Stage; Self::COUNT] = [
        Self::Setup,
        Self::Regions,
        Self::CreaseCut,
        Self::Intersection,
        Self::Mapping,
        Self::ContactZone,
        Self::Parametrization,
        Self::Directions,
        Self::Guide,
        Self::Deformation,
        Self::Blend,
        Self::PartContacts,
        Self::Untangle,
        Self::Separation,
        Self::Quality,
        Self::Factorization,
        Self::Analysis,
    ];

    /// The key of reports (`snake_case`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Setup => "setup",
            Self::Regions => "regions",
            Self::CreaseCut => "crease_cut",
            Self::Intersection => "intersection",
            Self::Mapping => "mapping",
            Self::ContactZone => "contact_zone",
            Self::Parametrization => "parametrization",
            Self::Directions => "directions",
            Self::Guide => "guide",
            Self::Deformation => "deformation",
            Self::Blend => "blend",
            Self::PartContacts => "part_contacts",
            Self::Untangle => "untangle",
            Self::Separation => "separation",
            Self::Quality => "quality",
            Self::Factorization => "factorization",
            Self::Analysis => "analysis",
        }
    }

    /// A short column label: the thesis' abbreviations (tables 7.1–7.2) for its columns.
    pub const fn label(self) -> &'static str {
        match self {
            Self::Setup => "setup",
            Self::Regions => "reg.",
            Self::CreaseCut => "cut",
            Self::Intersection => "i.",
            Self::Mapping => "m.",
            Self::ContactZone => "c.",
            Self::Parametrization => "p.",
            Self::Directions => "di.",
            Self::Guide => "g.",
            Self::Deformation => "de.",
            Self::Blend => "bl.",
            Self::PartContacts => "parts",
            Self::Untangle => "unt.",
            Self::Separation => "sep.",
            Self::Quality => "q.",
            Self::Factorization => "s.",
            Self::Analysis => "an.",
        }
    }

    /// The thesis section the stage follows.
    pub const fn thesis_section(self) -> &'static str {
        match self {
            Self::Setup => "ch. 3",
            Self::Regions => "§4.5",
            Self::CreaseCut => "§6.1.3",
            Self::Intersection => "§4.1",
            Self::Mapping => "§4.2",
            Self::ContactZone => "§4.3–4.4",
            Self::Parametrization => "§5.1",
            Self::Directions => "§5.2",
            Self::Guide => "§5.3",
            Self::Deformation => "§5.4–5.5",
            Self::Blend => "§6, App. C",
            Self::PartContacts | Self::Untangle => "ch. 6 (beyond)",
            Self::Separation => "§4.3, App. C",
            Self::Quality => "§7.2",
            Self::Factorization | Self::Analysis => "App. B",
        }
    }

    /// True for a share of other stages' time rather than a span of its own: the factorizations
    /// (within parametrization, directions and guide) and the analyses (within the
    /// factorizations).
    pub const fn is_nested(self) -> bool {
        matches!(self, Self::Factorization | Self::Analysis)
    }

    /// True for the columns of the thesis' tables 7.1–7.2 (table 7.2's s. is the factorizations).
    pub const fn in_thesis_tables(self) -> bool {
        !matches!(
            self,
            Self::Setup
                | Self::Regions
                | Self::CreaseCut
                | Self::Blend
                | Self::PartContacts
                | Self::Untangle
                | Self::Separation
                | Self::Quality
                | Self::Analysis
        )
    }

    /// The stage of a report key.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The stages that are spans of their own (not [nested](Self::is_nested)), in order: together
    /// they take at most the frame's time on one thread.
    pub fn spans() -> impl Iterator<Item = Stage> {
        Self::ALL.into_iter().filter(|s| !s.is_nested())
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One value per [`Stage`], indexed by it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerStage<T>([T; Stage::COUNT]);

/// Wall-clock time spent in each stage, summed over region pairs (ch. 4) and regions (ch. 5): the
/// breakdown of the thesis' tables 7.1–7.2.
pub type StageTimes = PerStage<Duration>;

impl<T: Default> Default for PerStage<T> {
    fn default() -> Self {
        Self(std::array::from_fn(|_| T::default()))
    }
}

impl<T> PerStage<T> {
    /// The value of each stage from `value`.
    pub fn from_fn(mut value: impl FnMut(Stage) -> T) -> Self {
        Self(std::array::from_fn(|i| value(Stage::ALL[i])))
    }

    /// Every stage with its value, in the order of [`Stage::ALL`].
    pub fn iter(&self) -> impl Iterator<Item = (Stage, &T)> {
        Stage::ALL.into_iter().zip(&self.0)
    }

    /// The values mapped by `f`.
    pub fn map<U>(&self, mut f: impl FnMut(Stage, &T) -> U) -> PerStage<U> {
        PerStage::from_fn(|stage| f(stage, &self[stage]))
    }
}

/// A deterministic count of one stage's work in a frame: what a change that makes a stage do
/// more multiplies, whatever the machine, the load or the thread count. Each field counts one
/// kind of work where it is done; a stage leaves the kinds it does not do at zero.
///
/// **Counting.** The code that does the work records it ([`Work::record`], or the `count_*`
/// shorthands) into the *span* running on its thread; [`Work::measure`] runs a closure in a span of
/// its own and returns what was recorded in it, leaving the enclosing span as it was, so spans
/// nest and every unit is counted once, in the innermost span (a stage nested in another, the
/// factorizations in the parametrization, is counted apart from it). Work done by parallel
/// tasks reaches the span that started them through [`SharedWork`]: each task is measured, the
/// totals are summed and recorded once the tasks are done. Integer sums do not depend on the
/// order, so the counts are the same on any number of threads (tested); a task that is not
/// measured would leave its work in whichever span its thread is running.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Work {
    /// Traversals of a spatial tree (ray and segment casts, closest points, winding numbers, box
    /// and distance queries; one per query point).
    #[serde(default)]
    pub queries: u64,
    /// Primitive tests of a query point or segment against one triangle: exact segment–triangle
    /// crossings, triangle–triangle tests, closest points on a triangle, solid angles.
    #[serde(default)]
    pub triangle_tests: u64,
    /// Rounds of an iteration that runs until it converges (the separation pass, the extent's
    /// clamped re-solve).
    #[serde(default)]
    pub rounds: u64,
    /// Rows of the linear systems solved (one per unknown per right-hand side), or analyzed (the
    /// [`Stage::Analysis`] of coupled-row submatrices).
    #[serde(default)]
    pub rows: u64,
    /// Multiply-adds of the numeric factorizations (from their symbolic analyses, the columns
    /// recomputed: `Σ c_j²` over them, `c_j` the column counts).
    #[serde(default)]
    pub flops: u64,
}

impl AddAssign for Work {
    fn add_assign(&mut self, other: Work) {
        self.queries += other.queries;
        self.triangle_tests += other.triangle_tests;
        self.rounds += other.rounds;
        self.rows += other.rows;
        self.flops += other.flops;
    }
}

/// The span of work recorded on each thread (see [`Work`]).
struct Tally {
    queries: Cell<u64>,
    triangle_tests: Cell<u64>,
    rounds: Cell<u64>,
    rows: Cell<u64>,
    flops: Cell<u64>,
}

thread_local! {
    static TALLY: Tally = const {
        Tally {
            queries: Cell::new(0),
            triangle_tests: Cell::new(0),
            rounds: Cell::new(0),
            rows: Cell::new(0),
            flops: Cell::new(0),
        }
    };
}

impl Tally {
    fn take(&self) -> Work {
        Work {
            queries: self.queries.take(),
            triangle_tests: self.triangle_tests.take(),
            rounds: self.rounds.take(),
            rows: self.rows.take(),
            flops: self.flops.take(),
        }
    }

    fn add(&self, w: Work) {
        self.queries.set(self.queries.get() + w.queries);
        self.triangle_tests.set(self.triangle_tests.get() + w.triangle_tests);
        self.rounds.set(self.rounds.get() + w.rounds);
        self.rows.set(self.rows.get() + w.rows);
        self.flops.set(self.flops.get() + w.flops);
    }
}

impl Work {
    /// No work.
    pub const ZERO: Work = Work { queries: 0, triangle_tests: 0, rounds: 0, rows: 0, flops: 0 };

    /// The kinds of work with their report names, in a fixed order.
    pub fn fields(&self) -> [(&'static str, u64); 5] {
        [
            ("queries", self.queries),
            ("triangle_tests", self.triangle_tests),
            ("rounds", self.rounds),
            ("rows", self.rows),
            ("flops", self.flops),
        ]
    }

    /// True if every count is zero.
    pub fn is_zero(&self) -> bool {
        *self == Self::ZERO
    }

    /// Adds this work to the span running on this thread.
    pub fn record(self) {
        TALLY.with(|t| t.add(self));
    }

    /// Records `n` spatial queries.
    #[inline]
    pub fn count_queries(n: u64) {
        TALLY.with(|t| t.queries.set(t.queries.get() + n));
    }

    /// Records `n` primitive tests against a triangle.
    #[inline]
    pub fn count_triangle_tests(n: u64) {
        TALLY.with(|t| t.triangle_tests.set(t.triangle_tests.get() + n));
    }

    /// Records `n` rounds of an iteration.
    pub fn count_rounds(n: u64) {
        TALLY.with(|t| t.rounds.set(t.rounds.get() + n));
    }

    /// Records `n` rows solved.
    #[inline]
    pub fn count_rows(n: u64) {
        TALLY.with(|t| t.rows.set(t.rows.get() + n));
    }

    /// Records `n` factorization multiply-adds.
    pub fn count_flops(n: u64) {
        TALLY.with(|t| t.flops.set(t.flops.get() + n));
    }

    /// The work recorded in the current span since it began or since the last lap, which starts
    /// again from zero: the stages of a computation measured one after the other inside one
    /// [`Work::measure`].
    pub fn lap() -> Work {
        TALLY.with(Tally::take)
    }

    /// Runs `f` in a span of its own: its result and the work recorded in the span (see the
    /// type's doc). The enclosing span is left as it was.
    pub fn measure<R>(f: impl FnOnce() -> R) -> (R, Work) {
        let outer = TALLY.with(Tally::take);
        let result = f();
        let inner = TALLY.with(|t| {
            let inner = t.take();
            t.add(outer);
            inner
        });
        (result, inner)
    }
}

/// The work of parallel tasks, gathered for the span that started them (see [`Work`]): each task
/// runs in [`SharedWork::measure`], and [`SharedWork::record`] adds the total to the current
/// span once they are done.
#[derive(Debug, Default)]
pub struct SharedWork {
    queries: AtomicU64,
    triangle_tests: AtomicU64,
    rounds: AtomicU64,
    rows: AtomicU64,
    flops: AtomicU64,
}

impl SharedWork {
    /// Runs `f` in a span of its own and adds what it recorded to the shared total.
    pub fn measure<R>(&self, f: impl FnOnce() -> R) -> R {
        let (result, w) = Work::measure(f);
        if !w.is_zero() {
            self.queries.fetch_add(w.queries, Ordering::Relaxed);
            self.triangle_tests.fetch_add(w.triangle_tests, Ordering::Relaxed);
            self.rounds.fetch_add(w.rounds, Ordering::Relaxed);
            self.rows.fetch_add(w.rows, Ordering::Relaxed);
            self.flops.fetch_add(w.flops, Ordering::Relaxed);
        }
        result
    }

    /// The total so far.
    pub fn total(&self) -> Work {
        Work {
            queries: self.queries.load(Ordering::Relaxed),
            triangle_tests: self.triangle_tests.load(Ordering::Relaxed),
            rounds: self.rounds.load(Ordering::Relaxed),
            rows: self.rows.load(Ordering::Relaxed),
            flops: self.flops.load(Ordering::Relaxed),
        }
    }

    /// Adds the total to the span running on this thread.
    pub fn record(self) {
        self.total().record();
    }
}

/// The work of each stage in a frame (summed like [`StageTimes`]).
pub type StageWork = PerStage<Work>;

impl StageTimes {
    /// The times in milliseconds.
    pub fn millis(&self) -> PerStage<f64> {
        self.map(|_, d| d.as_secs_f64() * 1e3)
    }
}

impl<T> Index<Stage> for PerStage<T> {
    type Output = T;
    fn index(&self, stage: Stage) -> &T {
        &self.0[stage as usize]
    }
}

impl<T> IndexMut<Stage> for PerStage<T> {
    fn index_mut(&mut self, stage: Stage) -> &mut T {
        &mut self.0[stage as usize]
    }
}

impl<T: AddAssign + Copy> AddAssign<&PerStage<T>> for PerStage<T> {
    fn add_assign(&mut self, other: &PerStage<T>) {
        for (a, b) in self.0.iter_mut().zip(&other.0) {
            *a += *b;
        }
    }
}

impl<T: Serialize> Serialize for PerStage<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(Stage::COUNT))?;
        for (stage, value) in self.iter() {
            map.serialize_entry(stage.name(), value)?;
        }
        map.end()
    }
}

impl<'de, T: Deserialize<'de> + Default> Deserialize<'de> for PerStage<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct StageMap<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de> + Default> Visitor<'de> for StageMap<T> {
            type Value = PerStage<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a map from stage names to values")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut access: A) -> Result<Self::Value, A::Error> {
                let mut values = PerStage::default();
                while let Some(name) = access.next_key::<String>()? {
                    let stage = Stage::from_name(&name).ok_or_else(|| {
                        serde::de::Error::custom(format!(
                            "unknown stage \"{name}\"; the stages are {}",
                            Stage::ALL.map(Stage::name).join(", ")
                        ))
                    })?;
                    values[stage] = access.next_value()?;
                }
                Ok(values)
            }
        }
        deserializer.deserialize_map(StageMap(PhantomData))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_list_is_in_declaration_order_and_names_are_unique() {
        for (i, stage) in Stage::ALL.into_iter().enumerate() {
            assert_eq!(stage as usize, i, "{stage}");
            assert_eq!(Stage::from_name(stage.name()), Some(stage));
        }
        let mut names = Stage::ALL.map(Stage::name).to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Stage::COUNT);
    }

    #[test]
    fn nested_stages_are_shares_of_earlier_ones() {
        // A nested stage is timed within stages listed before it.
        let first_nested = Stage::ALL.iter().position(|s| s.is_nested()).unwrap_or(Stage::COUNT);
        assert!(Stage::ALL[first_nested..].iter().all(|s| s.is_nested()));
        assert_eq!(Stage::spans().count(), first_nested);
    }

    #[test]
    fn times_serialize_as_a_map_of_names_and_read_back() {
        let mut times = StageTimes::default();
        times[Stage::Regions] = Duration::from_millis(3);
        times += &times.clone();
        assert_eq!(times[Stage::Regions], Duration::from_millis(6));
        let json = serde_json::to_string(&times.millis()).unwrap();
        let keys: Vec<&str> = json.split('"').skip(1).step_by(2).collect();
        assert_eq!(keys, Stage::ALL.map(Stage::name), "{json}");
        assert!(json.contains(r#""regions":6.0"#), "{json}");
        let back: StageTimes = serde_json::from_str(&serde_json::to_string(&times).unwrap()).unwrap();
        assert_eq!(back, times);
        let missing: StageTimes = serde_json::from_str("{}").unwrap();
        assert_eq!(missing, StageTimes::default());
        assert!(serde_json::from_str::<StageTimes>(r#"{"warp": {"secs": 1, "nanos": 0}}"#).is_err());
    }
}
