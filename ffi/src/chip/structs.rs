//! The `#[repr(C)]` structs of a stepped cycle and how each is filled
//! from the probe table's signal of the same name.

use pipeline::probes::{Signal, SignalSet};
use pipeline::stepper::Cycle;

/// What a PE drove on one link port (`top.pe_K.left`, `top.pe_K.right`)
/// in a cycle. Payloads are 0 while their valid is 0. Widths are the
/// configuration's: `C` = max(`accum_color`, `merge`) bits, `A` =
/// max(`accum_alpha`, `merge`) bits, `V` = `voxel` bits, `S` = `sample`
/// bits; a word's low bits hold it (two's complement over its width).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubeLinkPort {
    /// `ray_r`, `ray_g`, `ray_b` (C bits), `ray_a` (A bits): a migrating
    /// ray's accumulators.
    pub ray_rgba: [u64; 4],
    /// `ray_prev` (S bits): its previous-sample word (pre-integrated
    /// frames; else 0).
    pub ray_prev: u64,
    /// `parent_r`, `parent_g`, `parent_b` (C), `parent_a` (A): a merge,
    /// split or fold row's edge ray.
    pub parent_rgba: [u64; 4],
    /// `ray_mx` (16 bits, two's complement): the migrating ray's index.
    pub ray_mx: u16,
    /// `ray_row` (16 bits): its row in the region.
    pub ray_row: u16,
    /// `edge_0`, `edge_1` (V bits): the edge column's voxels at rows y0,
    /// y0 + 1 of the row sampled next.
    pub edge: [u16; 2],
    /// `halo_0` .. `halo_7` (V bits): the gradient's halo words (shaded
    /// frames; else 0).
    pub halo: [u16; 8],
    /// `parent_mx` (16 bits, two's complement): the edge ray's index.
    pub parent_mx: u16,
    /// `ray_valid` (1 bit).
    pub ray_valid: u8,
    /// `edge_valid` (1 bit).
    pub edge_valid: u8,
    /// `parent_valid` (1 bit).
    pub parent_valid: u8,
}

/// What a PE streamed to the host in a readout cycle (`top.pe_K.host`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubeHostPort {
    /// `r`, `g`, `b` (C bits), `a` (A bits): the ray's final words.
    pub rgba: [u64; 4],
    /// `mx` (16 bits, two's complement): the ray's index.
    pub mx: u16,
    /// `row` (16 bits): its row in region 0.
    pub row: u16,
    /// `valid` (1 bit).
    pub valid: u8,
}

/// A PE's own signals in a cycle (`top.pe_K`): its sample path's output
/// registers, counters and registers. Words of the configuration's
/// formats (`sample`, `alpha`, `opacity_corr`, `accum_color`,
/// `accum_alpha`, `gradient`, `grad_norm`, `normal_dot`, `color`,
/// `voi_weight`, `voi_factor`, `preint_tau` bits) in the low bits; a
/// unit's words are 0 in a frame without it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubePeSignals {
    /// `sample`: the interpolated sample of its last sampling cycle.
    pub sample: u64,
    /// `alpha`: the classified opacity.
    pub alpha: u64,
    /// `alpha_corr`: the corrected opacity.
    pub alpha_corr: u64,
    /// `acc_r`, `acc_g`, `acc_b`, `acc_a`: the accumulators after
    /// compositing.
    pub acc: [u64; 4],
    /// `grad_x`, `grad_y`, `grad_z` (shaded frames).
    pub grad: [u64; 3],
    /// `grad_norm` (shaded frames).
    pub grad_norm: u64,
    /// `n_dot_l` (shaded frames).
    pub n_dot_l: u64,
    /// `shaded_r`, `shaded_g`, `shaded_b` (shaded frames).
    pub shaded: [u64; 3],
    /// `voi_weight` (volume of interest).
    pub voi_weight: u64,
    /// `voi_factor` (volume of interest).
    pub voi_factor: u64,
    /// `pre_back` (pre-integrated frames).
    pub pre_back: u64,
    /// `pre_tau` (pre-integrated frames).
    pub pre_tau: u64,
    /// `rays_sent` (32 bits): rays sent to a neighbour so far.
    pub rays_sent: u32,
    /// `stalls` (32 bits): stall cycles counted so far.
    pub stalls: u32,
    /// `ray_mx` (16 bits, two's complement): the last sample's ray.
    pub ray_mx: u16,
    /// `ray_row` (16 bits).
    pub ray_row: u16,
    /// `rays_held` (16 bits): ray columns in the compositing buffer.
    pub rays_held: u16,
    /// `fifo_left`, `fifo_right` (16 bits): the link FIFOs' levels.
    pub fifo: [u16; 2],
    /// `edge_reg_0`, `edge_reg_1` (V bits): the edge register.
    pub edge_reg: [u16; 2],
    /// `halo_reg_0` .. `halo_reg_7` (V bits, shaded frames).
    pub halo_reg: [u16; 8],
    /// `pass_children` (16 bits).
    pub pass_children: u16,
    /// `incoming` (8 bits): columns being received.
    pub incoming: u8,
    /// `busy` (1 bit): it sampled this cycle.
    pub busy: u8,
    /// `terminated` (1 bit, front to back only): the sample terminated
    /// its ray.
    pub terminated: u8,
    /// `in_flight` (1 bit): samples still in its datapath.
    pub in_flight: u8,
}

/// A PE's report lines to the controller after a cycle (not in the
/// waveform): the facts the controller reads between cycles.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubePeReport {
    /// The first cycle by which every sample it issued is written back.
    pub drained_at: u64,
    /// A bound on every held ray's scoreboard stamp.
    pub lands_by: u64,
    /// Child rays its merges (front to back, folds) have written.
    pub merge_outputs: u64,
    /// Child rays its splits have written.
    pub split_outputs: u64,
    /// Held columns it samples in the current slice.
    pub active: u32,
    /// Children of its current merge, split or fold.
    pub pass_width: u32,
    /// Length of its current sparse pass slot's work list.
    pub slot_work: u32,
    /// 1 when its link FIFOs and receive buffer are empty.
    pub settled: u8,
    /// 1 when its readout has streamed every held ray.
    pub readout_done: u8,
}

/// PE `k` in a cycle: its signals, both link ports, its host port and
/// its report lines.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubePe {
    /// `top.pe_K`.
    pub pe: ErcubePeSignals,
    /// `top.pe_K.left`: towards PE `k - 1`.
    pub left: ErcubeLinkPort,
    /// `top.pe_K.right`: towards PE `k + 1`.
    pub right: ErcubeLinkPort,
    /// `top.pe_K.host`.
    pub host: ErcubeHostPort,
    /// The report lines.
    pub report: ErcubePeReport,
}

/// The controller in a cycle (`top.ctrl`) and how many commands it
/// broadcast to every PE since the previous cycle
/// ([`ercube_chip_command`](crate::chip::ercube_chip_command)).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubeBroadcast {
    /// The cycle (counting from 1).
    pub cycle: u64,
    /// Commands broadcast before this cycle.
    pub n_commands: u32,
    /// `slice` (16 bits).
    pub slice: u16,
    /// `row` (16 bits): the ray row sampled or the parent row filtered.
    pub row: u16,
    /// `pass_x` (16 bits): the parent row a pass's x filter reads.
    pub pass_x: u16,
    /// `pass_y` (16 bits): the child row a pass's y filter writes.
    pub pass_y: u16,
    /// `pass_col` (16 bits): the pass's column.
    pub pass_col: u16,
    /// `drive_row` (16 bits): the parent row whose edge rays are driven.
    pub drive_row: u16,
    /// `stage` (4 bits): 0 sample, 1 migrate, 2 merge, 3 readout, 4 skip,
    /// 5 split, 6 fold, 7 drain, 8 stall, 9 memory.
    pub stage: u8,
    /// `pass_x_valid` (1 bit).
    pub pass_x_valid: u8,
    /// `pass_y_valid` (1 bit).
    pub pass_y_valid: u8,
    /// `drive_valid` (1 bit).
    pub drive_valid: u8,
}

/// One command the controller broadcast to every PE between two cycles.
/// `kind`: 0 begin slice (`a`, `b`: its first and last ray index), 1 plan
/// rows (`a`: the slice's first row in the region's grid, `b`: its rows),
/// 2 begin row (`a`: the slice's row), 3 begin merge, 4 begin split, 5
/// begin fold, 6 end merge, 7 end split, 8 end fold, 9 plan moves (`a`: 1
/// around a ring, 0 along the line), 10 begin readout.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ErcubeCommand {
    /// Its kind.
    pub kind: u32,
    /// Its first argument (0 if none).
    pub a: i64,
    /// Its second argument (0 if none).
    pub b: i64,
}

/// Stores `value` in the field of `pe` its signal names; false for a
/// name no field holds.
fn fill(pe: &mut ErcubePe, s: &Signal) -> bool {
    let v = s.value;
    let index =
        |name: &str, prefix: &str| -> Option<usize> { name.strip_prefix(prefix)?.parse().ok() };
    match s.scope {
        "" => fill_pe(&mut pe.pe, s.name, v, index),
        "left" => fill_link(&mut pe.left, s.name, v, index),
        "right" => fill_link(&mut pe.right, s.name, v, index),
        "host" => {
            let h = &mut pe.host;
            match s.name {
                "valid" => h.valid = v as u8,
                "mx" => h.mx = v as u16,
                "row" => h.row = v as u16,
                "r" => h.rgba[0] = v,
                "g" => h.rgba[1] = v,
                "b" => h.rgba[2] = v,
                "a" => h.rgba[3] = v,
                _ => return false,
            }
            true
        }
        _ => false,
    }
}

fn fill_pe(
    p: &mut ErcubePeSignals,
    name: &str,
    v: u64,
    index: impl Fn(&str, &str) -> Option<usize>,
) -> bool {
    match name {
        "busy" => p.busy = v as u8,
        "ray_mx" => p.ray_mx = v as u16,
        "ray_row" => p.ray_row = v as u16,
        "sample" => p.sample = v,
        "alpha" => p.alpha = v,
        "alpha_corr" => p.alpha_corr = v,
        "acc_r" => p.acc[0] = v,
        "acc_g" => p.acc[1] = v,
        "acc_b" => p.acc[2] = v,
        "acc_a" => p.acc[3] = v,
        "grad_x" => p.grad[0] = v,
        "grad_y" => p.grad[1] = v,
        "grad_z" => p.grad[2] = v,
        "grad_norm" => p.grad_norm = v,
        "n_dot_l" => p.n_dot_l = v,
        "shaded_r" => p.shaded[0] = v,
        "shaded_g" => p.shaded[1] = v,
        "shaded_b" => p.shaded[2] = v,
        "voi_weight" => p.voi_weight = v,
        "voi_factor" => p.voi_factor = v,
        "pre_back" => p.pre_back = v,
        "pre_tau" => p.pre_tau = v,
        "rays_sent" => p.rays_sent = v as u32,
        "terminated" => p.terminated = v as u8,
        "rays_held" => p.rays_held = v as u16,
        "fifo_left" => p.fifo[0] = v as u16,
        "fifo_right" => p.fifo[1] = v as u16,
        "incoming" => p.incoming = v as u8,
        "in_flight" => p.in_flight = v as u8,
        "pass_children" => p.pass_children = v as u16,
        "stalls" => p.stalls = v as u32,
        n => match (index(n, "edge_reg_"), index(n, "halo_reg_")) {
            (Some(i), _) if i < 2 => p.edge_reg[i] = v as u16,
            (_, Some(i)) if i < 8 => p.halo_reg[i] = v as u16,
            _ => return false,
        },
    }
    true
}

fn fill_link(
    p: &mut ErcubeLinkPort,
    name: &str,
    v: u64,
    index: impl Fn(&str, &str) -> Option<usize>,
) -> bool {
    match name {
        "ray_valid" => p.ray_valid = v as u8,
        "ray_mx" => p.ray_mx = v as u16,
        "ray_row" => p.ray_row = v as u16,
        "ray_r" => p.ray_rgba[0] = v,
        "ray_g" => p.ray_rgba[1] = v,
        "ray_b" => p.ray_rgba[2] = v,
        "ray_a" => p.ray_rgba[3] = v,
        "ray_prev" => p.ray_prev = v,
        "edge_valid" => p.edge_valid = v as u8,
        "parent_valid" => p.parent_valid = v as u8,
        "parent_mx" => p.parent_mx = v as u16,
        "parent_r" => p.parent_rgba[0] = v,
        "parent_g" => p.parent_rgba[1] = v,
        "parent_b" => p.parent_rgba[2] = v,
        "parent_a" => p.parent_rgba[3] = v,
        n => match (index(n, "edge_"), index(n, "halo_")) {
            (Some(i), _) if i < 2 => p.edge[i] = v as u16,
            (_, Some(i)) if i < 8 => p.halo[i] = v as u16,
            _ => return false,
        },
    }
    true
}

/// PE `k` of `cycle` as the C struct.
pub fn pe_of(cycle: &Cycle, k: usize) -> Option<ErcubePe> {
    let pc = cycle.pes.get(k)?;
    let mut out = ErcubePe::default();
    for s in cycle.signals.pe(pc) {
        let known = fill(&mut out, &s);
        debug_assert!(known, "no field for signal {}.{}", s.scope, s.name);
    }
    let r = pc.report;
    out.report = ErcubePeReport {
        drained_at: r.drained_at,
        lands_by: r.lands_by,
        merge_outputs: r.merge_outputs,
        split_outputs: r.split_outputs,
        active: r.active,
        pass_width: r.pass_width,
        slot_work: r.slot_work,
        settled: u8::from(r.settled),
        readout_done: u8::from(r.readout_done),
    };
    Some(out)
}

/// The controller of `cycle` as the C struct.
pub fn broadcast_of(cycle: &Cycle) -> ErcubeBroadcast {
    let mut b = ErcubeBroadcast {
        cycle: cycle.number,
        n_commands: cycle.commands.len() as u32,
        ..Default::default()
    };
    for s in cycle.signals.ctrl(&cycle.ctrl) {
        let v = s.value;
        match s.name {
            "stage" => b.stage = v as u8,
            "slice" => b.slice = v as u16,
            "row" => b.row = v as u16,
            "pass_x_valid" => b.pass_x_valid = v as u8,
            "pass_x" => b.pass_x = v as u16,
            "pass_y_valid" => b.pass_y_valid = v as u8,
            "pass_y" => b.pass_y = v as u16,
            "pass_col" => b.pass_col = v as u16,
            "drive_valid" => b.drive_valid = v as u8,
            "drive_row" => b.drive_row = v as u16,
            other => debug_assert!(false, "no field for signal ctrl.{other}"),
        }
    }
    b
}

/// Whether every signal a frame with `signals` can have fills a field.
pub fn every_signal_has_a_field(signals: &SignalSet) -> Result<(), String> {
    let mut pe = ErcubePe::default();
    for (scope, name, width, signed) in signals.pe_declared() {
        let s = Signal {
            scope,
            name,
            group: "",
            width,
            signed,
            value: 0,
        };
        if !fill(&mut pe, &s) {
            return Err(format!("{scope}.{name}"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_signal_of_every_unit_has_a_field() {
        use pipeline::config::{Order, PipelineConfig};
        for order in [Order::BackToFront, Order::FrontToBack] {
            let cfg = PipelineConfig {
                order,
                ..PipelineConfig::default()
            };
            for units in [(false, false, false), (true, true, true)] {
                let set = SignalSet::new(&cfg, units);
                assert_eq!(
                    every_signal_has_a_field(&set),
                    Ok(()),
                    "{order:?} {units:?}"
                );
            }
        }
    }

    #[test]
    fn the_structs_sizes_are_the_headers() {
        // ffi/tests/c/chip.c asserts the same sizes on the C side.
        assert_eq!(std::mem::size_of::<ErcubeLinkPort>(), 104);
        assert_eq!(std::mem::size_of::<ErcubeHostPort>(), 40);
        assert_eq!(std::mem::size_of::<ErcubePeSignals>(), 200);
        assert_eq!(std::mem::size_of::<ErcubePeReport>(), 48);
        assert_eq!(std::mem::size_of::<ErcubePe>(), 200 + 2 * 104 + 40 + 48);
        assert_eq!(std::mem::size_of::<ErcubeBroadcast>(), 32);
        assert_eq!(std::mem::size_of::<ErcubeCommand>(), 24);
    }
}
