//! Placeholder: filled by the spatial-query work.
