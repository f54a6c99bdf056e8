//! Image metrics on linear float images (pure CPU).

pub mod check;
pub mod cpbd;
pub mod error;
mod filter;
pub mod flip;
pub mod image;
pub mod reproject;
pub mod ssim;
pub mod stereo;
pub mod temporal;

pub use check::MetricsError;
pub use cpbd::{cpbd, CpbdResult};
pub use error::{mse, psnr, rse, RSE_EPSILON};
pub use flip::{flip_hdr, flip_ldr, FlipResult, HdrFlipResult, DEFAULT_PPD};
pub use image::LinearImage;
pub use reproject::{pixel_difference, reproject, FirstHits, ViewBuffers, MISS_INSTANCE};
pub use ssim::{ssim, SsimResult};
pub use stereo::{stereo_discrepancy, StereoDiscrepancy};
pub use temporal::{temporal_instability, TemporalInstability};
