//! How the explorer shares the machine between pages: each page (a browser tab, named
//! by the `tab` field it sends) has at most one request per view at work, a newer one
//! cancelling the older; requests from all pages take turns for a few compute slots in
//! the order they came, so two tabs progress side by side and the memory in use is
//! bounded by the slots, whatever the sequence of requests. Each slot has a rayon pool
//! of its own as wide as the machine: in one shared pool a long request's many batches
//! would fill the workers' queues and a second request's batches would wait behind
//! them (rayon takes work from outside the pool only when a worker's own queue is
//! empty); with a pool per slot the operating system shares the cores between them.

use jeffcott_core::control::Cancel;
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// Requests computing at once at most.
pub const SLOTS: usize = 2;

/// The work of every page: cancel flags by (tab, view), and the compute slots.
pub struct Work {
    current: Mutex<HashMap<(String, String), Arc<Cancel>>>,
    slots: Mutex<Slots>,
    turn: Condvar,
    pools: Vec<rayon::ThreadPool>,
}

impl Default for Work {
    fn default() -> Self {
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        Work {
            current: Mutex::default(),
            slots: Mutex::new(Slots {
                free: (0..SLOTS).collect(),
                ..Slots::default()
            }),
            turn: Condvar::new(),
            pools: (0..SLOTS)
                .map(|i| {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .thread_name(move |t| format!("explore-{i}-{t}"))
                        .build()
                        .expect("a thread pool")
                })
                .collect(),
        }
    }
}

#[derive(Default)]
struct Slots {
    free: Vec<usize>,
    next: u64,
    queue: VecDeque<u64>,
}

/// A request's claim on its (tab, view): its cancel flag, released when dropped.
pub struct Claim<'a> {
    work: &'a Work,
    key: (String, String),
    /// Set when a newer request of the same tab and view arrives, or the tab closes.
    pub cancel: Arc<Cancel>,
}

/// A held compute slot, given back when dropped.
pub struct Slot<'a>(&'a Work, usize);

impl Slot<'_> {
    /// Runs `f` with this slot's thread pool as the pool of its parallel loops.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.0.pools[self.1].install(f)
    }
}

impl Work {
    /// Claims (tab, view) for a new request, cancelling the one before it.
    pub fn claim(&self, tab: &str, view: &str) -> Claim<'_> {
        let key = (tab.to_string(), view.to_string());
        let cancel = Arc::new(Cancel::new());
        let mut map = self.current.lock().expect("work map");
        if let Some(old) = map.insert(key.clone(), cancel.clone()) {
            old.set();
        }
        Claim {
            work: self,
            key,
            cancel,
        }
    }

    /// Cancels every request of `tab` (the page was closed or reloaded).
    pub fn close_tab(&self, tab: &str) -> usize {
        let mut map = self.current.lock().expect("work map");
        let mut n = 0;
        map.retain(|(t, _), c| {
            if t == tab {
                c.set();
                n += 1;
            }
            t != tab
        });
        n
    }

    /// Requests at work or waiting, by (tab, view).
    pub fn active(&self) -> usize {
        self.current.lock().expect("work map").len()
    }

    /// Waits for a compute slot in arrival order; `None` when `cancel` is set first.
    pub fn slot(&self, cancel: &Cancel) -> Option<Slot<'_>> {
        let mut s = self.slots.lock().expect("slots");
        let ticket = s.next;
        s.next += 1;
        s.queue.push_back(ticket);
        loop {
            if cancel.is_set() {
                s.queue.retain(|&t| t != ticket);
                self.turn.notify_all();
                return None;
            }
            if !s.free.is_empty() && s.queue.front() == Some(&ticket) {
                s.queue.pop_front();
                let pool = s.free.pop().expect("a free slot");
                // The next in line may fit in another free slot.
                self.turn.notify_all();
                return Some(Slot(self, pool));
            }
            s = self
                .turn
                .wait_timeout(s, Duration::from_millis(20))
                .expect("slots")
                .0;
        }
    }
}

impl Drop for Claim<'_> {
    fn drop(&mut self) {
        let mut map = self.work.current.lock().expect("work map");
        if map
            .get(&self.key)
            .is_some_and(|c| Arc::ptr_eq(c, &self.cancel))
        {
            map.remove(&self.key);
        }
    }
}

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        self.0.slots.lock().expect("slots").free.push(self.1);
        self.0.turn.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_newer_request_of_the_same_tab_and_view_cancels_the_older_only() {
        let w = Work::default();
        let a = w.claim("t1", "basin");
        let other_view = w.claim("t1", "bifurcation");
        let other_tab = w.claim("t2", "basin");
        let b = w.claim("t1", "basin");
        assert!(a.cancel.is_set());
        assert!(!b.cancel.is_set() && !other_view.cancel.is_set() && !other_tab.cancel.is_set());
        drop(a);
        assert_eq!(w.active(), 3, "the older claim's drop leaves the newer one");
        assert_eq!(w.close_tab("t1"), 2);
        assert!(b.cancel.is_set() && other_view.cancel.is_set() && !other_tab.cancel.is_set());
    }

    #[test]
    fn slots_are_bounded_and_a_cancelled_waiter_leaves_the_queue() {
        let w = Work::default();
        let never = Cancel::new();
        let held: Vec<_> = (0..SLOTS).map(|_| w.slot(&never).unwrap()).collect();
        let gone = Cancel::new();
        gone.set();
        assert!(w.slot(&gone).is_none());
        std::thread::scope(|s| {
            let waiter = s.spawn(|| w.slot(&never).is_some());
            std::thread::sleep(Duration::from_millis(60));
            assert!(!waiter.is_finished(), "no slot is free");
            drop(held);
            assert!(waiter.join().unwrap());
        });
    }
}
