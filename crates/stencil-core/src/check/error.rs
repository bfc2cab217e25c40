//! Why the check could not measure (its own leaf, so the check and the triangulation share it).

#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// A point of the outline the triangulation cannot take (only an absurd size, which the
    /// size limits refuse first, can make one).
    #[error(
        "the width check cannot triangulate the outline: its point ({x_mm}, {y_mm}) mm is {problem}; \
         check the picture's size and the margin"
    )]
    Coordinate {
        x_mm: f64,
        y_mm: f64,
        problem: &'static str,
    },
    /// The picture breaks into too many pieces to measure ([`super::bound_pieces`]).
    #[error(
        "the picture breaks into {material} separate pieces of material and {cut} of cut \
         (4-connected pixels), more than the {limit} the check measures; a sheet in that many \
         pieces cannot hold together as a stencil (is it a stencil, with white for material?)"
    )]
    TooManyPieces {
        material: usize,
        cut: usize,
        limit: usize,
    },
}
