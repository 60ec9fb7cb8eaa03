//! Test harnesses shared by every family: Pearson chi-square tests of
//! sampling routines against their densities ([`chi2`]), the per-pixel
//! Z-test against reference mean/variance images ([`ztest`]), and an
//! in-memory parameter list for plugins' `from_params` ([`params`]).
//!
//! They live in the library (not behind `cfg(test)`) so the scene crate's
//! and the binary's tests can use them too.

pub mod chi2;
pub mod params;
pub mod ztest;
