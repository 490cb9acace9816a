//! A worker thread that reports events over a channel and can be asked to stop: what the
//! viewer's scoring and export jobs share. The UI polls it every frame, so it never waits
//! for the worker; dropping the handle asks the worker to stop.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::thread::JoinHandle;

/// A running (or finished) worker thread and the events it has not yet delivered.
#[derive(Debug)]
pub struct BackgroundThread<E> {
    events: Receiver<E>,
    cancel: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl<E: Send + 'static> BackgroundThread<E> {
    /// Starts `work` on a thread called `name`; it sends its events to the given sender and
    /// should return soon after the flag is set.
    pub fn spawn(name: &str, work: impl FnOnce(&Sender<E>, &AtomicBool) + Send + 'static) -> Self {
        let (sender, events) = channel();
        let cancel = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&cancel);
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || work(&sender, &flag))
            .ok();
        Self {
            events,
            cancel,
            thread,
        }
    }
}

impl<E> BackgroundThread<E> {
    /// The events that have arrived since the last call (never blocks). Once the worker has
    /// hung up, its thread is joined.
    pub fn poll(&mut self) -> Vec<E> {
        let mut out = Vec::new();
        loop {
            match self.events.try_recv() {
                Ok(event) => out.push(event),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    if let Some(thread) = self.thread.take() {
                        let _ = thread.join();
                    }
                    break;
                }
            }
        }
        out
    }

    /// Whether the worker thread has ended (all its events may still wait in [`Self::poll`]).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// Asks the worker to stop.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// Whether stopping has been asked for.
    pub fn is_cancelling(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

impl<E> Drop for BackgroundThread<E> {
    fn drop(&mut self) {
        self.cancel();
    }
}
