//! Integration tests of the library, one module per library module, all in one test binary
//! (one link of burn, egui and wgpu instead of one per file). Every test runs on small data
//! it generates; the helpers live in `tests/support/`.

#[path = "../support/mod.rs"]
mod support;

mod annotate {
    //! `vadscope::annotate`: edits with undo and redo, interpolation and the per-frame
    //! queries, import/export round trips, crash-safe saving (a SIGKILL in the middle of a
    //! burst of edits) and damaged label files. `vadscope labels` end to end is in the `cli`
    //! tests.

    mod edits;
    mod formats;
    mod storage;
}

mod flow {
    //! `vadscope::flow`: DIS on synthetic frame pairs with exact motion, edge cases and the
    //! flow cache.

    mod cache;
    mod edge_cases;
    mod synthetic;
}

mod model {
    //! `vadscope::model`: checkpoints and batched inference. Parity with the PyTorch
    //! reference is in the `parity` tests.

    mod checkpoint;
    mod inference;
}

mod render {
    //! `vadscope::render`: every view, and the golden images of `tests/golden/`.

    mod golden;
    mod views;
}

mod score {
    //! `vadscope::score`: box and flow sources, score caches, fusion and scoring runs.

    mod boxes;
    mod cache;
    mod flows;
    mod fusion;
    mod run;
    mod validation;
}

mod sequence {
    //! `vadscope::sequence`: reading and writing scenarios, labels, layouts, flow files and
    //! malformed input.

    mod flow_files;
    mod labels;
    mod layouts;
    mod malformed;
    mod reader;
    mod writer;
}

mod train {
    //! `vadscope::train`: cubes from scenarios, the training stages and weight averaging.

    mod averaging;
    mod fixtures;
    mod scenarios;
    mod stages;
}
