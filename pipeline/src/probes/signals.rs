//! The probes' values without a waveform: a cycle's controller and PEs
//! read through the same tables the recorder samples, so a caller stepping
//! the array ([`crate::stepper`]) sees every signal with the name, width
//! and value the VCD shows for that cycle.

use super::{
    bits, link_alpha, link_color, Ctrl, PeView, PortView, Probe, Stage, CTRL_PROBES, HOST_PROBES,
    PE_PROBES, PORT_PROBES,
};
use crate::config::PipelineConfig;
use crate::pe::{Pe, PeReport, Ports};

/// One signal's value in a cycle, as the waveform shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Signal {
    /// The scope below the PE (`""` for the PE's own signals, `"left"`,
    /// `"right"`, `"host"`) or `""` for the controller's: the VCD names the
    /// signal `top.pe_K.SCOPE.NAME` (`top.pe_K.NAME`, `top.ctrl.NAME`).
    pub scope: &'static str,
    /// The signal's name.
    pub name: &'static str,
    /// Its group (`--trace-signals`): `ctrl`, `datapath`, `acc`, `ports`
    /// or `regs`.
    pub group: &'static str,
    /// Its width in bits.
    pub width: u32,
    /// Whether its word is two's complement over `width` (a ray index, a
    /// word of a signed format).
    pub signed: bool,
    /// Its value: the low `width` bits, two's complement for a signed
    /// word, as the waveform holds it.
    pub value: u64,
}

/// The signals a frame's waveform has, and their widths: a configuration
/// and the units its datapath loads (shading, volume of interest,
/// pre-integration), as the recorder registers them.
#[derive(Debug, Clone, Copy)]
pub struct SignalSet {
    cfg: PipelineConfig,
    units: (bool, bool, bool),
}

/// A PE in one cycle as the probes see it: its sample path, counters and
/// registers (scope `top.pe_K`), the ports it drove (`left`, `right`,
/// `host`) and its report lines to the controller, copied when the cycle
/// commits.
#[derive(Debug, Clone)]
pub struct PeCycle {
    view: PeView,
    /// What it drove on its ports this cycle.
    pub ports: Ports,
    /// Its report lines after the cycle ([`Pe::report`]).
    pub report: PeReport,
}

impl PeCycle {
    /// PE `pe` after cycle `cycle` of `stage`, having driven `ports`.
    pub(crate) fn of(pe: &Pe, ports: &Ports, stage: Stage, cycle: u64, set: &SignalSet) -> Self {
        PeCycle {
            view: PeView::of(pe, stage, cycle, bits(set.cfg.gradient)),
            ports: *ports,
            report: pe.report(),
        }
    }
}

impl SignalSet {
    /// The signals of a frame of `cfg` whose datapath has the units
    /// `(shading, volume of interest, pre-integration)`.
    pub fn new(cfg: &PipelineConfig, units: (bool, bool, bool)) -> SignalSet {
        SignalSet { cfg: *cfg, units }
    }

    /// The configuration.
    pub fn config(&self) -> &PipelineConfig {
        &self.cfg
    }

    /// Appends the signals of `table` in `scope` read from `state`.
    fn read<S>(&self, scope: &'static str, table: &[Probe<S>], state: &S, out: &mut Vec<Signal>) {
        for p in table.iter().filter(|p| p.shown(&self.cfg, self.units)) {
            out.push(Signal {
                scope,
                name: p.name,
                group: p.group.name,
                width: (p.width)(&self.cfg),
                signed: (p.signed)(&self.cfg),
                value: (p.read)(state),
            });
        }
    }

    /// Every signal a PE has in this frame (scope, name, width, whether
    /// two's complement), in the order [`SignalSet::pe`] reads them.
    pub fn pe_declared(&self) -> Vec<(&'static str, &'static str, u32, bool)> {
        let mut out = Vec::new();
        let mut add =
            |scope: &'static str, names: &mut dyn Iterator<Item = (&'static str, u32, bool)>| {
                out.extend(names.map(|(n, w, s)| (scope, n, w, s)));
            };
        add("", &mut self.declared(PE_PROBES));
        add("left", &mut self.declared(PORT_PROBES));
        add("right", &mut self.declared(PORT_PROBES));
        add("host", &mut self.declared(HOST_PROBES));
        out
    }

    /// The names, widths and signedness of `table`'s signals in this
    /// frame.
    fn declared<'t, S>(
        &'t self,
        table: &'t [Probe<S>],
    ) -> impl Iterator<Item = (&'static str, u32, bool)> + 't {
        table
            .iter()
            .filter(|p| p.shown(&self.cfg, self.units))
            .map(|p| (p.name, (p.width)(&self.cfg), (p.signed)(&self.cfg)))
    }

    /// The controller's signals (scope `top.ctrl`) while it shows `ctrl`.
    pub fn ctrl(&self, ctrl: &Ctrl) -> Vec<Signal> {
        let mut out = Vec::new();
        self.read("", CTRL_PROBES, ctrl, &mut out);
        out
    }

    /// A PE's signals in a cycle (scope `top.pe_K` and its ports), in the
    /// order the waveform declares them.
    pub fn pe(&self, pe: &PeCycle) -> Vec<Signal> {
        let mut out = Vec::new();
        self.pe_into(pe, &mut out);
        out
    }

    /// [`SignalSet::pe`] into `out` (cleared first), so a caller reading
    /// every cycle reuses one buffer.
    pub fn pe_into(&self, pe: &PeCycle, out: &mut Vec<Signal>) {
        out.clear();
        self.read("", PE_PROBES, &pe.view, out);
        for (scope, port) in [("left", pe.ports.left), ("right", pe.ports.right)] {
            let view = PortView {
                port,
                color: link_color(&self.cfg),
                alpha: link_alpha(&self.cfg),
            };
            self.read(scope, PORT_PROBES, &view, out);
        }
        self.read("host", HOST_PROBES, &pe.ports.host, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed::Format;

    fn signed(cfg: &PipelineConfig) -> Vec<String> {
        SignalSet::new(cfg, (true, true, true))
            .pe_declared()
            .into_iter()
            .filter(|d| d.3)
            .map(|(scope, name, ..)| format!("{scope}.{name}"))
            .collect()
    }

    #[test]
    fn ray_indices_and_words_of_signed_formats_are_signed() {
        // The default formats: only the gradient is signed.
        let cfg = PipelineConfig::default();
        assert_eq!(
            signed(&cfg),
            [
                ".ray_mx",
                ".grad_x",
                ".grad_y",
                ".grad_z",
                "left.ray_mx",
                "left.parent_mx",
                "right.ray_mx",
                "right.parent_mx",
                "host.mx"
            ]
        );
        // A signed merge word makes every link and host colour word signed.
        let merge = Format::signed(cfg.merge.bits(), cfg.merge.frac()).unwrap();
        let cfg = PipelineConfig { merge, ..cfg };
        let s = signed(&cfg);
        for w in ["left.ray_r", "right.parent_a", "host.g"] {
            assert!(s.iter().any(|n| n == w), "{w} in {s:?}");
        }
        assert!(!s.iter().any(|n| n == ".acc_r"), "{s:?}");
    }
}
