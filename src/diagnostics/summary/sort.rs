//! The external sort of a quantity's draws: runs of at most [`Limits::run_draws`] draws
//! (value, index) sorted in memory and written to a store, and a k-way merge that streams
//! them in order. Order statistics are picked from one merged stream.
//!
//! [`Limits::run_draws`]: super::Limits::run_draws

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::sync::atomic::Ordering as Atomic;

use super::store::{Record, Store, Workspace, WRITE_BATCH};
use crate::diagnostics::DiagnosticsError;

/// Sorted runs of records in one store.
#[derive(Debug)]
pub(super) struct Runs<'w> {
    store: Store<'w>,
    /// (first record, records) of each run.
    bounds: Vec<(usize, usize)>,
}

pub(super) struct RunWriter<'w> {
    store: Store<'w>,
    buf: Vec<Record>,
    cap: usize,
    bounds: Vec<(usize, usize)>,
    written: usize,
    bytes: Vec<u8>,
}

impl<'w> RunWriter<'w> {
    pub(super) fn new(ws: &'w Workspace, spill: bool) -> Result<Self, DiagnosticsError> {
        Ok(Self {
            store: ws.store(spill)?,
            buf: Vec::new(),
            cap: if spill {
                ws.limits.run_draws.max(1)
            } else {
                usize::MAX
            },
            bounds: Vec::new(),
            written: 0,
            bytes: Vec::new(),
        })
    }

    pub(super) fn push(&mut self, r: Record) -> Result<(), DiagnosticsError> {
        self.buf.push(r);
        if self.buf.len() >= self.cap {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), DiagnosticsError> {
        if self.buf.is_empty() {
            return Ok(());
        }
        // Ties may come out in any order: equal values have equal ranks.
        self.buf.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let start = self.written;
        for (k, batch) in self.buf.chunks(WRITE_BATCH).enumerate() {
            self.store
                .write_records(start + k * WRITE_BATCH, batch, &mut self.bytes)?;
        }
        self.bounds.push((start, self.buf.len()));
        self.written += self.buf.len();
        self.buf.clear();
        Ok(())
    }

    pub(super) fn finish(mut self) -> Result<Runs<'w>, DiagnosticsError> {
        self.flush()?;
        self.buf = Vec::new();
        Ok(Runs {
            store: self.store,
            bounds: self.bounds,
        })
    }
}

impl Runs<'_> {
    /// A stream of every record in ascending order of value (ties by run, then as sorted).
    pub(super) fn merge(&self) -> Merge<'_> {
        let k = self.bounds.len();
        self.store.ws.most_runs.fetch_max(k, Atomic::Relaxed);
        // The read buffers of one stream share a quarter of the memory of one run.
        let batch = (self.store.ws.limits.run_draws / (4 * k.max(1))).max(1);
        Merge {
            runs: self,
            cursors: self
                .bounds
                .iter()
                .map(|&(start, len)| Cursor {
                    next: start,
                    end: start + len,
                    buf: Vec::new(),
                    pos: 0,
                })
                .collect(),
            heap: BinaryHeap::with_capacity(k),
            batch,
            started: false,
            bytes: Vec::new(),
        }
    }
}

struct Cursor {
    next: usize,
    end: usize,
    buf: Vec<Record>,
    pos: usize,
}

/// Heads of the runs, smallest value first (then lowest run).
struct Head {
    value: f64,
    index: u32,
    run: usize,
}

impl PartialEq for Head {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Head {}

impl PartialOrd for Head {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Head {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap.
        other
            .value
            .total_cmp(&self.value)
            .then(other.run.cmp(&self.run))
    }
}

/// The k-way merge of sorted runs.
pub(super) struct Merge<'a> {
    runs: &'a Runs<'a>,
    cursors: Vec<Cursor>,
    heap: BinaryHeap<Head>,
    batch: usize,
    started: bool,
    bytes: Vec<u8>,
}

impl<'a> Merge<'a> {
    /// The next record of run `r`, refilling its buffer from the store.
    fn pull(&mut self, r: usize) -> Result<Option<Record>, DiagnosticsError> {
        let c = &mut self.cursors[r];
        if c.pos == c.buf.len() {
            if c.next == c.end {
                return Ok(None);
            }
            let count = self.batch.min(c.end - c.next);
            self.runs
                .store
                .read_records(c.next, count, &mut c.buf, &mut self.bytes)?;
            c.next += count;
            c.pos = 0;
        }
        let rec = c.buf[c.pos];
        c.pos += 1;
        Ok(Some(rec))
    }

    pub(super) fn next(&mut self) -> Result<Option<Record>, DiagnosticsError> {
        if !self.started {
            self.started = true;
            for r in 0..self.cursors.len() {
                if let Some((value, index)) = self.pull(r)? {
                    self.heap.push(Head {
                        value,
                        index,
                        run: r,
                    });
                }
            }
        }
        let Some(head) = self.heap.pop() else {
            return Ok(None);
        };
        if let Some((value, index)) = self.pull(head.run)? {
            self.heap.push(Head {
                value,
                index,
                run: head.run,
            });
        }
        Ok(Some((head.value, head.index)))
    }

    /// The values from here on, as an iterator; an error ends it and is kept in `error`.
    pub(super) fn values<'e>(
        &'e mut self,
        error: &'e mut Option<DiagnosticsError>,
    ) -> impl Iterator<Item = f64> + use<'a, 'e> {
        std::iter::from_fn(move || match self.next() {
            Ok(r) => r.map(|(v, _)| v),
            Err(e) => {
                *error = Some(e);
                None
            }
        })
    }
}

/// The order statistics at `all` (positions among every record) and `kept` (positions among
/// the records `keep` accepts), from one merged stream.
pub(super) fn pick(
    runs: &Runs,
    all: &[usize],
    kept: &[usize],
    keep: impl Fn(u32) -> bool,
) -> Result<(Picked, Picked), DiagnosticsError> {
    let (mut a, mut k) = (Picked::wanting(all), Picked::wanting(kept));
    let mut merge = runs.merge();
    let (mut i, mut j) = (0, 0);
    while let Some((v, index)) = merge.next()? {
        a.offer(i, v);
        i += 1;
        if keep(index) {
            k.offer(j, v);
            j += 1;
        }
    }
    Ok((a, k))
}

/// Values at chosen positions of a sorted stream.
pub(super) struct Picked(Vec<(usize, f64)>);

impl Picked {
    fn wanting(positions: &[usize]) -> Self {
        let mut p: Vec<(usize, f64)> = positions.iter().map(|&i| (i, f64::NAN)).collect();
        p.sort_by_key(|x| x.0);
        p.dedup_by_key(|x| x.0);
        Self(p)
    }

    fn offer(&mut self, i: usize, v: f64) {
        if let Ok(k) = self.0.binary_search_by_key(&i, |x| x.0) {
            self.0[k].1 = v;
        }
    }

    pub(super) fn at(&self, i: usize) -> f64 {
        let k = self
            .0
            .binary_search_by_key(&i, |x| x.0)
            .expect("a position asked for was picked");
        self.0[k].1
    }
}

/// The positions a function of sorted values reads: it is called with an accessor that
/// records them (the functions here read positions that depend only on the count).
pub(super) fn positions(f: impl Fn(&dyn Fn(usize) -> f64)) -> Vec<usize> {
    let seen = std::cell::RefCell::new(Vec::new());
    f(&|i| {
        seen.borrow_mut().push(i);
        0.0
    });
    seen.into_inner()
}
