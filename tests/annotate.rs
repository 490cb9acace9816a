//! Integration tests of `vadscope::annotate`: edits with undo and redo, interpolation and
//! the per-frame queries, import/export round trips, crash-safe saving (a SIGKILL in the
//! middle of a burst of edits) and damaged label files; `vadscope labels` end to end.

mod cli_common;
mod score_common;

#[path = "annotate/cli.rs"]
mod cli;
#[path = "annotate/common.rs"]
mod common;
#[path = "annotate/edits.rs"]
mod edits;
#[path = "annotate/formats.rs"]
mod formats;
#[path = "annotate/storage.rs"]
mod storage;
