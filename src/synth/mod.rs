//! Deterministic synthetic scenes with exact ground truth and noisy detections.
//!
//! A [`Scene`] renders textured shapes (discs, ellipses, rectangles, triangles, stars, Ls,
//! irregular polygons) moving over a static textured background, behind static occluding bars,
//! and reports per frame the RGB image, the ground-truth instance masks of the **visible** pixels,
//! and the detections a noisy detector would give ([`NoiseConfig`]).
//!
//! # Determinism
//! Everything is a function of [`SynthConfig`] (including its `seed`): the same config gives
//! byte-identical images, ground truth and detections on every run and every target, native or
//! wasm32. Randomness comes from `rand_xoshiro` streams, one per purpose (layout, objects,
//! per-frame detection noise, sensor noise), so the detection noise settings never change the
//! images. Only IEEE-exact float operations are used; sines and cosines come from
//! `math::sin_cos`, not the platform's libm. No hash maps.
//!
//! # Geometry and drawing
//! Each object is a polygon in object space, rotated by `angle`, scaled by `scale` and placed at
//! its centre. A pixel belongs to an object when its centre is inside the transformed polygon
//! (even–odd rule, half-open edges). Objects are drawn from far to near (ascending `z`, then id),
//! so nearer objects hide farther ones; occluders are in front of every object. Ground-truth
//! masks are the pixels each object finally owns; `visibility` is that count over the object's
//! full silhouette (unclipped by the frame border and unoccluded). An object with no visible
//! pixel has no ground truth in that frame. Textures live in object space, so they rotate and
//! scale with the object; there is no anti-aliasing, so every ground-truth pixel has exactly a
//! palette colour of its object (before illumination drift or sensor noise, when enabled).
//!
//! # Motion
//! Random objects move with a velocity whose speed stays within `speed`, change it by a random
//! acceleration redrawn every `accel_period` frames, rotate at a constant rate and breathe in
//! scale within `scale_range`. At the frame border they follow [`BorderPolicy`]: bounce off it,
//! wrap around (same id), or leave and be replaced by a fresh object (new id) entering through
//! a border. Scripted objects ([`ScriptedShape`]) move at constant velocity and angular velocity
//! from a given start, so tests can compute their trajectory exactly; they follow the border
//! policy too but are never replaced.
//!
//! Frame `t` (1-based) shows the state after `t − 1` motion steps; a scripted object's centre in
//! frame `t` is `center + (t − 1)·velocity`.

mod background;
pub(crate) mod math;
pub(crate) mod noise;
// The follower fills warped outlines with the same scanline rule.
pub(crate) mod raster;
mod shape;

pub use shape::ShapeKind;

use crate::frame::{BBox, Detection, Frame, FrameError, Mask, Point};
use crate::io::{Record, RecordFlags, Rle};
use math::{below, sin_cos, stream, uniform};
use rand::Rng;
use raster::Rasterizer;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors building a [`Scene`] from a [`SynthConfig`].
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SynthError {
    /// The frame size is outside `16..=8192` on a side.
    #[error("frame size {width}x{height} is outside 16..=8192 per side")]
    InvalidSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// A numeric setting is outside its allowed range (or not finite).
    #[error("{field} = {value} is outside [{min}, {max}]")]
    OutOfRange {
        /// The setting, as its path in the config.
        field: &'static str,
        /// The value given.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// A `(low, high)` setting has `low > high`.
    #[error("{field} = ({lo}, {hi}) is an empty range")]
    EmptyRange {
        /// The setting.
        field: &'static str,
        /// Low end given.
        lo: f64,
        /// High end given.
        hi: f64,
    },
    /// The objects' textures would need more memory than the scene allows.
    #[error("textures of {shapes} shapes up to radius {radius} need {bytes} bytes, at most {max}")]
    TooLarge {
        /// Objects alive at once (random plus scripted).
        shapes: u64,
        /// Largest object radius (times aspect for scripted shapes).
        radius: f64,
        /// Estimated texture bytes.
        bytes: u64,
        /// The limit.
        max: u64,
    },
    /// More objects than a frame's id buffer can hold.
    #[error("{shapes} shapes requested, at most {max} are supported")]
    TooManyShapes {
        /// Objects requested (random plus scripted).
        shapes: u64,
        /// The limit.
        max: u64,
    },
}

/// Scenario families that stress a shape tracker, one stress each (see
/// [`SynthConfig::family`] for their settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Family {
    /// Four streams of shapes (right, down, left, up) crossing one another, entering and
    /// leaving: 10 shapes of radius 16–30 at 2.5–4.5 px/frame.
    Crossing,
    /// A dense crowd of look-alikes: 30 ellipses of radius 13–17 in colours of one hue band,
    /// bouncing at 1–3 px/frame, touching and overlapping often.
    Crowd,
    /// Non-rigid shapes: 8 discs, ellipses, irregular polygons and stars whose area pulsates
    /// by up to ±50 % (periods 30–90 frames) and whose outlines ripple (orders 2–4, up to 12 %
    /// of the radius), bouncing at 1.5–3.5 px/frame; no occluders.
    Deform,
    /// Occluders: 8 shapes crossing horizontally at 3–5 px/frame behind two full-height bars
    /// (sized for ~15-frame hides) and two free-standing rectangles.
    Occluders,
    /// Births and deaths: 10 fast shapes (3.5–6.5 px/frame) leaving through every border and
    /// replaced by new ones entering.
    EnterLeave,
    /// A moving camera: the view pans (up to 3 px/frame) and zooms (0.8–1.25×, period 150
    /// frames) over a world 1.6× the frame holding 10 shapes and a bar.
    Camera,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 6] = [
        Family::Crossing,
        Family::Crowd,
        Family::Deform,
        Family::Occluders,
        Family::EnterLeave,
        Family::Camera,
    ];

    /// The family's name (`crossing`, `crowd`, `deform`, `occluders`, `enter-leave`, `camera`).
    pub fn name(self) -> &'static str {
        match self {
            Family::Crossing => "crossing",
            Family::Crowd => "crowd",
            Family::Deform => "deform",
            Family::Occluders => "occluders",
            Family::EnterLeave => "enter-leave",
            Family::Camera => "camera",
        }
    }
}

impl std::str::FromStr for Family {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Family::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Family::ALL.iter().map(|f| f.name()).collect();
                format!("unknown scene family {s:?} (known: {})", names.join(", "))
            })
    }
}

/// What happens when an object reaches the frame border.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BorderPolicy {
    /// Reflect the velocity when the object's bounding circle touches the border: objects stay
    /// fully inside the frame and keep their id for the whole sequence.
    Bounce,
    /// Objects leave through the border; once fully outside they are removed and (random ones)
    /// replaced by a new object, with a new id, entering through a random border. Ids are never
    /// reused.
    Exit,
    /// Objects leaving through one side come back through the opposite one, keeping their id
    /// (they have no ground truth while fully outside).
    Wrap,
}

/// How random objects look and move. Sizes are in pixels, rates per frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotionConfig {
    /// Range of the outline radius (half the largest extent) at scale 1. Default `(14, 40)`.
    pub radius: (f64, f64),
    /// Range of the speed, pixels per frame. Default `(1.5, 5.0)`.
    pub speed: (f64, f64),
    /// Largest acceleration magnitude, pixels per frame². Default `0.12`.
    pub accel: f64,
    /// Frames between two acceleration changes, drawn in this range. Default `(20, 60)`.
    pub accel_period: (u32, u32),
    /// Largest angular speed, radians per frame. Default `0.04`.
    pub max_rotation: f64,
    /// Largest relative scale change per frame. Default `0.003`.
    pub max_scale_rate: f64,
    /// Scale limits (must contain 1; objects start at scale 1). Default `(0.8, 1.25)`.
    pub scale_range: (f64, f64),
    /// When set, initial and entering directions lie within this many radians of horizontal
    /// (left or right), which makes objects cross vertical occluders. Default `None` (any).
    pub direction_spread: Option<f64>,
    /// Border behaviour. Default [`BorderPolicy::Exit`].
    pub border: BorderPolicy,
    /// Outline families random objects are drawn from; `None`: every [`ShapeKind`].
    #[serde(default)]
    pub kinds: Option<Vec<ShapeKind>>,
    /// Headings (radians, 0 = rightwards, π/2 = downwards) random objects start and enter
    /// with, each within `direction_spread` (default 0.2) of one of these: streams that cross.
    /// `None`: any direction (or `direction_spread` around horizontal).
    #[serde(default)]
    pub headings: Option<Vec<f64>>,
    /// Non-rigid deformation of random objects; `None`: rigid shapes.
    #[serde(default)]
    pub deform: Option<DeformConfig>,
}

/// Non-rigid deformation: each random object's area pulsates and its outline ripples, both
/// smoothly and with its own seeded rates (drawn from a stream of their own, so turning
/// deformation on changes nothing else in the scene). The texture follows the pulsation; the
/// ripples move the outline over it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DeformConfig {
    /// The area varies as `1 + a·sin(2πt/T + φ)` with `a` drawn in
    /// `[area_amplitude/2, area_amplitude]` per object: 0.5 is ±50 % (largest area 3× the
    /// smallest).
    pub area_amplitude: f64,
    /// Radial ripples of orders 2, 3 and 4, each of amplitude up to this fraction of the
    /// radius, every one with its own period and phase.
    pub outline_amplitude: f64,
    /// Range of the periods (frames) of the pulsation and the ripples.
    pub period: (f64, f64),
}

/// A camera moving over a world larger than the frame: the background, the occluders and the
/// objects live in world coordinates; each frame is the view through a camera that pans and
/// zooms smoothly (its motion drawn from a stream of its own). Ground truth and detections are
/// in image coordinates; objects enter and leave the view as it pans.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraConfig {
    /// The world is this many times the frame on each side (≥ 1).
    pub world_scale: f64,
    /// Largest pan speed, world pixels per frame.
    pub pan_speed: f64,
    /// Zoom range (image pixels per world pixel), e.g. `(0.8, 1.25)`; must contain values
    /// for which the view fits in the world.
    pub zoom_range: (f64, f64),
    /// Period (frames) of the zoom's oscillation through its range.
    pub zoom_period: f64,
}

impl Default for MotionConfig {
    fn default() -> Self {
        Self {
            radius: (14.0, 40.0),
            speed: (1.5, 5.0),
            accel: 0.12,
            accel_period: (20, 60),
            max_rotation: 0.04,
            max_scale_rate: 0.003,
            scale_range: (0.8, 1.25),
            direction_spread: None,
            border: BorderPolicy::Exit,
            kinds: None,
            headings: None,
            deform: None,
        }
    }
}

/// An axis-aligned occluder in whole pixels (drawn in front of every object).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct OccluderRect {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
}

impl OccluderRect {
    /// The rectangle as a box.
    pub fn bbox(&self) -> BBox {
        BBox::new(self.x as f64, self.y as f64, self.w as f64, self.h as f64)
    }
}

/// Static occluders: vertical bars plus explicit rectangles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OcclusionConfig {
    /// Number of full-height vertical bars, spread evenly with a seeded jitter. Default `1`.
    pub bars: u32,
    /// Bar width in pixels; `None` sizes bars so that an object of mean radius at mean speed,
    /// crossing horizontally, is fully hidden for about `hidden_frames` frames:
    /// `2·mean radius + hidden_frames·mean speed`. Default `None`.
    pub bar_width: Option<u32>,
    /// Target full-occlusion length used when `bar_width` is `None`. Default `10`.
    pub hidden_frames: f64,
    /// Extra occluders at fixed places. Default none.
    pub rects: Vec<OccluderRect>,
}

impl Default for OcclusionConfig {
    fn default() -> Self {
        Self {
            bars: 1,
            bar_width: None,
            hidden_frames: 10.0,
            rects: Vec::new(),
        }
    }
}

/// Whole-image effects, and how far object colours keep from the background's grey level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AppearanceConfig {
    /// Amplitude of a slow global gain `1 + a·sin(2π(t−1)/period)`. Default `0` (off).
    pub illumination_drift: f64,
    /// Period of the illumination drift, in frames. Default `250`.
    pub illumination_period: f64,
    /// Uniform per-channel sensor noise amplitude, grey levels. Default `0` (off).
    pub sensor_noise: u8,
    /// Least luma difference between any object colour and the background's nominal grey.
    /// Default `50`.
    pub min_contrast: f64,
    /// All objects' colours lie within this hue distance (on the 0–6 hue circle) of one
    /// scene-wide hue, with 2–3 colours each: look-alike objects. `None`: any colours.
    #[serde(default)]
    pub similar_colours: Option<f64>,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        Self {
            illumination_drift: 0.0,
            illumination_period: 250.0,
            sensor_noise: 0,
            min_contrast: 50.0,
            similar_colours: None,
        }
    }
}

/// The detection noise model (see the `noise` module docs for the exact process).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseConfig {
    /// Probability that a visible object is not detected. Default `0.05`.
    pub miss_rate: f64,
    /// Mean number of false-positive blobs per frame (at most 16). Default `0.2`.
    pub false_positives: f64,
    /// Probability that a detected mask is eroded or dilated. Default `0.3`.
    pub morph_prob: f64,
    /// Largest erosion/dilation radius in pixels (1..=this, uniformly). Default `2`.
    pub morph_max: u32,
    /// Probability that a detected mask is split in two. Default `0.02`.
    pub split_prob: f64,
    /// Standard deviation of the box-only variant's jitter, relative to box size. Default `0.03`.
    pub box_jitter: f64,
    /// Objects (and split parts, false positives) with fewer visible pixels are never
    /// detected. Default `16`.
    pub min_area: u64,
}

impl Default for NoiseConfig {
    fn default() -> Self {
        Self {
            miss_rate: 0.05,
            false_positives: 0.2,
            morph_prob: 0.3,
            morph_max: 2,
            split_prob: 0.02,
            box_jitter: 0.03,
            min_area: 16,
        }
    }
}

impl NoiseConfig {
    /// A detector that sees every object exactly: no misses, no false positives, exact masks.
    pub fn perfect() -> Self {
        Self {
            miss_rate: 0.0,
            false_positives: 0.0,
            morph_prob: 0.0,
            morph_max: 0,
            split_prob: 0.0,
            box_jitter: 0.0,
            min_area: 1,
        }
    }
}

/// An object with a fully specified, constant-velocity trajectory (for tests that need to know
/// exactly where an object is).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScriptedShape {
    /// Outline family.
    pub kind: ShapeKind,
    /// Outline radius (for rectangles, the half-width).
    pub radius: f64,
    /// Minor/major ratio for ellipses and rectangles (rectangle half-height = `radius·aspect`).
    pub aspect: f64,
    /// Centre in frame 1.
    pub center: Point,
    /// Displacement per frame.
    pub velocity: Point,
    /// Rotation in frame 1, radians.
    pub angle: f64,
    /// Rotation per frame, radians.
    pub angular_velocity: f64,
    /// Depth order: higher is nearer (random objects have `z` in `[0, 1)`).
    pub z: f64,
}

impl ScriptedShape {
    /// An axis-aligned, non-rotating rectangle of half-sizes `half_w × half_h` centred on
    /// `center` in frame 1, moving by `velocity` per frame, drawn in front of random objects.
    pub fn rectangle(center: Point, half_w: f64, half_h: f64, velocity: Point) -> Self {
        Self {
            kind: ShapeKind::Rectangle,
            radius: half_w,
            aspect: if half_w > 0.0 { half_h / half_w } else { 1.0 },
            center,
            velocity,
            angle: 0.0,
            angular_velocity: 0.0,
            z: 1.0,
        }
    }
}

/// The named scenes (the CLI's `synth --preset`, the browser's `new SynthScene(name)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(target_arch = "wasm32", derive(tsify::Tsify))]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ScenePreset {
    /// [`SynthConfig::default`]: 640×480, 300 frames, 10 shapes leaving and entering, one
    /// occluding bar.
    #[default]
    Default,
    /// [`SynthConfig::occlusion_scene`]: 8 shapes crossing and bouncing behind two bars
    /// (~10-frame occlusions), 640×480.
    Occlusion,
    /// [`SynthConfig::demo`]: the 1280×720 browser demo, 600 frames, 12 shapes entering and
    /// leaving, two occluding bars.
    Demo,
}

impl ScenePreset {
    /// The scene's config; `seed` seeds the scenes that take one (the occlusion scene).
    pub fn config(self, seed: u64) -> SynthConfig {
        match self {
            ScenePreset::Default => SynthConfig::default(),
            ScenePreset::Occlusion => SynthConfig::occlusion_scene(seed),
            ScenePreset::Demo => SynthConfig::demo(),
        }
    }
}

/// Everything that defines a synthetic sequence. `Default` gives a 640×480, 25 fps, 300-frame
/// sequence of 10 shapes with one occluding bar and the default detection noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// Seed of every random choice. Default `0`.
    pub seed: u64,
    /// Number of frames. Default `300`.
    pub frames: u32,
    /// Number of random objects alive at once (with [`BorderPolicy::Exit`], replacements keep
    /// the count). Default `10`.
    pub shapes: u32,
    /// Frame width in pixels. Default `640`.
    pub width: u32,
    /// Frame height in pixels. Default `480`.
    pub height: u32,
    /// Frame rate (only written to `seqinfo.ini`; motion is per frame). Default `25`.
    pub fps: f64,
    /// How random objects move.
    pub motion: MotionConfig,
    /// Static occluders.
    pub occlusion: OcclusionConfig,
    /// Whole-image effects.
    pub appearance: AppearanceConfig,
    /// Detection noise.
    pub noise: NoiseConfig,
    /// Objects with exact trajectories, added to the random ones. Default none.
    pub scripted: Vec<ScriptedShape>,
    /// A panning and zooming camera; `None`: a static camera whose view is the world.
    #[serde(default)]
    pub camera: Option<CameraConfig>,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            frames: 300,
            shapes: 10,
            width: 640,
            height: 480,
            fps: 25.0,
            motion: MotionConfig::default(),
            occlusion: OcclusionConfig::default(),
            appearance: AppearanceConfig::default(),
            noise: NoiseConfig::default(),
            scripted: Vec::new(),
            camera: None,
        }
    }
}

impl SynthConfig {
    /// The default scene with another seed.
    pub fn with_seed(seed: u64) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }

    /// Crossings and occlusions: 8 shapes of radius 16–24 bounce around 640×480 moving within
    /// 20° of horizontal at 3–5 px/frame, so they cross one another and two full-height bars
    /// 80 px wide, sized to hide the mean object for 10 frames (seeds 1–3: 89 full occlusions
    /// of 4–19 frames, median 11, and objects crossing in ~20% of frames); 5% misses and the
    /// default noise otherwise. 300 frames.
    pub fn occlusion_scene(seed: u64) -> Self {
        Self {
            seed,
            shapes: 8,
            motion: MotionConfig {
                radius: (16.0, 24.0),
                speed: (3.0, 5.0),
                accel: 0.0,
                max_rotation: 0.02,
                max_scale_rate: 0.0,
                scale_range: (1.0, 1.0),
                direction_spread: Some(0.35),
                border: BorderPolicy::Bounce,
                ..MotionConfig::default()
            },
            occlusion: OcclusionConfig {
                bars: 2,
                bar_width: None,
                hidden_frames: 10.0,
                rects: Vec::new(),
            },
            ..Self::default()
        }
    }

    /// The browser demo's default: 1280×720, 600 frames, 12 larger shapes entering and leaving,
    /// two bars, a slight illumination drift and sensor noise. Seed 2024.
    pub fn demo() -> Self {
        Self {
            seed: 2024,
            frames: 600,
            shapes: 12,
            width: 1280,
            height: 720,
            motion: MotionConfig {
                radius: (24.0, 64.0),
                speed: (1.5, 6.0),
                ..MotionConfig::default()
            },
            occlusion: OcclusionConfig {
                bars: 2,
                ..OcclusionConfig::default()
            },
            appearance: AppearanceConfig {
                illumination_drift: 0.03,
                sensor_noise: 2,
                ..AppearanceConfig::default()
            },
            ..Self::default()
        }
    }

    /// The same scene at another frame size, for speed measurements at a chosen resolution
    /// (the app's bench page): shape radii, speeds and bar widths are scaled by
    /// √(new area / old area), fixed occluder rectangles by the width and height ratios, so
    /// the scene keeps its look, its object count and its occlusions and only the pixel count
    /// changes. Scripted trajectories and the camera path are left in their pixels (the
    /// presets have none). The size is checked when the scene is built ([`Scene::new`]).
    pub fn scaled_to(mut self, width: u32, height: u32) -> Self {
        let (sx, sy) = (
            width as f64 / self.width.max(1) as f64,
            height as f64 / self.height.max(1) as f64,
        );
        let s = (sx * sy).sqrt();
        let m = &mut self.motion;
        m.radius = (m.radius.0 * s, m.radius.1 * s);
        m.speed = (m.speed.0 * s, m.speed.1 * s);
        let o = &mut self.occlusion;
        o.bar_width = o.bar_width.map(|w| ((w as f64 * s).round() as u32).max(1));
        for r in &mut o.rects {
            r.x = (r.x as f64 * sx).round() as u32;
            r.y = (r.y as f64 * sy).round() as u32;
            r.w = ((r.w as f64 * sx).round() as u32).max(1);
            r.h = ((r.h as f64 * sy).round() as u32).max(1);
        }
        self.width = width;
        self.height = height;
        self
    }

    /// A scene of the scenario family `family` (see [`Family`]): 640×480, 25 fps, 300 frames,
    /// the default detection noise.
    pub fn family(family: Family, seed: u64) -> Self {
        use std::f64::consts::{FRAC_PI_2, PI};
        let base = Self {
            seed,
            occlusion: OcclusionConfig {
                bars: 0,
                ..OcclusionConfig::default()
            },
            ..Self::default()
        };
        match family {
            Family::Crossing => Self {
                shapes: 10,
                motion: MotionConfig {
                    radius: (16.0, 30.0),
                    speed: (2.5, 4.5),
                    accel: 0.03,
                    headings: Some(vec![0.0, FRAC_PI_2, PI, -FRAC_PI_2]),
                    direction_spread: Some(0.15),
                    border: BorderPolicy::Exit,
                    ..MotionConfig::default()
                },
                ..base
            },
            Family::Crowd => Self {
                shapes: 30,
                motion: MotionConfig {
                    radius: (13.0, 17.0),
                    speed: (1.0, 3.0),
                    max_rotation: 0.02,
                    kinds: Some(vec![ShapeKind::Ellipse]),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                appearance: AppearanceConfig {
                    similar_colours: Some(0.35),
                    ..AppearanceConfig::default()
                },
                ..base
            },
            Family::Deform => Self {
                shapes: 8,
                motion: MotionConfig {
                    radius: (22.0, 34.0),
                    speed: (1.5, 3.5),
                    kinds: Some(vec![
                        ShapeKind::Disc,
                        ShapeKind::Ellipse,
                        ShapeKind::Irregular,
                        ShapeKind::Star,
                    ]),
                    scale_range: (1.0, 1.0),
                    max_scale_rate: 0.0,
                    deform: Some(DeformConfig {
                        area_amplitude: 0.5,
                        outline_amplitude: 0.12,
                        period: (30.0, 90.0),
                    }),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                ..base
            },
            Family::Occluders => Self {
                shapes: 8,
                motion: MotionConfig {
                    radius: (16.0, 24.0),
                    speed: (3.0, 5.0),
                    accel: 0.0,
                    direction_spread: Some(0.35),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                occlusion: OcclusionConfig {
                    bars: 2,
                    bar_width: None,
                    hidden_frames: 15.0,
                    rects: vec![
                        OccluderRect {
                            x: 250,
                            y: 40,
                            w: 130,
                            h: 110,
                        },
                        OccluderRect {
                            x: 400,
                            y: 330,
                            w: 150,
                            h: 110,
                        },
                    ],
                },
                ..base
            },
            Family::EnterLeave => Self {
                shapes: 10,
                motion: MotionConfig {
                    radius: (14.0, 30.0),
                    speed: (3.5, 6.5),
                    accel: 0.1,
                    border: BorderPolicy::Exit,
                    ..MotionConfig::default()
                },
                ..base
            },
            Family::Camera => Self {
                shapes: 10,
                motion: MotionConfig {
                    radius: (16.0, 30.0),
                    speed: (1.0, 3.0),
                    border: BorderPolicy::Bounce,
                    ..MotionConfig::default()
                },
                occlusion: OcclusionConfig {
                    bars: 1,
                    ..OcclusionConfig::default()
                },
                camera: Some(CameraConfig {
                    world_scale: 1.6,
                    pan_speed: 3.0,
                    zoom_range: (0.8, 1.25),
                    zoom_period: 150.0,
                }),
                ..base
            },
        }
    }

    /// Checks every setting; [`Scene::new`] calls it.
    pub fn validate(&self) -> Result<(), SynthError> {
        fn range(field: &'static str, v: f64, min: f64, max: f64) -> Result<(), SynthError> {
            if v.is_finite() && v >= min && v <= max {
                Ok(())
            } else {
                Err(SynthError::OutOfRange {
                    field,
                    value: v,
                    min,
                    max,
                })
            }
        }
        fn pair(field: &'static str, p: (f64, f64), min: f64, max: f64) -> Result<(), SynthError> {
            range(field, p.0, min, max)?;
            range(field, p.1, min, max)?;
            if p.0 > p.1 {
                return Err(SynthError::EmptyRange {
                    field,
                    lo: p.0,
                    hi: p.1,
                });
            }
            Ok(())
        }
        if !(16..=8192).contains(&self.width) || !(16..=8192).contains(&self.height) {
            return Err(SynthError::InvalidSize {
                width: self.width,
                height: self.height,
            });
        }
        let total = self.shapes as u64 + self.scripted.len() as u64;
        if total > MAX_SHAPES {
            return Err(SynthError::TooManyShapes {
                shapes: total,
                max: MAX_SHAPES,
            });
        }
        range("fps", self.fps, 1e-3, 1e4)?;
        let m = &self.motion;
        pair("motion.radius", m.radius, 2.0, 500.0)?;
        pair("motion.speed", m.speed, 0.0, 1000.0)?;
        range("motion.accel", m.accel, 0.0, 100.0)?;
        let ap = (m.accel_period.0 as f64, m.accel_period.1 as f64);
        pair("motion.accel_period", ap, 1.0, 1e6)?;
        range("motion.max_rotation", m.max_rotation, 0.0, 3.2)?;
        range("motion.max_scale_rate", m.max_scale_rate, 0.0, 0.5)?;
        pair("motion.scale_range", m.scale_range, 0.1, 10.0)?;
        range("motion.scale_range.0", m.scale_range.0, 0.1, 1.0)?;
        range("motion.scale_range.1", m.scale_range.1, 1.0, 10.0)?;
        if let Some(s) = m.direction_spread {
            range("motion.direction_spread", s, 0.0, std::f64::consts::PI)?;
        }
        if let Some(k) = &m.kinds {
            range("motion.kinds.len", k.len() as f64, 1.0, 1e3)?;
        }
        if let Some(hs) = &m.headings {
            range("motion.headings.len", hs.len() as f64, 1.0, 1e3)?;
            for &h in hs {
                range("motion.headings", h, -100.0, 100.0)?;
            }
        }
        if let Some(d) = &m.deform {
            range("motion.deform.area_amplitude", d.area_amplitude, 0.0, 0.9)?;
            range(
                "motion.deform.outline_amplitude",
                d.outline_amplitude,
                0.0,
                0.5,
            )?;
            pair("motion.deform.period", d.period, 2.0, 1e6)?;
        }
        if let Some(c) = &self.camera {
            range("camera.world_scale", c.world_scale, 1.0, 8.0)?;
            range("camera.pan_speed", c.pan_speed, 0.0, 1000.0)?;
            pair("camera.zoom_range", c.zoom_range, 1.0 / c.world_scale, 10.0)?;
            range("camera.zoom_period", c.zoom_period, 2.0, 1e9)?;
            let world = |side: u32| side as f64 * c.world_scale;
            if world(self.width) * world(self.height) > 64.0 * 1024.0 * 1024.0 {
                return Err(SynthError::OutOfRange {
                    field: "camera.world_scale",
                    value: c.world_scale,
                    min: 1.0,
                    max: (64.0 * 1024.0 * 1024.0 / (self.width as f64 * self.height as f64)).sqrt(),
                });
            }
        }
        let o = &self.occlusion;
        range("occlusion.bars", o.bars as f64, 0.0, 100.0)?;
        range("occlusion.hidden_frames", o.hidden_frames, 0.0, 1e4)?;
        let a = &self.appearance;
        range(
            "appearance.illumination_drift",
            a.illumination_drift,
            0.0,
            0.5,
        )?;
        range(
            "appearance.illumination_period",
            a.illumination_period,
            1.0,
            1e9,
        )?;
        range("appearance.min_contrast", a.min_contrast, 0.0, 100.0)?;
        if let Some(c) = a.similar_colours {
            range("appearance.similar_colours", c, 0.0, 3.0)?;
        }
        let n = &self.noise;
        range("noise.miss_rate", n.miss_rate, 0.0, 1.0)?;
        range("noise.false_positives", n.false_positives, 0.0, 16.0)?;
        range("noise.morph_prob", n.morph_prob, 0.0, 1.0)?;
        range("noise.morph_max", n.morph_max as f64, 0.0, 10.0)?;
        range("noise.split_prob", n.split_prob, 0.0, 1.0)?;
        range("noise.box_jitter", n.box_jitter, 0.0, 1.0)?;
        for s in &self.scripted {
            range("scripted.radius", s.radius, 1.0, 1000.0)?;
            range("scripted.aspect", s.aspect, 0.01, 10.0)?;
            range("scripted.center.x", s.center.x, -1e6, 1e6)?;
            range("scripted.center.y", s.center.y, -1e6, 1e6)?;
            range("scripted.velocity.x", s.velocity.x, -1e4, 1e4)?;
            range("scripted.velocity.y", s.velocity.y, -1e4, 1e4)?;
            range("scripted.angle", s.angle, -1e6, 1e6)?;
            range("scripted.angular_velocity", s.angular_velocity, -1e3, 1e3)?;
            range("scripted.z", s.z, -1e9, 1e9)?;
        }
        // Textures live in object space at scale 1, about (2·bound)² texels of 3 bytes each;
        // refuse configs whose live objects would need hundreds of megabytes (in wasm32 an
        // allocation failure aborts the page).
        let texture = |r: f64| {
            let side = 2.0 * (r * std::f64::consts::SQRT_2 + 3.0);
            (3.0 * side * side) as u64
        };
        let mut bytes = self.shapes as u64 * texture(m.radius.1);
        let mut radius = m.radius.1;
        for s in &self.scripted {
            let r = s.radius * s.aspect.max(1.0);
            radius = radius.max(r);
            bytes += texture(r);
        }
        if bytes > MAX_TEXTURE_BYTES {
            return Err(SynthError::TooLarge {
                shapes: total,
                radius,
                bytes,
                max: MAX_TEXTURE_BYTES,
            });
        }
        Ok(())
    }

    /// The bar width the scene uses: `bar_width`, or the automatic size described there.
    pub fn effective_bar_width(&self) -> u32 {
        self.occlusion.bar_width.unwrap_or_else(|| {
            let m = &self.motion;
            let r = (m.radius.0 + m.radius.1) / 2.0;
            let v = (m.speed.0 + m.speed.1) / 2.0;
            (2.0 * r + self.occlusion.hidden_frames * v)
                .round()
                .max(1.0) as u32
        })
    }
}

/// Objects a frame can hold (the id buffer is 16-bit).
const MAX_SHAPES: u64 = 10_000;
/// Texture memory a scene may use.
const MAX_TEXTURE_BYTES: u64 = 256 << 20;

/// Purposes of the scene-wide random streams.
const LAYOUT_STREAM: u64 = 0x6c61_796f;
const OBJECT_STREAM: u64 = 0x6f62_6a73;
const SENSOR_STREAM: u64 = 0x7365_6e73;
const DEFORM_STREAM: u64 = 0x6465_666f;
const CAMERA_STREAM: u64 = 0x6361_6d65;
const PALETTE_STREAM: u64 = 0x7061_6c65;

/// One object's ground truth in one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GtObject {
    /// Object id (1-based, never reused within a scene).
    pub id: u64,
    /// Outline family.
    pub kind: ShapeKind,
    /// Visible pixels (never empty; disjoint from every other object's in the frame).
    pub mask: Mask,
    /// Tight box of `mask`.
    pub bbox: BBox,
    /// Visible pixels over the full silhouette's pixels, in `(0, 1]`.
    pub visibility: f64,
    /// Pixels of the full silhouette (unclipped, unoccluded).
    pub full_area: u64,
    /// The colours the object's texture uses.
    pub palette: Vec<[u8; 3]>,
}

/// One rendered frame with its ground truth and detections.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthFrame {
    /// Frame number, 1-based.
    pub index: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// RGB8 pixels, row-major, `3·width` bytes per row.
    pub image: Vec<u8>,
    /// Ground truth of the visible objects, by increasing id.
    pub gt: Vec<GtObject>,
    /// Noisy mask detections (each with its mask's tight box), object detections first (by id)
    /// then false positives.
    pub detections: Vec<Detection>,
    /// For each detection, the id of the object it came from (`None` for false positives).
    pub detection_sources: Vec<Option<u64>>,
    /// Box-only variant of `detections` (same order, same scores): jittered boxes, no masks.
    pub box_detections: Vec<Detection>,
}

impl SynthFrame {
    /// A borrowed RGB view of the image.
    pub fn frame(&self) -> Result<Frame<'_>, FrameError> {
        Frame::rgb(&self.image, self.width, self.height)
    }

    /// Ground truth as records: class 1, score 1 ("consider"), visibility, mask as RLE.
    pub fn gt_records(&self) -> Vec<Record> {
        self.gt
            .iter()
            .map(|g| Record {
                frame: self.index,
                id: g.id as i64,
                bbox: g.bbox,
                score: 1.0,
                class: 1,
                visibility: g.visibility,
                mask: Some(Rle::from_mask(&g.mask, self.width, self.height)),
                flags: RecordFlags::default(),
            })
            .collect()
    }

    /// Mask detections as records: id -1, class -1, the detection's score, mask as RLE.
    pub fn detection_records(&self) -> Vec<Record> {
        self.detections
            .iter()
            .map(|d| Record {
                frame: self.index,
                id: -1,
                bbox: d.bbox,
                score: d.score,
                class: -1,
                visibility: -1.0,
                mask: d
                    .mask
                    .as_ref()
                    .map(|m| Rle::from_mask(m, self.width, self.height)),
                flags: RecordFlags::default(),
            })
            .collect()
    }

    /// Box-only detections as records: id -1, class -1, the score, no mask.
    pub fn box_detection_records(&self) -> Vec<Record> {
        self.box_detections
            .iter()
            .map(|d| Record {
                frame: self.index,
                id: -1,
                bbox: d.bbox,
                score: d.score,
                class: -1,
                visibility: -1.0,
                mask: None,
                flags: RecordFlags::default(),
            })
            .collect()
    }
}

/// A byte under the illumination gain `g16` (16.16 fixed point), rounded, at most 255.
#[inline]
fn lit(p: u8, g16: u32) -> u8 {
    ((p as u32 * g16 + 32768) >> 16).min(255) as u8
}

/// One object's model and state.
#[derive(Debug, Clone)]
struct Object {
    id: u64,
    kind: ShapeKind,
    poly: Vec<[f64; 2]>,
    bound: f64,
    texture: shape::Texture,
    palette: Vec<[u8; 3]>,
    pos: [f64; 2],
    vel: [f64; 2],
    acc: [f64; 2],
    accel_timer: u32,
    angle: f64,
    omega: f64,
    scale: f64,
    dscale: f64,
    z: f64,
    scripted: bool,
    entered: bool,
    age: u32,
    /// This frame: clipped rectangle `[x0, x1) × [y0, y1)` of the spans drawn, if any.
    drawn: Option<[i32; 4]>,
    /// This frame: full silhouette pixel count.
    full_area: u64,
    /// Non-rigid deformation, when the scene deforms its objects.
    deform: Option<Deform>,
}

/// One object's deformation (see [`DeformConfig`]): its area pulsation and three radial
/// ripples, each `(amplitude, angular rate per frame, phase)`, the ripples with the cosine and
/// sine of their angular offset.
#[derive(Debug, Clone)]
struct Deform {
    area: (f64, f64, f64),
    ripples: [(f64, f64, f64, f64, f64); 3],
}

impl Deform {
    fn draw(cfg: &DeformConfig, seed: u64, id: u64) -> Deform {
        let mut rng = stream(seed ^ id.wrapping_mul(0x9E6C_63D0_676A_9A99), DEFORM_STREAM);
        let rate = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
            std::f64::consts::TAU / uniform(rng, cfg.period.0, cfg.period.1)
        };
        let area = (
            uniform(&mut rng, 0.5 * cfg.area_amplitude, cfg.area_amplitude),
            rate(&mut rng),
            uniform(&mut rng, 0.0, std::f64::consts::TAU),
        );
        let mut ripples = [(0.0, 0.0, 0.0, 1.0, 0.0); 3];
        for r in &mut ripples {
            let amp = uniform(&mut rng, 0.3, 1.0) * cfg.outline_amplitude;
            let w = rate(&mut rng);
            let phase = uniform(&mut rng, 0.0, std::f64::consts::TAU);
            let (sp, cp) = sin_cos(uniform(&mut rng, 0.0, std::f64::consts::TAU));
            *r = (amp, w, phase, cp, sp);
        }
        Deform { area, ripples }
    }

    /// Area factor at frame age `t`.
    fn area_factor(&self, t: f64) -> f64 {
        let (a, w, p) = self.area;
        1.0 + a * sin_cos(w * t + p).0
    }

    /// Radial factor at frame age `t` of the outline point in direction `(c, s)` (unit).
    fn radial(&self, t: f64, c: f64, s: f64) -> f64 {
        // cos/sin of 2θ, 3θ, 4θ by complex multiplication: exact arithmetic, no trig.
        let (c2, s2) = (c * c - s * s, 2.0 * c * s);
        let (c3, s3) = (c2 * c - s2 * s, s2 * c + c2 * s);
        let (c4, s4) = (c2 * c2 - s2 * s2, 2.0 * c2 * s2);
        let mut f = 1.0;
        for (&(amp, w, p, cp, sp), (ck, sk)) in
            self.ripples.iter().zip([(c2, s2), (c3, s3), (c4, s4)])
        {
            f += amp * sin_cos(w * t + p).0 * (ck * cp - sk * sp);
        }
        f
    }

    /// How far beyond its rigid bound the object can reach.
    fn reach(&self) -> f64 {
        (1.0 + self.area.0).sqrt() * (1.0 + self.ripples.iter().map(|r| r.0).sum::<f64>())
    }
}

/// The camera of a scene with [`CameraConfig`]: the view's centre in world coordinates, its
/// pan velocity and acceleration, and its own random stream.
#[derive(Debug, Clone)]
struct Camera {
    cfg: CameraConfig,
    centre: [f64; 2],
    vel: [f64; 2],
    acc: [f64; 2],
    timer: u32,
    rng: rand_xoshiro::Xoshiro256PlusPlus,
}

impl Camera {
    /// Image pixels per world pixel in frame `index` (1-based): a smooth oscillation through
    /// the zoom range.
    fn zoom(&self, index: u32) -> f64 {
        let (lo, hi) = self.cfg.zoom_range;
        let t = (index - 1) as f64 / self.cfg.zoom_period;
        lo + (hi - lo) * (0.5 + 0.5 * sin_cos(std::f64::consts::TAU * t).0)
    }

    /// World coordinates of the view's top-left corner for a `w × h` image at `zoom`.
    fn origin(&self, w: u32, h: u32, zoom: f64) -> [f64; 2] {
        [
            self.centre[0] - 0.5 * w as f64 / zoom,
            self.centre[1] - 0.5 * h as f64 / zoom,
        ]
    }

    /// One frame of panning, keeping the largest view inside the `world`.
    fn step(&mut self, world: (u32, u32), w: u32, h: u32) {
        if self.timer == 0 {
            let (s, c) = sin_cos(uniform(&mut self.rng, 0.0, std::f64::consts::TAU));
            let a = 0.15 * self.cfg.pan_speed * uniform(&mut self.rng, 0.0, 1.0);
            self.acc = [a * c, a * s];
            self.timer = below(&mut self.rng, 30, 90);
        }
        self.timer -= 1;
        let max = self.cfg.pan_speed;
        for i in 0..2 {
            self.vel[i] = (self.vel[i] + self.acc[i]).clamp(-max, max);
        }
        let min_zoom = self.cfg.zoom_range.0;
        let half = [0.5 * w as f64 / min_zoom, 0.5 * h as f64 / min_zoom];
        let size = [world.0 as f64, world.1 as f64];
        for i in 0..2 {
            self.centre[i] += self.vel[i];
            let (lo, hi) = (half[i], (size[i] - half[i]).max(half[i]));
            if (self.centre[i] < lo && self.vel[i] < 0.0)
                || (self.centre[i] > hi && self.vel[i] > 0.0)
            {
                self.vel[i] = -self.vel[i];
                self.acc[i] = -self.acc[i];
            }
            self.centre[i] = self.centre[i].clamp(lo, hi);
        }
    }
}

/// A synthetic sequence being generated frame by frame (also an [`Iterator`] of frames).
#[derive(Debug, Clone)]
pub struct Scene {
    cfg: SynthConfig,
    next_index: u32,
    next_id: u64,
    objects: Vec<Object>,
    background: Vec<u8>,
    occ: Vec<u8>,
    occluders: Vec<OccluderRect>,
    ids: Vec<u16>,
    poly: Vec<[f64; 2]>,
    order: Vec<usize>,
    /// Scratch for the sensor noise bytes.
    noise: Vec<u8>,
    raster: Rasterizer,
    rng: rand_xoshiro::Xoshiro256PlusPlus,
    /// The world's size: the frame's, or larger with a camera.
    world: (u32, u32),
    camera: Option<Camera>,
    /// With a camera: this frame's view of the occluder mask.
    view_occ: Vec<u8>,
    /// The scene-wide hue of look-alike objects ([`AppearanceConfig::similar_colours`]).
    base_hue: f64,
}

impl Scene {
    /// Validates `cfg`, renders the background and occluders and places the initial objects.
    pub fn new(cfg: SynthConfig) -> Result<Scene, SynthError> {
        cfg.validate()?;
        let world = match &cfg.camera {
            Some(c) => (
                (cfg.width as f64 * c.world_scale).round() as u32,
                (cfg.height as f64 * c.world_scale).round() as u32,
            ),
            None => (cfg.width, cfg.height),
        };
        let (w, h) = world;
        let camera = cfg.camera.map(|c| {
            let mut rng = stream(cfg.seed, CAMERA_STREAM);
            let centre = [
                uniform(&mut rng, 0.4, 0.6) * w as f64,
                uniform(&mut rng, 0.4, 0.6) * h as f64,
            ];
            Camera {
                cfg: c,
                centre,
                vel: [0.0, 0.0],
                acc: [0.0, 0.0],
                timer: 0,
                rng,
            }
        });
        let base_hue = uniform(&mut stream(cfg.seed, PALETTE_STREAM), 0.0, 6.0);
        let mut layout = stream(cfg.seed, LAYOUT_STREAM);
        let mut background = background::render(&mut layout, w, h);
        let occluders = background::occluders(
            &mut layout,
            w,
            h,
            cfg.occlusion.bars,
            cfg.effective_bar_width(),
            &cfg.occlusion.rects,
        );
        let mut occ = vec![0u8; w as usize * h as usize];
        background::draw_occluders(&mut layout, &mut background, &mut occ, w, h, &occluders);
        let mut scene = Scene {
            next_index: 1,
            next_id: 1,
            objects: Vec::new(),
            background,
            occ,
            occluders,
            ids: vec![0; cfg.width as usize * cfg.height as usize],
            poly: Vec::new(),
            order: Vec::new(),
            noise: Vec::new(),
            raster: Rasterizer::default(),
            rng: stream(cfg.seed, OBJECT_STREAM),
            world,
            camera,
            view_occ: Vec::new(),
            base_hue,
            cfg,
        };
        for i in 0..scene.cfg.scripted.len() {
            let s = scene.cfg.scripted[i].clone();
            let o = scene.scripted_object(&s);
            scene.objects.push(o);
        }
        for _ in 0..scene.cfg.shapes {
            let o = scene.random_object(true);
            scene.objects.push(o);
        }
        Ok(scene)
    }

    /// The configuration.
    pub fn config(&self) -> &SynthConfig {
        &self.cfg
    }

    /// The static background with the occluders drawn in (RGB8, no objects, no illumination
    /// drift or sensor noise): what a perfect background model converges to. With a
    /// [`CameraConfig`] it is the whole world ([`Scene::world_size`]), of which each frame
    /// shows a moving view.
    pub fn background(&self) -> &[u8] {
        &self.background
    }

    /// The world's size: the frame's, or larger with a [`CameraConfig`].
    pub fn world_size(&self) -> (u32, u32) {
        self.world
    }

    /// The static occluders (bars first, then the configured rectangles), in world
    /// coordinates (image coordinates without a camera).
    pub fn occluders(&self) -> &[OccluderRect] {
        &self.occluders
    }

    /// The number of the next frame [`Scene::frame`] returns (1-based).
    pub fn next_index(&self) -> u32 {
        self.next_index
    }

    /// Renders the next frame and advances the motion; `None` after `frames` frames.
    pub fn frame(&mut self) -> Option<SynthFrame> {
        if self.next_index > self.cfg.frames {
            return None;
        }
        let index = self.next_index;
        let mut image = self.render();
        let gt = self.ground_truth();
        self.apply_appearance(index, &mut image);
        let noisy = noise::detect(
            &self.cfg.noise,
            self.cfg.seed,
            index,
            &gt,
            self.cfg.width,
            self.cfg.height,
            &mut self.raster,
        );
        self.step();
        self.next_index += 1;
        Some(SynthFrame {
            index,
            width: self.cfg.width,
            height: self.cfg.height,
            image,
            gt,
            detections: noisy.masks,
            detection_sources: noisy.sources,
            box_detections: noisy.boxes,
        })
    }

    fn scripted_object(&mut self, s: &ScriptedShape) -> Object {
        let poly = shape::outline(s.kind, s.radius, s.aspect, &mut self.rng);
        self.make_object(
            s.kind,
            poly,
            [s.center.x, s.center.y],
            [s.velocity.x, s.velocity.y],
            s.angle,
            s.angular_velocity,
            s.z,
            true,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn make_object(
        &mut self,
        kind: ShapeKind,
        poly: Vec<[f64; 2]>,
        pos: [f64; 2],
        vel: [f64; 2],
        angle: f64,
        omega: f64,
        z: f64,
        scripted: bool,
    ) -> Object {
        let bound = shape::bound(&poly);
        let palette = match self.cfg.appearance.similar_colours {
            Some(spread) => shape::palette_near(
                &mut self.rng,
                background::BG_LUMA,
                self.cfg.appearance.min_contrast,
                self.base_hue,
                spread,
            ),
            None => shape::palette(
                &mut self.rng,
                background::BG_LUMA,
                self.cfg.appearance.min_contrast,
            ),
        };
        let texture = shape::texture(&mut self.rng, bound, &palette);
        let id = self.next_id;
        self.next_id += 1;
        let deform = match (&self.cfg.motion.deform, scripted) {
            (Some(d), false) => Some(Deform::draw(d, self.cfg.seed, id)),
            _ => None,
        };
        // A deforming outline needs vertices to ripple: split long edges.
        let poly = if deform.is_some() {
            shape::subdivide(&poly, 0.15 * bound)
        } else {
            poly
        };
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let entered = pos[0] + bound > 0.0
            && pos[0] - bound < w
            && pos[1] + bound > 0.0
            && pos[1] - bound < h;
        Object {
            id,
            kind,
            poly,
            bound,
            texture,
            palette,
            pos,
            vel,
            acc: [0.0, 0.0],
            accel_timer: 0,
            angle,
            omega,
            scale: 1.0,
            dscale: 0.0,
            z,
            scripted,
            entered,
            age: 0,
            drawn: None,
            full_area: 0,
            deform,
        }
    }

    /// A random object, placed inside the frame (`inside`) or just outside a border, heading in.
    fn random_object(&mut self, inside: bool) -> Object {
        let m = self.cfg.motion.clone();
        let rng = &mut self.rng;
        let kind = match &m.kinds {
            Some(k) => k[below(rng, 0, k.len() as u32) as usize],
            None => ShapeKind::ALL[below(rng, 0, ShapeKind::ALL.len() as u32) as usize],
        };
        let r = uniform(rng, m.radius.0, m.radius.1);
        let aspect = uniform(rng, 0.45, 0.85);
        let poly = shape::outline(kind, r, aspect, rng);
        let reach = shape::bound(&poly) * m.scale_range.1;
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let speed = uniform(rng, m.speed.0, m.speed.1);
        let spread = m.direction_spread.unwrap_or(std::f64::consts::PI);
        let leftward = rng.gen::<u32>() & 1 == 1;
        let mut dir = uniform(rng, -spread, spread);
        let pos;
        if inside {
            let px = if w > 2.0 * reach {
                uniform(rng, reach, w - reach)
            } else {
                w / 2.0
            };
            let py = if h > 2.0 * reach {
                uniform(rng, reach, h - reach)
            } else {
                h / 2.0
            };
            if leftward {
                dir += std::f64::consts::PI;
            }
            pos = [px, py];
        } else {
            // Enter through a side, heading inwards within ±60° (or the configured spread).
            let sides = if m
                .direction_spread
                .is_some_and(|s| s < std::f64::consts::FRAC_PI_4)
            {
                2
            } else {
                4
            };
            let side = below(rng, 0, sides);
            let spread = spread.min(1.05);
            dir = uniform(rng, -spread, spread);
            let along_x = uniform(rng, 0.0, w);
            let along_y = uniform(rng, 0.0, h);
            let out = reach + 1.0;
            pos = match side {
                0 => [-out, along_y],
                1 => {
                    dir += std::f64::consts::PI;
                    [w + out, along_y]
                }
                2 => {
                    dir += std::f64::consts::FRAC_PI_2;
                    [along_x, -out]
                }
                _ => {
                    dir -= std::f64::consts::FRAC_PI_2;
                    [along_x, h + out]
                }
            };
        }
        let mut pos = pos;
        if let Some(hs) = &m.headings {
            // Streams: a heading of the list, within the spread; objects entering come in
            // through the side the heading leaves from.
            let spread = m.direction_spread.unwrap_or(0.2);
            let hd = hs[below(rng, 0, hs.len() as u32) as usize];
            dir = hd + uniform(rng, -spread, spread);
            if !inside {
                let (sh, ch) = sin_cos(hd);
                let out = reach + 1.0;
                pos = if ch.abs() >= sh.abs() {
                    let y = uniform(rng, 0.0, h);
                    if ch > 0.0 {
                        [-out, y]
                    } else {
                        [w + out, y]
                    }
                } else {
                    let x = uniform(rng, 0.0, w);
                    if sh > 0.0 {
                        [x, -out]
                    } else {
                        [x, h + out]
                    }
                };
            }
        }
        let (s, c) = sin_cos(dir);
        let angle = uniform(rng, 0.0, std::f64::consts::TAU);
        let omega = uniform(rng, -m.max_rotation, m.max_rotation);
        let dscale = uniform(rng, -m.max_scale_rate, m.max_scale_rate);
        let z = uniform(rng, 0.0, 1.0);
        let mut o = self.make_object(
            kind,
            poly,
            pos,
            [speed * c, speed * s],
            angle,
            omega,
            z,
            false,
        );
        o.dscale = dscale;
        o
    }

    /// Draws background and objects into a new image and fills the id buffer.
    fn render(&mut self) -> Vec<u8> {
        let (w, h) = (self.cfg.width as i32, self.cfg.height as i32);
        // With a camera, the image starts as the view of the world background (nearest world
        // pixel of each image pixel's centre), and the occluder mask is viewed the same way.
        let view = self.camera.as_ref().map(|cam| {
            let zoom = cam.zoom(self.next_index);
            (cam.origin(self.cfg.width, self.cfg.height, zoom), zoom)
        });
        let mut img = match view {
            None => self.background.clone(),
            Some((org, zoom)) => {
                let (ww, wh) = (self.world.0 as usize, self.world.1 as usize);
                let mut img = vec![0u8; 3 * w as usize * h as usize];
                self.view_occ.resize(w as usize * h as usize, 0);
                let cols: Vec<usize> = (0..w)
                    .map(|x| {
                        ((org[0] + (x as f64 + 0.5) / zoom).floor().max(0.0) as usize).min(ww - 1)
                    })
                    .collect();
                for y in 0..h as usize {
                    let wy =
                        ((org[1] + (y as f64 + 0.5) / zoom).floor().max(0.0) as usize).min(wh - 1);
                    for (x, &wx) in cols.iter().enumerate() {
                        let (i, wi) = (y * w as usize + x, wy * ww + wx);
                        img[3 * i..3 * i + 3].copy_from_slice(&self.background[3 * wi..3 * wi + 3]);
                        self.view_occ[i] = self.occ[wi];
                    }
                }
                img
            }
        };
        self.ids.fill(0);
        self.order.clear();
        self.order.extend(0..self.objects.len());
        let objs = &self.objects;
        self.order.sort_by(|&a, &b| {
            objs[a]
                .z
                .total_cmp(&objs[b].z)
                .then(objs[a].id.cmp(&objs[b].id))
        });
        let Scene {
            objects,
            order,
            poly,
            raster,
            ids,
            occ,
            view_occ,
            ..
        } = self;
        let occ: &[u8] = if view.is_some() { view_occ } else { occ };
        for &k in order.iter() {
            let o = &mut objects[k];
            let (sn, cs) = sin_cos(o.angle);
            let mut sc = o.scale;
            let (mut cx, mut cy) = (o.pos[0], o.pos[1]);
            let t = o.age as f64;
            if let Some(d) = &o.deform {
                // The pulsation scales the area (and the texture with it).
                sc *= d.area_factor(t).sqrt();
            }
            if let Some((org, zoom)) = view {
                cx = (cx - org[0]) * zoom;
                cy = (cy - org[1]) * zoom;
                sc *= zoom;
            }
            poly.clear();
            let deform = o.deform.as_ref();
            poly.extend(o.poly.iter().map(|p| {
                // Ripples move each outline point along its direction from the centre.
                let f = match deform {
                    Some(d) => {
                        let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
                        if r > 0.0 {
                            d.radial(t, p[0] / r, p[1] / r)
                        } else {
                            1.0
                        }
                    }
                    None => 1.0,
                };
                let (px, py) = (p[0] * f, p[1] * f);
                [cx + sc * (cs * px - sn * py), cy + sc * (sn * px + cs * py)]
            }));
            o.full_area = raster.area(poly);
            let slot = (k + 1) as u16;
            // Object coordinates of a pixel centre: the inverse rotation and scale; moving one
            // pixel right adds (cos, −sin)/scale.
            let (du, dv) = (cs / sc, -sn / sc);
            let tex = &o.texture;
            let texels = tex.bytes();
            let mut drawn: Option<[i32; 4]> = None;
            raster.spans(poly, 0..h, |y, xa, xb| {
                let (xa, xb) = (xa.max(0), xb.min(w));
                if xb <= xa {
                    return;
                }
                let dy = y as f64 + 0.5 - cy;
                let dx = xa as f64 + 0.5 - cx;
                let mut u = (dx * cs + dy * sn) / sc;
                let mut v = (dy * cs - dx * sn) / sc;
                let row = y as usize * w as usize;
                for i in row + xa as usize..row + xb as usize {
                    if occ[i] == 0 {
                        let t = tex.offset(u, v);
                        img[3 * i..3 * i + 3].copy_from_slice(&texels[t..t + 3]);
                        ids[i] = slot;
                    }
                    u += du;
                    v += dv;
                }
                drawn = Some(match drawn {
                    None => [xa, y, xb, y + 1],
                    Some(d) => [d[0].min(xa), d[1].min(y), d[2].max(xb), d[3].max(y + 1)],
                });
            });
            o.drawn = drawn;
        }
        img
    }

    /// Ground truth from the id buffer, by increasing id (the objects' order).
    fn ground_truth(&self) -> Vec<GtObject> {
        let w = self.cfg.width as usize;
        let mut out = Vec::with_capacity(self.objects.len());
        for (k, o) in self.objects.iter().enumerate() {
            let Some([x0, y0, x1, y1]) = o.drawn else {
                continue;
            };
            let slot = (k + 1) as u16;
            let (mut tx0, mut ty0, mut tx1, mut ty1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
            for y in y0..y1 {
                let row = &self.ids[y as usize * w + x0 as usize..y as usize * w + x1 as usize];
                if let (Some(a), Some(b)) = (
                    row.iter().position(|&v| v == slot),
                    row.iter().rposition(|&v| v == slot),
                ) {
                    tx0 = tx0.min(x0 + a as i32);
                    tx1 = tx1.max(x0 + b as i32 + 1);
                    ty0 = ty0.min(y);
                    ty1 = ty1.max(y + 1);
                }
            }
            if tx0 >= tx1 {
                continue;
            }
            let (mw, mh) = ((tx1 - tx0) as usize, (ty1 - ty0) as usize);
            let mut data = Vec::with_capacity(mw * mh);
            for y in ty0..ty1 {
                let s = y as usize * w + tx0 as usize;
                data.extend(self.ids[s..s + mw].iter().map(|&v| (v == slot) as u8));
            }
            let Ok(mask) = Mask::new(tx0, ty0, mw as u32, mh as u32, data) else {
                continue;
            };
            let area = mask.area();
            out.push(GtObject {
                id: o.id,
                kind: o.kind,
                bbox: BBox::new(tx0 as f64, ty0 as f64, mw as f64, mh as f64),
                mask,
                visibility: area as f64 / o.full_area.max(area) as f64,
                full_area: o.full_area,
                palette: o.palette.clone(),
            });
        }
        out
    }

    /// Illumination drift and sensor noise, applied after the ground truth is taken.
    fn apply_appearance(&mut self, index: u32, img: &mut [u8]) {
        let a = &self.cfg.appearance;
        // Plain element-wise integer arithmetic over the whole image, written so that it
        // vectorises (a lookup table or a per-byte division would not), in one pass when both
        // apply: the gain, then the noise, byte by byte, as two passes would (they were four
        // fifths of the demo scene's 1280×720 frame).
        let gain = (a.illumination_drift > 0.0).then(|| {
            let t = (index - 1) as f64 / a.illumination_period;
            let gain = 1.0 + a.illumination_drift * sin_cos(std::f64::consts::TAU * t).0;
            (gain * 65536.0 + 0.5) as u32
        });
        if a.sensor_noise == 0 {
            if let Some(g16) = gain {
                img.iter_mut().for_each(|p| *p = lit(*p, g16));
            }
            return;
        }
        let amp = a.sensor_noise as i16;
        let span = 2 * amp as u16 + 1;
        let mut rng = stream(
            self.cfg.seed ^ (index as u64).wrapping_mul(0x2545_F491_4F6C_DD1D),
            SENSOR_STREAM,
        );
        // The noise bytes: one 64-bit draw per 8 bytes, little-endian, the last draw cut to
        // what is left.
        self.noise.resize(img.len(), 0);
        let mut chunks = self.noise.chunks_exact_mut(8);
        for chunk in &mut chunks {
            chunk.copy_from_slice(&rng.gen::<u64>().to_le_bytes());
        }
        let rest = chunks.into_remainder();
        if !rest.is_empty() {
            let bits = rng.gen::<u64>().to_le_bytes();
            rest.copy_from_slice(&bits[..rest.len()]);
        }
        // Multiply-shift maps a random byte onto 0..span without a division.
        let noisy =
            |v: u8, n: u8| (v as i16 + ((n as u16 * span) >> 8) as i16 - amp).clamp(0, 255) as u8;
        match gain {
            Some(g16) => img
                .iter_mut()
                .zip(&self.noise)
                .for_each(|(p, &n)| *p = noisy(lit(*p, g16), n)),
            None => img
                .iter_mut()
                .zip(&self.noise)
                .for_each(|(p, &n)| *p = noisy(*p, n)),
        }
    }

    /// Advances every object by one frame and applies the border policy.
    fn step(&mut self) {
        let (w, h) = (self.world.0 as f64, self.world.1 as f64);
        let m = self.cfg.motion.clone();
        if let Some(cam) = &mut self.camera {
            cam.step(self.world, self.cfg.width, self.cfg.height);
        }
        for o in &mut self.objects {
            o.age += 1;
            if !o.scripted {
                if o.accel_timer == 0 {
                    let (s, c) = sin_cos(uniform(&mut self.rng, 0.0, std::f64::consts::TAU));
                    let a = m.accel * uniform(&mut self.rng, 0.0, 1.0).sqrt();
                    o.acc = [a * c, a * s];
                    o.accel_timer = below(&mut self.rng, m.accel_period.0, m.accel_period.1 + 1);
                }
                o.accel_timer -= 1;
                o.vel[0] += o.acc[0];
                o.vel[1] += o.acc[1];
                let sp = (o.vel[0] * o.vel[0] + o.vel[1] * o.vel[1]).sqrt();
                if sp > m.speed.1 && sp > 0.0 {
                    o.vel = [o.vel[0] * m.speed.1 / sp, o.vel[1] * m.speed.1 / sp];
                } else if sp < m.speed.0 {
                    o.vel = if sp > 1e-9 {
                        [o.vel[0] * m.speed.0 / sp, o.vel[1] * m.speed.0 / sp]
                    } else {
                        [m.speed.0, 0.0]
                    };
                }
                o.scale += o.scale * o.dscale;
                if o.scale < m.scale_range.0 || o.scale > m.scale_range.1 {
                    o.scale = o.scale.clamp(m.scale_range.0, m.scale_range.1);
                    o.dscale = -o.dscale;
                }
            }
            o.pos[0] += o.vel[0];
            o.pos[1] += o.vel[1];
            o.angle += o.omega;
            if o.angle >= std::f64::consts::TAU || o.angle < 0.0 {
                o.angle = o.angle.rem_euclid(std::f64::consts::TAU);
            }
            let r = o.bound * o.scale * o.deform.as_ref().map_or(1.0, Deform::reach);
            match m.border {
                BorderPolicy::Bounce => {
                    for (axis, size) in [(0, w), (1, h)] {
                        if (o.pos[axis] - r < 0.0 && o.vel[axis] < 0.0)
                            || (o.pos[axis] + r > size && o.vel[axis] > 0.0)
                        {
                            o.vel[axis] = -o.vel[axis];
                            o.acc[axis] = -o.acc[axis];
                        }
                    }
                }
                BorderPolicy::Wrap => {
                    for (axis, size) in [(0, w), (1, h)] {
                        if o.pos[axis] + r < 0.0 {
                            o.pos[axis] += size + 2.0 * r;
                        } else if o.pos[axis] - r > size {
                            o.pos[axis] -= size + 2.0 * r;
                        }
                    }
                }
                BorderPolicy::Exit => {}
            }
            let inside =
                o.pos[0] + r > 0.0 && o.pos[0] - r < w && o.pos[1] + r > 0.0 && o.pos[1] - r < h;
            if inside {
                o.entered = true;
            }
        }
        if m.border == BorderPolicy::Exit {
            let before = self.objects.iter().filter(|o| !o.scripted).count();
            self.objects.retain(|o| {
                let r = o.bound * o.scale * o.deform.as_ref().map_or(1.0, Deform::reach);
                let inside = o.pos[0] + r > 0.0
                    && o.pos[0] - r < w
                    && o.pos[1] + r > 0.0
                    && o.pos[1] - r < h;
                // Objects that never made it in (an acceleration turned them away) give up
                // after a while rather than linger off-screen forever.
                inside || (!o.entered && o.age < 400)
            });
            let after = self.objects.iter().filter(|o| !o.scripted).count();
            for _ in after..before {
                let o = self.random_object(false);
                self.objects.push(o);
            }
        }
    }
}

impl Iterator for Scene {
    type Item = SynthFrame;

    fn next(&mut self) -> Option<SynthFrame> {
        self.frame()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_validation_names_the_field() {
        let mut c = SynthConfig::default();
        c.noise.miss_rate = 1.5;
        assert!(matches!(
            Scene::new(c).unwrap_err(),
            SynthError::OutOfRange {
                field: "noise.miss_rate",
                ..
            }
        ));
        let c = SynthConfig {
            width: 4,
            ..SynthConfig::default()
        };
        assert!(matches!(
            Scene::new(c).unwrap_err(),
            SynthError::InvalidSize { .. }
        ));
        let mut c = SynthConfig::default();
        c.motion.speed = (5.0, 1.0);
        assert!(matches!(
            Scene::new(c).unwrap_err(),
            SynthError::EmptyRange { .. }
        ));
        let mut c = SynthConfig::default();
        c.motion.radius.0 = f64::NAN;
        assert!(Scene::new(c).is_err());
        let c = SynthConfig {
            shapes: 5000,
            motion: MotionConfig {
                radius: (400.0, 500.0),
                ..MotionConfig::default()
            },
            ..SynthConfig::default()
        };
        assert!(matches!(
            Scene::new(c).unwrap_err(),
            SynthError::TooLarge { .. }
        ));
    }

    #[test]
    fn exit_policy_replaces_objects_with_new_ids() {
        let mut c = SynthConfig::with_seed(3);
        c.frames = 300;
        c.motion.speed = (5.0, 8.0);
        let sc = Scene::new(c).unwrap();
        let mut max_id = 0;
        let mut alive = Vec::new();
        for f in sc {
            max_id = max_id.max(f.gt.iter().map(|g| g.id).max().unwrap_or(0));
            alive.push(f.gt.len());
        }
        assert!(max_id > 10, "some objects left and were replaced");
        assert!(alive.iter().all(|&n| n <= 10));
        assert!(alive.iter().filter(|&&n| n >= 7).count() > 200);
    }

    /// The demo at 1920×1080 is the demo 1.5× larger: the frames have the new size, the shapes
    /// are about 1.5× wider, as many are in view, and a size the scene refuses stays refused.
    #[test]
    fn scaled_scene_keeps_its_look() {
        // Mean √(full area) of the objects in view, and mean count in view, over 60 frames.
        let stats = |c: SynthConfig| {
            let (mut size, mut n, mut frames) = (0.0, 0.0, 0.0);
            for f in Scene::new(c).unwrap().take(60) {
                assert!(f.image.len() == 3 * (f.width * f.height) as usize);
                for g in &f.gt {
                    size += (g.full_area as f64).sqrt();
                    n += 1.0;
                }
                frames += 1.0;
            }
            (size / n, n / frames)
        };
        let (size, count) = stats(SynthConfig::demo());
        let big = SynthConfig::demo().scaled_to(1920, 1080);
        assert_eq!((big.width, big.height), (1920, 1080));
        let (big_size, big_count) = stats(big);
        let ratio = big_size / size;
        assert!((1.35..1.65).contains(&ratio), "size ratio {ratio}");
        assert!(
            (big_count - count).abs() <= 0.25 * count,
            "{count} vs {big_count}"
        );
        // The same scene at its own size is unchanged.
        assert_eq!(
            SynthConfig::demo().scaled_to(1280, 720),
            SynthConfig::demo()
        );
        let mut c = SynthConfig::default();
        c.occlusion.rects.push(OccluderRect {
            x: 320,
            y: 240,
            w: 64,
            h: 48,
        });
        let c = c.scaled_to(1280, 960);
        assert_eq!(
            c.occlusion.rects[0],
            OccluderRect {
                x: 640,
                y: 480,
                w: 128,
                h: 96
            }
        );
        assert!(matches!(
            Scene::new(SynthConfig::demo().scaled_to(8, 8)).unwrap_err(),
            SynthError::InvalidSize { .. }
        ));
    }
}
