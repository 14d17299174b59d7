//! World seeds shared out to worker threads, one at a time.

use std::sync::Mutex;

/// The seeds not yet taken by a worker.
pub struct SeedQueue {
    seeds: Vec<u64>,
    next: Mutex<usize>,
}

impl SeedQueue {
    pub fn new(seeds: Vec<u64>) -> Self {
        Self {
            seeds,
            next: Mutex::new(0),
        }
    }

    /// The next seed to run; `None` when every seed is taken.
    pub fn take(&self) -> Option<u64> {
        let mut g = self.next.lock().unwrap_or_else(|e| e.into_inner());
        let seed = self.seeds.get(*g).copied();
        *g += 1;
        seed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_seed_is_taken_once() {
        let q = SeedQueue::new(vec![3, 4]);
        assert_eq!((q.take(), q.take(), q.take()), (Some(3), Some(4), None));
    }
}
