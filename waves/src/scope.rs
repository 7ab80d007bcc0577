//! Hierarchical scope names of probes.

use std::fmt;

/// The name of the top-level scope; every probe lives below it.
pub const TOP: &str = "top";

/// A hierarchical scope such as `top`, `top.ctrl` or `top.pe_3.mac`.
///
/// PE scopes are named `pe_<k>` rather than `pe[k]`: GTKWave treats brackets
/// as bit-select syntax and mis-parses such scope names in save files. The
/// PE index is remembered here (not re-parsed from the name) so that the PE
/// filter of [`crate::TraceConfig`] cannot be fooled by a scope that merely
/// happens to be called `pe_7`.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ScopePath {
    parts: Vec<String>,
    pe: Option<u32>,
}

impl ScopePath {
    /// The root scope `top`.
    pub fn top() -> Self {
        ScopePath {
            parts: vec![TOP.to_string()],
            pe: None,
        }
    }

    /// The scope `top.pe_<k>` of processing element `k`.
    pub fn pe(k: u32) -> Self {
        ScopePath {
            parts: vec![TOP.to_string(), pe_scope_name(k)],
            pe: Some(k),
        }
    }

    /// A sub-scope of `self`, e.g. `ScopePath::top().child("ctrl")`.
    ///
    /// Sub-scopes of a PE scope belong to that PE for filtering. The name is
    /// validated when a signal is registered in it.
    pub fn child(&self, name: &str) -> Self {
        let mut parts = self.parts.clone();
        parts.push(name.to_string());
        ScopePath { parts, pe: self.pe }
    }

    /// The PE this scope belongs to, if any.
    pub fn pe_index(&self) -> Option<u32> {
        self.pe
    }

    /// The components, starting with `top`.
    pub fn parts(&self) -> &[String] {
        &self.parts
    }
}

impl fmt::Display for ScopePath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.parts.join("."))
    }
}

/// The VCD scope name used for PE `k`.
pub fn pe_scope_name(k: u32) -> String {
    format!("pe_{k}")
}

/// Whether `name` survives VCD, GTKWave and our own dotted naming intact.
pub(crate) fn is_valid_name(name: &str) -> bool {
    let mut chars = name.chars();
    match chars.next() {
        Some(c) if c.is_ascii_alphabetic() || c == '_' => {}
        _ => return false,
    }
    chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_pe_membership() {
        let mac = ScopePath::pe(3).child("mac");
        assert_eq!(mac.to_string(), "top.pe_3.mac");
        assert_eq!(mac.pe_index(), Some(3));
        let fake = ScopePath::top().child("pe_3");
        assert_eq!(fake.to_string(), "top.pe_3");
        assert_eq!(fake.pe_index(), None);
        assert_eq!(ScopePath::top().child("ctrl").to_string(), "top.ctrl");
    }

    #[test]
    fn name_validation() {
        for ok in ["acc", "_x", "a1_b2", "Valid"] {
            assert!(is_valid_name(ok), "{ok}");
        }
        for bad in ["", "1a", "a.b", "a[3]", "a b", "é", "a-b"] {
            assert!(!is_valid_name(bad), "{bad}");
        }
    }
}
