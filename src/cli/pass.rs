//! The boundary passes (the split and the fold, front to back; the merge,
//! back to front) as `ercube cosim --stage split|merge|fold` and `ercube
//! rtl` use them:
//! their README sections and what the co-simulation replays, one
//! [`CliPass`] each, for one runner of each command ([`super::cosim_pass`],
//! [`super::rtl_pass`]).

use std::fmt::Write as _;

use pipeline::cosim::fold::Fold;
use pipeline::cosim::merge::Merge;
use pipeline::cosim::pass::PassKind;
use pipeline::cosim::split::Split;
use pipeline::hw::fold_rtl::FoldShape;
use pipeline::hw::merge_rtl::MergeShape;
use pipeline::hw::split_rtl::SplitShape;

/// What the commands need of a pass beyond its co-simulation.
pub trait CliPass: PassKind {
    /// The pass's name in the README's heading (`dense split`).
    const TITLE: &'static str;
    /// What the co-simulation replays from the model.
    const REPLAYED: &'static str;
    /// The README section's paragraph on the module, for a view-space
    /// volume of `dims`.
    fn paragraph(shape: &Self::Shape, dims: [usize; 3]) -> String;
}

impl CliPass for Split {
    const TITLE: &'static str = "dense split";
    const REPLAYED: &'static str = "the pass broadcast and the parents";
    fn paragraph(s: &SplitShape, dims: [usize; 3]) -> String {
        let f = Self::dims(s);
        format!(
            "From `pipeline::hw::split_rtl`, for a view-space volume of {}x{}x{} (`--dims`): the \
             bilinear split's x filter (the mean of a child's two parents, accumulator words on \
             `a_*`, `b_*`, into `merge`), its line buffer as the PE declares it ({} rows x {} \
             children x {} bits, a register file read without a clock) and its y filter (the mean of \
             the one or two parent rows a child row takes, back into the accumulators, with the \
             termination comparator). {} memory bits and {} register bits a PE. `begin_split` \
             latches the PE's child count and the grids' rows; `x_valid`, `x_row`, `y_valid`, \
             `y_row`, `col` are the pass broadcast; `lx_*` and `w_*` are the registered line-buffer \
             and bank writes. Not in the module: the parents' fetch (compositing buffer and link), \
             the edge drive, the children's bank, the sparse split's work lists and the bank swap.\n",
            dims[0], dims[1], dims[2], f.rows, f.width, 4 * u32::from(f.merge.bits()), f.memory_bits, f.register_bits
        )
    }
}

impl CliPass for Merge {
    const TITLE: &'static str = "dense merge";
    const REPLAYED: &'static str = "the pass broadcast, the held parents and the edge rays";
    fn paragraph(s: &MergeShape, dims: [usize; 3]) -> String {
        let f = Self::dims(s);
        format!(
            "From `pipeline::hw::merge_rtl`, for a view-space volume of {}x{}x{} (`--dims`): the \
             Bartlett merge's x tent (parents 2m - 1, 2m, 2m + 1 of child m, each a held column's \
             accumulator word on `h0_*` .. `h2_*`, the left or right neighbour's edge ray on \
             `el_*`, `er_*`, or zero, into `merge`), its line buffer as the PE declares it ({} rows \
             x {} children x {} bits, a register file read without a clock) and its y tent (parent \
             rows 2 my - 1 ..= 2 my + 1 of child row my, back into the accumulators). {} memory \
             bits and {} register bits a PE. `begin_merge` latches the PE's child count, first \
             child and held span and the grids' rows; `x_valid`, `x_row`, `y_valid`, `y_row`, \
             `col` are the pass broadcast; `lx_*` and `w_*` are the registered line-buffer and bank \
             writes. Not in the module: the held parents' fetch (the compositing buffer's read), \
             the edge drive, the children's bank, the sparse merge's work lists and the bank swap.\n",
            dims[0], dims[1], dims[2], f.rows, f.width, 4 * u32::from(f.merge.bits()), f.memory_bits, f.register_bits
        )
    }
}

impl CliPass for Fold {
    const TITLE: &'static str = "dense fold";
    const REPLAYED: &'static str =
        "the pass broadcast, the held results and inherited states, the left edge differences and the kept finals";
    fn paragraph(s: &FoldShape, dims: [usize; 3]) -> String {
        let f = Self::dims(s);
        format!(
            "From `pipeline::hw::fold_rtl`, for a view-space volume of {}x{}x{} (`--dims`): the \
             fold's differences (each held back column's result, a `merge` word on `h0_*` .. \
             `h2_*`, less its inherited state, an accumulator word on `i0_*` .. `i2_*`, into \
             `merge`), the Bartlett merge's x tent of back columns 2m - 1, 2m, 2m + 1 of child m \
             (a held column's difference, the left neighbour's edge difference on `el_*`, or zero), \
             its line buffer as the PE declares it ({} rows x {} children x {} bits, a register \
             file read without a clock), its y tent (back rows 2 my - 1 ..= 2 my + 1 of child row \
             my) and the add of the child's kept final state (`f_*`) into `merge`. {} memory bits \
             and {} register bits a PE. `begin_fold` latches the PE's child count, first child and \
             held span and the grids' rows; `x_valid`, `x_row`, `y_valid`, `y_row`, `col` are the \
             pass broadcast; `lx_*` and `w_*` are the registered line-buffer and bank writes. Not \
             in the module: the compositing buffer's read of the results and inherited states, \
             the kept finals' read, the edge drive, the children's bank, the sparse fold's work \
             lists and the bank swap.\n",
            dims[0], dims[1], dims[2], f.rows, f.width, 4 * u32::from(f.merge.bits()), f.memory_bits, f.register_bits
        )
    }
}

/// The README's section on pass `K`'s module.
pub fn section<K: CliPass>(s: &K::Shape, dims: [usize; 3]) -> String {
    let mut t = String::new();
    let _ = writeln!(t, "\n## {}: the PE's {}\n", K::MODULE, K::TITLE);
    let _ = writeln!(t, "{}", K::paragraph(s, dims));
    t
}
