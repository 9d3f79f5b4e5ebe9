//! Parallel batches of queries on a [`TriangleBvh`], with results in input order.
//!
//! The collision detection of thesis §4.1 intersects every edge of one working region with the
//! other (and back), and the mapping of §4.2.2 casts one ray per vertex: thousands to hundreds of
//! thousands of independent queries per frame. They run on rayon's pool in fixed-size chunks;
//! each chunk writes into its own buffers and the chunks are concatenated in input order, so the
//! output does not depend on the number of threads or on scheduling.

use glam::DVec3;
use rayon::prelude::*;

use super::bvh::TriangleBvh;
use super::queries::{ClosestPoint, Hit, Ray, hit_order};
use crate::stage::SharedWork;

/// Queries per parallel task: large enough to amortize task overhead, small enough to balance.
const CHUNK: usize = 128;

/// Results of a batch of queries, stored flat: the results of query `i` are [`Self::get`]`(i)`,
/// in the order the single query returns them.
#[derive(Clone, Debug, PartialEq)]
pub struct Batch<T> {
    offsets: Vec<usize>,
    hits: Vec<T>,
}

/// Hits of a batch of segment or ray queries; each query's hits are sorted like
/// [`TriangleBvh::segment_hits`].
pub type BatchHits = Batch<Hit>;

impl<T> Default for Batch<T> {
    fn default() -> Self {
        Self { offsets: Vec::new(), hits: Vec::new() }
    }
}

impl<T> Batch<T> {
    /// Number of queries.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// True if there was no query.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The results of query `i` (empty if `i` is out of range).
    pub fn get(&self, i: usize) -> &[T] {
        match (self.offsets.get(i), self.offsets.get(i + 1)) {
            (Some(&s), Some(&e)) => &self.hits[s..e],
            _ => &[],
        }
    }

    /// The results of each query, in query order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[T]> + '_ {
        self.offsets.windows(2).map(|w| &self.hits[w[0]..w[1]])
    }

    /// All results, query after query.
    pub fn all(&self) -> &[T] {
        &self.hits
    }

    /// Total number of results.
    pub fn total(&self) -> usize {
        self.hits.len()
    }
}

impl<T> Batch<T> {
    /// A batch from its flat parts: the results of query `i` are `hits[offsets[i]..offsets[i + 1]]`
    /// (`offsets` starts at 0, is non-decreasing and ends at `hits.len()`).
    pub(crate) fn from_parts(offsets: Vec<usize>, hits: Vec<T>) -> Self {
        debug_assert!(offsets.first().is_none_or(|&o| o == 0) && offsets.last().is_none_or(|&o| o == hits.len()));
        Self { offsets, hits }
    }
}

impl<T: Clone + Send> Batch<T> {
    /// Runs `run(query, out)` (which must clear `out` and fill it) on every query in parallel.
    /// A batch of at most one chunk runs on the calling thread (no task to split).
    pub(crate) fn gather<Q: Sync>(queries: &[Q], run: impl Fn(&Q, &mut Vec<T>) + Sync) -> Self {
        if queries.len() <= CHUNK {
            let mut offsets = Vec::with_capacity(queries.len() + 1);
            let (mut hits, mut scratch) = (Vec::new(), Vec::new());
            offsets.push(0);
            for q in queries {
                run(q, &mut scratch);
                hits.extend_from_slice(&scratch);
                offsets.push(hits.len());
            }
            return Self { offsets, hits };
        }
        let work = SharedWork::default();
        let chunks: Vec<(Vec<usize>, Vec<T>)> = queries
            .par_chunks(CHUNK)
            .map(|chunk| {
                work.measure(|| {
                    let mut counts = Vec::with_capacity(chunk.len());
                    let mut hits = Vec::new();
                    let mut scratch = Vec::new();
                    for q in chunk {
                        run(q, &mut scratch);
                        counts.push(scratch.len());
                        hits.extend_from_slice(&scratch);
                    }
                    (counts, hits)
                })
            })
            .collect();
        work.record();
        let total = chunks.iter().map(|c| c.1.len()).sum();
        let mut offsets = Vec::with_capacity(queries.len() + 1);
        let mut hits = Vec::with_capacity(total);
        offsets.push(0);
        for (counts, chunk_hits) in chunks {
            for n in counts {
                offsets.push(offsets[offsets.len() - 1] + n);
            }
            hits.extend(chunk_hits);
        }
        Self { offsets, hits }
    }
}

impl TriangleBvh {
    /// [`Self::segment_hits`] for each segment `[a, b]`, in parallel; results in input order.
    pub fn segment_hits_batch(&self, segments: &[[DVec3; 2]]) -> BatchHits {
        BatchHits::gather(segments, |&[a, b], out| self.segment_hits(a, b, out))
    }

    /// [`Self::segment_hits`] for the edges `[positions[i], positions[j]]` of another mesh (e.g.
    /// the edges of the opposite working region, thesis §4.1), in parallel, in input order.
    /// Edges with an out-of-range index have no hit.
    pub fn edge_hits_batch(&self, positions: &[DVec3], edges: &[[u32; 2]]) -> BatchHits {
        BatchHits::gather(edges, |&[i, j], out| match (positions.get(i as usize), positions.get(j as usize)) {
            (Some(&a), Some(&b)) => self.segment_hits(a, b, out),
            _ => out.clear(),
        })
    }

    /// [`Self::ray_hits`] for each ray, in parallel; results in input order.
    pub fn ray_hits_batch(&self, rays: &[Ray]) -> BatchHits {
        BatchHits::gather(rays, |ray, out| {
            out.clear();
            self.for_each_ray_hit(ray, |h| out.push(h));
            out.sort_unstable_by(hit_order);
        })
    }

    /// [`Self::ray_nearest`] for each ray, in parallel; results in input order.
    pub fn ray_nearest_batch(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        let work = SharedWork::default();
        let hits = rays.par_iter().with_min_len(CHUNK / 4).map(|r| work.measure(|| self.ray_nearest(r))).collect();
        work.record();
        hits
    }

    /// [`Self::ray_farthest`] for each ray, in parallel; results in input order (the vertex
    /// matching of thesis §4.2.2).
    pub fn ray_farthest_batch(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        let work = SharedWork::default();
        let hits = rays.par_iter().with_min_len(CHUNK / 4).map(|r| work.measure(|| self.ray_farthest(r))).collect();
        work.record();
        hits
    }

    /// [`Self::closest_point`] for each point, in parallel; results in input order.
    pub fn closest_point_batch(&self, points: &[DVec3]) -> Vec<Option<ClosestPoint>> {
        let work = SharedWork::default();
        let found =
            points.par_iter().with_min_len(CHUNK / 4).map(|&p| work.measure(|| self.closest_point(p))).collect();
        work.record();
        found
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::mesh::{Topology, shapes};
    use std::time::Instant;

    fn pseudo_random_segments(n: usize, seed: u64, scale: f64) -> Vec<[DVec3; 2]> {
        let mut lcg = Lcg::from_state(seed);
        let mut rnd = move || lcg.next_signed() * scale;
        (0..n).map(|_| [DVec3::new(rnd(), rnd(), rnd()), DVec3::new(rnd(), rnd(), rnd())]).collect()
    }

    #[test]
    fn batch_results_match_single_queries_and_do_not_depend_on_thread_count() {
        let mesh = shapes::icosphere(1.0, 4);
        let tree = TriangleBvh::new(&mesh).unwrap();
        let segments = pseudo_random_segments(3000, 42, 1.5);
        let rays: Vec<Ray> = segments.iter().map(|&[a, b]| Ray::new(a, b - a)).collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                (
                    tree.segment_hits_batch(&segments),
                    tree.ray_hits_batch(&rays),
                    tree.ray_farthest_batch(&rays),
                    tree.ray_nearest_batch(&rays),
                    tree.closest_point_batch(&segments.iter().map(|s| s[0]).collect::<Vec<_>>()),
                )
            })
        };
        let one = run(1);
        let four = run(4);
        assert_eq!(one, four);
        let (seg_hits, ray_hits, farthest, nearest, _) = &one;
        assert_eq!(seg_hits.len(), segments.len());
        assert!(seg_hits.total() > 1000);
        let mut single = Vec::new();
        for (i, &[a, b]) in segments.iter().enumerate() {
            tree.segment_hits(a, b, &mut single);
            assert_eq!(seg_hits.get(i), &single[..]);
            let hits = ray_hits.get(i);
            assert_eq!(farthest[i], hits.last().copied());
            assert_eq!(nearest[i], hits.first().copied());
        }
        // Edges of another mesh.
        let other = shapes::cube(1.2, 6);
        let edges = Topology::new(&other).edges().to_vec();
        let by_edge = tree.edge_hits_batch(&other.positions, &edges);
        assert_eq!(by_edge.len(), edges.len());
        assert!(by_edge.total() > 0);
    }

    /// Timings (run with `cargo test -p squish spatial_timings -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn spatial_timings() {
        let time = |name: &str, f: &mut dyn FnMut() -> usize| {
            let t0 = Instant::now();
            let n = f();
            println!("  {name:<46} {:>9.2} ms  ({n} results)", t0.elapsed().as_secs_f64() * 1e3);
        };
        println!("{} rayon threads", rayon::current_num_threads());
        for (label, mesh) in [
            ("UV sphere 200 × 101", shapes::uv_sphere(1.0, 200, 101)),
            ("icosphere level 6", shapes::icosphere(1.0, 6)),
        ] {
            println!("{label}: {} triangles", mesh.num_triangles());
            let mut tree = None;
            time("build", &mut || {
                tree = Some(TriangleBvh::new(&mesh).unwrap());
                1
            });
            let mut tree = tree.unwrap();
            let moved: Vec<DVec3> = mesh.positions.iter().map(|p| *p * 1.01).collect();
            time("refit", &mut || {
                tree.refit(&moved).unwrap();
                1
            });
            tree.refit(&mesh.positions).unwrap();
            let segments = pseudo_random_segments(100_000, 1, 1.2);
            // Edge-like segments: about one mesh edge long, near the surface.
            let edge_len = 2.0 * std::f64::consts::PI / 200.0;
            let short: Vec<[DVec3; 2]> = segments
                .iter()
                .map(|&[a, b]| {
                    let p = a.normalize_or_zero();
                    [p * 0.99, p * 0.99 + (b - a).normalize_or_zero() * edge_len]
                })
                .collect();
            let rays: Vec<Ray> = segments.iter().map(|&[a, b]| Ray::new(a, b - a)).collect();
            let points: Vec<DVec3> = segments.iter().map(|s| s[0]).collect();
            time("100k long segments, all hits, 1 thread", &mut || {
                let mut out = Vec::new();
                segments
                    .iter()
                    .map(|&[a, b]| {
                        tree.segment_hits(a, b, &mut out);
                        out.len()
                    })
                    .sum()
            });
            time("100k long segments, all hits, batch", &mut || tree.segment_hits_batch(&segments).total());
            time("100k edge-like segments, batch", &mut || tree.segment_hits_batch(&short).total());
            time("100k rays, farthest hit, batch", &mut || tree.ray_farthest_batch(&rays).iter().flatten().count());
            time("100k rays, nearest hit, batch", &mut || tree.ray_nearest_batch(&rays).iter().flatten().count());
            time("100k closest points, batch", &mut || tree.closest_point_batch(&points).iter().flatten().count());
            let near_surface: Vec<DVec3> =
                points.iter().map(|p| p.normalize_or_zero() * (0.95 + 0.1 * (p.x * 40.0).sin().abs())).collect();
            time("100k closest points near the surface, batch", &mut || {
                tree.closest_point_batch(&near_surface).iter().flatten().count()
            });
            time("100k winding numbers (crossings), parallel", &mut || {
                points.par_iter().map(|&p| tree.winding_number(p)).filter(|&w| w != 0).count()
            });
            time("self-intersections (faces found)", &mut || {
                super::super::self_intersections(&mesh).unwrap().faces.len()
            });
            let mut other = shapes::icosphere(0.8, 5);
            other.map_positions(|p| p + DVec3::new(1.0, 0.1, 0.2));
            time("build + pairs vs a 20k-face sphere", &mut || {
                let other_tree = TriangleBvh::new(&other).unwrap();
                tree.intersections_with(&other_tree).len()
            });
        }
    }
}
