//! The waves crate's integration tests, one binary (it links once).

#[path = "../../../tests/support/tools.rs"]
mod tools;

mod filters;
mod interop;
mod roundtrip;
