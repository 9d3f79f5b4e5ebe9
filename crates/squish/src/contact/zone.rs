//! Contact zones 𝒞_a, 𝒞_b with the geometrical criterion of method B (thesis §4.4.2, Eq. 4.2–4.4,
//! THESIS-NOTES item 8).
//!
//! **Sign decision.** The per-point value is the penetration along 𝒮's normal, c = −δᵀn′ (see
//! [`super::surface`]): positive where the point is inside the other object, negative where there
//! is a gap, and equal at a point of a and at its match on b. The thesis' δᵀn′ is the same
//! quantity with its n′ oriented the other way.
//!
//! **Threshold (Eq. 4.3).** ε_c = m_𝒮 + τ·σ_𝒮, with m_𝒮 and σ_𝒮 the mean and standard deviation
//! of c over ℳ_a and ℳ_b *together*: c is known at every vertex and boundary point of ℳ, linear
//! in between, and integrated with [`EdgeRegion::integrate`] (App. A), area-weighted over both
//! regions, so the definition is symmetric in a and b. σ is integrated as ∫(c − m)² (second pass,
//! no cancellation). Larger τ → larger ε_c → smaller zones (Fig. 4.11).
//!
//! **Criterion (Eq. 4.2 + safeguard).** A vertex i of ℳ_l is in 𝒞_l iff c_i ≥ ε_c and
//! min(−toward·n_i, toward·n″_i) ≥ cos θ (θ = 80° by default; toward = +d̂ on a, −d̂ on b, so this
//! is min(−d̂ᵀn_i, d̂ᵀn″_i) on a and min(d̂ᵀn_j, −d̂ᵀn″_j) on b).
//!
//! **Exact boundary (Eq. 4.4).** On every edge from i ∈ 𝒞 to j ∉ 𝒞 the data of the far end is
//! j's own if j ∈ ℳ (α_end = 1); otherwise the edge carries a boundary point of ℳ at α_ℳ and the
//! data is that point's (α_end = α_ℳ). δ, n′, the own normal n and n″ are each interpolated
//! linearly between i (α = 0) and the far end; c(α) = −δ(α)ᵀn′(α) is quadratic and the two
//! safeguard terms are linear. α_ij is the smallest α in [0, α_end] at which any condition stops
//! holding (robust quadratic roots, with a bisection if round-off hides a sign change), α_end if
//! none does. The exact point is then recomputed: p(α) on the edge, the line through it along
//! toward is cast on the other mesh (farthest hit, as for vertices), and p′, n′ follow from the
//! formulas of §4.3; at α = 0 and α = α_end the end data is reused as is. Each boundary point
//! stores p_ij, p′_ij and n′_ij. Zones may have several components.

use glam::DVec3;

use super::mapping::{NO_SLOT, SideMapping, cast_matches};
use super::region::crossing_edges;
use super::surface::{SideSurface, SurfaceSample, surface_sample};
use super::{ContactSide, ContactZone, EdgeRegion, Sample};

/// Statistics of c = −δᵀn′ over 𝒮 and the resulting threshold.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CriterionStats {
    /// Total area of ℳ_a and ℳ_b (on the meshes) over which c was integrated.
    pub area: f64,
    /// m_𝒮: area-weighted mean of c.
    pub mean: f64,
    /// σ_𝒮: area-weighted standard deviation of c.
    pub std_dev: f64,
    /// ε_c = m_𝒮 + τσ_𝒮.
    pub threshold: f64,
    /// The typical penetration depth P = ∫c₊² / ∫c₊ over ℳ (c₊ = max(c, 0); 0 without
    /// penetration): continuous, and 0 when the contact starts. Computed only for a pair with a
    /// threshold floor ([`crate::params::PairParams::contact_threshold_floor`]), τ > 0 or a
    /// contact gap (it bounds the gap), 0 otherwise.
    pub penetration: f64,
    /// m_𝒮 + τσ_𝒮 when it was above P and ε_c was clamped to P (τ > 0 only; see
    /// `docs/decisions.md`, "Contact spread τ"), `None` otherwise.
    #[serde(default)]
    pub unclamped_threshold: Option<f64>,
}

/// Penetration c at every sample of ℳ (0 for a vertex outside ℳ, which integration never asks).
fn depth_at(mapping: &SideMapping, surface: &SideSurface, s: Sample) -> f64 {
    surface.sample(mapping, s).map_or(0.0, |x| x.depth)
}

/// m_𝒮, σ_𝒮 and ε_c over both mapping regions (Eq. 4.3).
pub fn criterion(
    sides: [&ContactSide; 2],
    mappings: [&SideMapping; 2],
    surfaces: [&SideSurface; 2],
    tau: f64,
) -> CriterionStats {
    let mut area = 0.0;
    let mut total = 0.0;
    for l in 0..2 {
        let (a, c) = mappings[l].region.integrate(
            sides[l].mesh,
            sides[l].topology,
            |s| depth_at(mappings[l], surfaces[l], s),
            |c: f64| c,
        );
        area += a;
        total += c;
    }
    if area <= 0.0 {
        return CriterionStats::default();
    }
    let mean = total / area;
    let mut spread = 0.0;
    for l in 0..2 {
        let (_, s) = mappings[l].region.integrate(
            sides[l].mesh,
            sides[l].topology,
            |s| depth_at(mappings[l], surfaces[l], s),
            |c: f64| (c - mean) * (c - mean),
        );
        spread += s;
    }
    let std_dev = (spread / area).max(0.0).sqrt();
    CriterionStats { area, mean, std_dev, threshold: mean + tau * std_dev, penetration: 0.0, unclamped_threshold: None }
}

/// The typical penetration depth P = ∫c₊² / ∫c₊ over ℳ (c₊ = max(c, 0); 0 without penetration),
/// for [`crate::params::PairParams::contact_threshold_floor`].
pub fn typical_penetration(sides: [&ContactSide; 2], mappings: [&SideMapping; 2], surfaces: [&SideSurface; 2]) -> f64 {
    let (mut first, mut second) = (0.0, 0.0);
    for l in 0..2 {
        let depth = |s| depth_at(mappings[l], surfaces[l], s).max(0.0);
        first += mappings[l].region.integrate(sides[l].mesh, sides[l].topology, depth, |c: f64| c).1;
        second += mappings[l].region.integrate(sides[l].mesh, sides[l].topology, depth, |c: f64| c * c).1;
    }
    if first > 0.0 { second / first } else { 0.0 }
}

/// The safeguard value min(−toward·n, toward·n″) of a sample.
#[inline]
fn guard(s: &SurfaceSample, toward: DVec3) -> f64 {
    (-toward.dot(s.normal)).min(toward.dot(s.match_normal))
}

/// Smallest s in [0, 1] at which f(s) = a·s² + b·s + c stops being ≥ 0, given f(0) = c ≥ 0;
/// `None` if f ≥ 0 on all of [0, 1].
pub fn first_exit(a: f64, b: f64, c: f64) -> Option<f64> {
    if c.is_nan() || a.is_nan() || b.is_nan() {
        return None;
    }
    if c < 0.0 {
        return Some(0.0);
    }
    let f = |s: f64| (a * s + b) * s + c;
    let mut best: Option<f64> = None;
    let mut consider = |r: f64| {
        // A root where f goes down through zero.
        if r.is_finite() && (0.0..=1.0).contains(&r) && 2.0 * a * r + b < 0.0 {
            best = Some(best.map_or(r, |x: f64| x.min(r)));
        }
    };
    if a == 0.0 {
        if b != 0.0 {
            consider(-c / b);
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            // Numerically stable pair of roots (no cancellation between b and √disc).
            let q = -0.5 * (b + disc.sqrt().copysign(b));
            if q != 0.0 {
                consider(q / a);
                consider(c / q);
            } else if a < 0.0 {
                // b = 0 and c = 0: f = a·s², negative right away.
                best = Some(0.0);
            }
        }
    }
    if best.is_none() && f(1.0) < 0.0 {
        // A sign change the closed form lost to round-off: bisect it.
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if f(mid) >= 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        best = Some(hi);
    }
    best
}

/// A contact zone and its figures.
#[derive(Clone, Debug)]
pub struct ZoneResult {
    pub zone: ContactZone,
    /// Area of 𝒞 measured at its points on 𝒮 (p′).
    pub area_on_surface: f64,
    /// Area of 𝒞 on its own mesh.
    pub area_on_mesh: f64,
    /// Boundary points whose recomputed match fell back to the closest point.
    pub closest_point_matches: usize,
}

/// Per-side constants of the zone extraction.
#[derive(Clone, Copy, Debug)]
pub struct ZoneSetup {
    /// +d̂ for a, −d̂ for b.
    pub toward: DVec3,
    /// d̂.
    pub mapping_direction: DVec3,
    /// k̄ of this side and of the other.
    pub k_own: f64,
    pub k_other: f64,
    /// ε_c.
    pub threshold: f64,
    /// cos of the safeguard angle.
    pub cos_guard: f64,
}

/// 𝒞 on one side (module docs).
pub fn extract_zone(
    side: &ContactSide,
    other: &ContactSide,
    mapping: &SideMapping,
    surface: &SideSurface,
    setup: &ZoneSetup,
) -> ZoneResult {
    let toward = setup.toward;
    let holds = |s: &SurfaceSample| s.depth >= setup.threshold && guard(s, toward) >= setup.cos_guard;
    let nv = side.mesh.num_vertices();
    let mut inside = vec![false; nv];
    for (&v, s) in mapping.vertices.iter().zip(&surface.vertex_samples) {
        inside[v as usize] = holds(s);
    }
    // Edges leaving the zone, in increasing edge id (the order of the zone's points).
    struct Leaving {
        edge: u32,
        alpha: f64,
        /// The sample to reuse as is (α = 0 or α = α_end), if any.
        reuse: Option<SurfaceSample>,
    }
    let mut leaving: Vec<Leaving> = Vec::new();
    let edges = side.topology.edges();
    let crossing = crossing_edges(side.topology, &inside);
    for &e in &crossing {
        let [x, y] = edges[e as usize];
        let (i, j) = if inside[x as usize] { (x, y) } else { (y, x) };
        let Some(si) = surface.sample(mapping, Sample::Vertex(i)).copied() else { continue };
        let end = if mapping.vertex_slot[j as usize] != NO_SLOT {
            surface.sample(mapping, Sample::Vertex(j)).map(|s| (*s, 1.0))
        } else {
            mapping.region.point_on_edge(e).and_then(|p| {
                let point = mapping.region.points()[p as usize];
                (point.inside == i).then(|| surface.point_samples.get(p as usize).map(|s| (*s, point.alpha))).flatten()
            })
        };
        let Some((se, alpha_end)) = end else {
            // Unreachable (i ∈ ℳ, j ∉ ℳ means ℳ has a point here); keep the zone at i.
            leaving.push(Leaving { edge: e, alpha: 0.0, reuse: Some(si) });
            continue;
        };
        let (d0, dd) = (si.displacement(), se.displacement() - si.displacement());
        let (m0, dm) = (si.surface_normal, se.surface_normal - si.surface_normal);
        let depth = first_exit(-dd.dot(dm), -(d0.dot(dm) + dd.dot(m0)), si.depth - setup.threshold);
        let own = first_exit(0.0, -toward.dot(se.normal - si.normal), -toward.dot(si.normal) - setup.cos_guard);
        let matched = first_exit(
            0.0,
            toward.dot(se.match_normal - si.match_normal),
            toward.dot(si.match_normal) - setup.cos_guard,
        );
        let s = [depth, own, matched].into_iter().flatten().fold(1.0f64, f64::min);
        let (alpha, reuse) = if s >= 1.0 {
            (alpha_end, Some(se))
        } else if s <= 0.0 {
            (0.0, Some(si))
        } else {
            (s * alpha_end, None)
        };
        leaving.push(Leaving { edge: e, alpha, reuse });
    }
    let region = EdgeRegion::from_crossing_edges(side.topology, inside, &crossing, |e, _, _| {
        leaving.binary_search_by_key(&e, |l| l.edge).map_or(0.0, |k| leaving[k].alpha)
    });
    debug_assert_eq!(region.points().len(), leaving.len());
    // Recompute the exact points on 𝒮 of the boundary points strictly inside their range.
    let recompute: Vec<usize> = (0..leaving.len()).filter(|&k| leaving[k].reuse.is_none()).collect();
    let positions: Vec<DVec3> = recompute.iter().map(|&k| region.point_position(side.mesh, k as u32)).collect();
    let (matches, closest_point_matches) = cast_matches(&positions, other, toward);
    let mut boundary: Vec<SurfaceSample> = leaving.iter().map(|l| l.reuse.unwrap_or_default()).collect();
    for ((&k, p), m) in recompute.iter().zip(positions).zip(&matches) {
        let n = region.interpolate(side.normals, Sample::Point(k as u32)).normalize_or_zero();
        boundary[k] = surface_sample(p, n, m, toward, setup.k_own, setup.k_other);
    }
    let mut targets = side.mesh.positions.clone();
    let mut normals = vec![DVec3::ZERO; nv];
    for (&v, s) in mapping.vertices.iter().zip(&surface.vertex_samples) {
        if region.contains(v) {
            targets[v as usize] = s.target;
            normals[v as usize] = s.surface_normal;
        }
    }
    let boundary_positions: Vec<DVec3> =
        (0..region.points().len() as u32).map(|p| region.point_position(side.mesh, p)).collect();
    let boundary_targets: Vec<DVec3> = boundary.iter().map(|s| s.target).collect();
    let boundary_normals: Vec<DVec3> = boundary.iter().map(|s| s.surface_normal).collect();
    let area_on_surface = region.area_with(side.mesh, side.topology, |s| match s {
        Sample::Vertex(v) => targets[v as usize],
        Sample::Point(p) => boundary_targets[p as usize],
    });
    let area_on_mesh = region.area(side.mesh, side.topology);
    ZoneResult {
        zone: ContactZone {
            region,
            targets,
            normals,
            boundary_positions,
            boundary_targets,
            boundary_normals,
            direction: -toward,
            mapping_direction: setup.mapping_direction,
        },
        area_on_surface,
        area_on_mesh,
        closest_point_matches,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_exit_finds_the_first_downward_root() {
        // Linear: 1 − 2s leaves at ½.
        assert_eq!(first_exit(0.0, -2.0, 1.0), Some(0.5));
        // Increasing: never leaves.
        assert_eq!(first_exit(0.0, 2.0, 1.0), None);
        // Convex dip between 0.2 and 0.6: (s − 0.2)(s − 0.6) = s² − 0.8s + 0.12.
        let r = first_exit(1.0, -0.8, 0.12).unwrap();
        assert!((r - 0.2).abs() < 1e-15, "{r}");
        // Concave, leaving at 0.7: −(s − 0.7)(s + 1) = −s² − 0.3s + 0.7.
        let r = first_exit(-1.0, -0.3, 0.7).unwrap();
        assert!((r - 0.7).abs() < 1e-15, "{r}");
        // Convex with roots outside [0, 1]: none.
        assert_eq!(first_exit(1.0, -3.0, 2.0 + 1e-3), None);
        assert_eq!(first_exit(1.0, 0.0, 0.5), None);
        // Starting exactly at zero and going down: 0.
        assert_eq!(first_exit(0.0, -1.0, 0.0), Some(0.0));
        assert_eq!(first_exit(-1.0, 0.0, 0.0), Some(0.0));
        // Tiny quadratic term: the linear root, accurately (no cancellation).
        let r = first_exit(1e-20, -1.0, 0.25).unwrap();
        assert!((r - 0.25).abs() < 1e-15, "{r}");
        // Ends negative: a root is always found in [0, 1].
        for (a, b, c) in [(1e-300, -1.0, 1.0 - 1e-16), (3.0, -4.0, 1.0 - 1e-17)] {
            let f1: f64 = a + b + c;
            if f1 < 0.0 {
                assert!(first_exit(a, b, c).is_some());
            }
        }
    }
}
