//! The parameter schema as front ends read it: every row of the one declaration of every
//! parameter ([`squish::params`] for the deformer's, the scene file's `frames` and `output`
//! tables from [`squish_io::scene`]), level by level; `squish params --json` and the Python
//! module's `squish.params_schema()`.

use serde::Serialize;
use squish::params::{ArticulationParams, ObjectParams, PairParams, SchemaEntry, entries};
use squish_io::scene::{FrameRange, OutputSpec};

use crate::error::ShotError;

/// A group of parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// `[[objects]]`, `--set a.KEY` / `b.KEY`.
    Object,
    /// `[[pairs]]`, `--set pair.KEY`.
    Pair,
    /// `[[objects.self_contact]]`.
    Articulation,
    /// The scene file's `frames` and `output`.
    Scene,
}

impl Level {
    pub const ALL: [Self; 4] = [Self::Object, Self::Pair, Self::Articulation, Self::Scene];

    /// The schema rows of the level.
    pub fn entries(self) -> Vec<SchemaEntry> {
        match self {
            Self::Object => entries::<ObjectParams>(),
            Self::Pair => entries::<PairParams>(),
            Self::Articulation => entries::<ArticulationParams>(),
            Self::Scene => {
                let mut all = entries::<FrameRange>();
                all.extend(entries::<OutputSpec>());
                all
            }
        }
    }
}

#[derive(Serialize)]
struct Schema {
    /// Bumped when the form of a row changes.
    schema_version: u32,
    parameters: Vec<SchemaEntry>,
}

/// Every row of the schema, level by level, as JSON.
pub fn schema_json() -> Result<String, ShotError> {
    let parameters = Level::ALL.iter().flat_map(|l| l.entries()).collect();
    Ok(serde_json::to_string_pretty(&Schema { schema_version: 1, parameters })?)
}
