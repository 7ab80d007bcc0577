//! The recorder: registers a run's signals from the tables and samples them every traced cycle.

use waves::{Sampler, ScopePath, SignalId, Tracer, WavesError};

use super::{
    bits, link_alpha, link_color, parse_groups, Ctrl, PeView, PortView, Probe, CTRL_PROBES, GROUPS,
    HOST_PROBES, PE_PROBES, PORT_PROBES,
};
use crate::config::PipelineConfig;
use crate::pe::{Pe, Ports};

/// Registers every present signal of `table` in `scope`; one id per line
/// (NONE for the absent and the unselected).
fn register<S>(
    tracer: &mut Tracer,
    (cfg, units): (&PipelineConfig, (bool, bool, bool)),
    scope: &ScopePath,
    table: &[Probe<S>],
) -> Result<Vec<SignalId>, WavesError> {
    table
        .iter()
        .map(|p| {
            if !p.shown(cfg, units) {
                return Ok(SignalId::NONE);
            }
            let width = (p.width)(cfg);
            if p.names.is_empty() {
                tracer.register_in(&p.group, scope, p.name, width)
            } else {
                tracer.register_enum_in(&p.group, scope, p.name, width, p.names)
            }
        })
        .collect()
}

/// Sets every signal of `table` from `state`.
#[inline]
fn sample<S>(s: &mut Sampler<'_>, table: &[Probe<S>], ids: &[SignalId], state: &S) {
    for (p, &id) in table.iter().zip(ids) {
        if id.is_traced() {
            s.set(id, (p.read)(state));
        }
    }
}

/// The ids of one PE's signals.
struct PeIds {
    pe: Vec<SignalId>,
    /// Left and right port.
    ports: [Vec<SignalId>; 2],
    host: Vec<SignalId>,
    any_port: bool,
}

/// The probes of a run: the tracer and the ids of every table's signals.
pub(crate) struct Probes {
    tracer: Tracer,
    /// The description's nodes traced by name (`--trace-nodes`).
    nodes: Option<super::nodes::NodeTrace>,
    ctrl: Vec<SignalId>,
    pes: Vec<PeIds>,
    color: u32,
    alpha: u32,
    grad: u32,
}

impl Probes {
    /// Refuses a selection naming an unknown group (before a frame is
    /// loaded: the signals are registered when it starts).
    pub(crate) fn check_groups(tracer: &Tracer) -> Result<(), WavesError> {
        if let Some(bad) = tracer
            .selected_groups()
            .and_then(|set| set.iter().find(|g| !GROUPS.iter().any(|k| k.name == *g)))
        {
            return Err(WavesError::InvalidSpec {
                what: "signal group",
                text: bad.clone(),
                reason: parse_groups(bad).err().unwrap_or_default(),
            });
        }
        Ok(())
    }

    /// Registers the signals of `p` PEs (with the shading unit's when
    /// `units.0`, the volume-of-interest stage's when `units.1`, the
    /// pre-integration unit's when `units.2`), and the nodes of the
    /// datapath's description that `nodes` names (its datapath and the
    /// patterns; [`super::nodes`]); an unknown group in the tracer's
    /// selection, or a pattern naming no node, is an error.
    pub(crate) fn new(
        mut tracer: Tracer,
        p: usize,
        cfg: &PipelineConfig,
        units: (bool, bool, bool),
        nodes: Option<(&crate::datapath::Datapath, &[String])>,
    ) -> Result<Probes, WavesError> {
        let c = (cfg, units);
        Probes::check_groups(&tracer)?;
        let ctrl = register(&mut tracer, c, &ScopePath::top().child("ctrl"), CTRL_PROBES)?;
        let mut pes = Vec::with_capacity(p);
        for k in 0..p {
            let scope = ScopePath::pe(k as u32);
            let pe = register(&mut tracer, c, &scope, PE_PROBES)?;
            let ports = [
                register(&mut tracer, c, &scope.child("left"), PORT_PROBES)?,
                register(&mut tracer, c, &scope.child("right"), PORT_PROBES)?,
            ];
            let host = register(&mut tracer, c, &scope.child("host"), HOST_PROBES)?;
            let any_port = ports.iter().flatten().any(|id| id.is_traced());
            pes.push(PeIds {
                pe,
                ports,
                host,
                any_port,
            });
        }
        // After the tables' signals, so the other signals keep their
        // declaration order and codes.
        let nodes = match nodes {
            Some((dp, pats)) => Some(super::nodes::NodeTrace::new(&mut tracer, p, dp, pats)?),
            None => None,
        };
        Ok(Probes {
            tracer,
            nodes,
            ctrl,
            pes,
            color: link_color(cfg),
            alpha: link_alpha(cfg),
            grad: bits(cfg.gradient),
        })
    }

    /// Records cycle `cycle`: the controller's `ctrl`, every PE, and the
    /// ports the PEs drove in it (`ports[k]`: PE `k`'s; an empty slice
    /// when no PE drives a link in this cycle).
    pub(crate) fn sample(&mut self, cycle: u64, pes: &[Pe], ports: &[Ports], ctrl: Ctrl) {
        let Probes {
            tracer,
            nodes,
            ctrl: ctrl_ids,
            pes: ids,
            color,
            alpha,
            grad,
        } = self;
        tracer.sample(cycle, |s| {
            sample(s, CTRL_PROBES, ctrl_ids, &ctrl);
            let idle = Ports::default();
            for (k, (pe, id)) in pes.iter().zip(ids.iter()).enumerate() {
                let view = PeView::of(pe, ctrl.stage, cycle, *grad);
                sample(s, PE_PROBES, &id.pe, &view);
                if id.any_port {
                    let driven = ports.get(k).copied().unwrap_or(idle);
                    sample(s, HOST_PROBES, &id.host, &driven.host);
                    for (port, pids) in [driven.left, driven.right].into_iter().zip(&id.ports) {
                        let view = PortView {
                            port,
                            color: *color,
                            alpha: *alpha,
                        };
                        sample(s, PORT_PROBES, pids, &view);
                    }
                }
            }
        });
        if let Some(n) = nodes.as_mut() {
            n.sample(tracer, cycle, pes, ctrl.stage == super::Stage::Sample);
        }
    }

    /// Completes the trace files.
    pub(crate) fn finish(self) -> Result<Option<waves::TraceInfo>, WavesError> {
        if let Some(e) = self.nodes.as_ref().and_then(|n| n.error()) {
            return Err(e);
        }
        self.tracer.finish()
    }
}
