//! Line plots (placeholder while being written).
