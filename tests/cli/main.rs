//! The `vadscope` binary end to end, one module per subcommand, all in one test binary. Each
//! test runs the binary built for these tests on small scenarios it generates; the helpers
//! live in `tests/support/` (`support::cli` runs the binary).

#[path = "../support/mod.rs"]
mod support;

mod bundled_model;
mod flow;
mod full_disk;
mod generate;
mod kills;
mod labels;
mod render;
mod score;
mod train;
