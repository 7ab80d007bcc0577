//! Scope `top.pe_K`: a PE's signals (its sample path, accumulators,
//! counters, registers and FIFO levels), read from a copy of its state.

use super::{bits, index16, word, Probe, ACC, DATAPATH, REGS};
use crate::config::Order;
use crate::datapath::SampleTrace;
use crate::pe::Pe;
use crate::probes::Stage;

/// The traced width of a gradient word.
fn bits_of_grad(s: &PeView) -> u32 {
    s.grad_bits
}

/// A PE as its probes see it: what its last sampling cycle did, its ray
/// counter, its registers and FIFO levels, and the controller's stage (a
/// PE is busy only while sampling). A copy rather than a borrow, so the
/// tables' readers need no lifetime.
#[derive(Debug, Clone)]
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
    pub(super) fn of(pe: &Pe, stage: Stage, cycle: u64, grad_bits: u32) -> PeView {
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
pub(super) const PE_PROBES: &[Probe<PeView>] = &[
    Probe::<PeView>::new("busy", DATAPATH, |_| 1, |s| u64::from(s.busy())),
    Probe::<PeView>::new("ray_mx", DATAPATH, |_| 16, |s| index16(s.last.mx)).signed(),
    Probe::<PeView>::new("ray_row", DATAPATH, |_| 16, |s| s.last.row as u64 & 0xffff),
    Probe::<PeView>::new(
        "sample",
        DATAPATH,
        |c| bits(c.sample),
        |s| s.last.sample as u64,
    )
    .signed_as(|c| c.sample.is_signed()),
    Probe::<PeView>::new(
        "alpha",
        DATAPATH,
        |c| bits(c.alpha),
        |s| s.last.alpha as u64,
    )
    .signed_as(|c| c.alpha.is_signed()),
    Probe::<PeView>::new(
        "alpha_corr",
        DATAPATH,
        |c| bits(c.opacity_corr),
        |s| s.last.corrected as u64,
    )
    .signed_as(|c| c.opacity_corr.is_signed()),
    Probe::<PeView>::new(
        "acc_r",
        ACC,
        |c| bits(c.accum_color),
        |s| s.last.acc.raw[0] as u64,
    )
    .signed_as(|c| c.accum_color.is_signed()),
    Probe::<PeView>::new(
        "acc_g",
        ACC,
        |c| bits(c.accum_color),
        |s| s.last.acc.raw[1] as u64,
    )
    .signed_as(|c| c.accum_color.is_signed()),
    Probe::<PeView>::new(
        "acc_b",
        ACC,
        |c| bits(c.accum_color),
        |s| s.last.acc.raw[2] as u64,
    )
    .signed_as(|c| c.accum_color.is_signed()),
    Probe::<PeView>::new(
        "acc_a",
        ACC,
        |c| bits(c.accum_alpha),
        |s| s.last.acc.raw[3] as u64,
    )
    .signed_as(|c| c.accum_alpha.is_signed()),
    Probe::<PeView>::new(
        "grad_x",
        DATAPATH,
        |c| bits(c.gradient),
        |s| word(s.last.shade.grad[0], bits_of_grad(s)),
    )
    .signed_as(|c| c.gradient.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "grad_y",
        DATAPATH,
        |c| bits(c.gradient),
        |s| word(s.last.shade.grad[1], bits_of_grad(s)),
    )
    .signed_as(|c| c.gradient.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "grad_z",
        DATAPATH,
        |c| bits(c.gradient),
        |s| word(s.last.shade.grad[2], bits_of_grad(s)),
    )
    .signed_as(|c| c.gradient.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "grad_norm",
        DATAPATH,
        |c| bits(c.grad_norm),
        |s| s.last.shade.norm as u64,
    )
    .signed_as(|c| c.grad_norm.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "n_dot_l",
        DATAPATH,
        |c| bits(c.normal_dot),
        |s| s.last.shade.diffuse as u64,
    )
    .signed_as(|c| c.normal_dot.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "shaded_r",
        DATAPATH,
        |c| bits(c.color),
        |s| s.last.shade.rgb[0] as u64,
    )
    .signed_as(|c| c.color.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "shaded_g",
        DATAPATH,
        |c| bits(c.color),
        |s| s.last.shade.rgb[1] as u64,
    )
    .signed_as(|c| c.color.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "shaded_b",
        DATAPATH,
        |c| bits(c.color),
        |s| s.last.shade.rgb[2] as u64,
    )
    .signed_as(|c| c.color.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "voi_weight",
        DATAPATH,
        |c| bits(c.voi_weight),
        |s| s.last.voi.weight as u64,
    )
    .signed_as(|c| c.voi_weight.is_signed())
    .with_voi(),
    Probe::<PeView>::new(
        "voi_factor",
        DATAPATH,
        |c| bits(c.voi_factor),
        |s| s.last.voi.factor as u64,
    )
    .signed_as(|c| c.voi_factor.is_signed())
    .with_voi(),
    Probe::<PeView>::new(
        "pre_back",
        DATAPATH,
        |c| bits(c.sample),
        |s| s.last.preint.back as u64,
    )
    .signed_as(|c| c.sample.is_signed())
    .with_preint(),
    Probe::<PeView>::new(
        "pre_tau",
        DATAPATH,
        |c| bits(c.preint_tau),
        |s| s.last.preint.tau as u64,
    )
    .signed_as(|c| c.preint_tau.is_signed())
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
    )
    .signed_as(|c| c.voxel.is_signed()),
    Probe::<PeView>::new(
        "edge_reg_1",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.edge_reg[1]),
    )
    .signed_as(|c| c.voxel.is_signed()),
    Probe::<PeView>::new(
        "halo_reg_0",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[0]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_1",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[1]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_2",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[2]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_3",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[3]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_4",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[4]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_5",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[5]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_6",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[6]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new(
        "halo_reg_7",
        REGS,
        |c| bits(c.voxel),
        |s| u64::from(s.halo_reg[7]),
    )
    .signed_as(|c| c.voxel.is_signed())
    .shaded(),
    Probe::<PeView>::new("in_flight", REGS, |_| 1, |s| u64::from(s.in_flight)),
    Probe::<PeView>::new("pass_children", REGS, |_| 16, |s| s.children & 0xffff),
    Probe::<PeView>::new("stalls", REGS, |_| 32, |s| s.stalls & 0xffff_ffff),
];
