//! Test harnesses shared by every family: Pearson chi-square tests of
//! sampling routines against their densities ([`chi2`]), and the per-pixel
//! Z-test against reference mean/variance images ([`ztest`]).
//!
//! They live in the library (not behind `cfg(test)`) so the scene crate's
//! and the binary's tests can use them too.

pub mod chi2;
pub mod ztest;
