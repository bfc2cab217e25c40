//! Toolpaths: cut order, travel optimisation, passes, time estimate, G-code text.
//! OWNER: the G-code issue.

pub mod estimate;
