//! The scenario generator: determinism across thread counts, the traffic's dynamics, the
//! ground truth it writes, and the bundled samples it regenerates pixel for pixel.

mod determinism;
mod dynamics;
mod groundtruth;
mod sample_sequences;
