//! Acceptance tests of the contact definition (the list).

use glam::DVec3;

use super::test_support::*;
use super::*;

#[test]
fn smoke_sphere_in_plane() {
    let (sphere, grid) = sphere_in_grid(0.2, 4, 60);
    let r = contact_pair(&sphere.side(), &grid.side(), &PairParams::default()).unwrap();
    println!("{:?} {:?} {:#?}", r.direction, r.direction_source, r.stats);
    println!("{:?} area {}", r.criterion, r.contact_area);
}
