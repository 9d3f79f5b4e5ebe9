//! Why a frame fails. Every variant names the object, region or pair at fault and, where there is
//! one, what to change.

use crate::contact::ContactError;
use crate::deform::DeformError;
use crate::mesh::MeshError;
use crate::spatial::SpatialError;

/// Why a frame failed. Every variant names the object or pair at fault.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("object \"{object}\": {source}")]
    Mesh { object: String, source: MeshError },
    #[error("object \"{object}\": {source}")]
    Spatial { object: String, source: SpatialError },
    #[error("pair (\"{a}\", \"{b}\"): {source}")]
    Contact { a: String, b: String, source: ContactError },
    #[error("object \"{object}\": {source}")]
    Deform { object: String, source: DeformError },
    #[error("pair {pair} refers to object {index}, but the frame has {count} objects")]
    PairIndex { pair: usize, index: usize, count: usize },
    #[error(
        "pair {pair} pairs object \"{object}\" with itself; self-contact needs several explicit working regions \
         (region = \"components\" or \"mask\")"
    )]
    SelfPair { pair: usize, object: String },
    #[error("object \"{object}\": {source}")]
    Parameter { object: String, source: crate::params::ParamError },
    #[error("object \"{object}\": working region: {reason}")]
    InvalidRegion { object: String, reason: String },
    #[error(
        "object \"{object}\": {what} has {actual} values but the mesh has {expected} vertices; give one value per vertex"
    )]
    PerVertexLength { object: String, what: &'static str, expected: usize, actual: usize },
    #[error("object \"{object}\", articulation \"{articulation}\": {source}")]
    SelfContact { object: String, articulation: String, source: Box<crate::skinning::SelfContactError> },
    #[error(
        "object \"{object}\", working region {region}: {reason}; use a larger working region (a wider mask or \
         distance) or a smaller extent"
    )]
    RegionTooSmall { object: String, region: usize, reason: String },
}

impl PipelineError {
    /// The failure of a contact between regions the pipeline chose itself (the part pairs of
    /// `self_contact = "auto"`): the same fault, without advice about a working region that the
    /// user never gave.
    pub(super) fn automatic_wording(&self) -> String {
        match self {
            Self::Contact { source, .. } => contact_automatic_wording(source),
            Self::RegionTooSmall { region, reason, .. } => format!("region {region}: {reason}"),
            other => other.to_string(),
        }
    }

    /// A working-region message of `object` as the pipeline's error.
    pub(super) fn invalid_region(object: &str, reason: String) -> Self {
        Self::InvalidRegion { object: object.to_string(), reason }
    }
}

/// [`PipelineError::automatic_wording`] of a contact stage's failure (also an automatic
/// articulation's).
pub(super) fn contact_automatic_wording(error: &ContactError) -> String {
    match error {
        ContactError::IntersectionReachesBorder { vertex, .. } => format!(
            "the intersection reaches vertex {vertex} on the border of its regions: it does not close inside them"
        ),
        ContactError::DirectionUndefined => {
            "the automatic mapping direction is undefined: the normals over the intersection regions cancel out \
             (Eq. 4.1)"
                .to_string()
        }
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn automatic_contacts_fail_without_advice_about_working_regions() {
        let border = PipelineError::Contact {
            a: "fox (region 0)".into(),
            b: "fox (region 1)".into(),
            source: ContactError::IntersectionReachesBorder { object: "fox (region 1)".into(), vertex: 7 },
        };
        let small = PipelineError::RegionTooSmall { object: "fox".into(), region: 1, reason: "too thin".into() };
        let undefined =
            PipelineError::Contact { a: "a".into(), b: "b".into(), source: ContactError::DirectionUndefined };
        for (error, names) in [(&border, "vertex 7"), (&small, "region 1: too thin"), (&undefined, "Eq. 4.1")] {
            let automatic = error.automatic_wording();
            assert!(error.to_string().contains("working region") || error.to_string().contains("give the pair"));
            assert!(automatic.contains(names), "{automatic}");
            for advice in ["working region", "use a", "give the"] {
                assert!(!automatic.contains(advice), "{automatic}");
            }
        }
    }
}
