//! # tilesynth core
//!
//! The hot loops of tilesynth, free of any Python dependency (the bindings live in `rust/py/`, compiled only
//! with the `python` feature). Everything takes `ndarray` views and returns owned arrays or a
//! [`error::TilesynthError`].
//!
//! - [`ssd`]: exhaustive sum of squared differences of a template over every translation of an image,
//!   by FFT correlation against a cached image spectrum, with exact re-ranking of the best matches.
//! - [`maxflow`]: a Boykov–Kolmogorov max-flow / min-cut solver and a 4-connected pixel-grid front end.
//! - [`omega`]: the ω-tile cutting curve (Kwatra edge weights, circle and cross terminals) and composition.
//! - [`poisson`]: Poisson smoothing (guided interpolation) of a region, by multigrid-preconditioned
//!   conjugate gradients to a stated relative residual.
//! - [`synth`]: copying tiles into a large output by an index map.
//! - [`population`]: the ω-tile objective `E` for whole populations of gene vectors (exact, cached
//!   per-patch SSD maps).
//! - [`png`]: PNG scanline reconstruction (16-bit colour PNGs, which Pillow truncates to 8 bits).
//! - [`wang`]: Wang tiles: Cohen's diamond samples joined by minimum-error cuts (DP or graph cut) with the
//!   improved match and objective of 001 for whole populations, and the closed cut of strict Wang tiles (004).
//! - [`parallel`]: local thread pools (`threads` argument, `TILESYNTH_NUM_THREADS`).
//! - [`png`]: PNG scanline unfiltering, for the 16-bit PNG reader of the Python layer.
//!
//! Conventions: images are C-contiguous `f32` `(H, W, C)` in [0, 1]; masks are `bool`; energies and
//! capacities are `f64`. Results never depend on the number of threads.
#![deny(missing_docs)]
#![warn(clippy::all)]

pub mod error;
pub mod gradients;
pub mod maxflow;
pub mod omega;
pub mod parallel;
pub mod png;
pub mod poisson;
pub mod population;
pub mod ssd;
pub mod synth;
pub mod wang;

#[cfg(feature = "python")]
mod py;

pub use error::{Result, TilesynthError};
