//! Reading the manifest of `ercube vectors --stage pe` for the PE's
//! testbench: its fields, its files' ports checked against the module's,
//! and the module's memories.

use pipeline::cosim::pe_vectors::Decl;
use serde_json::Value;

/// A file's port, as the manifest lists it.
pub(super) struct Col {
    /// The port's name.
    pub name: String,
    /// Stimulus (else an expected output).
    pub input: bool,
    /// Bits.
    pub bits: u32,
    /// Two's complement.
    pub signed: bool,
    /// The valid a checked output is compared under (`None`: every clock).
    pub when: Option<String>,
}

/// The manifest's `key`, or one line naming it.
pub(super) fn field<'a>(v: &'a Value, key: &str) -> Result<&'a Value, String> {
    v.get(key)
        .ok_or_else(|| format!("manifest.json: no \"{key}\""))
}

/// The count at `key`.
pub(super) fn num(v: &Value, key: &str) -> Result<u64, String> {
    field(v, key)?
        .as_u64()
        .ok_or_else(|| format!("manifest.json: \"{key}\" is not a count"))
}

/// The text at `key`.
pub(super) fn text<'a>(v: &'a Value, key: &str) -> Result<&'a str, String> {
    field(v, key)?
        .as_str()
        .ok_or_else(|| format!("manifest.json: \"{key}\" is not text"))
}

/// The files' ports from the manifest, checked against the module's.
pub(super) fn columns(man: &Value, decls: &[Decl]) -> Result<Vec<Col>, String> {
    let files = field(man, "files")?
        .as_array()
        .ok_or("manifest.json: \"files\" is not a list")?;
    let mut cols = Vec::new();
    for f in files {
        let name = text(f, "signal")?.to_owned();
        let input = text(f, "direction")? == "in";
        let bits = num(f, "width")? as u32;
        let signed = field(f, "signed")?.as_bool().unwrap_or(false);
        let checked = text(f, "checked")?;
        let when = checked
            .strip_prefix("where ")
            .and_then(|s| s.strip_suffix(" is 1"))
            .map(str::to_owned);
        match decls.iter().find(|d| d.name == name) {
            Some(d) if d.input == input && d.bits == bits => {}
            Some(d) => {
                return Err(format!(
                    "port {name} is {} bits {}, the vectors' is {bits} bits {}",
                    d.bits,
                    if d.input { "in" } else { "out" },
                    if input { "in" } else { "out" }
                ))
            }
            None => {
                return Err(format!(
                    "the module has no port {name} (a column of the vectors)"
                ))
            }
        }
        cols.push(Col {
            name,
            input,
            bits,
            signed,
            when,
        });
    }
    Ok(cols)
}

/// The width of the memory `name` in the module's text (`reg [H:0] name
/// [` or `reg signed [H:0] name [`), or `None` when the module has no
/// such memory.
pub(super) fn memory_bits(verilog: &str, name: &str) -> Option<u32> {
    verilog.lines().find_map(|l| {
        let l = l.trim();
        let l = l.strip_prefix("reg ")?.trim_start();
        let rest = l.strip_prefix("signed ").unwrap_or(l).trim_start();
        let rest = rest.strip_prefix('[')?;
        let (hi, rest) = rest.split_once(":0]")?;
        let rest = rest.trim_start().strip_prefix(name)?;
        rest.trim_start()
            .starts_with('[')
            .then(|| hi.trim().parse::<u32>().ok().map(|h| h + 1))?
    })
}

#[cfg(test)]
mod tests {
    use super::memory_bits;

    /// Plain and signed memories (a round-robin column map's ray indices
    /// are signed); a register, a wire or a prefix of the name is none.
    #[test]
    fn memory_bits_reads_plain_and_signed_memories() {
        let v = "  reg [7:0] sb0 [0:63];\n  reg signed [15:0] cm_mx [0:5];\n  reg [2:0] cm_sl[0:5];\n  reg [3:0] one;\n  wire [4:0] w [0:1];\n  reg [9:0] locx [0:1];";
        assert_eq!(memory_bits(v, "sb0"), Some(8));
        assert_eq!(memory_bits(v, "cm_mx"), Some(16));
        assert_eq!(memory_bits(v, "cm_sl"), Some(3));
        assert_eq!(memory_bits(v, "one"), None);
        assert_eq!(memory_bits(v, "w"), None);
        assert_eq!(memory_bits(v, "loc"), None);
    }
}
