//! The golden model's integration tests, one binary (it links once):
//! the conventions every method shares (`foundation`), ER-Perspective's
//! properties and the paper's figures (`figures`), and skipping
//! (`skipping`).

#[path = "../../../tests/support/scenes.rs"]
mod scenes;

mod ergaze;
mod figures;
mod formats;
mod foundation;
mod gaze;
mod lanes;
mod mipgaze;
mod mipmap;
mod opacity;
mod orientation;
mod preexact;
mod preint;
mod refine;
mod shading;
mod shearwarp;
mod skipping;
mod substeps;
mod swshade;
mod voi;
