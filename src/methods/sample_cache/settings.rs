//! Options of the `sample-cache` method and their command-line spellings.

use serde::Serialize;
use std::str::FromStr;

/// `--retrace`: which cached samples are retraced each frame (§3.2, §3.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Retrace {
    /// One slot per pixel, round robin.
    Single,
    /// Every slot every frame.
    Multi,
    /// One sample per 4×4 block plus every sample of pixels failing Eq. 2.
    Adaptive,
}

/// `--shading`: which samples are shaded each frame (§3.3, §3.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Shading {
    Uniform,
    Adaptive,
    /// No sample is shaded: the frame is the visibility passes and the
    /// reconstruction alone, as the paper times its retrace modes (Fig. 7:
    /// "shading is skipped in this test"). Surface samples keep no radiance,
    /// so the image shows the background samples and the surfaces' emission.
    Skip,
}

/// `--payload`: what a cache entry holds besides its 128-bit first hit
/// (Listing 1). `radiance`: the 128-bit radiance record (mean radiance,
/// effective count), 256 bits per entry, what shading accumulates into,
/// and the 32-bit slot depth (reconstruction's closest sample, one copy
/// beside the double-buffered entries).
/// `none`: the first hit alone, the paper's "no-shade" rows of Fig. 6 /
/// Table 1 (reprojection without a shading payload); nothing can be shaded
/// into it, so it needs `--shading skip`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Payload {
    Radiance,
    None,
}

/// `--reproject`: one pass with racy sample writes (default) or two passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reproject {
    OnePass,
    TwoPass,
}

/// `--accumulation`: how shade.comp (the sample cache's and isrt's) averages
/// a sample's paths.
/// `mean` (default): the running mean, as §4–5 accumulate the "secondary
/// ray results for diffuse global illumination" of the main comparisons,
/// and as HashCache's cells average theirs (hash_table/update.comp).
/// `alpha-min`: appendix C's analysis of specular materials: the running
/// mean's blend factor floored at α_min = (1 − α_GGX)·0.5 + α_GGX·0.1 for
/// every sample whose BSDF has a specular lobe (metal, transmission, or a
/// dielectric specular layer: glTF's default specular 1 included).
/// `fixed:A`: every sample's blend factor floored at A (§5.2 uses α = 0.1):
/// a running mean while 1/(c_s + 1) > A, then an exponential average with α = A.
/// Until session 50 `mean` was `alpha-min`: every glTF dielectric has a
/// specular layer, so the sample cache's history was capped at an
/// effective 10–19 shadings nearly everywhere while HashCache's ran to 1024
/// (an audit of the experiments against the paper).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Accumulation {
    RunningMean,
    AlphaMin,
    FixedAlpha(f32),
}

impl Accumulation {
    /// The shaders' `ACCUM_MODE` (common/accumulation.glsl
    /// `accumulation_floor`): 0 running mean, 1 fixed α, 2 appendix C's α_min.
    pub fn mode(self) -> u32 {
        match self {
            Accumulation::RunningMean => 0,
            Accumulation::FixedAlpha(_) => 1,
            Accumulation::AlphaMin => 2,
        }
    }

    /// `fixed:A` with A in (0, 1].
    pub fn validate(self) -> Result<(), String> {
        match self {
            Accumulation::FixedAlpha(a) if !(a > 0.0 && a <= 1.0) => {
                Err(format!("bad --accumulation fixed:{a}: α must be in (0, 1]"))
            }
            _ => Ok(()),
        }
    }

    /// The α of `fixed:A` (0 otherwise), pushed to the shading pass.
    pub fn fixed_alpha(self) -> f32 {
        match self {
            Accumulation::FixedAlpha(a) => a,
            _ => 0.0,
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct SampleCacheSettings {
    /// N slots per pixel (≤ 16 with the 32-bit mask).
    pub slots: u32,
    pub n_target: u32,
    pub delta: u32,
    pub retrace: Retrace,
    pub shading: Shading,
    pub payload: Payload,
    /// 1.0 = one shading invocation per pixel (adaptive shading).
    pub shading_rate: f32,
    pub reproject: Reproject,
    pub accumulation: Accumulation,
    /// Retrace tolerance ε0, relative to the hit distance (orthographic
    /// eyes: to the view's half height, camera.glsl `eye_tolerance_scale`).
    pub eps0: f32,
    /// Eq. 2's ε1.
    pub eps1: f32,
    /// Download the debug views (trace mask, samples per pixel, shaded, occupancy).
    pub debug_views: bool,
    /// §3.6 stereo blending of the reconstructed eyes.
    pub stereo_blend: crate::stereo::BlendMode,
    /// Sharpness R ∈ [0, 1] of the blending: Y's 3×3 moment blur has
    /// neighbour weight 1 − R (R = 1: none), and Dodgson's kernel for X's
    /// moments interpolates at R = 1 (exact at pixel centres, neighbours
    /// still contributing between them).
    pub sharpness: f32,
}

impl Default for SampleCacheSettings {
    fn default() -> Self {
        SampleCacheSettings {
            slots: 12,
            n_target: 4,
            delta: 1,
            retrace: Retrace::Adaptive,
            shading: Shading::Uniform,
            payload: Payload::Radiance,
            shading_rate: 1.0,
            reproject: Reproject::OnePass,
            accumulation: Accumulation::RunningMean,
            eps0: 0.001,
            eps1: 0.005,
            debug_views: false,
            stereo_blend: crate::stereo::BlendMode::None,
            sharpness: 0.5,
        }
    }
}

impl SampleCacheSettings {
    /// Checks ranges; the message names the option.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=16).contains(&self.slots) {
            return Err(format!(
                "bad --slots {}: the 32-bit mask holds 1 to 16 slots",
                self.slots
            ));
        }
        if self.n_target == 0 || self.n_target > self.slots {
            return Err(format!(
                "bad --n-target {}: expected 1..={} (the slot count)",
                self.n_target, self.slots
            ));
        }
        if self.delta >= self.n_target {
            return Err(format!(
                "bad --delta {}: must be below --n-target {}",
                self.delta, self.n_target
            ));
        }
        if !(self.shading_rate.is_finite()
            && self.shading_rate > 0.0
            && self.shading_rate <= self.slots as f32)
        {
            return Err(format!(
                "bad --shading-rate {}: expected a fraction in (0, {}]",
                self.shading_rate, self.slots
            ));
        }
        if !(0.0..=1.0).contains(&self.sharpness) {
            return Err(format!(
                "bad --sharpness {}: expected R in [0, 1]",
                self.sharpness
            ));
        }
        if self.payload == Payload::None && self.shading != Shading::Skip {
            return Err(
                "bad --payload none: a cache without the radiance record cannot be shaded; \
                 use it with --shading skip"
                    .into(),
            );
        }
        self.accumulation.validate()
    }
}

impl FromStr for Retrace {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "single" => Ok(Retrace::Single),
            "multi" => Ok(Retrace::Multi),
            "adaptive" => Ok(Retrace::Adaptive),
            _ => Err(format!(
                "bad --retrace '{s}': expected single, multi or adaptive"
            )),
        }
    }
}

impl FromStr for Shading {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "uniform" => Ok(Shading::Uniform),
            "adaptive" => Ok(Shading::Adaptive),
            "skip" => Ok(Shading::Skip),
            _ => Err(format!(
                "bad --shading '{s}': expected uniform, adaptive or skip"
            )),
        }
    }
}

impl FromStr for Payload {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "radiance" => Ok(Payload::Radiance),
            "none" => Ok(Payload::None),
            _ => Err(format!("bad --payload '{s}': expected radiance or none")),
        }
    }
}

impl FromStr for Reproject {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "one-pass" => Ok(Reproject::OnePass),
            "two-pass" => Ok(Reproject::TwoPass),
            _ => Err(format!(
                "bad --reproject '{s}': expected one-pass or two-pass"
            )),
        }
    }
}

impl FromStr for Accumulation {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "mean" {
            return Ok(Accumulation::RunningMean);
        }
        if s == "alpha-min" {
            return Ok(Accumulation::AlphaMin);
        }
        if let Some(a) = s.strip_prefix("fixed:") {
            let a: f32 = a
                .parse()
                .map_err(|_| format!("bad --accumulation '{s}': α is not a number"))?;
            return Ok(Accumulation::FixedAlpha(a));
        }
        Err(format!(
            "bad --accumulation '{s}': expected mean, alpha-min or fixed:ALPHA"
        ))
    }
}
