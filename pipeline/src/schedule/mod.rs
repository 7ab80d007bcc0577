//! A frame's schedule: which stages of [`crate::stages`] the controller
//! runs, in which order, for each compositing order. Each returns the
//! baseplane's raw words, their formats (colour, opacity) and the number
//! of region boundaries filtered.

pub(crate) mod btf;
mod ftb;

pub(crate) use btf::back_to_front;
pub(crate) use ftb::front_to_back;

use crate::fixed::Format;

/// What a schedule hands back: raw words, their formats, merges run.
pub(crate) type Output = (Vec<[i64; 4]>, [Format; 2], u64);
