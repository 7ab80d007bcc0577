//! Scopes `top.pe_K.left`, `top.pe_K.right` and `top.pe_K.host`: what a
//! PE drives on its link ports and its host port in a cycle.

use super::{
    bits, index16, link_alpha, link_alpha_signed, link_color, link_color_signed, word, Probe, PORTS,
};
use crate::pe::{Port, Readout};

/// Scope `top.pe_K.host`: the ray word a PE streams to the host in a
/// readout cycle.
pub(super) const HOST_PROBES: &[Probe<Option<Readout>>] = &[
    Probe::<Option<Readout>>::new("valid", PORTS, |_| 1, |s| u64::from(s.is_some())),
    Probe::<Option<Readout>>::new("mx", PORTS, |_| 16, |s| s.map_or(0, |o| index16(o.mx))).signed(),
    Probe::<Option<Readout>>::new(
        "row",
        PORTS,
        |_| 16,
        |s| s.map_or(0, |o| u64::from(o.row) & 0xffff),
    ),
    Probe::<Option<Readout>>::new("r", PORTS, link_color, |s| {
        s.map_or(0, |o| o.acc.raw[0] as u64)
    })
    .signed_as(link_color_signed),
    Probe::<Option<Readout>>::new("g", PORTS, link_color, |s| {
        s.map_or(0, |o| o.acc.raw[1] as u64)
    })
    .signed_as(link_color_signed),
    Probe::<Option<Readout>>::new("b", PORTS, link_color, |s| {
        s.map_or(0, |o| o.acc.raw[2] as u64)
    })
    .signed_as(link_color_signed),
    Probe::<Option<Readout>>::new("a", PORTS, link_alpha, |s| {
        s.map_or(0, |o| o.acc.raw[3] as u64)
    })
    .signed_as(link_alpha_signed),
];

/// A link port as its probes see it: what the PE drove on it this cycle,
/// and the widths of its words.
pub(crate) struct PortView {
    pub(super) port: Port,
    pub(super) color: u32,
    pub(super) alpha: u32,
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
pub(super) const PORT_PROBES: &[Probe<PortView>] = &[
    Probe::<PortView>::new(
        "ray_valid",
        PORTS,
        |_| 1,
        |s| u64::from(s.port.ray.is_some()),
    ),
    Probe::<PortView>::new("ray_mx", PORTS, |_| 16, |s| s.ray(|r| index16(r.mx))).signed(),
    Probe::<PortView>::new(
        "ray_row",
        PORTS,
        |_| 16,
        |s| s.ray(|r| u64::from(r.row) & 0xffff),
    ),
    Probe::<PortView>::new("ray_r", PORTS, link_color, |s| {
        s.ray(|r| word(r.acc.raw[0], s.color))
    })
    .signed_as(link_color_signed),
    Probe::<PortView>::new("ray_g", PORTS, link_color, |s| {
        s.ray(|r| word(r.acc.raw[1], s.color))
    })
    .signed_as(link_color_signed),
    Probe::<PortView>::new("ray_b", PORTS, link_color, |s| {
        s.ray(|r| word(r.acc.raw[2], s.color))
    })
    .signed_as(link_color_signed),
    Probe::<PortView>::new("ray_a", PORTS, link_alpha, |s| {
        s.ray(|r| word(r.acc.raw[3], s.alpha))
    })
    .signed_as(link_alpha_signed),
    Probe::<PortView>::new(
        "ray_prev",
        PORTS,
        |c| bits(c.sample),
        |s| s.ray(|r| r.prev as u64),
    )
    .signed_as(|c| c.sample.is_signed())
    .with_preint(),
    Probe::<PortView>::new("edge_valid", PORTS, |_| 1, |s| u64::from(s.port.edge_valid)),
    Probe::<PortView>::new(
        "edge_0",
        PORTS,
        |c| bits(c.voxel),
        |s| u64::from(s.port.edge[0]) * u64::from(s.port.edge_valid),
    )
    .signed_as(|c| c.voxel.is_signed()),
    Probe::<PortView>::new(
        "edge_1",
        PORTS,
        |c| bits(c.voxel),
        |s| u64::from(s.port.edge[1]) * u64::from(s.port.edge_valid),
    )
    .signed_as(|c| c.voxel.is_signed()),
    // The gradient's halo (to the left neighbour) while the array shades;
    // the right port's edge words then carry the last column.
    Probe::<PortView>::new("halo_0", PORTS, |c| bits(c.voxel), |s| s.halo(0))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_1", PORTS, |c| bits(c.voxel), |s| s.halo(1))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_2", PORTS, |c| bits(c.voxel), |s| s.halo(2))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_3", PORTS, |c| bits(c.voxel), |s| s.halo(3))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_4", PORTS, |c| bits(c.voxel), |s| s.halo(4))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_5", PORTS, |c| bits(c.voxel), |s| s.halo(5))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_6", PORTS, |c| bits(c.voxel), |s| s.halo(6))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
    Probe::<PortView>::new("halo_7", PORTS, |c| bits(c.voxel), |s| s.halo(7))
        .signed_as(|c| c.voxel.is_signed())
        .shaded(),
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
    )
    .signed(),
    Probe::<PortView>::new("parent_r", PORTS, link_color, |s| s.parent(0))
        .signed_as(link_color_signed),
    Probe::<PortView>::new("parent_g", PORTS, link_color, |s| s.parent(1))
        .signed_as(link_color_signed),
    Probe::<PortView>::new("parent_b", PORTS, link_color, |s| s.parent(2))
        .signed_as(link_color_signed),
    Probe::<PortView>::new("parent_a", PORTS, link_alpha, |s| s.parent(3))
        .signed_as(link_alpha_signed),
];
