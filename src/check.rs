//! Physical checks on the cut geometry: one piece, bridge and feature widths against a material.
//! OWNER: the vectors issue.

#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("placeholder")]
    Placeholder,
}
