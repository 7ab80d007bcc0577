//! The array's waveform probes, declared once beside the state they read:
//! one table per scope (the controller, a PE, a PE's link port), each line
//! a signal's name, group, width and how it is read. Registration and
//! sampling both walk the tables, so a new signal is one line here and no
//! edit in the array.
//!
//! Groups (`--trace-signals`, [`waves::TraceConfig::with_groups`]):
//! `ctrl` (the controller), `datapath` (a PE's sample path and counters),
//! `acc` (its accumulators after compositing) and `ports` (both link ports
//! of every PE, scopes `left` and `right`: rays migrating, edge voxels,
//! merge parents, each as valid and payload, and the host port of the
//! readout) are on by default; `regs` (a PE's registers and FIFO levels)
//! is off by default, since it more than doubles the signals of a PE.
//!
//! The stage is a [`Stage`], written as its numeric code; its names reach
//! GTKWave through the translate filter file written beside the `.gtkw`
//! (`<name>.stage.txt`).

/// The controller's stage signal, whose changes a save file marks.
pub const STAGE_SIGNAL: &str = "top.ctrl.stage";

/// The stages a save file marks every time they start (besides the first
/// start of each stage): the region boundaries and the readout.
pub const MARKED_STAGES: [Stage; 4] = [Stage::Merge, Stage::Split, Stage::Fold, Stage::Readout];

mod groups;
pub mod nodes;
mod pe;
mod ports;
mod recorder;
mod signals;
mod stage;

pub use groups::{parse_groups, ACC, CTRL, DATAPATH, GROUPS, PORTS, REGS};
use pe::{PeView, PE_PROBES};
use ports::{PortView, HOST_PROBES, PORT_PROBES};
pub(crate) use recorder::Probes;
pub use signals::{PeCycle, Signal, SignalSet};
pub use stage::Stage;

use waves::Group;

use crate::config::PipelineConfig;
use crate::fixed::Format;
use crate::stages::passes::PassBus;

/// The stages' codes and names, for the translate filter.
const STAGE_NAMES: [(u64, &str); Stage::ALL.len()] = {
    let mut names = [(0, ""); Stage::ALL.len()];
    let mut i = 0;
    while i < names.len() {
        names[i] = (Stage::ALL[i] as u64, Stage::ALL[i].name());
        i += 1;
    }
    names
};

/// One signal: its name, group, width (from the configuration), how it
/// is read from the state `S` of its scope, whether the configuration has
/// it at all, and the names of its values if it is an enumeration.
struct Probe<S> {
    name: &'static str,
    group: Group,
    width: fn(&PipelineConfig) -> u32,
    /// Whether the word is two's complement (from its format).
    signed: fn(&PipelineConfig) -> bool,
    read: fn(&S) -> u64,
    present: fn(&PipelineConfig) -> bool,
    /// Only in an array that shades (the gradient and shading unit's
    /// signals and port words), so unshaded waveforms stay as they were.
    shaded: bool,
    /// Only in an array with a volume of interest (its stage's registers),
    /// so waveforms without one stay as they were.
    voi: bool,
    /// Only in a pre-integrated frame (the unit's words), so other
    /// waveforms stay as they were.
    preint: bool,
    names: &'static [(u64, &'static str)],
}

impl<S> Probe<S> {
    const fn new(
        name: &'static str,
        group: Group,
        width: fn(&PipelineConfig) -> u32,
        read: fn(&S) -> u64,
    ) -> Self {
        Probe {
            name,
            group,
            width,
            signed: |_| false,
            read,
            present: |_| true,
            shaded: false,
            voi: false,
            preint: false,
            names: &[],
        }
    }

    /// Only while the array shades.
    const fn shaded(self) -> Self {
        Probe {
            shaded: true,
            ..self
        }
    }

    /// Only while the array has a volume of interest.
    const fn with_voi(self) -> Self {
        Probe { voi: true, ..self }
    }

    /// Only in a pre-integrated frame.
    const fn with_preint(self) -> Self {
        Probe {
            preint: true,
            ..self
        }
    }

    /// A two's-complement word (a ray index).
    const fn signed(self) -> Self {
        Probe {
            signed: |_| true,
            ..self
        }
    }

    /// A word of a format whose signedness `signed` reads.
    const fn signed_as(self, signed: fn(&PipelineConfig) -> bool) -> Self {
        Probe { signed, ..self }
    }

    /// An enumeration whose values have `names`.
    const fn named(self, names: &'static [(u64, &'static str)]) -> Self {
        Probe { names, ..self }
    }

    /// Only in configurations where `present` holds.
    const fn only(self, present: fn(&PipelineConfig) -> bool) -> Self {
        Probe { present, ..self }
    }

    /// Whether a frame of `cfg` with the `units` (shading, volume of
    /// interest, pre-integration) has this signal.
    fn shown(&self, cfg: &PipelineConfig, (shading, voi, preint): (bool, bool, bool)) -> bool {
        (self.present)(cfg)
            && (shading || !self.shaded)
            && (voi || !self.voi)
            && (preint || !self.preint)
    }
}

fn bits(f: Format) -> u32 {
    u32::from(f.bits())
}

/// Ray indices and rows are traced as 16-bit two's complement.
fn index16(v: i64) -> u64 {
    v as u64 & 0xffff
}

/// A word that crosses a link: accumulators back to front, also `merge`
/// words front to back (the fold's differences and results), so the port
/// carries the wider.
fn link_color(c: &PipelineConfig) -> u32 {
    bits(c.accum_color).max(bits(c.merge))
}
fn link_alpha(c: &PipelineConfig) -> u32 {
    bits(c.accum_alpha).max(bits(c.merge))
}
/// Whether a link's colour word is two's complement: either format is.
fn link_color_signed(c: &PipelineConfig) -> bool {
    c.accum_color.is_signed() || c.merge.is_signed()
}
fn link_alpha_signed(c: &PipelineConfig) -> bool {
    c.accum_alpha.is_signed() || c.merge.is_signed()
}

/// A raw word in two's complement over the port's width (the words are
/// unsigned at the default widths; a signed format shows its bit pattern).
fn word(v: i64, width: u32) -> u64 {
    if width >= 64 {
        v as u64
    } else {
        v as u64 & ((1 << width) - 1)
    }
}

/// What the controller shows in a cycle: its stage, the slice and row
/// it broadcasts, and in a merge, split or fold the pass's broadcast.
#[derive(Debug, Clone, Copy)]
pub struct Ctrl {
    /// The stage.
    pub stage: Stage,
    /// The slice (sampling, migration, skipping).
    pub slice: usize,
    /// The ray row sampled, or the parent row a pass filters.
    pub row: usize,
    /// A pass's broadcast: x row, y row, column, the row driven.
    pub pass: Option<PassBus>,
}

impl Ctrl {
    /// A cycle of `stage` at slice `slice` and row `row`.
    pub fn at(stage: Stage, slice: usize, row: usize) -> Ctrl {
        Ctrl {
            stage,
            slice,
            row,
            pass: None,
        }
    }
}

/// An optional row as a valid bit's value and a 16-bit payload.
fn opt16(v: Option<usize>) -> (u64, u64) {
    v.map_or((0, 0), |r| (1, r as u64 & 0xffff))
}

fn pass_of(s: &Ctrl) -> PassBus {
    s.pass.unwrap_or_default()
}

/// Scope `top.ctrl`.
const CTRL_PROBES: &[Probe<Ctrl>] = &[
    Probe::<Ctrl>::new("stage", CTRL, |_| 4, |s| s.stage.code()).named(&STAGE_NAMES),
    Probe::<Ctrl>::new("slice", CTRL, |_| 16, |s| s.slice as u64 & 0xffff),
    Probe::<Ctrl>::new("row", CTRL, |_| 16, |s| s.row as u64 & 0xffff),
    Probe::<Ctrl>::new("pass_x_valid", CTRL, |_| 1, |s| opt16(pass_of(s).x).0),
    Probe::<Ctrl>::new("pass_x", CTRL, |_| 16, |s| opt16(pass_of(s).x).1),
    Probe::<Ctrl>::new("pass_y_valid", CTRL, |_| 1, |s| opt16(pass_of(s).y).0),
    Probe::<Ctrl>::new("pass_y", CTRL, |_| 16, |s| opt16(pass_of(s).y).1),
    Probe::<Ctrl>::new(
        "pass_col",
        CTRL,
        |_| 16,
        |s| s.pass.map_or(0, |p| p.col as u64 & 0xffff),
    ),
    Probe::<Ctrl>::new("drive_valid", CTRL, |_| 1, |s| opt16(pass_of(s).drive).0),
    Probe::<Ctrl>::new("drive_row", CTRL, |_| 16, |s| opt16(pass_of(s).drive).1),
];
