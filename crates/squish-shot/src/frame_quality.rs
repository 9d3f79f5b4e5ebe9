//! Quality figures of one computed frame, as the shot reports them: per object, the relative
//! volume change, the contact area and the largest displacement from the input (the
//! frame-to-frame steps are set once the previous frame is known); per pair, the library's
//! quality pass ([`PairQuality`]: penetrations and intersecting faces before and after).

use serde::Serialize;
pub use squish::pipeline::PairQuality;
use squish::pipeline::{Frame, FrameResult};

/// Figures of one object at one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectQuality {
    pub name: String,
    /// True if the object was deformed at this frame.
    pub deformed: bool,
    /// (V_after − V_before) / |V_before|.
    pub relative_volume_change: f64,
    /// Largest contact area of the object's pairs (on the potential contact surface).
    pub contact_area: f64,
    /// Largest vertex displacement from this frame's input.
    pub max_deformation: f64,
    /// Largest vertex displacement from the previous frame's output (`None` for the first frame
    /// of the range, or after a frame that was not computed).
    pub output_step: Option<f64>,
    /// Largest vertex displacement of the input from the previous frame's input.
    pub input_step: Option<f64>,
    /// `output_step / input_step` (`None` when the input did not move).
    pub step_ratio: Option<f64>,
}

impl ObjectQuality {
    /// Sets the frame-to-frame steps.
    pub fn set_steps(&mut self, output: f64, input: f64) {
        self.output_step = Some(output);
        self.input_step = Some(input);
        self.step_ratio = (input > 0.0).then(|| output / input);
    }
}

/// The quality figures of a frame's result (the frame-to-frame steps are filled in later, by
/// the shot): the objects' from their figures, the pairs' from the library's quality pass.
pub fn measure(frame: &Frame, result: &FrameResult) -> (Vec<ObjectQuality>, Vec<PairQuality>) {
    let stats = &result.stats;
    let mut area = vec![0.0f64; stats.objects.len()];
    for pair in &stats.pairs {
        for &i in frame.pairs.get(pair.pair).map_or(&[][..], |p| &p.objects[..]) {
            area[i] = area[i].max(pair.contact_area);
        }
    }
    let objects = stats
        .objects
        .iter()
        .zip(&area)
        .map(|(o, &contact_area)| ObjectQuality {
            name: o.name.clone(),
            deformed: o.deformed,
            relative_volume_change: o.relative_volume_change,
            contact_area,
            max_deformation: o.max_displacement,
            output_step: None,
            input_step: None,
            step_ratio: None,
        })
        .collect();
    (objects, stats.quality.clone())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn step_ratio_is_undefined_for_a_still_input() {
        let mut o = ObjectQuality {
            name: "a".into(),
            deformed: true,
            relative_volume_change: 0.0,
            contact_area: 0.0,
            max_deformation: 0.0,
            output_step: None,
            input_step: None,
            step_ratio: None,
        };
        o.set_steps(0.2, 0.1);
        assert_eq!(o.step_ratio, Some(2.0));
        o.set_steps(0.2, 0.0);
        assert_eq!(o.step_ratio, None);
    }
}
