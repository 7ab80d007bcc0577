//! Bit-accurate, cycle-level model of ercube's 1D processing-element array
//! for ER-Perspective ray casting.
//!
//! [`fixed`] is the arithmetic every datapath register uses: declared
//! formats with `ap_fixed` quantisation and overflow semantics, exact
//! intermediates, event counters and bit packing. [`config`] holds the
//! run-time choice of every datapath width ([`config::PipelineConfig`]),
//! read from TOML and validated before a run.

pub mod config;
pub mod fixed;
