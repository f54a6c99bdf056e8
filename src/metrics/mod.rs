//! Image metrics on linear float images (pure CPU): the error (RSE),
//! sharpness (CPBD), temporal-stability and stereo-consistency measures of
//! Philippi et al. 2025 (Sec. 5, Figs. 10, 12 and 15), and the project's
//! additions the paper does not use (MSE, PSNR, SSIM, HDR-FLIP).
//!
//! - [`image`]: [`LinearImage`], Rec. 709 luminance, sRGB encode/decode, the
//!   display image and display luma every display-referred metric uses.
//! - [`error`]: RSE (`ε = 0.01`), MSE (linear), PSNR (display image, peak 1).
//! - [`ssim`](mod@ssim): SSIM (Wang et al. 2004) on display luma, mean and map.
//! - [`flip`]: LDR-FLIP (Andersson et al. 2020) and HDR-FLIP (2021), mean and
//!   map; validated against NVIDIA's `flip-evaluator` package.
//! - [`cpbd`](mod@cpbd): CPBD sharpness (Narvekar & Karam 2011).
//! - [`covisibility`]: the co-visibility mask of one view in another from
//!   geometry alone (depth, optionally first-hit ids), applicable to any
//!   image — `compare` builds it from the reference, one mask for all methods.
//! - [`ghosting`]: the pixels a moving object has just left (from the
//!   reference's geometry, like co-visibility) and the error restricted to them.
//! - [`reproject`](mod@reproject): backward reprojection between views with a
//!   co-visibility mask (depth, optionally first-hit ids).
//! - [`temporal`]: frame-to-frame reprojected difference.
//! - [`stereo`]: left-into-right stereo discrepancy (mean, p95, overlap).
//! - [`summary`]: [`ImageMetrics`], all per-image metrics in one record.
//! - [`reference_noise`]: the reference's own error, estimated from two
//!   independent half-sample references.
//! - [`ppd`]: FLIP's pixels per degree from an eye's field of view and width.
//! - [`uncertainty`]: standard errors of per-frame means and of ratios of
//!   paired means (delta method).
//!
//! Shared conventions: mismatched sizes and empty images are
//! [`MetricsError`]s, never panics; non-finite input values count as 0
//! (see [`image`]); display-referred metrics clamp linear values to `[0, 1]`
//! with no tone curve (HDR-FLIP does its own exposure bracketing).

pub mod check;
pub mod covisibility;
pub mod cpbd;
pub mod error;
mod filter;
pub mod flip;
pub mod ghosting;
pub mod image;
pub mod ppd;
pub mod reference_noise;
pub mod reproject;
pub mod ssim;
pub mod stereo;
pub mod summary;
pub mod temporal;
pub mod uncertainty;

pub use check::MetricsError;
pub use covisibility::{Covisibility, Geometry};
pub use cpbd::{cpbd, CpbdResult};
pub use error::{mse, psnr, rse, RSE_EPSILON};
pub use flip::{flip_hdr, flip_ldr, FlipResult, HdrFlipResult, DEFAULT_PPD};
pub use image::LinearImage;
pub use ppd::{centre_pixels_per_degree, eye_pixels_per_degree};
pub use reference_noise::{half_split_error, mean_of_halves, ReferenceNoise};
pub use reproject::{pixel_difference, reproject, FirstHits, ViewBuffers, MISS_INSTANCE};
pub use ssim::{ssim, SsimResult};
pub use stereo::{stereo_discrepancy, stereo_discrepancy_masked, StereoDiscrepancy};
pub use summary::ImageMetrics;
pub use temporal::{temporal_instability, temporal_instability_masked, TemporalInstability};
pub use uncertainty::{
    autocorrelation_factor, mean_stderr, ratio_of_means, t_quantile_975, MeanStderr,
};
