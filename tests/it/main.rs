//! The `ercube` program's integration tests, one binary (it links once):
//! the command-line contract (`cli`), the benchmark commands (`bench`),
//! the PE array run through the program (`array`), the peer renderer
//! comparison (`peers`, VTK when a Python has it), shading through the
//! program (`shade`), the skipping benchmark on a given architecture
//! (`skipbench`) and the rustdoc's intra-doc links (`docs`). Each
//! crate's own tests live beside it (`golden/tests/it`,
//! `pipeline/tests/it`, `waves/tests/it`); the helpers all of them share
//! are in `tests/support/`.

#[path = "../support/bin.rs"]
mod bin;
#[path = "../support/chip.rs"]
mod chip;
#[path = "../support/mutate.rs"]
mod mutate;
#[path = "../support/round_robin.rs"]
mod round_robin;
#[path = "../support/scenes.rs"]
mod scenes;
#[path = "../support/tools.rs"]
mod tools;

mod animate;
mod array;
mod bench;
mod bound;
mod cli;
mod cosim;
mod cosim_fold;
mod cosim_merge;
mod cosim_pass;
mod cosim_preint;
mod cosim_split;
mod docs;
mod explore;
mod frame_rate;
mod memory;
mod outputs;
mod pe_vectors;
mod peers;
mod preint;
mod refine;
mod runs;
mod shade;
mod shards;
mod shearwarp;
mod skipbench;
mod synth;
mod trace_nodes;
mod voi;
mod volumes;
