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
mod recorder;
mod stage;

pub use groups::{parse_groups, ACC, CTRL, DATAPATH, GROUPS, PORTS, REGS};
pub(crate) use recorder::Probes;
pub use stage::Stage;

use waves::Group;

use crate::config::{Order, PipelineConfig};
use crate::datapath::SampleTrace;
use crate::fixed::Format;
use crate::pe::{Pe, Port, Readout};
use crate::stages::passes::PassBus;

/// The stages' codes and names, for the translate filter.
const STAGE_NAMES: [(u64, &str); 10] = {
    let mut names = [(0, ""); 10];
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

    /// An enumeration whose values have `names`.
    const fn named(self, names: &'static [(u64, &'static str)]) -> Self {
        Probe { names, ..self }
    }

    /// Only in configurations where `present` holds.
    const fn only(self, present: fn(&PipelineConfig) -> bool) -> Self {
        Probe { present, ..self }
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

/// A raw word in two's complement over the port's width (the words are
/// unsigned at the default widths; a signed format shows its bit pattern).
/// The traced width of a gradient word.
fn bits_of_grad(s: &PeView) -> u32 {
    s.grad_bits
}

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

/// A PE as its probes see it: what its last sampling cycle did, its ray
/// counter, its registers and FIFO levels, and the controller's stage (a
/// PE is busy only while sampling). A copy rather than a borrow, so the
/// tables' readers need no lifetime.
pub(crate) struct PeView {
    last: SampleTrace,
    rays_sent: u64,
    stage: Stage,
    held: u64,
    fifo: [u64; 2],
    incoming: u64,
    edge_reg: [u16; 2],
    halo_reg: crate::shading::Halo,
    grad_bits: u32,
    in_flight: bool,
    children: u64,
    stalls: u64,
}

impl PeView {
    fn of(pe: &Pe, stage: Stage, cycle: u64, grad_bits: u32) -> PeView {
        PeView {
            grad_bits,
            last: pe.last,
            rays_sent: pe.counters.rays_sent,
            stage,
            held: pe.rays.len() as u64,
            fifo: [pe.out_left.len() as u64, pe.out_right.len() as u64],
            incoming: pe.incoming.len() as u64,
            edge_reg: pe.edge_value.left,
            halo_reg: pe.edge_value.halo,
            in_flight: !pe.datapath_empty(cycle + 1),
            children: pe.pass.children.len() as u64,
            stalls: pe.counters.stalls,
        }
    }
}

impl PeView {
    fn busy(&self) -> bool {
        self.stage == Stage::Sample && self.last.busy
    }
}

/// Scope `top.pe_K`, in the order the signals have always had (the
/// accumulators sit between the datapath's signals, so the groups share
/// one table).
const PE_PROBES: &[Probe<PeView>] = &[
    Probe::<PeView>::new("busy", DATAPATH, |_| 1, |s| u64::from(s.busy())),
    Probe::<PeView>::new("ray_mx", DATAPATH, |_| 16, |s| index16(s.last.mx)),
    Probe::<PeView>::new("ray_row", DATAPATH, |_| 16, |s| s.last.row as u64 & 0xffff),
    Probe::<PeView>::new(
        "sample",
        DATAPATH,
        |c| bits(c.sample),
        |s| s.last.sample as u64,
    ),
    Probe::<PeView>::new(
        "alpha",
        DATAPATH,
        |c| bits(c.alpha),
        |s| s.last.alpha as u64,
    ),
    Probe::<PeView>::new(
        "alpha_corr",
        DATAPATH,
        |c| bits(c.opacity_corr),
        |s| s.last.corrected as u64,
    ),
    Probe::<PeView>::new(
        "acc_r",
        ACC,
        |c| bits(c.accum_color),
        |s| s.last.acc.raw[0] as u64,
    ),
    Probe::<PeView>::new(
        "acc_g",
        ACC,
        |c| bits(c.accum_color),
        |s| s.last.acc.raw[1] as u64,
    ),
    Probe::<PeView>::new(
        "acc_b",
        ACC,
        |c| bits(c.accum_color),
        |s| s.last.acc.raw[2] as u64,
    ),
    Probe::<PeView>::new(
        "acc_a",
        ACC,
        |c| bits(c.accum_alpha),
        |s| s.last.acc.raw[3] as u64,
    ),
    Probe::<PeView>::new(
        "grad_x",
        DATAPATH,
        |c| bits(c.gradient),
        |s| word(s.last.shade.grad[0], bits_of_grad(s)),
    )
    .shaded(),
    Probe::<PeView>::new(
        "grad_y",
        DATAPATH,
        |c| bits(c.gradient),
        |s| word(s.last.shade.grad[1], bits_of_grad(s)),
    )
    .shaded(),
    Probe::<PeView>::new(
        "grad_z",
        DATAPATH,
        |c| bits(c.gradient),
        |s| word(s.last.shade.grad[2], bits_of_grad(s)),
    )
    .shaded(),
    Probe::<PeView>::new(
        "grad_norm",
        DATAPATH,
        |c| bits(c.grad_norm),
        |s| s.last.shade.norm as u64,
    )
    .shaded(),
    Probe::<PeView>::new(
        "n_dot_l",
        DATAPATH,
        |c| bits(c.normal_dot),
        |s| s.last.shade.diffuse as u64,
    )
    .shaded(),
    Probe::<PeView>::new(
        "shaded_r",
        DATAPATH,
        |c| bits(c.color),
        |s| s.last.shade.rgb[0] as u64,
    )
    .shaded(),
    Probe::<PeView>::new(
        "shaded_g",
        DATAPATH,
        |c| bits(c.color),
        |s| s.last.shade.rgb[1] as u64,
    )
    .shaded(),
    Probe::<PeView>::new(
        "shaded_b",
        DATAPATH,
        |c| bits(c.color),
        |s| s.last.shade.rgb[2] as u64,
    )
    .shaded(),
    Probe::<PeView>::new(
        "voi_weight",
        DATAPATH,
        |c| bits(c.voi_weight),
        |s| s.last.voi.weight as u64,
    )
    .with_voi(),
    Probe::<PeView>::new(
        "voi_factor",
        DATAPATH,
        |c| bits(c.voi_factor),
        |s| s.last.voi.factor as u64,
    )
    .with_voi(),
    Probe::<PeView>::new(
        "pre_back",
        DATAPATH,
        |c| bits(c.sample),
        |s| s.last.preint.back as u64,
    )
    .with_preint(),
    Probe::<PeView>::new(
        "pre_tau",
        DATAPATH,
        |c| bits(c.preint_tau),
        |s| s.last.preint.tau as u64,
    )
    .with_preint(),
    Probe::<PeView>::new("rays_sent", DATAPATH, |_| 32, |s| s.rays_sent & 0xffff_ffff),
    // Front to back only, so back-to-front waveforms stay as they were.
    Probe::<PeView>::new(
        "terminated",
        DATAPATH,
        |_| 1,
        |s| u64::from(s.busy() && s.last.terminated),
    )
    .only(|c| c.order == Order::FrontToBack),
    Probe::<PeView>::new("rays_held", REGS, |_| 16, |s| s.held & 0xffff),
    Probe::<PeView>::new("fifo_left", REGS, |_| 16, |s| s.fifo[0] & 0xffff),
    Probe::<PeView>::new("fifo_right", REGS, |_| 16, |s| s.fifo[1] & 0xffff),
    Probe::<PeView>::new("incoming", REGS, |_| 8, |s| s.incoming & 0xff),
    Probe::<PeView>::new(
        "edge_reg_0",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.edge_reg[0]),
    ),
    Probe::<PeView>::new(
        "edge_reg_1",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.edge_reg[1]),
    ),
    Probe::<PeView>::new(
        "halo_reg_0",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[0]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_1",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[1]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_2",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[2]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_3",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[3]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_4",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[4]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_5",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[5]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_6",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[6]),
    )
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_7",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[7]),
    )
    .shaded(),
    Probe::<PeView>::new("in_flight", REGS, |_| 1, |s| u64::from(s.in_flight)),
    Probe::<PeView>::new("pass_children", REGS, |_| 16, |s| s.children & 0xffff),
    Probe::<PeView>::new("stalls", REGS, |_| 32, |s| s.stalls & 0xffff_ffff),
];

/// Scope `top.pe_K.host`: the ray word a PE streams to the host in a
/// readout cycle.
const HOST_PROBES: &[Probe<Option<Readout>>] = &[
    Probe::<Option<Readout>>::new("valid", PORTS, |_| 1, |s| u64::from(s.is_some())),
    Probe::<Option<Readout>>::new("mx", PORTS, |_| 16, |s| s.map_or(0, |o| index16(o.mx))),
    Probe::<Option<Readout>>::new(
        "row",
        PORTS,
        |_| 16,
        |s| s.map_or(0, |o| u64::from(o.row) & 0xffff),
    ),
    Probe::<Option<Readout>>::new("r", PORTS, link_color, |s| {
        s.map_or(0, |o| o.acc.raw[0] as u64)
    }),
    Probe::<Option<Readout>>::new("g", PORTS, link_color, |s| {
        s.map_or(0, |o| o.acc.raw[1] as u64)
    }),
    Probe::<Option<Readout>>::new("b", PORTS, link_color, |s| {
        s.map_or(0, |o| o.acc.raw[2] as u64)
    }),
    Probe::<Option<Readout>>::new("a", PORTS, link_alpha, |s| {
        s.map_or(0, |o| o.acc.raw[3] as u64)
    }),
];

/// A link port as its probes see it: what the PE drove on it this cycle,
/// and the widths of its words.
pub(crate) struct PortView {
    port: Port,
    color: u32,
    alpha: u32,
}

impl PortView {
    fn ray(&self, f: impl Fn(&crate::pe::RayMove) -> u64) -> u64 {
        self.port.ray.as_ref().map_or(0, f)
    }
    /// Halo word `i`, shown while edge voxels are valid.
    fn halo(&self, i: usize) -> u64 {
        u64::from(self.port.halo[i]) * u64::from(self.port.edge_valid)
    }
    /// The parent's words, shown only while one is driven.
    fn parent(&self, ch: usize) -> u64 {
        let w = if ch < 3 { self.color } else { self.alpha };
        self.port
            .edge_mx
            .map_or(0, |_| word(self.port.edge_acc.raw[ch], w))
    }
}

/// Scopes `top.pe_K.left` and `top.pe_K.right` (towards PE `K - 1` and
/// `K + 1`): a ray migrating (its index, row and accumulators), the edge
/// voxels of the row sampled next (rows `y0` and `y0 + 1`) and the edge
/// ray of a merge, split or fold row (a parent, with its index). Payloads
/// read 0 while their valid is low.
const PORT_PROBES: &[Probe<PortView>] = &[
    Probe::<PortView>::new(
        "ray_valid",
        PORTS,
        |_| 1,
        |s| u64::from(s.port.ray.is_some()),
    ),
    Probe::<PortView>::new("ray_mx", PORTS, |_| 16, |s| s.ray(|r| index16(r.mx))),
    Probe::<PortView>::new(
        "ray_row",
        PORTS,
        |_| 16,
        |s| s.ray(|r| u64::from(r.row) & 0xffff),
    ),
    Probe::<PortView>::new("ray_r", PORTS, link_color, |s| {
        s.ray(|r| word(r.acc.raw[0], s.color))
    }),
    Probe::<PortView>::new("ray_g", PORTS, link_color, |s| {
        s.ray(|r| word(r.acc.raw[1], s.color))
    }),
    Probe::<PortView>::new("ray_b", PORTS, link_color, |s| {
        s.ray(|r| word(r.acc.raw[2], s.color))
    }),
    Probe::<PortView>::new("ray_a", PORTS, link_alpha, |s| {
        s.ray(|r| word(r.acc.raw[3], s.alpha))
    }),
    Probe::<PortView>::new(
        "ray_prev",
        PORTS,
        |c| bits(c.sample),
        |s| s.ray(|r| r.prev as u64),
    )
    .with_preint(),
    Probe::<PortView>::new("edge_valid", PORTS, |_| 1, |s| u64::from(s.port.edge_valid)),
    Probe::<PortView>::new(
        "edge_0",
        PORTS,
        |c| bits(c.voxel),
        |s| u64::from(s.port.edge[0]) * u64::from(s.port.edge_valid),
    ),
    Probe::<PortView>::new(
        "edge_1",
        PORTS,
        |c| bits(c.voxel),
        |s| u64::from(s.port.edge[1]) * u64::from(s.port.edge_valid),
    ),
    // The gradient's halo (to the left neighbour) while the array shades;
    // the right port's edge words then carry the last column.
    Probe::<PortView>::new("halo_0", PORTS, |c| bits(c.voxel), |s| s.halo(0)).shaded(),
    Probe::<PortView>::new("halo_1", PORTS, |c| bits(c.voxel), |s| s.halo(1)).shaded(),
    Probe::<PortView>::new("halo_2", PORTS, |c| bits(c.voxel), |s| s.halo(2)).shaded(),
    Probe::<PortView>::new("halo_3", PORTS, |c| bits(c.voxel), |s| s.halo(3)).shaded(),
    Probe::<PortView>::new("halo_4", PORTS, |c| bits(c.voxel), |s| s.halo(4)).shaded(),
    Probe::<PortView>::new("halo_5", PORTS, |c| bits(c.voxel), |s| s.halo(5)).shaded(),
    Probe::<PortView>::new("halo_6", PORTS, |c| bits(c.voxel), |s| s.halo(6)).shaded(),
    Probe::<PortView>::new("halo_7", PORTS, |c| bits(c.voxel), |s| s.halo(7)).shaded(),
    Probe::<PortView>::new(
        "parent_valid",
        PORTS,
        |_| 1,
        |s| u64::from(s.port.edge_mx.is_some()),
    ),
    Probe::<PortView>::new(
        "parent_mx",
        PORTS,
        |_| 16,
        |s| s.port.edge_mx.map_or(0, index16),
    ),
    Probe::<PortView>::new("parent_r", PORTS, link_color, |s| s.parent(0)),
    Probe::<PortView>::new("parent_g", PORTS, link_color, |s| s.parent(1)),
    Probe::<PortView>::new("parent_b", PORTS, link_color, |s| s.parent(2)),
    Probe::<PortView>::new("parent_a", PORTS, link_alpha, |s| s.parent(3)),
];
