//! Placeholder: filled by the linear-algebra work (thesis App. B).
