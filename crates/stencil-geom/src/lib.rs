//! Shared 2D geometry in millimetres for `stencil`'s stages: one place for what the vector stage,
//! the checker and the toolpath planner all need.
//!
//! Public API:
//! - [`clip`]: every call into Clipper (boolean operations and offsets of many polygons at once,
//!   in parallel), behind a gate ([`clip::check_rings`], a work estimate) so that no input can
//!   panic, abort or stall it; [`ClipError`] says why a shape was refused.
//! - [`kerf::offset_cuts`]: cut regions shrunk by half the tool's kerf, so the removed strip's
//!   edge lands on the design line; [`kerf::offset_cuts_curved`] offsets regions known as lines
//!   and arcs exactly (cavalier_contours).
//! - [`curve`]: closed outlines fitted with lines and arcs within a tolerance ([`curve::fit_ring`]),
//!   and flattened back ([`curve::flatten`]); [`curve::Curves`] finds a flattened ring's pieces
//!   again, so the writers carry the fitted arcs themselves.
//! - [`ring`]: measures of a ring as a point list: [`ring::bbox`], [`ring::signed_area2`],
//!   [`ring::area`], [`ring::point_in_ring`], [`ring::dist`].
//!
//! ```
//! use stencil_geom::ring::{area, point_in_ring, signed_area2};
//!
//! // A 10 x 5 mm rectangle, counter-clockwise: positive signed area.
//! let ring = [[0.0, 0.0], [10.0, 0.0], [10.0, 5.0], [0.0, 5.0]];
//! assert_eq!(area(&ring), 50.0);
//! assert!(signed_area2(&ring) > 0.0);
//! assert!(point_in_ring([2.0, 2.0], &ring) && !point_in_ring([12.0, 2.0], &ring));
//! ```
//!
//! Shapes are `geo` types (`Polygon<f64>`, `MultiPolygon<f64>`) where they cross crates; `geo`'s
//! own traits (`Contains`, `Area`, `BoundingRect`, ...) are used directly where they fit.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod clip;
pub mod curve;
pub mod kerf;
pub mod ring;

pub use clip::ClipError;
