//! Runs whose output files appear together or not at all.
//!
//! While a run is open ([`stage`]), a finished temporary file handed to
//! [`place`] stays under its temporary name beside its destination;
//! [`Staged::commit`] renames every file into place, and dropping the run
//! uncommitted (an error) deletes them. Outside a run, [`place`] renames at
//! once.
//!
//! A run belongs to the thread that opened it, and follows its work onto
//! another thread with [`carry`] and [`adopt`]. A file finished on a rayon
//! worker that holds no run (a parallel step inside the run's work) joins
//! the one run open in the process: rayon gives its workers no way to know
//! whose work they run, and a program runs one command at a time. Were
//! several runs open (tests in one process), such a file is refused rather
//! than given to a run it may not belong to.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use tempfile::{NamedTempFile, TempPath};

/// The finished files of one run, each with its destination, in the
/// order they were finished.
type Files = Arc<Mutex<Vec<(TempPath, PathBuf)>>>;

thread_local! {
    /// The run this thread's files join.
    static RUN: RefCell<Option<Files>> = const { RefCell::new(None) };
}

/// Every run open in the process, for files finished on rayon workers.
static OPEN: Mutex<Vec<Files>> = Mutex::new(Vec::new());

/// Locks `m`, ignoring poisoning: a panic elsewhere leaves a list of
/// paths that is still whole.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The run a file finished on this thread joins, if any.
fn current() -> std::io::Result<Option<Files>> {
    if let Some(run) = RUN.with_borrow(Clone::clone) {
        return Ok(Some(run));
    }
    if rayon::current_thread_index().is_none() {
        return Ok(None);
    }
    let open = lock(&OPEN);
    match open.len() {
        0 => Ok(None),
        1 => Ok(Some(open[0].clone())),
        n => Err(std::io::Error::other(format!(
            "a file finished on a worker thread while {n} runs are open cannot be given to one"
        ))),
    }
}

/// Puts a finished temporary file at `path`: renamed now, or at the
/// commit of the open run it joins.
pub fn place(tmp: NamedTempFile, path: &Path) -> std::io::Result<()> {
    match current()? {
        Some(run) => {
            lock(&run).push((tmp.into_temp_path(), path.to_owned()));
            Ok(())
        }
        None => tmp.persist(path).map(drop).map_err(|e| e.error),
    }
}

/// A run whose files appear together or not at all (see the crate's
/// documentation). It stays on the thread that opened it.
#[must_use = "a staged run's files appear only on commit"]
pub struct Staged {
    files: Files,
    /// Not `Send`: the run is this thread's ([`carry`] moves its work).
    _here: std::marker::PhantomData<*const ()>,
}

/// Opens a run for the files this thread (and the rayon workers of its
/// work) finish; one at a time per thread.
pub fn stage() -> Staged {
    let files: Files = Arc::default();
    RUN.set(Some(files.clone()));
    lock(&OPEN).push(files.clone());
    Staged {
        files,
        _here: std::marker::PhantomData,
    }
}

/// An open run in transit between threads ([`carry`], [`adopt`]), for a
/// run whose work moves onto a thread pool.
pub struct Carried(Option<Files>);

/// Takes this thread's open run (if any), to [`adopt`] on another.
pub fn carry() -> Carried {
    Carried(RUN.take())
}

/// Continues a [`carry`]-ed run on this thread (nothing if none was open).
pub fn adopt(c: Carried) {
    if c.0.is_some() {
        RUN.set(c.0);
    }
}

impl Staged {
    /// Closes the run: no file joins it any more.
    fn close(&self) -> Vec<(TempPath, PathBuf)> {
        lock(&OPEN).retain(|f| !Arc::ptr_eq(f, &self.files));
        RUN.with_borrow_mut(|r| {
            if r.as_ref().is_some_and(|f| Arc::ptr_eq(f, &self.files)) {
                *r = None;
            }
        });
        std::mem::take(&mut *lock(&self.files))
    }

    /// Renames every file into place, in the order finished; on an error
    /// the destination is returned with it.
    pub fn commit(self) -> Result<(), (PathBuf, std::io::Error)> {
        for (tmp, path) in self.close() {
            if let Err(e) = tmp.persist(&path) {
                return Err((path, e.error));
            }
        }
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        // Uncommitted: the temporary files are deleted as they drop.
        drop(self.close());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::io::Write;

    fn finish(path: &Path) {
        let mut tmp = NamedTempFile::new_in(path.parent().unwrap()).unwrap();
        tmp.write_all(b"x").unwrap();
        place(tmp, path).unwrap();
    }

    /// The tests open runs of their own, which must not overlap: a file
    /// finished on a worker while two are open is refused.
    static SERIAL: Mutex<()> = Mutex::new(());

    fn names(dir: &Path) -> usize {
        std::fs::read_dir(dir).unwrap().count()
    }

    /// Files finished on a pool's workers join the run open on the thread
    /// that started the work: none is in place before the commit, none is
    /// left when the run fails, whichever worker failed.
    #[test]
    fn files_finished_on_workers_join_the_run() {
        let _one = lock(&SERIAL);
        let dir = tempfile::tempdir().unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let paths: Vec<PathBuf> = (0..12).map(|k| dir.path().join(format!("f{k}"))).collect();
        let work = |fail: Option<usize>| {
            pool.install(|| {
                paths.par_iter().enumerate().try_for_each(|(k, p)| {
                    assert!(rayon::current_thread_index().is_some());
                    if Some(k) == fail {
                        return Err(k);
                    }
                    finish(p);
                    Ok(())
                })
            })
        };
        for fail in [0, 5, 11] {
            let run = stage();
            // The work runs on the pool's workers, not on this thread.
            assert!(work(Some(fail)).is_err());
            assert!(paths.iter().all(|p| !p.exists()));
            drop(run);
            assert_eq!(names(dir.path()), 0, "failure at file {fail} left files");
        }
        let run = stage();
        work(None).unwrap();
        assert!(paths.iter().all(|p| !p.exists()));
        run.commit().unwrap();
        assert!(paths.iter().all(|p| p.is_file()));
        assert_eq!(names(dir.path()), paths.len());
    }

    /// A thread that is not a pool's worker and holds no run puts its
    /// files in place at once, even while another thread's run is open.
    #[test]
    fn without_a_run_files_appear_at_once() {
        let _one = lock(&SERIAL);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a");
        let other = std::thread::spawn(|| {
            let run = stage();
            std::thread::sleep(std::time::Duration::from_millis(50));
            drop(run);
        });
        std::thread::sleep(std::time::Duration::from_millis(10));
        finish(&p);
        assert!(p.is_file());
        other.join().unwrap();
    }
}
