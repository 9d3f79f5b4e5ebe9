//! Welding vertices with equal (or nearly equal) positions.
//!
//! glTF exporters split vertices wherever a UV seam or a hard normal passes, so a closed
//! character reads as many open patches. The deformer needs the surface connected: welding
//! merges those copies into one vertex and remaps the triangles, and the map from file vertex to
//! welded vertex lets per-vertex data (skin weights, results) travel both ways.

use std::collections::HashMap;

use glam::DVec3;

/// How to weld.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum WeldMode {
    /// Keep the file's vertices as they are.
    #[default]
    Off,
    /// Merge vertices whose coordinates are bit-for-bit equal (`-0.0` equals `0.0`). Exporters
    /// write seam copies from the same source vertex, so this is exact and never merges
    /// vertices that merely happen to be close (e.g. lips, eyelids).
    Exact,
    /// Merge a vertex into the first earlier kept vertex within this distance (absolute, in the
    /// mesh's units). For files whose seam copies were rounded differently. Not transitive:
    /// each vertex is compared with kept vertices only, so chains of close points do not
    /// collapse into one.
    Within(f64),
}

/// The result of welding.
#[derive(Clone, Debug, PartialEq)]
pub struct Welded {
    /// Kept positions, in the order of their first occurrence in the input.
    pub positions: Vec<DVec3>,
    /// Triangles on the kept vertices; triangles that collapsed (two corners merged) are dropped.
    pub triangles: Vec<[u32; 3]>,
    /// For each input vertex, its welded vertex.
    pub vertex_map: Vec<u32>,
    /// For each kept vertex, the input vertex it was taken from (its first occurrence).
    pub representatives: Vec<u32>,
    /// Number of dropped triangles.
    pub collapsed_triangles: usize,
}

/// Welds `positions` (see [`WeldMode`]). Deterministic: depends only on the input order.
pub fn weld_positions(positions: &[DVec3], triangles: &[[u32; 3]], mode: WeldMode) -> Welded {
    let n = positions.len();
    let mut vertex_map = Vec::with_capacity(n);
    let mut representatives: Vec<u32> = Vec::new();
    match mode {
        WeldMode::Off => {
            vertex_map.extend(0..n as u32);
            representatives.extend(0..n as u32);
        }
        WeldMode::Exact => {
            let mut seen: HashMap<[u64; 3], u32> = HashMap::with_capacity(n);
            for (i, p) in positions.iter().enumerate() {
                // Adding 0.0 turns -0.0 into +0.0, so both hash alike.
                let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
                let id = *seen.entry(key).or_insert_with(|| {
                    representatives.push(i as u32);
                    (representatives.len() - 1) as u32
                });
                vertex_map.push(id);
            }
        }
        WeldMode::Within(tolerance) => {
            let tolerance = if tolerance.is_finite() { tolerance.max(0.0) } else { 0.0 };
            // Grid of cell size `tolerance`: a point within `tolerance` is in one of the 27
            // neighbouring cells. A zero tolerance degenerates to exact matching.
            let cell = if tolerance > 0.0 { tolerance } else { 1.0 };
            let key = |p: DVec3| -> [i64; 3] { (p / cell).floor().as_i64vec3().to_array() };
            let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
            let tol2 = tolerance * tolerance;
            for (i, p) in positions.iter().enumerate() {
                let k = key(*p);
                let mut found = None;
                'search: for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            if let Some(list) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                                // Lowest kept id first, for a result independent of hash order.
                                for &id in list {
                                    let q = positions[representatives[id as usize] as usize];
                                    if (q - *p).length_squared() <= tol2 && found.is_none_or(|f| id < f) {
                                        found = Some(id);
                                    }
                                }
                            }
                            if found.is_some() && tolerance == 0.0 {
                                break 'search;
                            }
                        }
                    }
                }
                let id = match found {
                    Some(id) => id,
                    None => {
                        representatives.push(i as u32);
                        let id = (representatives.len() - 1) as u32;
                        grid.entry(k).or_default().push(id);
                        id
                    }
                };
                vertex_map.push(id);
            }
        }
    }
    let kept: Vec<DVec3> = representatives.iter().map(|&i| positions[i as usize]).collect();
    let mut out = Vec::with_capacity(triangles.len());
    let mut collapsed = 0;
    for tri in triangles {
        let t = tri.map(|i| vertex_map.get(i as usize).copied().unwrap_or(i));
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            collapsed += 1;
        } else {
            out.push(t);
        }
    }
    Welded { positions: kept, triangles: out, vertex_map, representatives, collapsed_triangles: collapsed }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Two triangles of a quad whose shared edge is duplicated (a seam).
    fn seam_quad() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let p = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-0.0, 0.0, 0.0), // copy of 0
            DVec3::new(1.0, 1.0, 0.0),  // copy of 2
            DVec3::new(0.0, 1.0, 0.0),
        ];
        (p, vec![[0, 1, 2], [3, 4, 5]])
    }

    #[test]
    fn exact_weld_merges_seam_copies() {
        let (p, t) = seam_quad();
        let w = weld_positions(&p, &t, WeldMode::Exact);
        assert_eq!(w.positions.len(), 4);
        assert_eq!(w.vertex_map, vec![0, 1, 2, 0, 2, 3]);
        assert_eq!(w.representatives, vec![0, 1, 2, 5]);
        assert_eq!(w.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(weld_positions(&p, &t, WeldMode::Off).positions, p);
    }

    #[test]
    fn tolerance_weld_is_not_transitive_and_drops_collapsed_triangles() {
        let p = vec![DVec3::ZERO, DVec3::new(0.6e-3, 0.0, 0.0), DVec3::new(1.2e-3, 0.0, 0.0), DVec3::Y];
        let w = weld_positions(&p, &[[0, 1, 3], [1, 2, 3], [0, 2, 3]], WeldMode::Within(1e-3));
        // 1 merges into 0; 2 is 1.2e-3 from 0 (the kept vertex), so it stays.
        assert_eq!(w.vertex_map, vec![0, 0, 1, 2]);
        assert_eq!(w.collapsed_triangles, 1);
        assert_eq!(w.triangles, vec![[0, 1, 2], [0, 1, 2]]);
        let exact = weld_positions(&p, &[], WeldMode::Within(0.0));
        assert_eq!(exact.positions.len(), 4);
    }
}
