//! State elements declared as hardware: registers, memories (depth, word
//! width, ports) and bounded FIFOs (a declared depth; a push past it is
//! refused, never absorbed by growing).
//!
//! A unit lists its state once as [`StateDecl`]s (the PE's in
//! [`crate::pe::Pe::declaration`]); the cost model's memory inventory
//! charges those entries (the off-chip ones as external memory), and the model's FIFOs are [`Fifo`]s built with
//! the declared depth.

use std::collections::VecDeque;

use crate::cost::memory::MemPorts;

/// What a state element is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StateKind {
    /// A register of `width` bits (depth 1).
    Register,
    /// A memory of `depth` words of `width` bits with these ports.
    Memory(MemPorts),
    /// A first-in first-out queue of `depth` words of `width` bits (one
    /// write port, one read port).
    Fifo,
    /// A memory of `depth` words of `width` bits in external DRAM: the
    /// unit's region of a memory the array reaches through its memory
    /// channel ([`crate::stages::raybuf`]), no on-chip RAM. The cost model
    /// counts its bits as external memory, never as block RAM.
    OffChip,
}

/// One declared state element.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct StateDecl {
    /// Its name in the unit (snake case, as the probes and Verilog name
    /// it).
    pub name: &'static str,
    /// What it holds and how it is banked (the cost report's line).
    pub what: String,
    /// Register, memory, FIFO or off-chip memory.
    pub kind: StateKind,
    /// Copies (banks, sides, rows of a line buffer).
    pub copies: u32,
    /// Words per copy (1 for a register).
    pub depth: u64,
    /// Bits per word.
    pub width: u32,
}

impl StateDecl {
    /// Bits of one copy.
    pub fn bits(&self) -> u64 {
        self.depth * u64::from(self.width)
    }

    /// Whether it lives on the chip (everything but [`StateKind::OffChip`]).
    pub fn on_chip(&self) -> bool {
        self.kind != StateKind::OffChip
    }
}

/// A push into a full [`Fifo`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("a FIFO of depth {depth} is full")]
pub struct Overflow {
    /// The FIFO's declared depth.
    pub depth: usize,
}

/// A FIFO of a declared depth: [`Fifo::push`] refuses a word past it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fifo<T> {
    words: VecDeque<T>,
    depth: usize,
}

impl<T> Default for Fifo<T> {
    /// A FIFO of depth 0 (it refuses every push): a placeholder until the
    /// unit is built with its declared depth.
    fn default() -> Fifo<T> {
        Fifo::new(0)
    }
}

impl<T> Fifo<T> {
    /// An empty FIFO holding at most `depth` words.
    pub fn new(depth: usize) -> Fifo<T> {
        Fifo {
            words: VecDeque::new(),
            depth,
        }
    }

    /// The declared depth.
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Appends `w` at the back; refused when the FIFO holds `depth` words.
    pub fn push(&mut self, w: T) -> Result<(), Overflow> {
        if self.words.len() >= self.depth {
            return Err(Overflow { depth: self.depth });
        }
        self.words.push_back(w);
        Ok(())
    }

    /// Takes the front word.
    pub fn pop(&mut self) -> Option<T> {
        self.words.pop_front()
    }

    /// The front word.
    pub fn front(&self) -> Option<&T> {
        self.words.front()
    }

    /// Words held.
    pub fn len(&self) -> usize {
        self.words.len()
    }

    /// Whether it holds no word.
    pub fn is_empty(&self) -> bool {
        self.words.is_empty()
    }

    /// The words, front first.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.words.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A FIFO takes words up to its depth, refuses the next one without
    /// changing what it holds, and takes one again once a word leaves.
    #[test]
    fn a_push_past_the_depth_is_refused() {
        let mut f = Fifo::new(3);
        for w in 0..3 {
            f.push(w).unwrap();
        }
        assert_eq!(f.push(3), Err(Overflow { depth: 3 }));
        assert_eq!(f.len(), 3);
        assert_eq!(f.iter().copied().collect::<Vec<_>>(), [0, 1, 2]);
        assert_eq!(f.pop(), Some(0));
        f.push(3).unwrap();
        assert_eq!(f.iter().copied().collect::<Vec<_>>(), [1, 2, 3]);
        assert_eq!(Fifo::<u8>::default().push(0), Err(Overflow { depth: 0 }));
    }
}
