//! A least-recently-used cache bounded by a byte budget, with interior mutability so a
//! shared `&Scenario` can fill it from several threads. Scrubbing through a 30,000-frame
//! scenario therefore keeps at most `budget` bytes of decoded frames in memory.

use std::collections::{BTreeMap, HashMap};
use std::hash::Hash;
use std::sync::{Mutex, MutexGuard, PoisonError};

/// A thread-safe LRU map whose entries declare their size in bytes.
#[derive(Debug)]
pub struct ByteLru<K, V> {
    state: Mutex<LruState<K, V>>,
}

#[derive(Debug)]
struct LruState<K, V> {
    budget: usize,
    used: usize,
    clock: u64,
    entries: HashMap<K, Entry<V>>,
    /// Last-use tick → key, oldest first.
    by_age: BTreeMap<u64, K>,
}

#[derive(Debug)]
struct Entry<V> {
    value: V,
    bytes: usize,
    tick: u64,
}

impl<K: Hash + Eq + Clone, V: Clone> ByteLru<K, V> {
    /// An empty cache that holds at most `budget` bytes.
    pub fn new(budget: usize) -> Self {
        Self {
            state: Mutex::new(LruState {
                budget,
                used: 0,
                clock: 0,
                entries: HashMap::new(),
                by_age: BTreeMap::new(),
            }),
        }
    }

    fn lock(&self) -> MutexGuard<'_, LruState<K, V>> {
        // Every mutation below restores the invariants before it can panic, so the state
        // behind a poisoned lock is consistent.
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The value for `key`, marking it most recently used.
    pub fn get(&self, key: &K) -> Option<V> {
        let mut state = self.lock();
        state.clock += 1;
        let tick = state.clock;
        let entry = state.entries.get_mut(key)?;
        let old_tick = std::mem::replace(&mut entry.tick, tick);
        let value = entry.value.clone();
        state.by_age.remove(&old_tick);
        state.by_age.insert(tick, key.clone());
        Some(value)
    }

    /// Stores `value` (of `bytes` bytes) and evicts least recently used entries until the
    /// budget holds. A value larger than the whole budget is not stored.
    pub fn insert(&self, key: K, value: V, bytes: usize) {
        let mut state = self.lock();
        state.remove(&key);
        if bytes > state.budget {
            return;
        }
        state.clock += 1;
        let tick = state.clock;
        state.used += bytes;
        state.by_age.insert(tick, key.clone());
        state.entries.insert(key, Entry { value, bytes, tick });
        state.evict_to_budget();
    }

    /// The cached value, or `load()`'s value which is then cached. `load` runs without the
    /// lock held, so slow decodes on several threads do not serialise.
    pub fn get_or_try_insert<E>(
        &self,
        key: K,
        load: impl FnOnce() -> Result<(V, usize), E>,
    ) -> Result<V, E> {
        if let Some(value) = self.get(&key) {
            return Ok(value);
        }
        let (value, bytes) = load()?;
        self.insert(key, value.clone(), bytes);
        Ok(value)
    }

    /// Bytes currently held.
    pub fn bytes_used(&self) -> usize {
        self.lock().used
    }

    /// Number of entries currently held.
    pub fn len(&self) -> usize {
        self.lock().entries.len()
    }

    /// Whether the cache is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The byte budget.
    pub fn budget(&self) -> usize {
        self.lock().budget
    }

    /// Changes the budget, evicting at once if the cache is over the new one.
    pub fn set_budget(&self, budget: usize) {
        let mut state = self.lock();
        state.budget = budget;
        state.evict_to_budget();
    }

    /// Drops every entry.
    pub fn clear(&self) {
        let mut state = self.lock();
        state.entries.clear();
        state.by_age.clear();
        state.used = 0;
    }
}

impl<K: Hash + Eq + Clone, V> LruState<K, V> {
    fn remove(&mut self, key: &K) {
        if let Some(entry) = self.entries.remove(key) {
            self.used -= entry.bytes;
            self.by_age.remove(&entry.tick);
        }
    }

    fn evict_to_budget(&mut self) {
        while self.used > self.budget {
            let Some((_, oldest)) = self.by_age.pop_first() else {
                break;
            };
            if let Some(entry) = self.entries.remove(&oldest) {
                self.used -= entry.bytes;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evicts_least_recently_used_first() {
        let cache = ByteLru::new(30);
        cache.insert(1, "a", 10);
        cache.insert(2, "b", 10);
        cache.insert(3, "c", 10);
        assert_eq!(cache.get(&1), Some("a"));
        cache.insert(4, "d", 10);
        assert_eq!(cache.get(&2), None, "2 was the least recently used");
        assert_eq!(cache.get(&1), Some("a"));
        assert_eq!(cache.bytes_used(), 30);
        assert_eq!(cache.len(), 3);
    }

    #[test]
    fn never_exceeds_budget_and_skips_oversized_values() {
        let cache = ByteLru::new(100);
        for i in 0..1000u32 {
            cache.insert(i, i, 7 + (i as usize % 13));
            assert!(cache.bytes_used() <= 100);
        }
        cache.insert(5000, 0, 101);
        assert_eq!(cache.get(&5000), None);
        cache.set_budget(20);
        assert!(cache.bytes_used() <= 20);
        cache.clear();
        assert!(cache.is_empty());
        assert_eq!(cache.bytes_used(), 0);
    }

    #[test]
    fn reinserting_a_key_replaces_its_size() {
        let cache = ByteLru::new(50);
        cache.insert("k", 1, 40);
        cache.insert("k", 2, 5);
        assert_eq!(cache.bytes_used(), 5);
        assert_eq!(cache.get(&"k"), Some(2));
    }

    #[test]
    fn get_or_try_insert_loads_once_and_passes_errors() {
        let cache = ByteLru::new(10);
        let mut loads = 0;
        for _ in 0..3 {
            let value: Result<u8, ()> = cache.get_or_try_insert(1, || {
                loads += 1;
                Ok((9, 4))
            });
            assert_eq!(value, Ok(9));
        }
        assert_eq!(loads, 1);
        let failed: Result<u8, &str> = cache.get_or_try_insert(2, || Err("broken"));
        assert_eq!(failed, Err("broken"));
        assert_eq!(cache.len(), 1);
    }
}
