//! ercube's golden model: what the chip must compute, in floating point.
//!
//! The dataflow, module by module: [`volume`] (and [`load`], [`scenes`]) ->
//! [`tf`] (classification) -> [`geometry`] (principal axis, regions, rays:
//! the one source of truth shared with the pipeline) -> [`slices`] (the
//! permuted slice stack) and [`occupancy`] (min-max blocks, empty space)
//! -> [`skip`] (which samples a frame takes: empty space, culling,
//! [`clip`] planes) -> a method ([`methods`], built from [`sampling`] and
//! [`merge`]: ER back-to-front and front-to-back, under/oversampling, box
//! merge) -> [`warp::Baseplane`] -> [`warp`] -> [`image::Image`];
//! [`mod@reference`] renders the same camera by image-order ray casting as
//! ground truth, [`mipcast`] casts rays through a 3D mip-map
//! ([`mipmap`]) whose level follows each ray's footprint, [`shearwarp`]
//! composites sheared slices on an intermediate image and warps it,
//! [`gaze`] varies the casters' resolution around a gaze point and
//! [`ergaze`] ER's, by one frame per level, [`refine`] refines the
//! casters' rays where the image is complex (and progressively),
//! [`metrics`] compares images.

#![deny(rustdoc::broken_intra_doc_links)]

pub mod camera;
pub mod clip;
pub mod ergaze;
pub mod error;
pub mod gaze;
pub mod geometry;
pub mod gradients;
pub mod image;
pub mod load;
pub mod merge;
pub mod methods;
pub mod metrics;
pub mod mipcast;
pub mod mipmap;
pub mod occupancy;
pub mod opacity;
pub mod orient;
pub mod preint;
pub mod reference;
pub mod refine;
pub mod render;
pub mod sampling;
pub mod scenes;
pub mod shading;
pub mod shearwarp;
pub mod skip;
pub mod slices;
pub mod tf;
pub mod values;
pub mod voi;
pub mod volume;
pub mod warp;

pub use error::{Error, Result};
