//! Stereo blending (§3.6): each eye's pixel is blended with the other eye's
//! co-visible pixel, with a factor estimated from the sample cache's moments
//! (or, as the baseline of Philippi et al. 2023, from a 3×3 neighbourhood).

pub mod blend;

pub use blend::{beta_prime, dodgson, neighbour_weight, pixel_moments, BlendMode};
