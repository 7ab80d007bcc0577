//! The pre-integration unit's hardware ([`crate::preint`]), for an array
//! built with it ([`Geometry::units`]'s `preint`). Such a PE classifies whole slice
//! steps: the unit takes the place of the classification (its table
//! position, table, lerps and zero test) and of the opacity correction's
//! `-log2(1 - a)` table and product, and feeds the correction's exp stage
//! ([`crate::datapath::Datapath::transmit`]), which it shares, with its own
//! `p`.
//!
//! - **Table positions**: `f = s K` for the front scalar (the sample) and
//!   the back scalar (the ray's previous sample, read with its
//!   accumulators), each a multiply by the per-frame `step` constant, then
//!   the clamp at the last bin and the split into a bin index and a
//!   `weight`.
//! - **Table**: `(bins + 1)^2` words of `3 preint_color + preint_tau` bits
//!   ([`table_bits`]), in two banks by the front bin's parity so that the
//!   four words a step reads are two reads of each dual-read bank (bins
//!   `j` and `j + 1` of rows `i` and `i + 1`), as the slice buffer splits
//!   its rows; each bank's address is `row (bins + 1) + j`, and a mux puts
//!   the two banks' rows back in order when `i` is odd. It is block RAM:
//!   at 256 bins, 66 049 words per PE.
//! - **Lerps**: twelve, three per channel: along the back scalar on both
//!   rows (side by side), then along the front, each into its channel's
//!   format: two lerp levels deep.
//! - **`p = tau len`** into `log_transmittance` (a half step's `len`
//!   halved by a shift the mux picks), the extinction's zero test, and
//!   then the exp stage.
//! - **Dividers** `min(wc / tau, 1)`, one per channel, non-restoring with
//!   [`crate::preint::GUARD_BITS`] quotient bits below `color`'s LSB and an
//!   integer bit for the cap, beside the exp stage: at the default widths
//!   they, not the exp stage, set the depth of the composed sample
//!   ([`crate::hw::compose`], [`crate::cost::preint_latency`]).
//! - **The pass's rays**: the controller broadcasts per pass which rays
//!   composite a step, keep their sample and take slice 0's half step
//!   ([`crate::host::PreStep`]); each PE holds the three rectangles (a
//!   declared register, [`crate::pe::Pe::register_state`]) and tests its
//!   ray against them ([`crate::hw::address`]), and the half step's back
//!   scalar is the sample itself (a mux).
//! - **The previous sample**: every ray carries one more `sample` word
//!   ([`ray_bits`]) in the compositing buffer (or the external ray
//!   buffer's row buffers), the migration FIFOs and the ray ports; merges
//!   and splits drop it, so the merge ports and the front-to-back
//!   inherited states stay as they are.
//!
//! [`Geometry::units`]: super::inventory::Geometry::units

use super::inventory::{Geometry, Item};
use super::memory::MemPorts;
use super::units::Unit;
use crate::config::PipelineConfig;

fn bits(f: crate::fixed::Format) -> u32 {
    u32::from(f.bits())
}

/// Bins per table axis: golden's, one per classification entry up to
/// [`golden::preint::MAX_BINS`] ([`crate::preint::PreintUnit::bins`]).
pub fn bins(cfg: &PipelineConfig) -> u64 {
    u64::from(cfg.table_entries).min(golden::preint::MAX_BINS as u64)
}

/// Bits of one table word: R, G, B in `preint_color`, the extinction in
/// `preint_tau`.
pub fn table_word(cfg: &PipelineConfig) -> u32 {
    3 * bits(cfg.preint_color) + bits(cfg.preint_tau)
}

/// Bits of the table: `(bins + 1)^2` words (golden's `bins^2` with the
/// last row and column repeated) of [`table_word`].
pub fn table_bits(cfg: &PipelineConfig) -> u64 {
    let n = bins(cfg) + 1;
    n * n * u64::from(table_word(cfg))
}

/// Bits of the exact colouring's depth layers ([`crate::preint`], steps
/// 4b and 4c), which a unit loaded with `--pre-colouring exact` holds
/// beside [`table_bits`]: `LAYERS - 1` more `(bins + 1)^2` tables of R, G,
/// B in `preint_color` (layer 0 is the table's own colour words). The
/// inventory prices the fast unit; this is the memory the exact one adds.
pub fn exact_layer_bits(cfg: &PipelineConfig) -> u64 {
    let n = bins(cfg) + 1;
    (golden::preint::LAYERS as u64 - 1) * n * n * 3 * u64::from(bits(cfg.preint_color))
}

/// Bits a ray carries beyond its accumulators (and front to back its
/// inherited state) in the buffers and on the links: its previous sample
/// when `geo` pre-integrates, else none.
pub fn ray_bits(cfg: &PipelineConfig, geo: &Geometry) -> u32 {
    if geo.units.preint {
        bits(cfg.sample)
    } else {
        0
    }
}

/// Front rows of the two banks: the even rows `0, 2, ..., bins` and the
/// odd ones.
fn bank_rows(cfg: &PipelineConfig) -> [u64; 2] {
    let n = bins(cfg) + 1;
    [n.div_ceil(2), n / 2]
}

/// The table's memories: the two banks, loaded by the host between
/// frames through their read-write ports.
pub(super) fn memories(cfg: &PipelineConfig) -> Vec<Item> {
    let n = bins(cfg) + 1;
    let word = table_word(cfg);
    let [even, odd] = bank_rows(cfg);
    vec![Item::new(
        "memories",
        format!("pre-integration table ({n} x {n}, even and odd front rows)"),
        1,
        vec![
            Unit::Mem {
                depth: even * n,
                width: word,
                ports: MemPorts::DualRead,
            },
            Unit::Mem {
                depth: odd * n,
                width: word,
                ports: MemPorts::DualRead,
            },
        ],
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::inventory::pe_inventory;
    use crate::cost::target::Target;
    use crate::fixed::{Format, Overflow, Quant};

    fn mem_bits(item: &Item) -> u64 {
        item.units
            .iter()
            .map(|u| match u {
                Unit::Mem { depth, width, .. } => depth * u64::from(*width),
                _ => 0,
            })
            .sum::<u64>()
            * u64::from(item.count)
    }

    fn table_item(items: &[Item]) -> Option<&Item> {
        items
            .iter()
            .find(|i| i.name.starts_with("pre-integration table"))
    }

    #[test]
    fn unit_items_only_with_the_flag() {
        let cfg = PipelineConfig::default();
        let geo = Geometry::new([128, 128, 128], 16);
        let plain = pe_inventory(&cfg, &geo);
        let pre = pe_inventory(
            &cfg,
            &geo.clone().with_units(crate::hw::compose::Units {
                preint: true,
                ..Default::default()
            }),
        );
        let unit = |items: &[Item]| items.iter().filter(|i| i.group == "preint").count();
        assert_eq!(unit(&plain.items), 0);
        assert!(table_item(&plain.items).is_none());
        assert_eq!(
            unit(&pre.items),
            crate::hw::units::items(&crate::hw::preint::preint(&cfg))
                .iter()
                .filter(|i| i.group == "preint")
                .count()
        );
        assert!(table_item(&pre.items).is_some());
        // The unit takes the classification's place, tables included.
        let named = |items: &[Item], s: &str| items.iter().any(|i| i.name.contains(s));
        assert!(named(&plain.items, "classification table"));
        assert!(!named(&pre.items, "classification table"));
        assert!(!named(&pre.items, "-log2(1 - a)"));
        assert!(!pre.items.iter().any(|i| i.group == "classification"));
        // Each ray carries its previous sample in the buffer and the FIFOs.
        let width = |items: &[Item], s: &str| {
            items
                .iter()
                .find(|i| i.name.starts_with(s))
                .and_then(|i| match i.units[0] {
                    Unit::Mem { width, .. } => Some(width),
                    _ => None,
                })
        };
        let sm = u32::from(cfg.sample.bits());
        for m in ["compositing buffer", "link FIFO"] {
            assert!(width(&plain.items, m).is_some(), "{m} is charged");
            assert_eq!(
                width(&pre.items, m),
                width(&plain.items, m).map(|w| w + sm),
                "{m}"
            );
        }
        let r = pre.cost(Target::Xc7);
        assert!(r.bram > plain.cost(Target::Xc7).bram);
    }

    #[test]
    fn table_bits_are_the_formats() {
        let mut cfg = PipelineConfig::default();
        // 256 bins at 4096 entries: 257^2 words of 3 x 22 + 22 bits.
        assert_eq!(table_bits(&cfg), 257 * 257 * 88);
        let check = |cfg: &PipelineConfig| {
            let geo = Geometry::new([64, 64, 64], 8).with_units(crate::hw::compose::Units {
                preint: true,
                ..Default::default()
            });
            let pe = pe_inventory(cfg, &geo);
            let n = bins(cfg) + 1;
            let word = 3 * u64::from(cfg.preint_color.bits()) + u64::from(cfg.preint_tau.bits());
            let item = table_item(&pe.items).expect("the table");
            assert_eq!(mem_bits(item), n * n * word);
            assert_eq!(table_bits(cfg), n * n * word);
        };
        check(&cfg);
        cfg.table_entries = 64;
        cfg.preint_color = Format::new(16, 10, false, Quant::Rnd, Overflow::Sat).unwrap();
        cfg.preint_tau = Format::new(18, 11, false, Quant::Rnd, Overflow::Sat).unwrap();
        cfg.validate().unwrap();
        assert_eq!(bins(&cfg), 64);
        check(&cfg);
        assert_eq!(table_bits(&cfg), 65 * 65 * (3 * 16 + 18));
    }

    #[test]
    fn plain_cost_unchanged_without_the_flag() {
        let cfg = PipelineConfig::default();
        let geo = Geometry::new([128, 128, 128], 16);
        assert_eq!(
            geo.clone().with_units(crate::hw::compose::Units::default()),
            geo
        );
        assert_eq!(ray_bits(&cfg, &geo), 0);
        let pe = pe_inventory(
            &cfg,
            &geo.clone().with_units(crate::hw::compose::Units::default()),
        );
        // The default PE as `ercube cost` prices it without the unit (its
        // slice buffer two row banks of two slices, a write and two reads
        // each; its link FIFOs two rows deep in LUT-RAM, its ray memories sized for
        // the default view's end PEs, the row plan among them (256 rows x
        // 93 slots, 3 RAMB18, and its gathered word's 93 flip-flops), its
        // declared registers; its sample
        // datapath's registers and tables as the emitted module declares
        // them, the invisible sample's accumulator select included; the
        // 1,035 register bits the DSP48E1s take in are not fabric FFs; the
        // sample stage's control, `cost::sample_stage`, statement by
        // statement).
        let r = pe.cost(Target::Xc7);
        assert_eq!((r.dsp, r.lut, r.ff, r.bram), (29, 3981, 7274, 139));
        assert_eq!(pe.schedule.depth, crate::cost::datapath_latency(&cfg));
        // A report's JSON leaves the flag out unless it is set.
        let json = serde_json::to_string(&geo).unwrap();
        assert!(!json.contains("preint"), "{json}");
    }

    #[test]
    fn preint_latency_exceeds_plain() {
        let mut cfg = PipelineConfig::default();
        let (plain, pre) = (
            crate::cost::datapath_latency(&cfg),
            crate::cost::preint_latency(&cfg),
        );
        assert!(pre > plain, "{pre} vs {plain}");
        // The composed sample's scheduled depth, as the inventory reports
        // it.
        let geo = Geometry::new([128, 128, 128], 16);
        assert_eq!(
            pe_inventory(
                &cfg,
                &geo.clone().with_units(crate::hw::compose::Units {
                    preint: true,
                    ..Default::default()
                })
            )
            .schedule
            .depth,
            pre
        );
        assert_eq!(pe_inventory(&cfg, &geo).schedule.depth, plain);
        // A stated latency is kept.
        cfg.datapath_latency = 40;
        assert_eq!(crate::cost::preint_latency(&cfg), 40);
    }
}
