//! The signal groups `--trace-signals` selects from.

use waves::Group;

/// The controller: stage, slice and row broadcast.
pub const CTRL: Group = Group {
    name: "ctrl",
    default: true,
};
/// A PE's sample path (ray, sample, opacities) and its ray counter.
pub const DATAPATH: Group = Group {
    name: "datapath",
    default: true,
};
/// A PE's accumulators after compositing.
pub const ACC: Group = Group {
    name: "acc",
    default: true,
};
/// Both link ports of every PE (scopes `left` and `right`), valid and
/// payload per kind, and its host port (the readout): what the
/// architecture is about, so on by default.
pub const PORTS: Group = Group {
    name: "ports",
    default: true,
};
/// A PE's registers and FIFO levels: rays held, migration FIFOs, columns
/// arriving, the edge register, whether samples are in flight, the pass's
/// children, the stall counter.
pub const REGS: Group = Group {
    name: "regs",
    default: false,
};
/// Every group, in the order `--trace-signals` lists them.
pub const GROUPS: [Group; 5] = [CTRL, PORTS, DATAPATH, ACC, REGS];

/// Parses a comma-separated group list such as `ctrl,ports`; `all` is
/// every group. An unknown name is an error naming the known ones.
pub fn parse_groups(text: &str) -> Result<Vec<&'static str>, String> {
    if text.trim().eq_ignore_ascii_case("all") {
        return Ok(GROUPS.iter().map(|g| g.name).collect());
    }
    text.split(',')
        .map(str::trim)
        .map(|name| {
            GROUPS
                .iter()
                .find(|g| g.name == name)
                .map(|g| g.name)
                .ok_or_else(|| {
                    let known: Vec<_> = GROUPS.iter().map(|g| g.name).collect();
                    format!(
                        "unknown signal group {name:?} (known: {}, or all)",
                        known.join(", ")
                    )
                })
        })
        .collect()
}
