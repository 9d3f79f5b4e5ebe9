//! Placeholder: skeletons and animation clips.
