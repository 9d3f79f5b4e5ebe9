//! 2D segments bucketed in horizontal slabs, for the crossing queries of the mapping's projected
//! region (thesis §4.2.2): is a projected vertex inside the contour (a horizontal ray to the
//! right, counting crossings), and where does a projected edge cross it.
//!
//! The same exact answers as [`super::SegmentTree2`] (tested): candidates are every stored segment
//! whose box meets the query's box (inclusive comparisons, so nothing the exact test could count
//! is dropped), and each candidate goes through the same exact predicate
//! ([`super::exact::segment_segment_2d`]). A contour has tens to hundreds of segments and is
//! queried a few hundred times, once per frame and side: building the slabs is a sort of the
//! segments' lowest points and a counting sort (the tree's build was a quarter of the projected
//! region's time), and a horizontal ray reads one slab of about √m segments.

use glam::DVec2;

use super::SpatialError;
use super::aabb_tree::Segment2Hit;
use super::batch::Batch;
use super::exact::segment_segment_2d;

/// Segments bucketed by the horizontal slabs their y-range meets; see the module doc.
#[derive(Clone, Debug)]
pub struct SegmentSlabs {
    segments: Vec<[DVec2; 2]>,
    /// Per segment: its box (min, max).
    boxes: Vec<(DVec2, DVec2)>,
    /// The heights between slabs, increasing: slab k is `[tops[k − 1], tops[k])` (unbounded at
    /// both ends). They are quantiles of the segments' lowest points, so each slab starts about
    /// √m segments even when the contour has several far-apart parts.
    tops: Vec<f64>,
    /// `items[slab_start[k]..slab_start[k + 1]]`: the segments meeting slab k, increasing.
    slab_start: Vec<usize>,
    items: Vec<u32>,
}

impl SegmentSlabs {
    /// Buckets finite segments (an error names the first one that is not).
    pub fn new(segments: &[[DVec2; 2]]) -> Result<Self, SpatialError> {
        let boxes: Vec<(DVec2, DVec2)> = segments.iter().map(|s| (s[0].min(s[1]), s[0].max(s[1]))).collect();
        if let Some(index) = segments.iter().position(|s| !(s[0].is_finite() && s[1].is_finite())) {
            let (min, max) = boxes[index];
            return Err(SpatialError::InvalidBox {
                index,
                min: min.extend(0.0).to_array(),
                max: max.extend(0.0).to_array(),
            });
        }
        // About √m slabs of about √m segments each.
        let slabs = ((segments.len() as f64).sqrt().ceil() as usize).clamp(1, 1024);
        let mut lows: Vec<f64> = boxes.iter().map(|b| b.0.y).collect();
        lows.sort_unstable_by(f64::total_cmp);
        let mut tops: Vec<f64> = (1..slabs).map(|k| lows[k * lows.len() / slabs]).collect();
        tops.dedup();
        let slabs = tops.len() + 1;
        let mut this =
            Self { segments: segments.to_vec(), boxes, tops, slab_start: vec![0; slabs + 1], items: Vec::new() };
        for b in &this.boxes {
            let (first, last) = (this.slab(b.0.y), this.slab(b.1.y));
            for k in first..=last {
                this.slab_start[k + 1] += 1;
            }
        }
        for k in 0..slabs {
            this.slab_start[k + 1] += this.slab_start[k];
        }
        let mut next = this.slab_start.clone();
        this.items = vec![0; this.slab_start[slabs]];
        for (i, b) in this.boxes.iter().enumerate() {
            let (first, last) = (this.slab(b.0.y), this.slab(b.1.y));
            for slot in &mut next[first..=last] {
                this.items[*slot] = i as u32;
                *slot += 1;
            }
        }
        Ok(this)
    }

    /// The slab of height y: monotone in y, so two overlapping y-ranges meet a common slab.
    #[inline]
    fn slab(&self, y: f64) -> usize {
        self.tops.partition_point(|&top| top <= y)
    }

    /// The segments, in input order.
    pub fn segments(&self) -> &[[DVec2; 2]] {
        &self.segments
    }

    /// All crossings of `[p, q]` with the stored segments, sorted along the query then by segment
    /// index, written to `out` (the rule of [`super::SegmentTree2::crossings`]).
    pub fn crossings(&self, p: DVec2, q: DVec2, out: &mut Vec<Segment2Hit>) {
        out.clear();
        let (lo, hi) = (p.min(q), p.max(q));
        let (first, last) = (self.slab(lo.y), self.slab(hi.y));
        for k in first..=last {
            for &i in &self.items[self.slab_start[k]..self.slab_start[k + 1]] {
                let b = self.boxes[i as usize];
                // Report a segment in the first slab it shares with the query only.
                if k != first && self.slab(b.0.y) < k {
                    continue;
                }
                if b.0.cmpgt(hi).any() || b.1.cmplt(lo).any() {
                    continue;
                }
                let [u, v] = self.segments[i as usize];
                if let Some(c) = segment_segment_2d(p, q, u, v) {
                    out.push(Segment2Hit { segment: i, s: c.s, t: c.t });
                }
            }
        }
        out.sort_unstable_by(|x, y| x.s.total_cmp(&y.s).then(x.segment.cmp(&y.segment)));
    }

    /// [`Self::crossings`] for each query segment `[p, q]`, in parallel; results in input order.
    pub fn crossings_batch(&self, queries: &[[DVec2; 2]]) -> Batch<Segment2Hit> {
        Batch::gather(queries, |&[p, q], out| self.crossings(p, q, out))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::spatial::SegmentTree2;

    #[test]
    fn the_slabs_answer_like_the_tree() {
        let mut rng = Lcg::new(17);
        for case in 0..40 {
            // A closed polygon (shared endpoints, as a region outline), on a lattice half the time
            // so that queries pass through its vertices and along its edges.
            let count = 3 + rng.next_index(120);
            let lattice = case % 2 == 0;
            let point = |rng: &mut Lcg| {
                let (x, y) = (rng.next_index(41) as f64 / 20.0 - 1.0, rng.next_index(41) as f64 / 20.0 - 1.0);
                if lattice { DVec2::new(x, y) } else { DVec2::new(x + 1e-3 * rng.next_index(1000) as f64, y) }
            };
            let corners: Vec<DVec2> = (0..count).map(|_| point(&mut rng)).collect();
            let segments: Vec<[DVec2; 2]> = (0..count).map(|k| [corners[k], corners[(k + 1) % count]]).collect();
            let tree = SegmentTree2::new(&segments).unwrap();
            let slabs = SegmentSlabs::new(&segments).unwrap();
            let mut queries: Vec<[DVec2; 2]> = (0..300).map(|_| [point(&mut rng), point(&mut rng)]).collect();
            // Horizontal rays to the right, as the inside test casts them.
            queries.extend((0..300).map(|_| {
                let p = point(&mut rng);
                [p, DVec2::new(5.0, p.y)]
            }));
            queries.push([DVec2::new(-3.0, -3.0), DVec2::new(-2.0, -2.5)]);
            let expected = tree.crossings_batch(&queries);
            let got = slabs.crossings_batch(&queries);
            assert_eq!(got, expected, "case {case}");
            assert!(expected.total() > 0);
        }
        assert!(SegmentSlabs::new(&[[DVec2::ZERO, DVec2::new(f64::NAN, 0.0)]]).is_err());
        let empty = SegmentSlabs::new(&[]).unwrap();
        let mut out = vec![Segment2Hit { segment: 0, s: 0.0, t: 0.0 }];
        empty.crossings(DVec2::ZERO, DVec2::ONE, &mut out);
        assert!(out.is_empty());
        // Two far-apart contours, one tiny: the slabs still split the big one.
        let ring = |centre: DVec2, radius: f64, count: usize| -> Vec<[DVec2; 2]> {
            let at = |k: usize| {
                let a = k as f64 / count as f64 * std::f64::consts::TAU;
                centre + radius * DVec2::new(a.cos(), a.sin())
            };
            (0..count).map(|k| [at(k), at(k + 1)]).collect()
        };
        let mut parts = ring(DVec2::ZERO, 1.0, 400);
        parts.extend(ring(DVec2::new(0.0, 1e6), 1e-3, 12));
        let (slabs, tree) = (SegmentSlabs::new(&parts).unwrap(), SegmentTree2::new(&parts).unwrap());
        assert!(slabs.slab_start.len() > 10);
        let widest = (0..slabs.slab_start.len() - 1).map(|k| slabs.slab_start[k + 1] - slabs.slab_start[k]).max();
        assert!(widest.unwrap() < 80, "{widest:?}");
        let rays: Vec<[DVec2; 2]> = (0..200)
            .map(|k| {
                let p = DVec2::new(0.3, k as f64 / 100.0 - 1.0);
                [p, DVec2::new(5.0, p.y)]
            })
            .chain([[DVec2::new(-0.0005, 1e6), DVec2::new(5.0, 1e6)]])
            .collect();
        assert_eq!(slabs.crossings_batch(&rays), tree.crossings_batch(&rays));
        // All segments on one horizontal line (zero-height span).
        let flat = [[DVec2::new(0.0, 0.5), DVec2::new(1.0, 0.5)], [DVec2::new(1.0, 0.5), DVec2::new(2.0, 0.5)]];
        let slabs = SegmentSlabs::new(&flat).unwrap();
        let tree = SegmentTree2::new(&flat).unwrap();
        let cross = [[DVec2::new(0.5, 0.0), DVec2::new(0.5, 1.0)], [DVec2::new(1.0, 0.0), DVec2::new(1.0, 1.0)]];
        assert_eq!(slabs.crossings_batch(&cross), tree.crossings_batch(&cross));
    }
}
