//! Options of the one TAA ([`super::TaaPass`]): the `taa` method's, and those
//! of the TAA `hash-cache`, `hybrid` and `--taa-output` run on their output.

use serde::Serialize;
use std::str::FromStr;

/// How the history and the new frame are blended: result = lerp(history,
/// current, α).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum TaaWeights {
    /// Exponential moving average with a fixed α (Yang et al. 2020, §3).
    Fixed,
    /// Per-pixel accumulated-sample-count weights: α = max(1/(n+1), α_min)
    /// with n the frames in the pixel's history, which restarts at 1 (the
    /// current frame alone) when the history is rejected. A fresh history
    /// is a running mean until it averages 1/α_min frames, then an EMA with
    /// α_min. (1/(n+1) is Eq. 4's β′ = 1 − σ_Y²/(Bias² + σ_X² + σ_Y²) for an
    /// unbiased history X of n frames, σ_X² = σ_Y²/n; α_min stands in for
    /// the bias.) The default; called `pfj23` until session 47.
    Count,
    /// Philippi et al. 2023 ([PFJ23], the paper's TAA weights, §4): α = β′
    /// of Eq. 4 per channel with the moments of X (the history) and Y (the
    /// current frame) estimated from 3×3 neighbourhoods — the previous
    /// output's around the history position, the current frame's around the
    /// pixel. PFJ23's abstract: "a new blending strategy that leverages
    /// variance to compute per pixel blending weights for both temporal and
    /// stereoscopic rendering"; the paper (§3.6) describes its stereo
    /// estimate as "based on neighborhood sampling", and its text is not
    /// available to this project, so the temporal estimate is the stereo
    /// one applied to (history, current): our reading, not the default
    /// (see `TaaSettings::default`). `--taa-alpha` does not enter.
    Pfj23,
}

impl FromStr for TaaWeights {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "fixed" => Ok(TaaWeights::Fixed),
            "count" => Ok(TaaWeights::Count),
            "pfj23" => Ok(TaaWeights::Pfj23),
            other => Err(format!(
                "bad --taa-weights '{other}': expected fixed, count or pfj23"
            )),
        }
    }
}

/// How the history is resampled at the reprojected position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TaaHistory {
    /// Catmull-Rom over the 4×4 texels around it (Karis 2014, "High-Quality
    /// Temporal Supersampling"; Yang et al. 2020, §4.1) where all sixteen
    /// are consistent with the pixel, else bilinear: the default since
    /// session 49.
    CatmullRom,
    /// Bilinear over the consistent texels of the 2×2, renormalised (the
    /// only fetch until session 49). Repeated bilinear resampling blurs a
    /// moving image: for a view panning 0.5 px a frame at α = 0.1 the
    /// steady-state contrast of a sinusoid of 0.2 cycles per pixel is 0.37
    /// of the input, against 0.68 with Catmull-Rom (R = α/(1 − (1 − α)H(f))).
    Bilinear,
}

impl FromStr for TaaHistory {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "catmull-rom" => Ok(TaaHistory::CatmullRom),
            "bilinear" => Ok(TaaHistory::Bilinear),
            other => Err(format!(
                "bad --taa-history '{other}': expected catmull-rom or bilinear"
            )),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TaaSettings {
    /// Blend factor of the new frame (fixed weights) or its lower bound α_min
    /// (count weights); pfj23 does not use it.
    pub alpha: f32,
    pub weights: TaaWeights,
    /// Half-width of the YCoCg clipping box in standard deviations of the 3×3
    /// neighbourhood (Salvi's variance clipping; 1 = the survey's γ ≈ 1).
    pub gamma: f32,
    /// How the history is resampled (`--taa-history`).
    pub history: TaaHistory,
    /// Clip the history at all (off only for ablations and tests; note that
    /// a flat neighbourhood has σ = 0, so no finite γ turns clipping off).
    pub clip: bool,
    /// Reject the history on disocclusion (off only for ablations and tests).
    pub reject_disocclusions: bool,
    /// Reproject points on moving instances with their object motion
    /// (previous → current instance transform; only where the scene
    /// animates). Off only for ablations and tests: camera-only reprojection.
    #[serde(skip)]
    pub motion_vectors: bool,
}

impl Default for TaaSettings {
    fn default() -> Self {
        TaaSettings {
            alpha: 0.1,
            // The paper's TAA is Yang et al. 2020 "using temporal weights as
            // derived by Philippi et al. [PFJ23]" (§4). The default is the
            // count weights, not our reading of PFJ23's (TaaWeights::Pfj23):
            // on 1 spp path-traced input that neighbourhood estimate lets the
            // Halton jitter's edge states through (docs/ARCHITECTURE.md
            // `taa`), and a baseline is not to be weakened by a reading of a
            // text we do not have.
            weights: TaaWeights::Count,
            gamma: 1.0,
            history: TaaHistory::CatmullRom,
            clip: true,
            reject_disocclusions: true,
            motion_vectors: true,
        }
    }
}

impl TaaSettings {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(format!(
                "bad --taa-alpha {}: expected a number in (0, 1]",
                self.alpha
            ));
        }
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return Err(format!(
                "bad --taa-gamma {}: expected a positive number",
                self.gamma
            ));
        }
        Ok(())
    }
}

/// Element `i` (1-based) of the Halton sequence in base `b`, in [0, 1).
pub fn halton(mut i: u32, b: u32) -> f32 {
    let (mut f, mut r) = (1.0f64, 0.0f64);
    while i > 0 {
        f /= b as f64;
        r += f * (i % b) as f64;
        i /= b;
    }
    r as f32
}

/// The sub-pixel position of frame `index`: Halton(2, 3), period 16
/// (Yang et al. 2020, §3.1), skipping element 0 = (0, 0), shifted so that
/// the 16 positions are centred on the pixel centre (0.5, 0.5). Elements
/// 1–16 alone average (0.4707, 0.4630): until session 55 TAA's converged
/// image sat (−0.03, −0.04) px off the references' and the other methods'
/// uniformly jittered pixels, an edge error no other method paid (found by
/// an audit). The shifted positions stay within [0.06, 0.97].
pub fn halton_jitter(index: u32) -> [f32; 2] {
    let centre = |b: u32| 0.5 - (1..=16).map(|i| halton(i, b) as f64).sum::<f64>() / 16.0;
    let i = index % 16 + 1;
    [
        (halton(i, 2) as f64 + centre(2)) as f32,
        (halton(i, 3) as f64 + centre(3)) as f32,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halton_known_values() {
        assert_eq!(halton(1, 2), 0.5);
        assert_eq!(halton(2, 2), 0.25);
        assert_eq!(halton(3, 2), 0.75);
        assert!((halton(1, 3) - 1.0 / 3.0).abs() < 1e-7);
        assert!((halton(2, 3) - 2.0 / 3.0).abs() < 1e-7);
        assert!((halton(4, 3) - 4.0 / 9.0).abs() < 1e-7);
        // The 16 jitters are distinct, inside the pixel, and centred on it
        // (the raw elements 1–16 average 0.4707 and 0.4630; in base 2
        // exactly (7.5 + 1/32)/16); f32 rounding of 16 values.
        let js: Vec<[f32; 2]> = (0..16).map(halton_jitter).collect();
        let mean = js.iter().fold([0.0f64; 2], |a, j| {
            [a[0] + j[0] as f64 / 16.0, a[1] + j[1] as f64 / 16.0]
        });
        assert!(
            (mean[0] - 0.5).abs() < 1e-6 && (mean[1] - 0.5).abs() < 1e-6,
            "{mean:?}"
        );
        let raw = (1..=16).map(|i| halton(i, 2) as f64).sum::<f64>() / 16.0;
        assert!((raw - (7.5 + 1.0 / 32.0) / 16.0).abs() < 1e-9);
        assert!(js
            .iter()
            .all(|j| j.iter().all(|v| (0.05..0.98).contains(v))));
        for a in 0..16 {
            for b in 0..a {
                assert_ne!(js[a], js[b]);
            }
        }
    }

    #[test]
    fn parse_weights() {
        assert_eq!("pfj23".parse::<TaaWeights>().unwrap(), TaaWeights::Pfj23);
        assert_eq!("count".parse::<TaaWeights>().unwrap(), TaaWeights::Count);
        assert_eq!("fixed".parse::<TaaWeights>().unwrap(), TaaWeights::Fixed);
        assert!("nope".parse::<TaaWeights>().is_err());
    }
}
