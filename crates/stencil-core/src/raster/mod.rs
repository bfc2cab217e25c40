//! Pixel grids shared by every stage before `vector`: the grayscale rendering and the two-tone bit grid.
//!
//! Row-major, origin top-left, Y down (image convention). Stages before `vector` work in pixels only;
//! millimetres appear through [`crate::units::Scale`].

mod distance;
mod grid;
mod label;
pub(crate) mod morph;
pub(crate) mod packed;
mod smooth;

pub(crate) use distance::{squared_distance, squared_distance_to};
pub(crate) use grid::edge_neighbours;
pub use grid::{BitGrid, Gray, TwoTone};
pub(crate) use label::{
    components, join, join_runs, push_runs, root, runs_of, touches_border, Run, NOT_LABELLED,
};
pub(crate) use morph::{close, open};
#[cfg(test)]
pub(crate) use smooth::box_average_bits;
pub(crate) use smooth::{
    blur, blur_of, blur_of_into, box_average, box_average_bits_into, convolve,
};
