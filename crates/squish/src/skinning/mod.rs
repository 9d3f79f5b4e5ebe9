//! Placeholder: skinning (thesis ch. 6) and linear blend skinning.
