//! A small process-wide store of the last few values made from a key: node lists and point sets
//! that later albedo jobs (a sweep, a benchmark, the next view direction) ask for again.

use std::sync::{Arc, Mutex};

/// The last `capacity` values made by [`RecentCache::get_or_make`], oldest dropped first.
pub(super) struct RecentCache<K, V> {
    entries: Mutex<Vec<(K, Arc<V>)>>,
    capacity: usize,
}

impl<K: PartialEq + Clone, V> RecentCache<K, V> {
    /// An empty store of at most `capacity` values.
    pub(super) const fn new(capacity: usize) -> RecentCache<K, V> {
        RecentCache {
            entries: Mutex::new(Vec::new()),
            capacity,
        }
    }

    /// The value kept for `key`, or `make()` kept and returned. `make` runs outside the lock:
    /// two threads may make the same value at once (it must not depend on which), and one of
    /// them is kept.
    pub(super) fn get_or_make(&self, key: &K, make: impl FnOnce() -> V) -> Arc<V> {
        let find = |entries: &[(K, Arc<V>)]| {
            entries
                .iter()
                .find(|(k, _)| k == key)
                .map(|(_, v)| v.clone())
        };
        let lock = || self.entries.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(v) = find(&lock()) {
            return v;
        }
        let value = Arc::new(make());
        let mut entries = lock();
        if find(&entries).is_none() {
            if entries.len() == self.capacity {
                entries.remove(0);
            }
            entries.push((key.clone(), value.clone()));
        }
        value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_last_values_and_makes_the_others_again() {
        let kept: RecentCache<u32, u32> = RecentCache::new(2);
        let made = std::cell::Cell::new(0);
        let get = |k: u32| {
            *kept.get_or_make(&k, || {
                made.set(made.get() + 1);
                10 * k
            })
        };
        assert_eq!((get(1), get(2), get(1)), (10, 20, 10));
        assert_eq!(made.get(), 2, "1 was kept");
        assert_eq!(get(3), 30); // drops 1, the oldest
        assert_eq!((get(2), made.get()), (20, 3));
        assert_eq!((get(1), made.get()), (10, 4));
    }
}
