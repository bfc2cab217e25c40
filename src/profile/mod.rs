//! Material and machine profiles, read from TOML and validated once at load.
//! OWNER: materials by the vectors issue (`material.rs`), machines by the G-code issue (`machine.rs`).
pub mod machine;
