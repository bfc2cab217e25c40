//! Why the check could not measure (its own leaf, so the check and the triangulation share it).

/// Why the check could not measure the outline.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// A point of the outline the triangulation cannot take (only an absurd size, which the
    /// size limits refuse first, can make one).
    #[error(
        "the width check cannot triangulate the outline: its point ({x_mm}, {y_mm}) mm is {problem}; \
         check the picture's size and the margin"
    )]
    Coordinate {
        /// The point, mm right.
        x_mm: f64,
        /// Mm down.
        y_mm: f64,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// The picture breaks into too many pieces to measure (`bound_pieces`).
    #[error(
        "the picture breaks into {material} separate pieces of material and {cut} of cut \
         (4-connected pixels), more than the {limit} the check measures; a sheet in that many \
         pieces cannot hold together as a stencil (is it a stencil, with white for material?)"
    )]
    TooManyPieces {
        /// Pieces of material.
        material: usize,
        /// Pieces of cut.
        cut: usize,
        /// The most the check measures.
        limit: usize,
    },
}
