//! [`FrameIndex`]: the sorted AnoVox frame ids of a scenario. A frame's *index* (0-based
//! position in this list) is the primary key everywhere in vadscope; the id is kept beside
//! it for display and file lookup.

use std::collections::HashMap;

use serde::Serialize;

use super::FrameId;

/// The frames of a scenario, sorted by id.
#[derive(Debug, Clone, Default)]
pub struct FrameIndex {
    ids: Vec<FrameId>,
    positions: HashMap<FrameId, usize>,
}

/// A hole in the id sequence: ids between `after` and `before` are missing, where the
/// scenario's usual step would have put frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct IdGap {
    /// Index of the frame before the gap.
    pub index: usize,
    /// Last id before the gap.
    pub after: FrameId,
    /// First id after the gap.
    pub before: FrameId,
    /// How many frames the usual step would have put in between.
    pub missing: u64,
}

/// A run of consecutive frame indices (inclusive), with their ids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct FrameRun {
    /// First index of the run.
    pub start_index: usize,
    /// Last index of the run (inclusive).
    pub end_index: usize,
    /// Id of the first frame.
    pub start_id: FrameId,
    /// Id of the last frame.
    pub end_id: FrameId,
}

impl FrameRun {
    /// Number of frames in the run.
    pub fn len(&self) -> usize {
        self.end_index - self.start_index + 1
    }

    /// Always false: a run holds at least one frame.
    pub fn is_empty(&self) -> bool {
        false
    }
}

impl std::fmt::Display for FrameRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.start_index == self.end_index {
            write!(f, "#{} (id {})", self.start_index, self.start_id)
        } else {
            write!(
                f,
                "#{}-#{} (ids {}-{}, {} frames)",
                self.start_index,
                self.end_index,
                self.start_id,
                self.end_id,
                self.len()
            )
        }
    }
}

impl FrameIndex {
    /// Builds the index from ids in any order; duplicates collapse.
    pub fn new(ids: impl IntoIterator<Item = FrameId>) -> Self {
        let mut ids: Vec<FrameId> = ids.into_iter().collect();
        ids.sort_unstable();
        ids.dedup();
        let positions = ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
        Self { ids, positions }
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether there are no frames.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The id of frame `index`.
    pub fn frame_id(&self, index: usize) -> Option<FrameId> {
        self.ids.get(index).copied()
    }

    /// The index of frame `id`.
    pub fn index_of(&self, id: FrameId) -> Option<usize> {
        self.positions.get(&id).copied()
    }

    /// All ids in index order.
    pub fn ids(&self) -> &[FrameId] {
        &self.ids
    }

    /// The usual distance between consecutive ids (the most common one; 1 when fewer than
    /// two frames). Recordings subsampled every k ticks have step k and no gaps.
    pub fn step(&self) -> u64 {
        let mut counts: HashMap<u64, usize> = HashMap::new();
        for pair in self.ids.windows(2) {
            *counts.entry(pair[1].0 - pair[0].0).or_default() += 1;
        }
        counts
            .into_iter()
            .max_by_key(|(step, count)| (*count, std::cmp::Reverse(*step)))
            .map_or(1, |(step, _)| step)
    }

    /// Places where consecutive ids are further apart than [`FrameIndex::step`].
    pub fn gaps(&self) -> Vec<IdGap> {
        let step = self.step();
        self.ids
            .windows(2)
            .enumerate()
            .filter(|(_, pair)| pair[1].0 - pair[0].0 > step)
            .map(|(index, pair)| IdGap {
                index,
                after: pair[0],
                before: pair[1],
                missing: (pair[1].0 - pair[0].0) / step - 1,
            })
            .collect()
    }

    /// Groups the indices for which `flag` is true into runs of consecutive indices.
    pub fn runs(&self, flag: impl Fn(usize) -> bool) -> Vec<FrameRun> {
        let mut runs: Vec<FrameRun> = Vec::new();
        for (index, id) in self.ids.iter().enumerate() {
            if !flag(index) {
                continue;
            }
            match runs.last_mut() {
                Some(run) if run.end_index + 1 == index => {
                    run.end_index = index;
                    run.end_id = *id;
                }
                _ => runs.push(FrameRun {
                    start_index: index,
                    end_index: index,
                    start_id: *id,
                    end_id: *id,
                }),
            }
        }
        runs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn index(ids: &[u64]) -> FrameIndex {
        FrameIndex::new(ids.iter().map(|&i| FrameId(i)))
    }

    #[test]
    fn sorts_numerically_and_maps_both_ways() {
        let frames = index(&[5720, 16, 100, 17]);
        assert_eq!(
            frames.ids(),
            &[FrameId(16), FrameId(17), FrameId(100), FrameId(5720)]
        );
        assert_eq!(frames.index_of(FrameId(100)), Some(2));
        assert_eq!(frames.frame_id(3), Some(FrameId(5720)));
        assert_eq!(frames.frame_id(4), None);
        assert_eq!(frames.index_of(FrameId(18)), None);
    }

    #[test]
    fn gaps_are_relative_to_the_usual_step() {
        let frames = index(&[16, 17, 18, 21, 22, 23]);
        assert_eq!(frames.step(), 1);
        assert_eq!(
            frames.gaps(),
            vec![IdGap {
                index: 2,
                after: FrameId(18),
                before: FrameId(21),
                missing: 2
            }]
        );
        let subsampled = index(&[403, 405, 407, 409, 413]);
        assert_eq!(subsampled.step(), 2);
        assert_eq!(subsampled.gaps().len(), 1);
        assert_eq!(subsampled.gaps()[0].missing, 1);
        assert!(index(&[7]).gaps().is_empty());
    }

    #[test]
    fn runs_group_consecutive_indices() {
        let frames = index(&[10, 11, 12, 13, 14, 15]);
        let runs = frames.runs(|i| i == 1 || i == 2 || i == 5);
        assert_eq!(runs.len(), 2);
        assert_eq!((runs[0].start_index, runs[0].end_index), (1, 2));
        assert_eq!(
            (runs[0].start_id, runs[0].end_id),
            (FrameId(11), FrameId(12))
        );
        assert_eq!(runs[1].len(), 1);
        assert_eq!(runs[0].to_string(), "#1-#2 (ids 11-12, 2 frames)");
    }
}
