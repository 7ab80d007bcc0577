//! Readers of the tools' reports: yosys's `stat -json` cell counts in the
//! estimator's resource classes, and nextpnr's `--report` JSON (achieved
//! clock, critical path, placed utilization).

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::Value;

use super::Part;
use crate::cost::Resources;

/// yosys's cell counts of one module (`num_cells_by_type` of the first
/// module in `stat -json`).
pub fn yosys_cells(stat: &Value) -> Result<BTreeMap<String, u64>, String> {
    let cells = stat["modules"]
        .as_object()
        .and_then(|mods| mods.values().next())
        .and_then(|m| m["num_cells_by_type"].as_object())
        .ok_or("yosys's stat -json has no cell counts")?;
    Ok(cells
        .iter()
        .map(|(k, n)| (k.clone(), n.as_u64().unwrap_or(0)))
        .collect())
}

/// Maps yosys cell types of `part` onto the estimator's classes
/// ([`Resources`]: LUTs with LUT-RAM and, on ECP5, the two LUT4s of a
/// CCU2C; fabric flip-flops; multiplier blocks; block RAM in the
/// estimator's units). Cells that cost nothing the estimator counts (I/O
/// and clock buffers, wide-function muxes) are skipped by name, and any
/// other type is an error rather than silently dropped.
pub fn classify(part: Part, cells: &BTreeMap<String, u64>) -> Result<Resources, String> {
    let mut r = Resources::default();
    for (ty, &n) in cells {
        let t = ty.as_str();
        // Newer yosys keeps a flattened instance's hierarchy as
        // `$scopeinfo` cells: names for debugging, no hardware.
        if t == "$scopeinfo" {
            continue;
        }
        match part {
            Part::Xc7 | Part::Xcup => match t {
                "LUT1" | "LUT2" | "LUT3" | "LUT4" | "LUT5" | "LUT6" | "INV" => r.lut += n,
                "SRL16E" | "SRLC32E" => {
                    r.lut += n;
                    r.lutram += n;
                }
                "RAM32M" | "RAM64M" | "RAM128X1D" | "RAM32M16" | "RAM64M8" => {
                    r.lut += 4 * n;
                    r.lutram += 4 * n;
                }
                "RAM64X1D" | "RAM32X1D" => {
                    r.lut += 2 * n;
                    r.lutram += 2 * n;
                }
                "FDRE" | "FDSE" | "FDCE" | "FDPE" => r.ff += n,
                "DSP48E1" | "DSP48E2" => r.dsp += n,
                "RAMB18E1" | "RAMB18E2" => r.bram += n,
                "RAMB36E1" | "RAMB36E2" => r.bram += 2 * n,
                "CARRY4" | "CARRY8" => r.carry += n,
                "IBUF" | "OBUF" | "BUFG" | "BUFGCE" | "MUXF7" | "MUXF8" | "MUXF9" => {}
                _ => return Err(format!("unexpected {part} cell {t}")),
            },
            Part::Ice40Up5k | Part::Ice40Hx8k => match t {
                "SB_LUT4" => r.lut += n,
                _ if t.starts_with("SB_DFF") => r.ff += n,
                "SB_MAC16" => r.dsp += n,
                "SB_RAM40_4K" => r.bram += n,
                "SB_CARRY" => r.carry += n,
                "SB_IO" | "SB_GB" => {}
                _ => return Err(format!("unexpected {part} cell {t}")),
            },
            Part::Ecp5_25k | Part::Ecp5_85k => match t {
                "LUT4" => r.lut += n,
                "CCU2C" => {
                    r.lut += 2 * n;
                    r.carry += n;
                }
                "TRELLIS_DPR16X4" => {
                    // Two LUT4 positions hold the RAM; the estimator
                    // charges the write port's slice too (six in all).
                    r.lut += 6 * n;
                    r.lutram += 6 * n;
                }
                "TRELLIS_FF" => r.ff += n,
                "MULT18X18D" => r.dsp += n,
                "DP16KD" => r.bram += n,
                "PFUMX" | "L6MUX21" | "TRELLIS_IO" | "DCCA" => {}
                _ => return Err(format!("unexpected {part} cell {t}")),
            },
        }
    }
    Ok(r)
}

/// One resource of the placed design: used of available.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Used {
    /// The nextpnr resource name (ICESTORM_LC, TRELLIS_COMB, ...).
    pub name: String,
    /// Used.
    pub used: u64,
    /// Available on the part.
    pub available: u64,
}

/// The critical path of the clock, as nextpnr reports it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CriticalPath {
    /// The cell the path starts from.
    pub from: String,
    /// The cell it ends in.
    pub to: String,
    /// Cells on the path (start and end included).
    pub cells: usize,
    /// Logic delay (clock-to-out, cell delays, setup), ns.
    pub logic_ns: f64,
    /// Routing delay, ns.
    pub routing_ns: f64,
}

/// What place and route measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Placed {
    /// The highest clock the placed and routed design meets, MHz.
    pub fmax_mhz: f64,
    /// The path that sets it (`None` when nextpnr lists none).
    pub critical_path: Option<CriticalPath>,
    /// Used resources (those with any use).
    pub utilization: Vec<Used>,
}

/// Reads nextpnr's `--report` JSON (one clock domain: the wrapper's).
pub fn nextpnr(report: &Value) -> Result<Placed, String> {
    let fmax = report["fmax"]
        .as_object()
        .and_then(|m| {
            m.values()
                .filter_map(|c| c["achieved"].as_f64())
                .reduce(f64::min)
        })
        .ok_or("nextpnr's report has no achieved clock (no register-to-register path?)")?;
    let critical_path = report["critical_paths"]
        .as_array()
        .and_then(|paths| {
            // The clock's own register-to-register path; the others are
            // from and to the pins.
            paths
                .iter()
                .find(|p| p["from"].as_str().is_some_and(|f| f.starts_with("posedge")))
        })
        .and_then(|p| p["path"].as_array())
        .map(|steps| {
            let mut logic = 0.0;
            let mut routing = 0.0;
            let mut cells: Vec<&str> = Vec::new();
            for s in steps {
                let d = s["delay"].as_f64().unwrap_or(0.0);
                if s["type"].as_str() == Some("routing") {
                    routing += d;
                } else {
                    logic += d;
                }
                for end in ["from", "to"] {
                    if let Some(c) = s[end]["cell"].as_str() {
                        if cells.last() != Some(&c) {
                            cells.push(c);
                        }
                    }
                }
            }
            CriticalPath {
                from: cells.first().unwrap_or(&"").to_string(),
                to: cells.last().unwrap_or(&"").to_string(),
                cells: cells.len(),
                logic_ns: logic,
                routing_ns: routing,
            }
        });
    let utilization = report["utilization"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter_map(|(k, v)| {
                    let used = v["used"].as_u64()?;
                    (used > 0).then(|| Used {
                        name: k.clone(),
                        used,
                        available: v["available"].as_u64().unwrap_or(0),
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(Placed {
        fmax_mhz: fmax,
        critical_path,
        utilization,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_nextpnr_report() {
        let r: Value = serde_json::from_str(
            r#"{"fmax": {"clk": {"achieved": 64.5, "constraint": 12}},
                "utilization": {"TRELLIS_FF": {"available": 24288, "used": 97},
                                "DCCA": {"available": 56, "used": 0}},
                "critical_paths": [
                  {"from": "posedge clk", "to": "posedge clk", "path": [
                    {"type": "clk-to-q", "delay": 0.5, "from": {"cell": "a"}, "to": {"cell": "a"}},
                    {"type": "routing", "delay": 2.0, "from": {"cell": "a"}, "to": {"cell": "m"}},
                    {"type": "logic", "delay": 1.0, "from": {"cell": "m"}, "to": {"cell": "m"}},
                    {"type": "routing", "delay": 1.5, "from": {"cell": "m"}, "to": {"cell": "b"}},
                    {"type": "setup", "delay": 0.25, "from": {"cell": "b"}, "to": {"cell": "b"}}]}]}"#,
        )
        .unwrap();
        let p = nextpnr(&r).unwrap();
        assert_eq!(p.fmax_mhz, 64.5);
        let c = p.critical_path.unwrap();
        assert_eq!((c.from.as_str(), c.to.as_str(), c.cells), ("a", "b", 3));
        assert_eq!((c.logic_ns, c.routing_ns), (1.75, 3.5));
        assert_eq!(p.utilization.len(), 1);
        assert!(nextpnr(&serde_json::json!({"fmax": {}})).is_err());
    }

    #[test]
    fn classifies_ecp5_cells_and_refuses_unknown_ones() {
        let cells: BTreeMap<String, u64> = [
            ("LUT4", 32),
            ("CCU2C", 16),
            ("TRELLIS_FF", 97),
            ("$scopeinfo", 3),
        ]
        .into_iter()
        .map(|(k, n)| (k.to_owned(), n))
        .collect();
        let r = classify(Part::Ecp5_25k, &cells).unwrap();
        assert_eq!((r.lut, r.ff, r.carry), (64, 97, 16));
        let odd: BTreeMap<String, u64> = [("WEIRD".to_owned(), 1)].into_iter().collect();
        assert!(classify(Part::Ice40Up5k, &odd).is_err());
    }
}
