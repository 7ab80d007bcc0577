//! The pipeline model's integration tests, one binary (it links once):
//! the array's structure, cycle accounting and waveforms (`model`), the
//! clock, latency and step shapes (`clock`), front
//! to back (`ftb`), ownership mappings (`mapping`), how rays move and where they live (`migration`), skipping (`skip`), equivalence with golden within the
//! derived bound (`equivalence`), numerical stress (`stress`) and the cost
//! estimator against yosys (`cost`), what the mappings and ray-buffer
//! placements cost (`architecture`), the waveforms beyond the default set (`traces`), and the gradient and
//! shading unit against golden's shading (`shading`), the volume-of-interest stage against golden's (`voi`), the pre-integration unit against golden's pre-integrated frames (`preint`). What runs the `ercube` program is in
//! the root `tests/it/`.

#[path = "../../../tests/support/chip.rs"]
mod chip;
#[path = "../../../tests/support/scenes.rs"]
mod scenes;
#[path = "../../../tests/support/tools.rs"]
mod tools;

mod architecture;
mod capture;
mod clock;
mod cost;
mod datapath_cost;
mod equivalence;
mod ftb;
mod kernel;
mod links;
mod load;
mod mapping;
mod merge_rtl;
mod migration;
mod model;
mod occupancy;
mod pass_rtl;
mod pe_maps;
mod pe_sample;
mod pe_units;
mod preexact;
mod preint;
mod readout_rtl;
mod rtl;
mod rtl_units;
mod shading;
mod skip;
mod split_rtl;
mod stepper;
mod stress;
mod support;
mod trace_nodes;
mod traces;
mod voi;
