//! # tilesynth core
//!
//! The hot loops of tilesynth, free of any Python dependency (the bindings live in `rust/py/`, compiled only
//! with the `python` feature). Everything takes `ndarray` views and returns owned arrays or a
//! [`error::TilesynthError`].
//!
//! - [`ssd`]: exhaustive sum of squared differences of a template over every translation of an image,
//!   by FFT correlation against a cached image spectrum, with exact re-ranking of the best matches.
//! - [`maxflow`]: a Boykov–Kolmogorov max-flow / min-cut solver and a 4-connected pixel-grid front end.
//! - [`seams`]: Kwatra's gradient-normalised seam weights, shared by every cut.
//! - [`omega`]: the ω-tile cutting curve (circle and cross terminals) and composition.
//! - [`poisson`]: Poisson smoothing (guided interpolation) of a region, by multigrid-preconditioned
//!   conjugate gradients to a stated relative residual.
//! - [`provenance`]: tile sets as provenance (labels and a per-tile source table) and the gather of any window
//!   of a tiling straight from the exemplar.
//! - [`blend`]: the seam blend of smooth material maps over a window (labels' coverage, two bands).
//! - [`synth`]: copying tiles into a large output by an index map.
//! - [`hash`]: the hashed lookup of complete tile sets (pcg3d of lattice coordinates, `HASH-SPEC.md`).
//! - [`population`]: the ω-tile objective `E` for whole populations of gene vectors (exact, cached
//!   per-patch SSD maps).
//! - [`png`]: PNG decoding (the `png` crate, with a pixel limit) and a fast encoder, parallel over row bands.
//! - [`openexr`]: OpenEXR read and write (the `exr` crate), half and float, any channel count.
//! - [`wang`]: Wang tiles: Cohen's diamond samples joined by minimum-error cuts (DP or graph cut) with the
//!   improved match and objective of 001 for whole populations, and the closed cut of strict Wang tiles (004).
//! - [`parallel`]: local thread pools (`threads` argument, `TILESYNTH_NUM_THREADS`).
//!
//! Conventions: images are C-contiguous `f32` `(H, W, C)` in [0, 1]; masks are `bool`; energies and
//! capacities are `f64`. Results never depend on the number of threads.
#![deny(missing_docs)]
#![warn(clippy::all)]

pub mod blend;
pub mod error;
pub mod gradients;
pub mod hash;
pub mod maxflow;
pub mod omega;
pub mod openexr;
pub mod parallel;
pub mod png;
pub mod poisson;
pub mod population;
pub mod provenance;
pub mod seams;
pub mod ssd;
pub mod synth;
pub mod wang;

#[cfg(feature = "python")]
mod py;

pub use error::{Result, TilesynthError};
