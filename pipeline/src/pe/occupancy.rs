//! The occupancy probe: the most a PE's declared ray memories held in a
//! frame, to set beside their declared depths ([`super::Pe::declaration`],
//! [`crate::capacity`]). Model bookkeeping (`PeModel`), not a register.

use super::Pe;

/// The most a PE's ray memories held at once in a frame.
///
/// Noted whenever they change: at each slice's start, after each
/// broadcast (a pass's children allocated, a migration planned), after
/// each clocked migration cycle and after each pass. An untraced migration
/// between slices moves whole columns without stepping the links, so
/// there it is noted only when the migration ends; clocked frames
/// (traced, or `FrameRun` clocked) note every migration cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct Occupancy {
    /// Ray columns holding a slot of the compositing buffer (the column
    /// map's entries): the held ones, those arriving and those leaving
    /// whose last row has not left yet.
    pub columns: u64,
    /// Child columns a merge, split or fold writes (each over a parent's
    /// slot, the children's bank of the buffer).
    pub children: u64,
    /// Rows of the tallest column (held, moving or a child).
    pub rows: u64,
    /// Rays of the held, moving and child columns (each column's own
    /// rows).
    pub rays: u64,
    /// Children of a pass's row (the line buffer's row width).
    pub line: u64,
    /// Front to back: rays of the final states kept for the fold.
    pub kept: u64,
}

impl Occupancy {
    /// The larger of each field.
    pub fn max(self, o: Occupancy) -> Occupancy {
        Occupancy {
            columns: self.columns.max(o.columns),
            children: self.children.max(o.children),
            rows: self.rows.max(o.rows),
            rays: self.rays.max(o.rays),
            line: self.line.max(o.line),
            kept: self.kept.max(o.kept),
        }
    }
}

impl Pe {
    /// What this PE's ray memories hold now.
    pub fn occupancy_now(&self) -> Occupancy {
        let cols = self
            .rays
            .iter()
            .chain(&self.incoming)
            .chain(&self.pass.next);
        let (mut rows, mut rays) = (0, 0);
        for c in cols {
            rows = rows.max(c.acc.len() as u64);
            rays += c.acc.len() as u64;
        }
        for q in [&self.out_left, &self.out_right] {
            rows = rows.max(q.column_rows().1);
            rays += q.column_rows().0;
        }
        let columns = self.rays.len()
            + self.incoming.len()
            + self.out_left.columns()
            + self.out_right.columns();
        Occupancy {
            columns: columns as u64,
            children: self.pass.next.len() as u64,
            rows,
            rays,
            line: self.pass.children.len() as u64,
            kept: self
                .finals
                .iter()
                .flatten()
                .map(|c| c.acc.len() as u64)
                .sum(),
        }
    }

    /// Folds what the memories hold now into the frame's peak.
    #[inline]
    pub(crate) fn note_occupancy(&mut self) {
        self.model.occupancy = self.model.occupancy.max(self.occupancy_now());
    }

    /// The peak since the PE was built.
    pub fn occupancy(&self) -> Occupancy {
        self.model.occupancy
    }
}
