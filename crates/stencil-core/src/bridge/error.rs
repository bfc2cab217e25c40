//! Why the islands could not be joined, or a bridge setting is wrong (a leaf).

/// Why the islands could not be joined, or a setting is wrong.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// No path through the cut leaves the island's group. Never for a labelling of the bit grid
    /// given (a path to another node or to the image edge always exists): the island map passed
    /// in does not describe the bits.
    #[error(
        "island {island} at pixel ({x}, {y}) has no path through the cut to the frame or another \
         island: the island map does not match the bit grid"
    )]
    Unreachable {
        /// The island's node.
        island: u32,
        /// A pixel of it, column.
        x: u32,
        /// Row.
        y: u32,
    },
    /// The island can be joined only through pixels the user forbade (`--keep-out`,
    /// `--no-bridge-near`). Its position is in millimetres from the picture's top left corner.
    #[error(
        "island {island} at ({x_mm:.1}, {y_mm:.1}) mm can only be joined through the areas kept \
         free of bridges: lighten the keep-out mask or move the disc there, or cut such islands away"
    )]
    KeptOut {
        /// The island's node.
        island: u32,
        /// Where it is, mm right.
        x_mm: f64,
        /// Mm down.
        y_mm: f64,
    },
    /// A `BridgeConfig` value out of its range.
    #[error("bridge setting {name} = {value} is invalid: {why}")]
    BadSetting {
        /// The setting's field name.
        name: &'static str,
        /// Its value, as printed.
        value: String,
        /// What it must be.
        why: &'static str,
    },
}
