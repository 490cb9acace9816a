//! [`Edit`]: every change to a [`LabelSet`], as data. Applying an edit checks it against the
//! labels, changes them and returns the inverse edit, which is what undo applies; edits are
//! serialised as they are into the journal.

use serde::{Deserialize, Serialize};

use super::AnnotateError;
use super::labels::{FailureTag, Interval, IntervalId, Keyframe, LabelSet, TagId, Track, TrackId};

/// One change to the labels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Edit {
    /// Adds an interval (its id must be free).
    AddInterval(Interval),
    /// Replaces the interval with the same id (move an edge, change class or note).
    UpdateInterval(Interval),
    /// Deletes an interval.
    DeleteInterval(IntervalId),
    /// Adds a track with its keyframes (its id must be free).
    AddTrack(Track),
    /// Deletes a track and all its keyframes.
    DeleteTrack(TrackId),
    /// Changes a track's class.
    SetTrackClass {
        /// The track.
        track: TrackId,
        /// The new class.
        class: u16,
    },
    /// Adds, moves or resizes a track's box at one frame (`Some`: a keyframe there; an
    /// `outside` keyframe deletes the box from that frame on), or removes the keyframe
    /// (`None`).
    SetKeyframe {
        /// The track.
        track: TrackId,
        /// Frame index.
        frame: usize,
        /// The keyframe, or `None` to remove it.
        keyframe: Option<Keyframe>,
    },
    /// Adds a failure tag (its id must be free).
    AddTag(FailureTag),
    /// Replaces the tag with the same id.
    UpdateTag(FailureTag),
    /// Deletes a tag.
    DeleteTag(TagId),
    /// Sets (`Some`) or clears (`None`) the note of a frame.
    SetNote {
        /// Frame index.
        frame: usize,
        /// The note.
        text: Option<String>,
    },
    /// Several edits applied (and undone) as one, e.g. an import.
    Batch(Vec<Edit>),
}

impl Edit {
    /// Applies the edit to `labels` and returns its inverse. An edit that does not fit
    /// (unknown id, frame out of range, empty range, bad box) changes nothing and is an
    /// [`AnnotateError::InvalidEdit`]; a batch is applied entirely or not at all.
    pub fn apply(&self, labels: &mut LabelSet) -> Result<Edit, AnnotateError> {
        let frames = labels.frame_count();
        let check_frame = |frame: usize| {
            if frame < frames {
                Ok(())
            } else {
                Err(AnnotateError::invalid(format!(
                    "frame {frame} is outside the scenario ({frames} frames)"
                )))
            }
        };
        let check_range = |start: usize, end: usize| {
            if start > end {
                return Err(AnnotateError::invalid(format!(
                    "range {start}..={end} ends before it starts"
                )));
            }
            check_frame(end)
        };
        match self {
            Edit::AddInterval(interval) => {
                check_range(interval.start, interval.end)?;
                if labels.intervals.contains_key(&interval.id) {
                    return Err(AnnotateError::invalid(format!(
                        "interval {} exists already",
                        interval.id.0
                    )));
                }
                labels.intervals.insert(interval.id, interval.clone());
                Ok(Edit::DeleteInterval(interval.id))
            }
            Edit::UpdateInterval(interval) => {
                check_range(interval.start, interval.end)?;
                let slot = labels
                    .intervals
                    .get_mut(&interval.id)
                    .ok_or_else(|| unknown("interval", interval.id.0))?;
                Ok(Edit::UpdateInterval(std::mem::replace(
                    slot,
                    interval.clone(),
                )))
            }
            Edit::DeleteInterval(id) => labels
                .intervals
                .remove(id)
                .map(Edit::AddInterval)
                .ok_or_else(|| unknown("interval", id.0)),
            Edit::AddTrack(track) => {
                if labels.tracks.contains_key(&track.id) {
                    return Err(AnnotateError::invalid(format!(
                        "track {} exists already",
                        track.id.0
                    )));
                }
                for (&frame, keyframe) in &track.keyframes {
                    check_frame(frame)?;
                    check_keyframe(keyframe)?;
                }
                labels.tracks.insert(track.id, track.clone());
                Ok(Edit::DeleteTrack(track.id))
            }
            Edit::DeleteTrack(id) => labels
                .tracks
                .remove(id)
                .map(Edit::AddTrack)
                .ok_or_else(|| unknown("track", id.0)),
            Edit::SetTrackClass { track, class } => {
                let slot = labels
                    .tracks
                    .get_mut(track)
                    .ok_or_else(|| unknown("track", track.0))?;
                let old = std::mem::replace(&mut slot.class, *class);
                Ok(Edit::SetTrackClass {
                    track: *track,
                    class: old,
                })
            }
            Edit::SetKeyframe {
                track,
                frame,
                keyframe,
            } => {
                check_frame(*frame)?;
                if let Some(keyframe) = keyframe {
                    check_keyframe(keyframe)?;
                }
                let slot = labels
                    .tracks
                    .get_mut(track)
                    .ok_or_else(|| unknown("track", track.0))?;
                let old = match keyframe {
                    Some(keyframe) => slot.keyframes.insert(*frame, *keyframe),
                    None => slot.keyframes.remove(frame),
                };
                Ok(Edit::SetKeyframe {
                    track: *track,
                    frame: *frame,
                    keyframe: old,
                })
            }
            Edit::AddTag(tag) => {
                check_range(tag.start, tag.end)?;
                if labels.tags.contains_key(&tag.id) {
                    return Err(AnnotateError::invalid(format!(
                        "tag {} exists already",
                        tag.id.0
                    )));
                }
                labels.tags.insert(tag.id, tag.clone());
                Ok(Edit::DeleteTag(tag.id))
            }
            Edit::UpdateTag(tag) => {
                check_range(tag.start, tag.end)?;
                let slot = labels
                    .tags
                    .get_mut(&tag.id)
                    .ok_or_else(|| unknown("tag", tag.id.0))?;
                Ok(Edit::UpdateTag(std::mem::replace(slot, tag.clone())))
            }
            Edit::DeleteTag(id) => labels
                .tags
                .remove(id)
                .map(Edit::AddTag)
                .ok_or_else(|| unknown("tag", id.0)),
            Edit::SetNote { frame, text } => {
                check_frame(*frame)?;
                let old = match text {
                    Some(text) => labels.notes.insert(*frame, text.clone()),
                    None => labels.notes.remove(frame),
                };
                Ok(Edit::SetNote {
                    frame: *frame,
                    text: old,
                })
            }
            Edit::Batch(edits) => {
                let mut inverses = Vec::with_capacity(edits.len());
                for (k, edit) in edits.iter().enumerate() {
                    match edit.apply(labels) {
                        Ok(inverse) => inverses.push(inverse),
                        Err(error) => {
                            for inverse in inverses.iter().rev() {
                                inverse
                                    .apply(labels)
                                    .expect("the inverse of an applied edit applies");
                            }
                            return Err(AnnotateError::invalid(format!(
                                "edit {k} of a batch of {}: {error}",
                                edits.len()
                            )));
                        }
                    }
                }
                inverses.reverse();
                Ok(Edit::Batch(inverses))
            }
        }
    }
}

fn unknown(what: &str, id: u64) -> AnnotateError {
    AnnotateError::invalid(format!("there is no {what} {id}"))
}

fn check_keyframe(keyframe: &Keyframe) -> Result<(), AnnotateError> {
    if keyframe.rect.is_valid() {
        Ok(())
    } else {
        let r = keyframe.rect;
        Err(AnnotateError::invalid(format!(
            "box ({}, {}, {}, {}) is not finite with x2 >= x1 and y2 >= y1",
            r.x1, r.y1, r.x2, r.y2
        )))
    }
}
