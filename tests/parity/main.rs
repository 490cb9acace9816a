//! Parity with reference implementations on the fixtures of `shared/parity/` (beside the
//! checkout; each test says SKIPPED and passes when it is absent): the metrics against
//! scikit-learn, SciPy and NumPy, the networks against PyTorch.

mod eval;
mod model;
