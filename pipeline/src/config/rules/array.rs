//! The rules of the array's fields: the datapath's latency, the PE count,
//! the occupancy blocks, the mapping, the links and the rays' buffer.

use super::in_range;
use crate::config::error::{invalid, ConfigError};
use crate::config::{PipelineConfig, MAX_PES};

/// The check of `datapath_latency`.
pub(in crate::config) fn datapath_latency(
    _: &PipelineConfig,
    field: &str,
    clocks: u16,
) -> Result<(), ConfigError> {
    if clocks > 256 {
        return Err(invalid(
            field,
            format!("datapath_latency = {clocks} is outside 0..=256"),
        ));
    }
    Ok(())
}

/// The check of `target_mhz`: within `0..=1000` and, when set, on a
/// family with a delay model (the clock's reachability is checked last,
/// by [`PipelineConfig::validate`], once every width has passed).
pub(in crate::config) fn target_mhz(
    c: &PipelineConfig,
    field: &str,
    mhz: u16,
) -> Result<(), ConfigError> {
    if mhz > 1000 {
        return Err(invalid(
            field,
            format!("target_mhz = {mhz} is outside 0..=1000"),
        ));
    }
    if mhz > 0 && crate::cost::fmax::model(c.target_family).is_none() {
        return Err(invalid(
            field,
            format!(
                "target_mhz = {mhz} needs a family with a delay model (target_family = \"ecp5\" or \"ice40\"), not \"{}\"",
                c.target_family.name()
            ),
        ));
    }
    Ok(())
}

/// The clock `target_mhz` asks for is one the delay model's schedule
/// reaches on `target_family` (no single operator slower than the period).
pub(in crate::config) fn pipelining(c: &PipelineConfig) -> Result<(), ConfigError> {
    if c.target_mhz == 0 {
        return Ok(());
    }
    let g = crate::hw::sample::plain(c);
    crate::cost::fmax::clock_schedule(&g, c.target_family, f64::from(c.target_mhz))
        .map(|_| ())
        .map_err(|e| invalid("target_mhz", e))
}

/// The check of `pes`.
pub(in crate::config) fn pes(_: &PipelineConfig, field: &str, pes: u16) -> Result<(), ConfigError> {
    if pes == 0 || pes > MAX_PES {
        return Err(invalid(
            field,
            format!("pes = {pes} is outside 1..={MAX_PES}"),
        ));
    }
    Ok(())
}

/// The check of `occupancy_block`.
pub(in crate::config) fn occupancy_block(
    _: &PipelineConfig,
    field: &str,
    b: u16,
) -> Result<(), ConfigError> {
    if !(b.is_power_of_two() && (2..=64).contains(&b)) {
        return Err(invalid(
            field,
            format!("occupancy_block = {b} is not a power of two from 2 to 64"),
        ));
    }
    Ok(())
}

/// `cyclic_width` in `1..=256`.
pub(in crate::config) fn cyclic_width(
    _: &PipelineConfig,
    field: &str,
    w: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(w), 1, 256)
}

/// `link_lanes` in `1..=4`, and above 1 only with the overlapped
/// migration (the between-slices one clocks the array's single ray port).
pub(in crate::config) fn link_lanes(
    c: &PipelineConfig,
    field: &str,
    n: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(n), 1, 4)?;
    if n > 1 && c.migration != crate::config::Migration::Overlapped {
        return Err(invalid(
            field,
            format!("{field} = {n} needs migration = \"overlapped\" (between slices a link carries one ray a cycle)"),
        ));
    }
    Ok(())
}

/// `link_fifo_depth` in `1..=4096`: a FIFO of no row could never send,
/// and past a few rows a deeper one only costs memory (the feed keeps
/// pace with the link at depth 2).
pub(in crate::config) fn link_fifo_depth(
    _: &PipelineConfig,
    field: &str,
    d: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(d), 1, 4096)
}

/// `ray_buffer_bandwidth` in `1..=4096`.
pub(in crate::config) fn ray_buffer_bandwidth(
    _: &PipelineConfig,
    field: &str,
    b: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(b), 1, 4096)
}

/// `ray_buffer_rows` in `2..=64`.
pub(in crate::config) fn ray_buffer_rows(
    _: &PipelineConfig,
    field: &str,
    r: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(r), 2, 64)
}

/// `host_bandwidth` in `1..=4096`.
pub(in crate::config) fn host_bandwidth(
    _: &PipelineConfig,
    field: &str,
    b: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(b), 1, 4096)
}

/// `ray_buffer_latency` in `0..=4096`.
pub(in crate::config) fn ray_buffer_latency(
    _: &PipelineConfig,
    field: &str,
    l: u16,
) -> Result<(), ConfigError> {
    in_range(field, i64::from(l), 0, 4096)
}
