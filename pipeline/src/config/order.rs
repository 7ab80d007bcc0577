//! The compositing order, the one mode field of the config.

use serde::{Deserialize, Serialize};

/// The compositing order of the PE array.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Order {
    /// ER back-to-front: rays composite from the rear, merge at each region
    /// boundary (golden `er`).
    #[default]
    BackToFront,
    /// ER front-to-back: rays composite from the front, split at each
    /// region boundary, fold back to one baseplane at the end (golden
    /// `er-ftb`), with early ray termination.
    FrontToBack,
}

impl Order {
    /// The name in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Order::BackToFront => "back-to-front",
            Order::FrontToBack => "front-to-back",
        }
    }
}
