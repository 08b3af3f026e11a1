//! Per-detection features for mask detections, in two levels of cost.
//!
//! - **Geometry** ([`MaskFeatures::extract`], every detection, cheap): centroid and area from
//!   the mask's moments (thesis eq. 7–10) and the convex shell the region estimator intersects.
//! - **Appearance** ([`MaskFeatures::describe`], on demand): the contour resampled into a shape
//!   context descriptor (Alg. 4), SIFT keypoints and descriptors inside the mask on a bounded
//!   crop (Alg. 5), and a grid sample of the mask's pixels for the colour analyser (Alg. 6).
//!   The tracker asks for it only for detections in ambiguous groups of competing pairs, for
//!   re-identification, and to keep each track's reference appearance fresh (see
//!   [`crate::track::online`]); the result is shared (`Arc`) between the detection and the
//!   track it becomes the last appearance of, so nothing is computed twice.
//!
//! # The shell
//!
//! The thesis builds the shell from the Canny edge vertices of the mask plus its centroid: the
//! outer boundary of their Delaunay mesh, i.e. their convex hull (§3.3). Canny on a binary mask
//! only ever fires on its boundary, on the boundary pixels or the background pixels next to
//! them, so that hull is the hull of the mask's pixel squares up to about one pixel.
//! [`ShellMode::Hull`] (default) computes the latter exactly from each row's first and last
//! foreground pixel: one pass over the bitmap, no blur, ~100× cheaper than Canny on a 128×128
//! mask. [`ShellMode::Canny`] runs the thesis' path (`geometry::mask_geometry`) on the mask
//! reduced so that its longer side is at most `max_side` pixels (thesis §3.2.2 itself suggests
//! reducing the spatial resolution before edge detection) and scales the shell back up; the
//! reduction moves shell vertices by at most about one reduced pixel, i.e. `side / max_side`
//! pixels (measured in `tests::bounded_canny_shell_error`).

use std::sync::{Arc, OnceLock};

use serde::{Deserialize, Serialize};

use crate::features::color::{view_palette, ColorConfig, ColorSample, ViewPalette, ViewReach};
use crate::features::shape_context::{ShapeContextConfig, ShapeDescriptor};
use crate::features::sift::{RegionCrop, SiftConfig, SiftFeatures};
use crate::features::transform::CellIndex;
use crate::frame::{BBox, Detection, Frame, Mask, Point};
use crate::geometry::{mask_geometry, ConvexShell, GeometryConfig, MaskCrop, Moments};

/// Per-detection features, computed once per frame by a [`FeatureExtractor`] and kept on the
/// track as its last appearance when the detection is matched.
///
/// The cheap part (centroid, area, shell) is computed for every detection in the prepare
/// phase; the appearance only when the tracker needs it (module docs), and then shared with
/// the track. The pair-cost terms that read a part return "no data" while it is absent.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct Features {
    /// Centroid: mask moments (thesis eq. 10) when there is a mask, else the box centre.
    pub centroid: Point,
    /// Area: foreground pixels of the mask, else the box area (0 when the extractor did not
    /// say).
    pub area: f64,
    /// The mask's convex shell, for the region estimator (`None` for box detections).
    pub shell: Option<Arc<ConvexShell>>,
    /// Appearance, when it was computed this frame.
    pub appearance: Option<Arc<Appearance>>,
}

impl Features {
    /// Features holding a centroid only.
    pub fn with_centroid(centroid: Point) -> Self {
        Self {
            centroid,
            ..Self::default()
        }
    }
}

/// Computes a detection's [`Features`]: the cheap part once per detection per frame, the
/// appearance on demand.
pub trait FeatureExtractor: Send {
    /// The cheap features of `det` in `frame` (`None` in box mode, where there are no pixels).
    fn extract(&self, frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String>;

    /// The appearance of `det` in `frame` (tracker frame number `frame_number`), `None` when
    /// the extractor computes none (the default). Called only for detections the tracker
    /// needs appearance for. A failure is treated as "no appearance": the terms that would
    /// read it drop out for this detection.
    fn describe(
        &self,
        frame: &Frame<'_>,
        det: &Detection,
        frame_number: u32,
    ) -> Result<Option<Appearance>, String> {
        let _ = (frame, det, frame_number);
        Ok(None)
    }
}

/// The default extractor: the centroid only. Needs no image.
#[derive(Debug, Clone, Copy, Default)]
pub struct BoxFeatures;

impl FeatureExtractor for BoxFeatures {
    fn extract(&self, _frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String> {
        let mut f = Features::with_centroid(det.centroid());
        f.area = match &det.mask {
            Some(m) => m.area() as f64,
            None => det.bbox.area(),
        };
        Ok(f)
    }
}

/// How a mask's convex shell is computed (module docs).
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ShellMode {
    /// The exact convex hull of the mask's pixel squares (default).
    Hull,
    /// The thesis' Canny-edge shell on the mask reduced to at most `max_side` pixels.
    Canny {
        /// Longest side, in pixels, Canny runs on (≥ 8).
        max_side: u32,
    },
}

/// Which appearance parts to compute: only those the enabled cost terms read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Needs {
    /// Shape context descriptor of the contour.
    pub shape: bool,
    /// SIFT keypoints and descriptors.
    pub sift: bool,
    /// Colour sample.
    pub colour: bool,
}

impl Needs {
    /// Whether nothing is needed.
    pub fn is_empty(&self) -> bool {
        !(self.shape || self.sift || self.colour)
    }

    /// Both sets of needs.
    pub fn union(self, o: Needs) -> Needs {
        Needs {
            shape: self.shape || o.shape,
            sift: self.sift || o.sift,
            colour: self.colour || o.colour,
        }
    }
}

/// Settings of the mask features and of when the tracker computes appearance.
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify), tsify(missing_as_null))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceConfig {
    /// How shells are computed. Default [`ShellMode::Hull`].
    pub shell: ShellMode,
    /// SIFT settings. Default: OpenCV's, without the 2× upsampling and with crops reduced to
    /// `max_side` 64: ~0.3 ms per 100×100 shape instead of ~1 ms (fewer, larger-scale
    /// keypoints: about 10 per shape instead of 25, enough for ratio-test matching).
    pub sift: SiftConfig,
    /// Colour analyser settings. Default: K = 10 as the thesis, at most 150 grid samples per
    /// shape: on the synthetic scenes the scores do not change between 50 and 1500 samples
    /// (`cargo run --release --example ablation -- --all`), while k-means time grows with them.
    ///
    /// `per_view` is on: the main association's C2 compares each view's own palette, k-means
    /// run once per view ([`Appearance::palette`]) instead of once per compared pair. In a
    /// crowd a view is compared with several candidates, and the per-pair k-means was most of
    /// the 200-shape bench's time (issue 10); on the robustness grid's 13 mask cells, online
    /// and offline, every score is the same either way (`tests/data/quality/README.md`).
    /// Re-identification's containment measure ([`ColourMode::Contained`](super::ColourMode))
    /// keeps the joint palette: it compares a possibly partial view with a whole one, where
    /// the two palettes' centroids of one colour drift apart by more than the tolerance; with
    /// per-view palettes there the mask cells lost 1.8 HOTA.
    pub colour: ColorConfig,
    /// Shape context settings. Default: 32 contour vertices (the χ² assignment is cubic in it;
    /// 32 costs ~0.1 ms a pair, 64 ~0.3 ms).
    pub shape_context: ShapeContextConfig,
    /// Compute appearance only where it is needed (ambiguous groups, re-identification,
    /// reference refresh). `false` computes it for every mask detection (for comparisons).
    /// Default true.
    pub lazy: bool,
    /// A group of competing pairs is ambiguous (its detections get appearance) when geometry
    /// and motion alone rank two candidates of a track (or of a detection) within this much
    /// of each other.
    /// Default 0.2 (costs are in `[0, 1]`).
    pub ambiguity: f64,
    /// A track's reference appearance (used to re-identify it after a loss) is recomputed when
    /// it is older than this many frames and the shape is seen whole (it is also taken before a
    /// crossing, and whenever it is missing). Default 60 (2 s at 30 fps): each refresh runs
    /// SIFT, and on the grid's mask cells every value from 40 frames up scores the same while
    /// 10 and 20 score lower (`tests/data/quality/README.md`); the bound is kept for real
    /// footage, whose views drift more than the synthetic shapes' do.
    pub refresh: u32,
    /// A detection is "whole" when its area is at least this fraction of its track's reference
    /// area; smaller ones are taken as partly occluded. Default 0.85: a partial view must be
    /// caught early, before its shrinking box drags the motion filter; a whole view taken for
    /// partial (an eroded mask) costs little, its completion keeps its centre.
    pub whole_ratio: f64,
    /// A view whose box exceeds this multiple of its track's predicted box, and covers most
    /// of the predicted box of another identified track that nothing matched, is taken as
    /// merged with that neighbour by the detector (two touching shapes in one mask or box):
    /// it keeps the track alive, but, like a sliver, it does not move the motion filter or
    /// the reference appearance, whose place and look it misreports; when the two part, each
    /// track is still where its own shape is. `None`: every view is trusted. Default `None`.
    pub merged_ratio: Option<f64>,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        Self {
            shell: ShellMode::Hull,
            sift: SiftConfig {
                upsample: false,
                max_side: Some(64),
                ..SiftConfig::default()
            },
            colour: ColorConfig {
                max_samples: 150,
                per_view: true,
                ..ColorConfig::default()
            },
            shape_context: ShapeContextConfig {
                vertices: 32,
                ..ShapeContextConfig::default()
            },
            lazy: true,
            ambiguity: 0.2,
            refresh: 60,
            whole_ratio: 0.85,
            merged_ratio: None,
        }
    }
}

impl AppearanceConfig {
    /// Checks every field's range (`field` names the offending one).
    pub fn validate(&self) -> Result<(), (&'static str, f64, &'static str)> {
        if let ShellMode::Canny { max_side } = self.shell {
            if max_side < 8 {
                return Err(("appearance.shell.max_side", max_side as f64, "must be ≥ 8"));
            }
        }
        self.sift
            .validate()
            .map_err(|_| ("appearance.sift", f64::NAN, "invalid SIFT config"))?;
        self.colour
            .validate()
            .map_err(|_| ("appearance.colour", f64::NAN, "invalid colour config"))?;
        self.shape_context.validate().map_err(|_| {
            (
                "appearance.shape_context",
                f64::NAN,
                "invalid shape context config",
            )
        })?;
        let a = self.ambiguity;
        if !(a.is_finite() && a >= 0.0) {
            return Err(("appearance.ambiguity", a, "must be finite and ≥ 0"));
        }
        let r = self.whole_ratio;
        if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
            return Err(("appearance.whole_ratio", r, "must be in [0, 1]"));
        }
        if let Some(m) = self.merged_ratio {
            if !(m.is_finite() && m > 1.0) {
                return Err(("appearance.merged_ratio", m, "must be finite and > 1"));
            }
        }
        Ok(())
    }
}

/// A shape's appearance at one frame: what the appearance cost terms compare.
#[derive(Debug, Clone, PartialEq)]
pub struct Appearance {
    /// Tracker frame number (1-based) it was computed in.
    pub frame: u32,
    /// Shape context descriptor of the outer contour, resampled (Alg. 4).
    pub shape: Option<ShapeDescriptor>,
    /// SIFT keypoints and descriptors inside the mask, frame coordinates (Alg. 5), computed
    /// the first time they are read ([`Appearance::sift`]).
    pub sift: Option<LazySift>,
    /// Grid sample of the mask's pixels (Alg. 6).
    pub colour: Option<ColorSample>,
    /// The colour sample's own palette, computed on first read ([`Appearance::palette`]).
    palette: OnceLock<Option<ViewPalette>>,
    /// The colour sample's positions indexed, built on first read
    /// ([`Appearance::colour_index`]).
    colour_index: OnceLock<Option<CellIndex>>,
    /// The palette's colours with their shares and reaches, built on first read
    /// ([`Appearance::colour_reach`]).
    colour_reach: OnceLock<Option<ViewReach>>,
}

impl Appearance {
    /// The view's appearance from its parts.
    pub fn new(
        frame: u32,
        shape: Option<ShapeDescriptor>,
        sift: Option<LazySift>,
        colour: Option<ColorSample>,
    ) -> Self {
        Self {
            frame,
            shape,
            sift,
            colour,
            palette: OnceLock::new(),
            colour_index: OnceLock::new(),
            colour_reach: OnceLock::new(),
        }
    }

    /// The colour sample's positions indexed ([`ColorSample::index`]), built on the first
    /// read (the per-view colour cost looks up the track's samples under each candidate's);
    /// `None` without a colour sample.
    pub fn colour_index(&self) -> Option<&CellIndex> {
        self.colour_index
            .get_or_init(|| Some(self.colour.as_ref()?.index()))
            .as_ref()
    }

    /// The colour sample's own palette ([`ColorConfig::per_view`]), computed with `cfg` on
    /// the first read (every later read returns that one); `None` without a colour sample.
    pub fn palette(&self, cfg: &ColorConfig) -> Option<&ViewPalette> {
        self.palette
            .get_or_init(|| view_palette(self.colour.as_ref()?, cfg).ok())
            .as_ref()
    }

    /// The colour sample's [`ViewReach`] over its own palette ([`Appearance::palette`], with
    /// `cfg`), built on the first read: what the re-identification screen compares each
    /// candidate's colours with (`track::ColourCost`); `None` without a colour sample.
    pub fn colour_reach(&self, cfg: &ColorConfig) -> Option<&ViewReach> {
        self.colour_reach
            .get_or_init(|| ViewReach::new(self.colour.as_ref()?, self.palette(cfg)?).ok())
            .as_ref()
    }

    /// The view's SIFT features, computed now if this is their first read; `None` when SIFT
    /// was not asked for (or could not be computed: a term reading them then drops out).
    pub fn sift(&self) -> Option<&SiftFeatures> {
        self.sift.as_ref()?.get()
    }
}

/// A view's SIFT features, computed on first read. The tracker describes most matched
/// detections in a crowd (colour is read by the main association, and a view's appearance is
/// taken before a crossing), but SIFT is read only to re-identify a lost track: computed
/// eagerly, it was most of the describe cost in crowded scenes (issue 10's profile), and
/// almost none of it was ever read. The region of the frame it needs is kept instead (its
/// pixels and the mask, [`RegionCrop`]), so the features are exactly those computed at once.
#[derive(Debug, Clone, PartialEq)]
pub struct LazySift {
    /// The cut-out input (`None`: the region lay outside the frame, no features).
    crop: Option<RegionCrop>,
    /// Settings.
    config: SiftConfig,
    /// The features, once computed (`None` inside: the computation failed).
    features: OnceLock<Option<SiftFeatures>>,
}

impl LazySift {
    /// SIFT of `region` of `frame` with `mask`, to be computed when first read.
    pub fn new(frame: &Frame<'_>, region: &BBox, mask: Option<&Mask>, config: &SiftConfig) -> Self {
        Self {
            crop: RegionCrop::new(frame, region, mask),
            config: config.clone(),
            features: OnceLock::new(),
        }
    }

    /// The features (computed now on the first call); empty when the region lay outside the
    /// frame, `None` when the computation failed.
    pub fn get(&self) -> Option<&SiftFeatures> {
        self.features
            .get_or_init(|| match &self.crop {
                Some(c) => c.detect(&self.config).ok(),
                None => Some(SiftFeatures::default()),
            })
            .as_ref()
    }

    /// Whether the features have been computed.
    pub fn is_computed(&self) -> bool {
        self.features.get().is_some()
    }
}

/// The feature extractor for mask detections (module docs). Box-only detections get the box
/// centre and area and no shell or appearance, exactly like [`BoxFeatures`].
#[derive(Debug, Clone, Default)]
pub struct MaskFeatures {
    /// Settings.
    pub config: AppearanceConfig,
    /// Which appearance parts [`MaskFeatures::describe`] computes.
    pub needs: Needs,
}

impl MaskFeatures {
    /// An extractor computing the appearance parts in `needs`.
    pub fn new(config: AppearanceConfig, needs: Needs) -> Self {
        Self { config, needs }
    }
}

impl FeatureExtractor for MaskFeatures {
    fn extract(&self, _frame: Option<&Frame<'_>>, det: &Detection) -> Result<Features, String> {
        let Some(mask) = det.mask.as_ref() else {
            let mut f = Features::with_centroid(det.bbox.center());
            f.area = det.bbox.area();
            return Ok(f);
        };
        let m = Moments::of_mask(mask).ok_or_else(|| "mask is empty".to_string())?;
        let shell = match self.config.shell {
            ShellMode::Hull => pixel_hull(mask),
            ShellMode::Canny { max_side } => canny_shell(mask, max_side)?,
        };
        let mut f = Features::with_centroid(m.centroid);
        f.area = m.m00;
        f.shell = Some(Arc::new(shell));
        Ok(f)
    }

    fn describe(
        &self,
        frame: &Frame<'_>,
        det: &Detection,
        frame_number: u32,
    ) -> Result<Option<Appearance>, String> {
        let Some(mask) = det.mask.as_ref() else {
            return Ok(None);
        };
        if self.needs.is_empty() {
            return Ok(None);
        }
        Ok(Some(describe_mask(
            frame,
            mask,
            &det.bbox,
            frame_number,
            &self.config,
            self.needs,
        )?))
    }
}

/// Computes the appearance parts in `needs` of the shape `mask` (box `bbox`) in `frame`.
/// Parts that cannot be computed (a contour too small for a descriptor, a mask outside the
/// frame) are left `None`, so the terms reading them drop out; only invalid settings are
/// errors.
pub fn describe_mask(
    frame: &Frame<'_>,
    mask: &Mask,
    bbox: &BBox,
    frame_number: u32,
    cfg: &AppearanceConfig,
    needs: Needs,
) -> Result<Appearance, String> {
    let shape = if needs.shape {
        contour_descriptor(mask, &cfg.shape_context)
    } else {
        None
    };
    let sift = if needs.sift {
        // Pad the crop so keypoints near the outline see some context; keypoints outside the
        // mask are dropped by the detection.
        let region = bbox.expanded(4.0);
        Some(LazySift::new(frame, &region, Some(mask), &cfg.sift))
    } else {
        None
    };
    let colour = if needs.colour {
        let s = ColorSample::from_mask(frame, mask, cfg.colour.max_samples);
        (!s.is_empty()).then_some(s)
    } else {
        None
    };
    Ok(Appearance::new(frame_number, shape, sift, colour))
}

/// The shape context descriptor of the mask's largest outer contour, `None` when the contour is
/// too small or degenerate to describe.
pub fn contour_descriptor(mask: &Mask, cfg: &ShapeContextConfig) -> Option<ShapeDescriptor> {
    let crop = MaskCrop::new(mask, 1).ok()?;
    let contour = crop.outer_contours().into_iter().next()?;
    ShapeDescriptor::from_contour(&contour, cfg).ok()
}

/// The convex hull of the mask's pixel squares ([`crate::geometry::shell::pixel_hull`]). Empty for an empty
/// mask.
pub fn pixel_hull(mask: &Mask) -> ConvexShell {
    crate::geometry::shell::pixel_hull(mask)
}

/// The thesis' Canny shell on the mask reduced to at most `max_side` pixels (module docs).
pub fn canny_shell(mask: &Mask, max_side: u32) -> Result<ConvexShell, String> {
    let tight = mask.tight();
    let side = tight.width().max(tight.height());
    let factor = side.div_ceil(max_side.max(1)).max(1);
    let cfg = GeometryConfig::default();
    if factor == 1 {
        return mask_geometry(&tight, &cfg)
            .map(|g| g.shell)
            .map_err(|e| e.to_string());
    }
    let small = reduce(&tight, factor);
    let g = mask_geometry(&small, &cfg).map_err(|e| e.to_string())?;
    // Reduced pixel i covers full pixels [i·f, (i+1)·f): a reduced coordinate u maps to
    // origin + u·f.
    let f = factor as f64;
    let (ox, oy) = (tight.x() as f64, tight.y() as f64);
    let pts: Vec<Point> = g
        .shell
        .vertices()
        .iter()
        .map(|p| Point::new(ox + p.x * f, oy + p.y * f))
        .collect();
    ConvexShell::from_points(&pts).map_err(|e| e.to_string())
}

/// Box-reduces a mask by an integer factor: a reduced pixel is foreground when at least half
/// of its block is (any pixel at all, for blocks of a thin part that would vanish otherwise).
/// The result is positioned at the origin, in reduced pixel units.
fn reduce(mask: &Mask, factor: u32) -> Mask {
    let (w, h) = (mask.width(), mask.height());
    let (sw, sh) = (w.div_ceil(factor), h.div_ceil(factor));
    let mut counts = vec![0u32; (sw * sh) as usize];
    let data = mask.data();
    for y in 0..h {
        for x in 0..w {
            if data[(y * w + x) as usize] != 0 {
                counts[((y / factor) * sw + x / factor) as usize] += 1;
            }
        }
    }
    let half = (factor * factor).div_ceil(2);
    let mut bits: Vec<u8> = counts.iter().map(|&c| u8::from(c >= half)).collect();
    if bits.iter().all(|&b| b == 0) {
        bits = counts.iter().map(|&c| u8::from(c > 0)).collect();
    }
    Mask::new(0, 0, sw, sh, bits).unwrap_or_else(|_| Mask::empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ellipse(cx: f64, cy: f64, a: f64, b: f64, angle: f64) -> Mask {
        let n = (2.0 * a.max(b)).ceil() as i32 + 4;
        let (s, c) = angle.sin_cos();
        let mut bits = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let (dx, dy) = (
                    x as f64 + 0.5 - n as f64 / 2.0,
                    y as f64 + 0.5 - n as f64 / 2.0,
                );
                let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
                bits.push(u8::from((u / a).powi(2) + (v / b).powi(2) <= 1.0));
            }
        }
        Mask::new(
            (cx - n as f64 / 2.0) as i32,
            (cy - n as f64 / 2.0) as i32,
            n as u32,
            n as u32,
            bits,
        )
        .unwrap()
        .tight()
    }

    /// Largest distance from a vertex of `a` to the shell `b` (one side of the Hausdorff
    /// distance between the polygons' vertex sets and areas).
    fn directed(a: &ConvexShell, b: &ConvexShell) -> f64 {
        a.vertices()
            .iter()
            .map(|p| {
                let d = ConvexShell::from_points(&[*p]).unwrap();
                d.distance(b)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn pixel_hull_contains_every_pixel_and_nothing_far() {
        for (a, b, t) in [(20.0, 9.0, 0.3), (3.0, 3.0, 0.0), (40.0, 12.0, 1.1)] {
            let m = ellipse(100.0, 80.0, a, b, t);
            let s = pixel_hull(&m);
            for (x, y) in m.pixels() {
                for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                    assert!(s.contains(Point::new(x as f64 + dx, y as f64 + dy)));
                }
            }
            // The hull of the pixel squares is never larger than the mask's box.
            let bb = m.bbox();
            let ab = s.aabb();
            assert!((ab.x - bb.x).abs() < 1e-9 && (ab.w - bb.w).abs() < 1e-9);
        }
        assert!(pixel_hull(&Mask::empty()).is_empty());
    }

    /// The reduced-resolution Canny shell stays within about one reduced pixel of the
    /// full-resolution one, and the pixel hull within about one pixel of both.
    #[test]
    fn bounded_canny_shell_error() {
        let full_cfg = GeometryConfig::default();
        for (a, b, t) in [(60.0, 25.0, 0.4), (45.0, 45.0, 0.0), (70.0, 30.0, 2.0)] {
            let m = ellipse(300.0, 200.0, a, b, t);
            let full = mask_geometry(&m, &full_cfg).unwrap().shell;
            let hull = pixel_hull(&m);
            let e_hull = directed(&hull, &full).max(directed(&full, &hull));
            assert!(e_hull <= 1.5, "pixel hull vs Canny: {e_hull}");
            for max_side in [32u32, 48, 64] {
                let side = m.width().max(m.height());
                let f = side.div_ceil(max_side) as f64;
                let s = canny_shell(&m, max_side).unwrap();
                let e = directed(&s, &full).max(directed(&full, &s));
                assert!(
                    e <= 1.5 * f + 1.0,
                    "max_side {max_side}: error {e} (factor {f})"
                );
            }
        }
    }

    #[test]
    fn extract_and_describe_masks_and_boxes() {
        let (w, h) = (200u32, 150u32);
        let img: Vec<u8> = (0..w * h * 3).map(|i| ((i * 7919) % 251) as u8).collect();
        let frame = Frame::rgb(&img, w, h).unwrap();
        let m = ellipse(100.0, 70.0, 30.0, 18.0, 0.2);
        let det = Detection::from_mask(m.clone(), 1.0);
        let all = Needs {
            shape: true,
            sift: true,
            colour: true,
        };
        let fx = MaskFeatures::new(AppearanceConfig::default(), all);
        let f = fx.extract(Some(&frame), &det).unwrap();
        assert_eq!(f.area, m.area() as f64);
        assert!(f.shell.as_ref().unwrap().contains(f.centroid));
        let a = fx.describe(&frame, &det, 7).unwrap().unwrap();
        assert_eq!(a.frame, 7);
        assert_eq!(a.shape.as_ref().unwrap().len(), 32);
        assert!(a.colour.as_ref().unwrap().len() <= 150);
        // The palette is computed on first read, once.
        let cfg = AppearanceConfig::default().colour;
        let p = a.palette(&cfg).unwrap();
        assert_eq!(p.labels.len(), a.colour.as_ref().unwrap().len());
        assert!(std::ptr::eq(p, a.palette(&cfg).unwrap()));
        // SIFT waits for its first read, and then equals the eager computation (on a frame
        // with blobs to find).
        let blobs: Vec<u8> = (0..w * h)
            .flat_map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let v = 128.0 + 100.0 * (x / 4.0).sin() * (y / 5.0).cos();
                [v as u8, (v * 0.8) as u8, 255 - v as u8]
            })
            .collect();
        let frame = Frame::rgb(&blobs, w, h).unwrap();
        let a = fx.describe(&frame, &det, 7).unwrap().unwrap();
        let lazy = a.sift.as_ref().unwrap();
        assert!(!lazy.is_computed());
        let eager = crate::features::sift::detect_in_region(
            &frame,
            &det.bbox.expanded(4.0),
            Some(&m),
            &AppearanceConfig::default().sift,
        )
        .unwrap();
        assert!(!eager.is_empty());
        assert_eq!(a.sift(), Some(&eager));
        assert!(lazy.is_computed());
        // Box detections: centre, area, nothing else.
        let b = Detection::from_box(BBox::new(10.0, 10.0, 20.0, 10.0), 1.0);
        let fb = fx.extract(Some(&frame), &b).unwrap();
        assert_eq!((fb.centroid, fb.area), (Point::new(20.0, 15.0), 200.0));
        assert!(fb.shell.is_none());
        assert!(fx.describe(&frame, &b, 1).unwrap().is_none());
        // A mask entirely outside the frame: no colour, no keypoints, no error.
        let out = Detection::from_mask(m.translated(1000, 1000), 1.0);
        let a = fx.describe(&frame, &out, 1).unwrap().unwrap();
        assert!(a.colour.is_none());
        assert!(a.sift().unwrap().is_empty());
        // An empty mask is an error of `extract`.
        let empty = Detection {
            mask: Some(Mask::empty()),
            ..Detection::from_box(BBox::new(0.0, 0.0, 1.0, 1.0), 1.0)
        };
        assert!(fx.extract(Some(&frame), &empty).is_err());
    }
}
