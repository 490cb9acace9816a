//! The frame cursor and playback: stepping, seeking and playing at the scenario's frame
//! rate, always on whole frame indices (nothing is derived from time but the next frame).

/// The current frame of a scenario of `len` frames and whether it plays.
#[derive(Debug, Clone, PartialEq)]
pub struct Playback {
    frame: usize,
    len: usize,
    playing: bool,
    fps: f64,
    pending: f64,
}

impl Playback {
    /// Frame 0 of a scenario of `len` frames played at `fps`.
    pub fn new(len: usize, fps: f64) -> Self {
        Self {
            frame: 0,
            len,
            playing: false,
            fps: if fps.is_finite() && fps > 0.0 {
                fps
            } else {
                10.0
            },
            pending: 0.0,
        }
    }

    /// The current frame index.
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there is no frame.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether it plays.
    pub fn is_playing(&self) -> bool {
        self.playing
    }

    /// Frames per second of playback.
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// Moves to `frame`, clamped to the scenario.
    pub fn seek(&mut self, frame: usize) {
        self.frame = frame.min(self.len.saturating_sub(1));
        self.pending = 0.0;
    }

    /// Moves by `delta` frames, clamped to the scenario.
    pub fn step(&mut self, delta: i64) {
        let target = (self.frame as i64).saturating_add(delta).max(0);
        self.seek(usize::try_from(target).unwrap_or(usize::MAX));
    }

    /// Starts or stops playing; playing from the last frame starts over.
    pub fn toggle(&mut self) {
        self.set_playing(!self.playing);
    }

    /// Starts or stops playing.
    pub fn set_playing(&mut self, playing: bool) {
        if playing && self.frame + 1 >= self.len {
            self.frame = 0;
        }
        self.playing = playing && self.len > 1;
        self.pending = 0.0;
    }

    /// Lets `seconds` of wall time pass: while playing, moves on by the whole frames they
    /// make and stops at the last frame. Returns whether the frame changed.
    pub fn advance(&mut self, seconds: f64) -> bool {
        if !self.playing || !seconds.is_finite() || seconds <= 0.0 {
            return false;
        }
        self.pending += seconds * self.fps;
        let whole = self.pending.floor();
        self.pending -= whole;
        let before = self.frame;
        self.frame = (self.frame + whole as usize).min(self.len.saturating_sub(1));
        if self.frame + 1 >= self.len {
            self.playing = false;
        }
        self.frame != before
    }
}
