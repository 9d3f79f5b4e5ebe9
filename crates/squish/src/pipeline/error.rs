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
    /// A working-region message of `object` as the pipeline's error.
    pub(super) fn invalid_region(object: &str, reason: String) -> Self {
        Self::InvalidRegion { object: object.to_string(), reason }
    }
}
