//! The desktop viewer: its GUI-free core (`AppState`) and the egui layer driven headless
//! through egui_kittest, all in one test binary. The helpers live in `tests/support/`
//! (`support::app`, which the `app` benchmark includes too).

#[path = "../support/mod.rs"]
mod support;

mod labeling;
mod state;
mod ui;
