//! Signal probes for the ercube cycle model: a registry of hierarchical
//! signals, a VCD and FST writer that costs one branch per cycle when off,
//! a VCD reader for tests, and GTKWave save files with translate filters
//! for enumerations.
//!
//! # Conventions
//!
//! * Scopes: `top`, `top.pe_<k>` for PE `k` (see [`ScopePath`]), any
//!   sub-scopes below them (`top.ctrl`, `top.pe_3.mac`).
//! * Time: `$timescale 100ps`, one clock cycle is
//!   [`TIME_UNITS_PER_CYCLE`] = 50 units = 5 ns, a cycle of the 200 MHz
//!   clock [`CLOCK_MHZ`] (the one `ercube cost` quotes Artix-7 frame rates
//!   at), and the values shown from time `50*c` are those the model set
//!   for cycle `c`. An optional `top.clk` rises at `50*c` and falls at
//!   `50*c + 25`. The file ends with a timestamp at `50*(last + 1)` so the
//!   last cycle has its full width; an FST's header starts at the first
//!   traced cycle.
//! * Only changes are written: the first sampled cycle writes every value
//!   set in it, later cycles only those that differ from the last written.
//! * A value that does not fit its declared width is an error
//!   ([`WavesError::ValueTooWide`], returned by [`Tracer::finish`]), never
//!   silently truncated.
//!
//! # Example
//!
//! ```
//! use waves::{PeFilter, ScopePath, Trace, TraceConfig, Tracer};
//!
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("run.vcd");
//! let config = TraceConfig::new(&path)
//!     .with_pes(PeFilter::parse("0,2")?)
//!     .with_cycles(2..=5);
//! let mut tracer = Tracer::new(config)?; // or Tracer::disabled()
//! let acc: Vec<_> = (0..4)
//!     .map(|k| tracer.register(&ScopePath::pe(k), "acc", 16))
//!     .collect::<Result<_, _>>()?;
//! let state = tracer.register(&ScopePath::top().child("ctrl"), "state", 3)?;
//!
//! for cycle in 0..10u64 {
//!     // ... the model computes cycle `cycle` ...
//!     tracer.sample(cycle, |s| {
//!         for (k, &id) in acc.iter().enumerate() {
//!             s.set(id, cycle * 100 + k as u64);
//!         }
//!         s.set(state, cycle % 8);
//!     });
//! }
//! let info = tracer.finish()?.expect("tracing was enabled");
//! info.write_gtkw(dir.path().join("run.gtkw"))?;
//!
//! let trace = Trace::read(&path)?;
//! assert_eq!(trace.signal("top.pe_2.acc").unwrap().u64_at_cycle(4), Some(402));
//! assert!(trace.signal("top.pe_1.acc").is_none());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![deny(rustdoc::broken_intra_doc_links)]
#![warn(missing_docs)]

mod atomic;
mod config;
mod error;
mod gtkw;
mod read;
mod scope;
mod sinks;
mod tracer;

pub use bitvec;
pub use config::{parse_cycle_window, Group, PeFilter, TraceConfig};
pub use error::WavesError;
pub use read::{Change, SignalTrace, Trace, WaveValue};
pub use scope::{pe_scope_name, ScopePath, TOP};
pub use tracer::{
    Sampler, SignalId, SignalInfo, TraceInfo, Tracer, CLOCK_MHZ, CLOCK_NAME, MAX_MARKERS,
    MAX_WIDTH, TIME_UNITS_PER_CYCLE, TIME_UNIT_PS,
};
