//! Colour maps for debug views: categorical colours for the vertex labels of the deformation
//! pipeline and for plot series, and a perceptual sequential map (dark purple → blue → green →
//! yellow, in the manner of viridis) for scalar fields such as the radial parametrization
//! u ∈ [0, 1].
//!
//! The sequential map is a degree-6 polynomial per sRGB channel, fitted for this crate by least
//! squares to a hand-picked viridis-like ramp; its luminance increases monotonically, so it
//! reads correctly in greyscale and for colour-blind viewers.

use crate::shading::{Rgb, srgb_to_linear, srgb8};

/// The role of a vertex in one frame of the deformation, as shown in debug views.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Label {
    /// Untouched by this contact.
    Outside,
    /// Inside the other object: the penetrating region.
    Intersection,
    /// In the region mapped by the radial parametrization.
    Mapping,
    /// On the contact surface.
    Contact,
    /// Free to deform (the bulge region).
    Deformable,
}

impl Label {
    /// Every label, in legend order.
    pub const ALL: [Label; 5] =
        [Label::Outside, Label::Intersection, Label::Mapping, Label::Contact, Label::Deformable];

    /// The label's linear colour: neutral grey for outside, then four well separated hues.
    pub fn color(self) -> Rgb {
        match self {
            Label::Outside => srgb8(0xa8, 0xa8, 0xa8),
            Label::Intersection => srgb8(0xd6, 0x3a, 0x2f),
            Label::Mapping => srgb8(0xf2, 0xa5, 0x1a),
            Label::Contact => srgb8(0x2f, 0x6f, 0xd6),
            Label::Deformable => srgb8(0x3f, 0xb0, 0x5a),
        }
    }

    /// Lower-case name, for legends.
    pub fn name(self) -> &'static str {
        match self {
            Label::Outside => "outside",
            Label::Intersection => "intersection",
            Label::Mapping => "mapping",
            Label::Contact => "contact",
            Label::Deformable => "deformable",
        }
    }
}

/// Per-vertex colours for per-vertex labels.
pub fn label_colors(labels: &[Label]) -> Vec<Rgb> {
    labels.iter().map(|l| l.color()).collect()
}

/// The `index`-th colour of a categorical palette of 8 hues chosen to stay distinguishable on
/// a white plot background; it cycles after 8.
pub fn categorical(index: usize) -> Rgb {
    const PALETTE: [[u8; 3]; 8] = [
        [0x1f, 0x6f, 0xc5],
        [0xe0, 0x6c, 0x10],
        [0x2e, 0x9e, 0x44],
        [0xc8, 0x2a, 0x3a],
        [0x7b, 0x4f, 0xbf],
        [0x8c, 0x5a, 0x3c],
        [0xd4, 0x4f, 0xa8],
        [0x50, 0x50, 0x50],
    ];
    let [r, g, b] = PALETTE[index % PALETTE.len()];
    srgb8(r, g, b)
}

/// Colour for values that have no meaningful colour (NaN scalars).
pub const MISSING_COLOR: Rgb = [0.9, 0.0, 0.9];

/// Polynomial coefficients (constant term first) of the sequential map's sRGB channels.
const SEQUENTIAL_COEFFS: [[f32; 7]; 3] = [
    [0.26117, 0.47814, -3.78162, 9.00196, -13.37866, 11.01588, -2.58239],
    [0.00439, 1.18978, 0.78514, -6.96405, 15.51691, -14.85095, 5.22815],
    [0.32475, 1.40153, -2.08649, -3.3854, 14.31526, -16.47454, 6.04819],
];

/// The sequential map at `t` (clamped to `[0, 1]`) as a linear colour; NaN gives
/// [`MISSING_COLOR`].
pub fn sequential(t: f64) -> Rgb {
    if t.is_nan() {
        return MISSING_COLOR;
    }
    let t = t.clamp(0.0, 1.0) as f32;
    let mut out = [0.0; 3];
    for (channel, coeffs) in out.iter_mut().zip(SEQUENTIAL_COEFFS.iter()) {
        // Horner's scheme.
        let srgb = coeffs.iter().rev().fold(0.0f32, |acc, &c| acc * t + c);
        *channel = srgb_to_linear(srgb.clamp(0.0, 1.0));
    }
    out
}

/// Per-vertex colours for per-vertex scalars through the sequential map. `range` gives the
/// values mapped to the two ends; by default it is the finite values' minimum and maximum.
/// Non-finite values get [`MISSING_COLOR`]; a constant field is drawn at the middle of the map.
pub fn scalar_colors(values: &[f64], range: Option<(f64, f64)>) -> Vec<Rgb> {
    let (lo, hi) = match range {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() => (lo, hi),
        _ => values
            .iter()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v))),
    };
    values
        .iter()
        .map(|&v| {
            if !v.is_finite() {
                MISSING_COLOR
            } else if hi > lo {
                sequential((v - lo) / (hi - lo))
            } else if hi < lo {
                // A reversed range maps hi → 0 and lo → 1, as asked.
                sequential((v - lo) / (hi - lo))
            } else {
                sequential(0.5)
            }
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    fn luminance(c: Rgb) -> f32 {
        0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    }

    #[test]
    fn sequential_map_is_monotonic_in_luminance_and_has_the_expected_ends() {
        let mut previous = -1.0;
        for i in 0..=256 {
            let l = luminance(sequential(f64::from(i) / 256.0));
            assert!(l > previous, "{i}: {l} <= {previous}");
            previous = l;
        }
        let dark = sequential(0.0);
        let light = sequential(1.0);
        // Purple at the low end (blue and red over green), yellow at the high end.
        assert!(dark[2] > dark[1] && dark[0] > dark[1] && luminance(dark) < 0.03, "{dark:?}");
        assert!(light[0] > 0.8 && light[1] > 0.7 && light[2] < 0.1, "{light:?}");
        assert_eq!(sequential(-5.0), dark);
        assert_eq!(sequential(f64::NAN), MISSING_COLOR);
    }

    #[test]
    fn scalar_colors_normalize_and_flag_missing_values() {
        let colors = scalar_colors(&[2.0, 4.0, f64::NAN, 3.0], None);
        assert_eq!(colors[0], sequential(0.0));
        assert_eq!(colors[1], sequential(1.0));
        assert_eq!(colors[2], MISSING_COLOR);
        assert_eq!(colors[3], sequential(0.5));
        assert_eq!(scalar_colors(&[7.0, 7.0], None), vec![sequential(0.5); 2]);
        assert_eq!(scalar_colors(&[0.5], Some((0.0, 2.0)))[0], sequential(0.25));
        assert!(scalar_colors(&[], None).is_empty());
    }

    #[test]
    fn label_colors_are_well_separated() {
        for (i, a) in Label::ALL.iter().enumerate() {
            for b in &Label::ALL[i + 1..] {
                let (ca, cb) = (a.color(), b.color());
                let d: f32 = (0..3).map(|k| (ca[k] - cb[k]).abs()).sum();
                assert!(d > 0.3, "{a:?} {b:?}");
            }
        }
    }
}
